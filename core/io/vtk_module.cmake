# The VTK-backed parts of fabrica_io (.vtp reading, label-volume extraction,
# windowed-sinc smoothing) in a shared module, libfabrica_io_vtk.so, that
# fabrica_io loads with dlopen on first use (src/vtk_module.hpp): programs
# that read other formats never load VTK. The module is found through
# $FABRICA_IO_VTK_MODULE, then lib/fabrica beside the executable's bin
# folder, the installed lib/fabrica, the build tree's lib/fabrica.
# Without it those functions throw ErrorKind::unavailable (exit code 4).
if(NOT FABRICA_HAVE_VTK)
  return()
endif()
include(GNUInstallDirs)
set(_fabrica_vtk_modules
  VTK::IOXML VTK::CommonCore VTK::CommonDataModel VTK::CommonExecutionModel
  VTK::FiltersCore VTK::FiltersGeneral)
add_library(fabrica_io_vtk MODULE
  ${CMAKE_CURRENT_LIST_DIR}/src/vtk_module_entry.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/mesh_io_vtk.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/label_volume_extract.cpp)
# fabrica_io and fabrica_core go in as static copies, their symbols hidden:
# the module exports its entry point only.
target_link_libraries(fabrica_io_vtk PRIVATE
  fabrica_io fabrica::core fabrica::warnings TBB::tbb ${_fabrica_vtk_modules})
target_link_options(fabrica_io_vtk PRIVATE LINKER:--exclude-libs,ALL)
# Every symbol resolved at link time, except under clang's sanitizers and
# libFuzzer (FABRICA_FUZZ): their runtimes live in the executable only.
if(NOT (CMAKE_CXX_COMPILER_ID MATCHES "Clang" AND (FABRICA_SANITIZE OR FABRICA_FUZZ)))
  target_link_options(fabrica_io_vtk PRIVATE LINKER:--no-undefined)
endif()
set_target_properties(fabrica_io_vtk PROPERTIES
  CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON POSITION_INDEPENDENT_CODE ON
  LIBRARY_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/${CMAKE_INSTALL_LIBDIR}/fabrica)
vtk_module_autoinit(TARGETS fabrica_io_vtk MODULES ${_fabrica_vtk_modules})

target_sources(fabrica_io PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/vtk_module_loader.cpp)
target_link_libraries(fabrica_io PRIVATE ${CMAKE_DL_LIBS})
file(RELATIVE_PATH _fabrica_bin_to_module ${CMAKE_INSTALL_FULL_BINDIR}
  ${CMAKE_INSTALL_FULL_LIBDIR}/fabrica)
# (Compiled alone in unity builds: its definitions stay its own.)
set_property(SOURCE ${CMAKE_CURRENT_LIST_DIR}/src/vtk_module_loader.cpp PROPERTY
  SKIP_UNITY_BUILD_INCLUSION ON)
set_property(SOURCE ${CMAKE_CURRENT_LIST_DIR}/src/vtk_module_loader.cpp APPEND PROPERTY
  COMPILE_DEFINITIONS
    FABRICA_IO_VTK_FILE="$<TARGET_FILE_NAME:fabrica_io_vtk>"
    FABRICA_IO_VTK_RELATIVE_DIR="${_fabrica_bin_to_module}"
    FABRICA_IO_VTK_INSTALL_DIR="${CMAKE_INSTALL_FULL_LIBDIR}/fabrica"
    FABRICA_IO_VTK_BUILD_DIR="${PROJECT_BINARY_DIR}/${CMAKE_INSTALL_LIBDIR}/fabrica")
# (fabrica_io cannot depend on the module, which links it: the programs
# and tests do, apps/fabrica/CMakeLists.txt and tests/CMakeLists.txt.)
unset(_fabrica_vtk_modules)
unset(_fabrica_bin_to_module)
