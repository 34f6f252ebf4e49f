# package.InstallAndConsume (cmake -P): installs this build into a temporary
# prefix, builds examples/cpp against it with find_package(fabrica) only
# (CMAKE_PREFIX_PATH = the prefix, no source-tree paths), runs both examples
# on a bundled mesh and checks their outputs.
#   -DBUILD_DIR= -DEXAMPLES= -DWORK= -DMESH= -DGENERATOR= [-DLAUNCHER=ccache]
include(${CMAKE_CURRENT_LIST_DIR}/package_common.cmake)
fabrica_require(install_and_consume.cmake BUILD_DIR EXAMPLES WORK MESH GENERATOR)

file(REMOVE_RECURSE "${WORK}")
set(prefix "${WORK}/prefix")
fabrica_run(${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${prefix}" --component fabrica_development)
foreach(f lib/cmake/fabrica/fabricaConfig.cmake lib/cmake/fabrica/fabricaConfigVersion.cmake
          include/fabrica/core/surface.hpp include/fabrica/io/mesh_io.hpp include/fabrica/lines/extract.hpp)
  if(NOT EXISTS "${prefix}/${f}")
    message(FATAL_ERROR "not installed: ${prefix}/${f}")
  endif()
endforeach()
# The installed package must not point into the source or build tree.
file(GLOB_RECURSE cmake_files "${prefix}/lib/cmake/fabrica/*.cmake")
get_filename_component(source_root "${EXAMPLES}/../.." ABSOLUTE)
foreach(f IN LISTS cmake_files)
  file(READ "${f}" text)
  foreach(tree "${source_root}" "${BUILD_DIR}")
    string(FIND "${text}" "${tree}" at)
    if(NOT at EQUAL -1)
      message(FATAL_ERROR "${f} refers to ${tree}: the installed package is not relocatable")
    endif()
  endforeach()
endforeach()

# A component the install does not have: find_package fails and says so.
file(WRITE "${WORK}/missing/CMakeLists.txt" "cmake_minimum_required(VERSION 3.25)
project(missing LANGUAGES CXX)
find_package(fabrica REQUIRED COMPONENTS lines no_such_part)\n")
execute_process(COMMAND ${CMAKE_COMMAND} -S "${WORK}/missing" -B "${WORK}/missing/build" -G "${GENERATOR}"
                        "-DCMAKE_PREFIX_PATH=${prefix}"
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "has no component 'no_such_part'")
  message(FATAL_ERROR "find_package(fabrica COMPONENTS no_such_part) did not fail clearly (${rc}):\n${err}")
endif()

fabrica_build_project("${EXAMPLES}" "${WORK}/examples" ARGS "-DCMAKE_PREFIX_PATH=${prefix}")

fabrica_run("${WORK}/examples/apparent_ridges_svg" "${MESH}" "${WORK}/lines.svg" anterior)
file(READ "${WORK}/lines.svg" svg)
string(REGEX MATCHALL "<path " paths "${svg}")
list(LENGTH paths n_paths)
if(n_paths LESS 5 OR NOT svg MATCHES "</svg>")
  message(FATAL_ERROR "lines.svg: ${n_paths} path elements (expected a drawing)")
endif()

fabrica_run("${WORK}/examples/curvature_csv" "${MESH}" "${WORK}/curvature.csv")
fabrica_off_vertex_count("${MESH}" nv)
file(STRINGS "${WORK}/curvature.csv" rows)
list(POP_FRONT rows header)
list(LENGTH rows n_rows)
if(NOT header STREQUAL "vertex,k1,k2" OR NOT n_rows EQUAL nv)
  message(FATAL_ERROR "curvature.csv: header '${header}', ${n_rows} rows for ${nv} vertices")
endif()
set(number "-?[0-9]+(\\.[0-9]*)?([eE][-+]?[0-9]+)?")
set(index 0)
foreach(row IN LISTS rows)
  if(NOT row MATCHES "^${index},${number},${number}$")
    message(FATAL_ERROR "curvature.csv row ${index} is not 'vertex,k1,k2' with finite numbers: ${row}")
  endif()
  math(EXPR index "${index} + 1")
endforeach()
message(STATUS "install + find_package + examples: ${n_paths} SVG paths, ${n_rows} curvature rows")
