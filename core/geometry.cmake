# Differential-geometry core: Surface cache, normals, mixed Voronoi areas,
# cotan Laplacian, gradients, Rusinkiewicz curvature and derivatives.
set(_fabrica_geometry_sources
  ${CMAKE_CURRENT_LIST_DIR}/src/surface.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/geometry.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/curvature.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/laplacian.cpp
)
target_sources(fabrica_core PRIVATE ${_fabrica_geometry_sources})
# No fused multiply-adds: the AVX2 and baseline versions of the hot loops
# (geometry_kernels.hpp, FABRICA_MULTIVERSION), and -march=native builds,
# then give bit-identical results.
set_source_files_properties(${_fabrica_geometry_sources} PROPERTIES COMPILE_OPTIONS -ffp-contract=off)
# The AVX2 lane type of the curvature fits (curvature_fit_kernel.hpp): this
# file alone is compiled with -mavx2 (no FMA: -mavx2 does not enable it, and
# -ffp-contract=off), and called only when the CPU has AVX2.
fabrica_avx2_source(${CMAKE_CURRENT_LIST_DIR}/src/curvature_fit_avx2.cpp FABRICA_CURVATURE_AVX2)
