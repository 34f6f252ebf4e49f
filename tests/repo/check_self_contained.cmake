# ctest repo.SelfContained: nothing in the repository points outside it (a
# user's clone has no team folder beside it): no test, benchmark, script,
# build file, source, shader or doc names a path into the team's data folder
# beside the checkout (or on the team's machines), and nothing cites the
# team's external algorithm notes; the project's own are docs/algorithms.md.
# The names are assembled below so that this file does not spell them.
# Run as: cmake -DROOT=<source dir> -P check_self_contained.cmake
file(GLOB_RECURSE files LIST_DIRECTORIES false
  "${ROOT}/tests/*.cpp" "${ROOT}/tests/*.hpp" "${ROOT}/tests/*.txt" "${ROOT}/tests/*.cmake"
  "${ROOT}/tests/*.py" "${ROOT}/tests/*.md" "${ROOT}/bench/*" "${ROOT}/scripts/*"
  "${ROOT}/cmake/*" "${ROOT}/CMakeLists.txt" "${ROOT}/.ci/*" "${ROOT}/README.md"
  "${ROOT}/docs/*" "${ROOT}/data/*.md" "${ROOT}/core/*" "${ROOT}/lines/*"
  "${ROOT}/hatching/*" "${ROOT}/render/*" "${ROOT}/shaders/*" "${ROOT}/apps/*"
  "${ROOT}/python/*" "${ROOT}/examples/*" "${ROOT}/fuzz/*.cpp" "${ROOT}/fuzz/*.txt")
set(team_folder "sha")
string(APPEND team_folder "red")
set(team_notes "ALGO")
string(APPEND team_notes "RITHMS")
set(bad "")
foreach(f IN LISTS files)
  if(f MATCHES "check_self_contained\\.cmake$" OR f MATCHES "\\.(xz|gz|png|jpg|pdf)$")
    continue()
  endif()
  # "${ROOT}/CMakeLists.txt" globs every CMakeLists.txt below ROOT, build
  # folders inside the checkout too, where other tests create and delete
  # files while this one runs (package.InstallAndConsume): not the project's.
  file(RELATIVE_PATH rel "${ROOT}" "${f}")
  if(rel MATCHES "^build[^/]*/" OR NOT EXISTS "${f}")
    continue()
  endif()
  # The file name is case-sensitive on purpose: docs/algorithms.md is fine.
  file(STRINGS "${f}" hits REGEX "\\.\\./${team_folder}|/work/${team_folder}|${team_notes}\\.md")
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
