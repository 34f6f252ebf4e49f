// Feature lines: fabrica.lines / LineDrawer -> Lines (a sequence of Line),
// and the SVG, PDF and JSON writers of `fabrica lines`.
#include <algorithm>
#include <cmath>
#include <mutex>

#include "common.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/writers.hpp"

namespace fabrica::python {

namespace {

/// A drawing seen through the camera it was drawn for.
struct PyLines {
  std::shared_ptr<const LineDrawing> drawing;
  Camera camera;
  std::shared_ptr<PySurface> surface;
  DrawLinesOptions options;
};

struct PyLine {
  std::shared_ptr<const PyLines> lines;
  std::size_t index = 0;
  const Polyline& polyline() const { return lines->drawing->lines.polylines[index]; }
};

std::string family_names() {
  std::string names;
  for (auto g : all_families()) names += std::string(names.empty() ? "" : ", ") + family_name(g);
  return names;
}

}  // namespace

std::vector<LineFamily> parse_families(const py::object& types,
                                       const std::vector<LineFamily>& fallback, bool allow_none) {
  if (types.is_none()) return fallback;
  std::vector<std::string> names;
  if (py::isinstance<py::str>(types)) {
    const std::string text = types.cast<std::string>();
    if (text == "default") return fallback;
    if (text == "all") return all_families();
    if (text == "reference" || text == "rtsc") return reference_families();
    if (allow_none && text == "none") return {};
    std::size_t start = 0;
    while (start <= text.size()) {
      const std::size_t comma = std::min(text.find(',', start), text.size());
      names.push_back(text.substr(start, comma - start));
      start = comma + 1;
    }
  } else {
    names = types.cast<std::vector<std::string>>();
  }
  std::vector<LineFamily> out;
  for (const std::string& name : names) {
    if (name.empty()) continue;
    const auto f = parse_family(name);
    if (!f)
      throw InputError("types: unknown line family \"" + name + "\" (known: " + family_names() +
                       ", or default, reference, all)");
    if (std::find(out.begin(), out.end(), *f) == out.end()) out.push_back(*f);
  }
  if (out.empty() && !allow_none) throw InputError("types: no line family given");
  return out;
}

namespace {

DrawLinesOptions lines_options(const py::object& types, double min_length, int smooth,
                               bool visibility, double feature_size, const py::dict& thresholds,
                               const std::optional<std::vector<double>>& light,
                               bool mesh_edge_contours, bool fade,
                               const std::optional<double>& crease_angle) {
  DrawLinesOptions d;
  LineOptions& o = d.lines;
  o.families = parse_families(types, LineOptions{}.families, false);
  o.feature_size = feature_size;
  o.contour.mesh_edges = mesh_edge_contours;
  for (const auto& [key, value] : thresholds) {
    const std::string k = key.cast<std::string>();
    const double t = value.cast<double>();
    const auto family = parse_family(k);
    double* threshold = family ? family_threshold(o, *family) : nullptr;
    if (!threshold) {
      std::string names;
      for (LineFamily f : thresholded_families())
        names += std::string(names.empty() ? "" : ", ") + family_name(f);
      throw InputError("thresholds: \"" + k + "\" has no threshold (families with one: " + names +
                       ")");
    }
    *threshold = t;
  }
  if (crease_angle) o.crease.angle_deg = *crease_angle;
  if (!fade) o.suggestive.fade = o.highlight.fade = 0.0;
  if (light) {
    if (light->size() != 3 || !std::isfinite((*light)[0]) || !std::isfinite((*light)[1]) ||
        !std::isfinite((*light)[2]) || Vec3((*light)[0], (*light)[1], (*light)[2]).norm() == 0.0)
      throw InputError("light: expected a non-zero direction (x, y, z)");
    o.pel.light_direction = o.laplacian.light_direction =
        Vec3((*light)[0], (*light)[1], (*light)[2]);
  }
  d.min_length_px = min_length;
  d.smooth = smooth;
  d.visibility = visibility;
  validate(d);
  return d;
}

/// The lines drawer of Python: a LineDrawer and the Surface it keeps alive.
/// draw() runs without the GIL; the drawer's per-view buffers take one
/// camera at a time (other threads wait).
struct PyLineDrawer {
  std::shared_ptr<PySurface> surface;
  std::unique_ptr<LineDrawer> drawer;
  std::unique_ptr<std::mutex> busy = std::make_unique<std::mutex>();

