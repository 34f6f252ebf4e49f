# Helpers of the package.* tests (cmake -P scripts).

# fabrica_require(SCRIPT VAR...): every -DVAR=... was given.
function(fabrica_require script)
  foreach(var IN LISTS ARGN)
    if(NOT DEFINED ${var})
      message(FATAL_ERROR "${script}: -D${var}=... missing")
    endif()
  endforeach()
endfunction()

# fabrica_run(COMMAND ARGS...): runs it, fails the test on a non-zero exit.
function(fabrica_run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "failed (${rc}): ${cmd}\n${out}\n${err}")
  endif()
endfunction()

# fabrica_build_project(SOURCE BINARY [TARGET T] [ARGS CMAKE_ARGS...]):
# configures and builds a small project (only target T when given) with this
# build's generator, compiler and launcher, 2 jobs.
function(fabrica_build_project source binary)
  cmake_parse_arguments(ARG "" "TARGET" "ARGS" ${ARGN})
  set(args -S "${source}" -B "${binary}" -G "${GENERATOR}" -DCMAKE_BUILD_TYPE=Release ${ARG_ARGS})
  if(LAUNCHER)
    list(APPEND args "-DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER}" "-DCMAKE_C_COMPILER_LAUNCHER=${LAUNCHER}")
  endif()
  if(CXX_COMPILER)
    list(APPEND args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
  endif()
  fabrica_run(${CMAKE_COMMAND} ${args})
  set(build --build "${binary}" -j 2)
  if(ARG_TARGET)
    list(APPEND build --target ${ARG_TARGET})
  endif()
  fabrica_run(${CMAKE_COMMAND} ${build})
endfunction()

# fabrica_off_vertex_count(OFF_FILE VAR): the vertex count of an OFF header.
function(fabrica_off_vertex_count file var)
  file(STRINGS "${file}" head LIMIT_COUNT 4 REGEX "^[ \t]*[0-9]")
  list(GET head 0 counts)
  string(REGEX MATCH "^[ \t]*([0-9]+)" _ "${counts}")
  set(${var} ${CMAKE_MATCH_1} PARENT_SCOPE)
endfunction()
