# Differential-geometry core: Surface cache, normals, mixed Voronoi areas,
# cotan Laplacian, gradients, Rusinkiewicz curvature and derivatives.
target_sources(fabrica_core PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/src/surface.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/geometry.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/curvature.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/laplacian.cpp
)
