// fabrica._fabrica: the compiled part of the `fabrica` Python package
// (docs/python.md). Errors become Python exceptions carrying the CLI's
// one-line message: fabrica.InputError (a ValueError) for bad input,
// fabrica.OutputError (an OSError) when an output cannot be written,
// fabrica.UnavailableError (a RuntimeError) when a facility is missing.
#include "common.hpp"
#include "fabrica/core/error.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_fabrica, m) {
  m.doc() = "fabrica: feature lines, hatching and focus-and-context illustrations of meshes";
  static py::exception<fabrica::Error> error(m, "Error", PyExc_RuntimeError);
  static py::exception<fabrica::InputError> input_error(m, "InputError", PyExc_ValueError);
  static py::exception<fabrica::OutputError> output_error(m, "OutputError", PyExc_OSError);
  static py::exception<fabrica::Error> unavailable(m, "UnavailableError", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const fabrica::Error& e) {
      switch (e.kind()) {
        case fabrica::ErrorKind::input:
          input_error(e.what());
          break;
        case fabrica::ErrorKind::output:
          output_error(e.what());
          break;
        case fabrica::ErrorKind::unavailable:
          unavailable(e.what());
          break;
        default:
          error(e.what());
      }
    }
  });
  fabrica::python::bind_mesh(m);
  fabrica::python::bind_lines(m);
  fabrica::python::bind_draw(m);
}
