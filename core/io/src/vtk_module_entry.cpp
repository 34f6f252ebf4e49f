// The entry point of libfabrica_io_vtk.so (src/vtk_module.hpp): the only
// symbol the module exports.
#include "vtk_module.hpp"

extern "C" __attribute__((visibility("default"))) const fabrica::io::detail::VtkModule*
FABRICA_IO_VTK_ENTRY() {
  static const fabrica::io::detail::VtkModule table = [] {
    fabrica::io::detail::VtkModule t;
    t.read_vtp = &fabrica::io::detail::read_vtp_with_vtk;
    t.extract_surfaces = &fabrica::io::detail::extract_surfaces_with_vtk;
    t.smooth_surface = &fabrica::io::detail::smooth_surface_with_vtk;
    return t;
  }();
  return &table;
}
