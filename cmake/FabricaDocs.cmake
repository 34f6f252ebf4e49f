# `fabrica_docs`: the API reference of the public headers (Doxygen HTML in
# BUILD/docs/api/html/index.html), with docs/library.md as its main page.
# Only when Doxygen is found; not part of the default build.
find_package(Doxygen QUIET)
if(NOT DOXYGEN_FOUND)
  message(STATUS "fabrica: Doxygen not found: no fabrica_docs target (install doxygen)")
  return()
endif()
set(DOXYGEN_PROJECT_NAME fabrica)
set(DOXYGEN_PROJECT_NUMBER ${PROJECT_VERSION})
set(DOXYGEN_PROJECT_BRIEF "Illustrations of anatomy meshes: feature lines, hatching, focus-and-context rendering")
set(DOXYGEN_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/docs/api)
set(DOXYGEN_USE_MDFILE_AS_MAINPAGE ${PROJECT_SOURCE_DIR}/docs/library.md)
set(DOXYGEN_EXAMPLE_PATH ${PROJECT_SOURCE_DIR}/examples/cpp)
set(DOXYGEN_STRIP_FROM_PATH ${PROJECT_SOURCE_DIR})
set(DOXYGEN_STRIP_FROM_INC_PATH ${PROJECT_SOURCE_DIR}/core/include ${PROJECT_SOURCE_DIR}/core/io/include
    ${PROJECT_SOURCE_DIR}/lines/include ${PROJECT_SOURCE_DIR}/hatching/include
    ${PROJECT_SOURCE_DIR}/render/include)
set(DOXYGEN_EXCLUDE_SYMBOLS "detail" "*::detail::*")
set(DOXYGEN_EXTRACT_ALL YES)
set(DOXYGEN_WARN_IF_UNDOCUMENTED NO)
set(DOXYGEN_QUIET YES)
set(DOXYGEN_GENERATE_TREEVIEW YES)
set(DOXYGEN_FULL_PATH_NAMES YES)
set(DOXYGEN_FILE_PATTERNS *.hpp *.h)
doxygen_add_docs(fabrica_docs
  ${PROJECT_SOURCE_DIR}/core/include ${PROJECT_SOURCE_DIR}/core/io/include
  ${PROJECT_SOURCE_DIR}/lines/include ${PROJECT_SOURCE_DIR}/hatching/include
  ${PROJECT_SOURCE_DIR}/render/include ${PROJECT_SOURCE_DIR}/docs/library.md
  COMMENT "Doxygen: the API reference -> ${PROJECT_BINARY_DIR}/docs/api/html/index.html")
