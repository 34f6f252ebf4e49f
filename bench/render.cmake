# Rendering: hybrid apparent ridges vs bare passes vs object space (docs/PERFORMANCE.md).
if(TARGET fabrica_render AND TARGET fabrica_lines)
  fabrica_add_bench(bench_render
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_render.cpp
    LIBS fabrica::render fabrica::lines fabrica::io)
endif()
# Hidden-line removal's depth buffer: GL against the CPU raster (issue 22, item 3).
if(TARGET fabrica_render AND TARGET fabrica_lines)
  fabrica_add_bench(bench_gl_depth
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/gl_depth.cpp
    LIBS fabrica::render fabrica::lines fabrica::io)
endif()
