# Geometry core: Surface precompute on a real scan (docs/PERFORMANCE.md).
fabrica_add_bench(bench_geometry
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_geometry.cpp
  LIBS fabrica::core fabrica::io TBB::tbb)
