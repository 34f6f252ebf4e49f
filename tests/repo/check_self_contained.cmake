# ctest repo.SelfContained: nothing in the repository points outside it (a
# user's clone has no team folder beside it): no test, benchmark, script,
# build file, source, shader or doc names a ../shared or /work/shared path,
# and nothing cites the team's external algorithm notes (ALGORITHMS.md);
# the project's own are docs/algorithms.md.
# Run as: cmake -DROOT=<source dir> -P check_self_contained.cmake
file(GLOB_RECURSE files LIST_DIRECTORIES false
  "${ROOT}/tests/*.cpp" "${ROOT}/tests/*.hpp" "${ROOT}/tests/*.txt" "${ROOT}/tests/*.cmake"
  "${ROOT}/tests/*.py" "${ROOT}/tests/*.md" "${ROOT}/bench/*" "${ROOT}/scripts/*"
  "${ROOT}/cmake/*" "${ROOT}/CMakeLists.txt" "${ROOT}/.ci/*" "${ROOT}/README.md"
  "${ROOT}/docs/*" "${ROOT}/data/*.md" "${ROOT}/core/*" "${ROOT}/lines/*"
  "${ROOT}/hatching/*" "${ROOT}/render/*" "${ROOT}/shaders/*" "${ROOT}/apps/*")
set(bad "")
foreach(f IN LISTS files)
  if(f MATCHES "check_self_contained\\.cmake$" OR f MATCHES "\\.(xz|gz|png|jpg|pdf)$")
    continue()
  endif()
  # The file name is case-sensitive on purpose: docs/algorithms.md is fine.
  file(STRINGS "${f}" hits REGEX "\\.\\./shared|/work/shared|ALGORITHMS\\.md")
  if(hits)
    string(APPEND bad "\n  ${f}: ${hits}")
  endif()
endforeach()
if(bad)
  message(FATAL_ERROR "files that point outside the repository (use in-repo paths: "
    "build/test-data/..., tests/data/SOURCES.md, docs/algorithms.md):${bad}")
endif()
list(LENGTH files n)
message(STATUS "${n} files checked: none points outside the repository")
