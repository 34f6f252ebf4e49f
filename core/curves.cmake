# Curves on the surface (SurfaceCurve) and their smoothing (Lawonn et al. 2014).
target_sources(fabrica_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/surface_curve.cpp)
