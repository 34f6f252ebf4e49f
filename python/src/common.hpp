// Shared pieces of the fabrica Python bindings (python/src/*.cpp).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/line_set.hpp"

namespace fabrica::python {

namespace py = pybind11;

/// A Surface made from a Mesh the way the CLI prepares it, with what the
/// preparation reported.
struct PySurface {
  std::shared_ptr<const Surface> surface;
  std::vector<std::string> notes;
};

/// A Mesh or Surface argument as a Surface (a Mesh is prepared as the CLI
/// does: oriented outward).
std::shared_ptr<PySurface> as_surface(const py::object& mesh_or_surface);
/// The TriangleMesh of a Mesh or Surface argument.
const TriangleMesh& as_mesh(const py::object& mesh_or_surface);

/// An (n, cols) array viewing `data` (no copy); `owner` stays alive as long
/// as the array does. Read-only.
template <typename T>
py::array view_array(const T* data, std::size_t rows, std::size_t cols, py::handle owner) {
  std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(rows)};
  std::vector<py::ssize_t> strides{static_cast<py::ssize_t>(cols * sizeof(T))};
  if (cols > 1) {
    shape.push_back(static_cast<py::ssize_t>(cols));
    strides.push_back(static_cast<py::ssize_t>(sizeof(T)));
  }
  py::array a(py::dtype::of<T>(), shape, strides, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

/// An array that takes over `values` (no copy): the vector moves into a
/// capsule that the array owns.
template <typename T>
py::array_t<T> own_array(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto* heap = new std::vector<T>(std::move(values));
  py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, heap->data(), owner);
}

std::vector<LineFamily> parse_families(const py::object& types,
                                       const std::vector<LineFamily>& fallback, bool allow_none);

void bind_mesh(py::module_& m);
void bind_lines(py::module_& m);
void bind_draw(py::module_& m);

}  // namespace fabrica::python