  std::shared_ptr<PyLines> draw(const Camera& camera) {
    validate_camera(camera, "camera");
    auto out = std::make_shared<PyLines>();
    out->camera = camera;
    out->surface = surface;
    out->options = drawer->options();
    py::gil_scoped_release release;
    const std::lock_guard<std::mutex> lock(*busy);
    out->drawing = std::make_shared<const LineDrawing>(drawer->draw(camera));
    return out;
  }
};

LineStyle line_style(double width, const std::string& hidden, bool taper) {
  LineStyle style;
  if (!(width > 0.0) || !std::isfinite(width)) throw InputError("width: must be a positive number");
  style.width_px = width;
  if (hidden == "dashed")
    style.hidden = HiddenLines::dashed;
  else if (hidden != "omit")
    throw InputError("hidden: use omit or dashed (got \"" + hidden + "\")");
  if (!taper) style.taper_fraction = 0.0;
  return style;
}

template <typename Get>
py::array line_values(const PyLine& line, int cols, Get get) {
  const Polyline& p = line.polyline();
  using T = decltype(get(p.vertices.front(), 0));
  std::vector<T> values;
  values.reserve(p.vertices.size() * cols);
  for (const LineVertex& v : p.vertices)
    for (int c = 0; c < cols; ++c) values.push_back(get(v, c));
  std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(p.vertices.size())};
  if (cols > 1) shape.push_back(cols);
  return own_array(std::move(values), shape);
}

/// write_svg / write_pdf: the same arguments, the same style.
using Writer = void (*)(const std::filesystem::path&, const LineSet&, const Camera&,
                        const LineStyle&);
void bind_writer(py::module_& m, const char* name, Writer writer, const char* doc) {
  m.def(
      name,
      [writer](const PyLines& l, const std::optional<Camera>& camera, const std::string& path,
               double width, const std::string& hidden, bool taper) {
        const LineStyle style = line_style(width, hidden, taper);
        py::gil_scoped_release release;
        writer(path, l.drawing->lines, camera.value_or(l.camera), style);
      },
      py::arg("lines"), py::arg("camera"), py::arg("path"), py::arg("width") = 1.2,
      py::arg("hidden") = "omit", py::arg("taper") = true, doc);
}

}  // namespace

