# One interface target carries the house warnings and tuning flags.
add_library(fabrica_warnings INTERFACE)
add_library(fabrica::warnings ALIAS fabrica_warnings)
target_compile_options(fabrica_warnings INTERFACE
  $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Wno-unused-parameter>)
if(FABRICA_NATIVE)
  target_compile_options(fabrica_warnings INTERFACE -march=native)
endif()
