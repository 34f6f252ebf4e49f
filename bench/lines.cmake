# Feature lines: per-view cost of every family, chaining and visibility on
# c3d_igea.ply (bench/bench_lines.cpp; docs/PERFORMANCE.md).
fabrica_add_bench(bench_lines
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_lines.cpp
  LIBS fabrica::lines fabrica::io TBB::tbb)
