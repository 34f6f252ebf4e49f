# Curves on the surface: the representation (SurfaceCurve, surface_curve.cpp)
# and the curve smoother (Lawonn et al. 2014, curve_smoothing.cpp).
target_sources(fabrica_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/surface_curve.cpp
                                    ${CMAKE_CURRENT_LIST_DIR}/src/curve_smoothing.cpp)
