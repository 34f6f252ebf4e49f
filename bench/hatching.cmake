# Shading-stroke hatching at 800², with and without intensity-ridge removal.
if(TARGET fabrica_hatching AND TARGET fabrica_io)
  fabrica_add_bench(bench_hatching
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_hatching.cpp
    LIBS fabrica::hatching fabrica::io)
endif()
