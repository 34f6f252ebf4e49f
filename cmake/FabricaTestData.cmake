# The real meshes, label volumes and reference lines the tests and benchmarks
# read are bundled in the repository (tests/data/fabrica-test-data.tar.xz, its
# files listed in tests/data/MANIFEST.txt, their sources and licenses in
# tests/data/SOURCES.md). They are unpacked at configure time into
# ${PROJECT_BINARY_DIR}/test-data (data/ and reference/), again only when the
# archive changes. Nothing outside the repository is read.
set(FABRICA_TEST_DATA_ARCHIVE "${PROJECT_SOURCE_DIR}/tests/data/fabrica-test-data.tar.xz")
set(FABRICA_TEST_DATA_DIR "${PROJECT_BINARY_DIR}/test-data")
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${FABRICA_TEST_DATA_ARCHIVE}")
file(SHA256 "${FABRICA_TEST_DATA_ARCHIVE}" _fabrica_data_hash)
set(_fabrica_data_stamp "${FABRICA_TEST_DATA_DIR}/.unpacked-${_fabrica_data_hash}")
if(NOT EXISTS "${_fabrica_data_stamp}")
  message(STATUS "fabrica: unpacking the bundled test data into ${FABRICA_TEST_DATA_DIR}")
  file(REMOVE_RECURSE "${FABRICA_TEST_DATA_DIR}")
  file(ARCHIVE_EXTRACT INPUT "${FABRICA_TEST_DATA_ARCHIVE}" DESTINATION "${FABRICA_TEST_DATA_DIR}")
  file(TOUCH "${_fabrica_data_stamp}")
endif()
# Where tests/ and bench/ find the files (meshes under data/meshes/, rtsc
# reference lines under reference/rtsc/).
set(FABRICA_TEST_MESHES "${FABRICA_TEST_DATA_DIR}/data")
set(FABRICA_TEST_REFERENCE "${FABRICA_TEST_DATA_DIR}/reference")
