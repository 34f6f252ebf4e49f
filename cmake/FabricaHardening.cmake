# Hardening builds (docs/reliability.md), each in its own build folder:
#   -DFABRICA_SANITIZE=address,undefined   the whole project and its tests under
#                                          ASan + UBSan (scripts/sanitize-test)
#   -DFABRICA_SANITIZE_FAST=ON             ...built cheaply for CI: unity build
#                                          (batches of sources per translation
#                                          unit), -O1 and line tables only (-g1)
#   -DFABRICA_FUZZ=ON (with clang)         libFuzzer targets of every reader in
#                                          fuzz/ (scripts/fuzz-smoke)
set(FABRICA_SANITIZE "" CACHE STRING "Sanitizers for every target, e.g. address,undefined")
option(FABRICA_FUZZ "Build the libFuzzer targets of the readers (clang only)" OFF)
if(FABRICA_FUZZ AND NOT FABRICA_SANITIZE)
  set(FABRICA_SANITIZE address,undefined)
endif()
option(FABRICA_SANITIZE_FAST "Build the sanitizer tree cheaply: unity build, -O1, line tables only" OFF)
if(FABRICA_SANITIZE)
  add_compile_options(-fsanitize=${FABRICA_SANITIZE} -fno-omit-frame-pointer
                      -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${FABRICA_SANITIZE})
  if(FABRICA_SANITIZE_FAST)
    # After the build type's flags, so -O1 and -g1 win over -O2 and -g; the
    # build type still decides NDEBUG. -g1 keeps file:line in the reports.
    add_compile_options(-O1 -g1)
    # Every target defined after this point (the whole project) is a unity
    # build; a source that cannot share a translation unit says so with
    # SKIP_UNITY_BUILD_INCLUSION next to its target.
    set(CMAKE_UNITY_BUILD ON)
    if(NOT DEFINED CMAKE_UNITY_BUILD_BATCH_SIZE)
      set(CMAKE_UNITY_BUILD_BATCH_SIZE 8)
    endif()
  endif()
endif()
if(FABRICA_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "FABRICA_FUZZ needs clang (CXX=clang++-14; Debian clang-14, libclang-rt-14-dev)")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()
