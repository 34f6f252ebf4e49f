# Feature lines: per-view cost of every family, chaining and visibility on
# c3d_igea.ply (bench/bench_lines.cpp; docs/PERFORMANCE.md).
fabrica_add_bench(bench_lines
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_lines.cpp
  LIBS fabrica::lines fabrica::io TBB::tbb)
# A plain per-view driver for profilers (callgrind, perf): bench/drive_lines.cpp.
add_executable(drive_lines ${CMAKE_CURRENT_LIST_DIR}/drive_lines.cpp)
target_link_libraries(drive_lines PRIVATE fabrica::lines fabrica::io TBB::tbb fabrica::warnings)
target_compile_definitions(drive_lines PRIVATE FABRICA_BENCH_DATA="${FABRICA_BENCH_DATA}")
# Larger meshes from a small one for the scaling benchmark (bench/scale_lines.sh).
add_executable(scale_mesh ${CMAKE_CURRENT_LIST_DIR}/scale_mesh.cpp)
target_link_libraries(scale_mesh PRIVATE fabrica::io fabrica::warnings)
# Context meshes for the viewer's orbit benchmark (bench/viewer_orbit.sh).
add_executable(make_context ${CMAKE_CURRENT_LIST_DIR}/make_context.cpp)
target_link_libraries(make_context PRIVATE fabrica::io fabrica::core fabrica::warnings)
# The viewer's per-frame lines after extraction (chaining, merge_collinear)
# for profilers: bench/drive_viewer_lines.cpp.
if(TARGET fabrica_render AND TARGET fabrica_hatching)
  add_executable(drive_viewer_lines ${CMAKE_CURRENT_LIST_DIR}/drive_viewer_lines.cpp
    ${PROJECT_SOURCE_DIR}/apps/viewer/structure_lines.cpp)
  target_include_directories(drive_viewer_lines PRIVATE ${PROJECT_SOURCE_DIR}/apps/viewer
    ${CMAKE_CURRENT_LIST_DIR})
  target_link_libraries(drive_viewer_lines PRIVATE fabrica::render fabrica::hatching fabrica::lines
    fabrica::io TBB::tbb fabrica::warnings)
  target_compile_definitions(drive_viewer_lines PRIVATE FABRICA_BENCH_DATA="${FABRICA_BENCH_DATA}")
endif()
