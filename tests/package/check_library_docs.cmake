# docs.LibraryExamples (cmake -P -DROOT=<source>): every file of examples/cpp
# appears verbatim in docs/library.md, so the documented examples are the
# ones CI builds and runs (package.InstallAndConsume).
file(READ "${ROOT}/docs/library.md" doc)
file(GLOB examples RELATIVE "${ROOT}" "${ROOT}/examples/cpp/*.cpp" "${ROOT}/examples/cpp/CMakeLists.txt")
if(NOT examples)
  message(FATAL_ERROR "no examples found under ${ROOT}/examples/cpp")
endif()
foreach(f IN LISTS examples)
  file(READ "${ROOT}/${f}" text)
  string(FIND "${doc}" "${text}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "docs/library.md does not hold ${f} verbatim: copy the file into it again")
  endif()
endforeach()
list(LENGTH examples n)
message(STATUS "docs/library.md holds all ${n} example files")
