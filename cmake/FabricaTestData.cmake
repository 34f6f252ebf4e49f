# The real meshes, label volumes and reference lines the tests and benchmarks
# read are bundled in the repository: tests/data/*.tar.xz (each under 4 MB;
# their files listed in tests/data/MANIFEST.txt, sources and licenses in
# tests/data/SOURCES.md). They are unpacked at configure time into
# ${CMAKE_BINARY_DIR}/test-data (data/ and reference/), again only when an
# archive changes. Nothing outside the repository is read.
file(GLOB FABRICA_TEST_DATA_ARCHIVES "${CMAKE_CURRENT_SOURCE_DIR}/tests/data/*.tar.xz")
list(SORT FABRICA_TEST_DATA_ARCHIVES)
set(FABRICA_TEST_DATA_DIR "${CMAKE_BINARY_DIR}/test-data")
set(_fabrica_data_hashes "")
foreach(archive IN LISTS FABRICA_TEST_DATA_ARCHIVES)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${archive}")
  file(SHA256 "${archive}" _hash)
  string(APPEND _fabrica_data_hashes "${_hash}")
endforeach()
string(SHA256 _fabrica_data_hash "${_fabrica_data_hashes}")
set(_fabrica_data_stamp "${FABRICA_TEST_DATA_DIR}/.unpacked-${_fabrica_data_hash}")
if(NOT EXISTS "${_fabrica_data_stamp}")
  message(STATUS "fabrica: unpacking the bundled test data into ${FABRICA_TEST_DATA_DIR}")
  file(REMOVE_RECURSE "${FABRICA_TEST_DATA_DIR}")
  foreach(archive IN LISTS FABRICA_TEST_DATA_ARCHIVES)
    file(ARCHIVE_EXTRACT INPUT "${archive}" DESTINATION "${FABRICA_TEST_DATA_DIR}")
  endforeach()
  file(TOUCH "${_fabrica_data_stamp}")
endif()
# Where tests/ and bench/ find the files (meshes under data/meshes/, rtsc
# reference lines under reference/rtsc/).
set(FABRICA_TEST_MESHES "${FABRICA_TEST_DATA_DIR}/data")
set(FABRICA_TEST_REFERENCE "${FABRICA_TEST_DATA_DIR}/reference")
