# ctest repo.SelfContained: no test, benchmark, script or build file points
# outside the repository (a user's clone has no ../shared beside it).
# Run as: cmake -DROOT=<source dir> -P check_self_contained.cmake
file(GLOB_RECURSE files LIST_DIRECTORIES false
  "${ROOT}/tests/*.cpp" "${ROOT}/tests/*.hpp" "${ROOT}/tests/*.txt" "${ROOT}/tests/*.cmake"
  "${ROOT}/tests/*.py" "${ROOT}/bench/*" "${ROOT}/scripts/*" "${ROOT}/cmake/*"
  "${ROOT}/CMakeLists.txt" "${ROOT}/.ci/*")
set(bad "")
foreach(f IN LISTS files)
  if(f MATCHES "check_self_contained\\.cmake$" OR f MATCHES "\\.(xz|gz|png)$")
    continue()
  endif()
  file(STRINGS "${f}" hits REGEX "\\.\\./shared|/work/shared")
  if(hits)
    string(APPEND bad "\n  ${f}: ${hits}")
  endif()
endforeach()
if(bad)
  message(FATAL_ERROR "files that point outside the repository:${bad}")
endif()
list(LENGTH files n)
message(STATUS "${n} files checked: none points outside the repository")
