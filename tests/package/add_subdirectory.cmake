# package.AddSubdirectory (cmake -P): a tiny project that pulls fabrica in
# with add_subdirectory(<fabrica source> fabrica_build) builds and runs.
#   -DSOURCE= -DWORK= -DMESH= -DGENERATOR= [-DLAUNCHER=ccache]
include(${CMAKE_CURRENT_LIST_DIR}/package_common.cmake)
fabrica_require(add_subdirectory.cmake SOURCE WORK MESH GENERATOR)
file(REMOVE_RECURSE "${WORK}")
# Only the program and the libraries it links are built. WORK sits beside
# the main build folder, so the libraries compile with the same relative
# paths and options as there, and ccache has them.
fabrica_build_project("${CMAKE_CURRENT_LIST_DIR}/subdirectory" "${WORK}" TARGET count_contours
  ARGS "-DFABRICA_SOURCE=${SOURCE}")
fabrica_run("${WORK}/count_contours" "${MESH}")
