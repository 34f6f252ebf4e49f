# Hardening builds (docs/reliability.md), each in its own build folder:
#   -DFABRICA_SANITIZE=address,undefined   the whole project and its tests under
#                                          ASan + UBSan (scripts/sanitize-test)
#   -DFABRICA_FUZZ=ON (with clang)         libFuzzer targets of every reader in
#                                          fuzz/ (scripts/fuzz-smoke)
set(FABRICA_SANITIZE "" CACHE STRING "Sanitizers for every target, e.g. address,undefined")
option(FABRICA_FUZZ "Build the libFuzzer targets of the readers (clang only)" OFF)
if(FABRICA_FUZZ AND NOT FABRICA_SANITIZE)
  set(FABRICA_SANITIZE address,undefined)
endif()
if(FABRICA_SANITIZE)
  add_compile_options(-fsanitize=${FABRICA_SANITIZE} -fno-omit-frame-pointer
                      -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${FABRICA_SANITIZE})
endif()
if(FABRICA_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "FABRICA_FUZZ needs clang (CXX=clang++-14; Debian clang-14, libclang-rt-14-dev)")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()