void bind_lines(py::module_& m) {
  py::class_<PyLine>(m, "Line", "One chained polyline of a line family")
      .def_property_readonly(
          "family", [](const PyLine& l) { return std::string(family_name(l.polyline().family)); })
      .def_property_readonly("closed", [](const PyLine& l) { return l.polyline().closed; })
      .def_property_readonly(
          "points",
          [](const PyLine& l) {
            const Camera& camera = l.lines->camera;
            return line_values(l, 2, [&camera](const LineVertex& v, int c) {
              return project(camera, v.position).pixel[c];
            });
          },
          "(k, 2) float64 image coordinates in pixels (x right, y down)")
      .def_property_readonly(
          "positions",
          [](const PyLine& l) {
            return line_values(l, 3, [](const LineVertex& v, int c) { return v.position[c]; });
          },
          "(k, 3) float64 positions on the surface (mm)")
      .def_property_readonly(
          "strength",
          [](const PyLine& l) {
            return line_values(l, 1, [](const LineVertex& v, int) { return v.strength; });
          },
          "(k,) float32 in [0, 1]: fade/width factor")
      .def_property_readonly(
          "visible",
          [](const PyLine& l) -> py::object {
            return line_values(l, 1,
                               [](const LineVertex& v, int) {
                                 return static_cast<std::uint8_t>(v.visible);
                               })
                .attr("view")("bool");
          },
          "(k,) bool: the vertex and the edge that starts there are visible")
      .def_property_readonly(
          "faces",
          [](const PyLine& l) {
            return line_values(l, 1, [](const LineVertex& v, int) { return v.anchor.face; });
          },
          "(k,) int32: the mesh face each vertex lies on")
      .def_property_readonly(
          "bary",
          [](const PyLine& l) {
            return line_values(l, 3, [](const LineVertex& v, int c) { return v.anchor.bary[c]; });
          },
          "(k, 3) float64 barycentric coordinates in that face")
      .def("__len__", [](const PyLine& l) { return l.polyline().vertices.size(); })
      .def("__repr__", [](const PyLine& l) {
        return std::string("<fabrica.Line ") + family_name(l.polyline().family) + ", " +
               std::to_string(l.polyline().vertices.size()) + " points" +
               (l.polyline().closed ? ", closed>" : ">");
      });

  py::class_<PyLines, std::shared_ptr<PyLines>>(
      m, "Lines",
      "The lines of one drawing: a sequence of Line, with the camera they were drawn for")
      .def("__len__", [](const PyLines& l) { return l.drawing->lines.polylines.size(); })
      .def("__getitem__",
           [](const std::shared_ptr<PyLines>& l, py::ssize_t i) {
             const auto n = static_cast<py::ssize_t>(l->drawing->lines.polylines.size());
             if (i < 0) i += n;
             if (i < 0 || i >= n) throw py::index_error("line index out of range");
             return PyLine{l, static_cast<std::size_t>(i)};
           })
      .def_property_readonly("camera", [](const PyLines& l) { return l.camera; })
      .def_property_readonly("feature_size",
                             [](const PyLines& l) { return l.drawing->feature_size; })
      .def_property_readonly(
          "segments",
          [](const PyLines& l) {
            py::dict d;
            for (const auto& [family, count] : l.drawing->segments) d[family_name(family)] = count;
            return d;
          },
          "raw segments extracted per family (before chaining)")
      .def(
          "to_json",
          [](const PyLines& l) {
            nlohmann::json header =
                drawing_header(*l.drawing, *l.surface->surface, l.camera, l.options);
            return lines_to_json(l.drawing->lines, header).dump(1);
          },
          "The JSON `fabrica lines -o x.json` writes (without its mesh and source keys)")
      .def("__repr__", [](const PyLines& l) {
        return "<fabrica.Lines " + std::to_string(l.drawing->lines.polylines.size()) +
               " polylines>";
      });

  py::class_<PyLineDrawer>(m, "LineDrawer",
                           "Draws the lines of one Surface for many cameras, keeping the "
                           "view-independent precomputation (orbits, batches of views).")
      .def(py::init([](const py::object& mesh, const py::object& types, double min_length,
                       int smooth, bool visibility, double feature_size, const py::dict& thresholds,
                       const std::optional<std::vector<double>>& light, bool mesh_edge_contours,
                       bool fade, const std::optional<double>& crease_angle) {
             auto d = std::make_unique<PyLineDrawer>();
             d->surface = as_surface(mesh);
             const DrawLinesOptions options =
                 lines_options(types, min_length, smooth, visibility, feature_size, thresholds,
                               light, mesh_edge_contours, fade, crease_angle);
             py::gil_scoped_release release;
             d->drawer = std::make_unique<LineDrawer>(*d->surface->surface, options);
             return d;
           }),
           py::arg("mesh"), py::arg("types") = py::none(), py::arg("min_length") = 3.0,
           py::arg("smooth") = 0, py::arg("visibility") = true, py::arg("feature_size") = 0.0,
           py::arg("thresholds") = py::dict(), py::arg("light") = py::none(),
           py::arg("mesh_edge_contours") = false, py::arg("fade") = true,
           py::arg("crease_angle") = py::none())
      .def("draw", &PyLineDrawer::draw, py::arg("camera"), "The Lines seen by `camera`")
      .def_property_readonly("feature_size",
                             [](const PyLineDrawer& d) { return d.drawer->feature_size(); })
      .def_property_readonly("surface", [](const PyLineDrawer& d) { return d.surface; });

  m.def(
      "lines",
      [](const py::object& mesh, const Camera& camera, const py::object& types, double min_length,
         int smooth, bool visibility, double feature_size, const py::dict& thresholds,
         const std::optional<std::vector<double>>& light, bool mesh_edge_contours, bool fade,
         const std::optional<double>& crease_angle) {
        PyLineDrawer d;
        d.surface = as_surface(mesh);
        const DrawLinesOptions options =
            lines_options(types, min_length, smooth, visibility, feature_size, thresholds, light,
                          mesh_edge_contours, fade, crease_angle);
        {
          py::gil_scoped_release release;
          d.drawer = std::make_unique<LineDrawer>(*d.surface->surface, options);
        }
        return d.draw(camera);
      },
      py::arg("mesh"), py::arg("camera"), py::arg("types") = py::none(),
      py::arg("min_length") = 3.0, py::arg("smooth") = 0, py::arg("visibility") = true,
      py::arg("feature_size") = 0.0, py::arg("thresholds") = py::dict(),
      py::arg("light") = py::none(), py::arg("mesh_edge_contours") = false, py::arg("fade") = true,
      py::arg("crease_angle") = py::none(),
      "Feature lines of a Mesh or Surface seen by `camera`, as `fabrica lines` draws them: "
      "types is a list of families (contour, boundary, crease, suggestive, highlight, ridge, "
      "valley, apparent, pel, laplacian, demarcating) or 'default', 'reference', 'all'; "
      "thresholds maps a family to its dimensionless threshold; min_length drops chains "
      "shorter than so many pixels; smooth > 0 smooths on the surface; visibility removes "
      "hidden lines. A Mesh is prepared (oriented outward) first.");

  bind_writer(m, "write_svg", &write_svg,
              "Writes the lines as SVG exactly as `fabrica lines -o x.svg` (width in pixels at "
              "1024 px; hidden 'omit' or 'dashed'). camera=None uses the lines' own.");
  m.def(
      "svg_string",
      [](const PyLines& l, const std::optional<Camera>& camera, double width,
         const std::string& hidden, bool taper) {
        return svg_string(l.drawing->lines, camera.value_or(l.camera),
                          line_style(width, hidden, taper));
      },
      py::arg("lines"), py::arg("camera") = py::none(), py::arg("width") = 1.2,
      py::arg("hidden") = "omit", py::arg("taper") = true, "The SVG document as text");
  bind_writer(m, "write_pdf", &write_pdf,
              "Writes the lines as vector PDF (cairo); UnavailableError when this build lacks it.");
  m.def("pdf_available", &pdf_available);
  m.def(
      "write_lines_json",
      [](const PyLines& l, const std::string& path) {
        nlohmann::json header =
            drawing_header(*l.drawing, *l.surface->surface, l.camera, l.options);
        py::gil_scoped_release release;
        write_lines_json(path, l.drawing->lines, header);
      },
      py::arg("lines"), py::arg("path"), "Writes the lines as fabrica-lines JSON");
  m.def(
      "families",
      [] {
        std::vector<std::string> names;
        for (auto f : all_families()) names.emplace_back(family_name(f));
        return names;
      },
      "Every line family's name");
}

}  // namespace fabrica::python
