// Hatching strokes (fabrica.hatch) and the headless renderer (fabrica.render)
// when this build has them.
#include "common.hpp"
#include "fabrica/core/error.hpp"
#ifdef FABRICA_PY_HAVE_HATCHING
#include "fabrica/hatching/draw.hpp"
#include "fabrica/hatching/svg_writer.hpp"
#endif
#ifdef FABRICA_PY_HAVE_RENDER
#include "fabrica/render/annotate.hpp"
#include "fabrica/render/draw.hpp"
#endif

namespace fabrica::python {

namespace {

#ifdef FABRICA_PY_HAVE_HATCHING
struct PyStrokes {
  std::shared_ptr<const hatching::StrokeSet> strokes;
};

/// Stroke i's image points (cols 2) or surface positions (cols 3).
py::array_t<double> stroke_array(const PyStrokes& s, std::size_t i, int cols) {
  if (i >= s.strokes->strokes.size()) throw py::index_error("stroke index out of range");
  const auto& vertices = s.strokes->strokes[i].vertices;
  std::vector<double> values;
  values.reserve(vertices.size() * static_cast<std::size_t>(cols));
  for (const auto& v : vertices)
    for (int c = 0; c < cols; ++c) values.push_back(cols == 2 ? v.pixel[c] : v.position[c]);
  return own_array(std::move(values), {static_cast<py::ssize_t>(vertices.size()), cols});
}

void bind_hatching(py::module_& m) {
  py::class_<PyStrokes>(m, "Strokes",
                        "Hatching strokes: a sequence of (k, 2) image polylines (pixels); "
                        "positions(i) gives a stroke's points on the surface")
      .def("__len__", [](const PyStrokes& s) { return s.strokes->strokes.size(); })
      .def(
          "__getitem__",
          [](const PyStrokes& s, py::ssize_t i) {
            const auto n = static_cast<py::ssize_t>(s.strokes->strokes.size());
            if (i < 0) i += n;
            if (i < 0 || i >= n) throw py::index_error("stroke index out of range");
            return stroke_array(s, static_cast<std::size_t>(i), 2);
          },
          "Stroke i as a (k, 2) array of image coordinates (as points(i))")
      .def(
          "points", [](const PyStrokes& s, std::size_t i) { return stroke_array(s, i, 2); },
          py::arg("i"), "(k, 2) image coordinates of stroke i")
      .def(
          "positions", [](const PyStrokes& s, std::size_t i) { return stroke_array(s, i, 3); },
          py::arg("i"), "(k, 3) positions on the surface (mm) of stroke i")
      .def_property_readonly(
          "polylines",
          [](const PyStrokes& s) {
            py::list out;
            for (std::size_t i = 0; i < s.strokes->strokes.size(); ++i)
              out.append(stroke_array(s, i, 2));
            return out;
          },
          "every stroke as a (k, 2) array of image coordinates")
      .def(
          "weights",
          [](const PyStrokes& s, std::size_t i) {
            if (i >= s.strokes->strokes.size()) throw py::index_error("stroke index out of range");
            std::vector<double> values;
            for (const auto& v : s.strokes->strokes[i].vertices) values.push_back(v.weight);
            const auto n = static_cast<py::ssize_t>(values.size());
            return own_array(std::move(values), {n});
          },
          py::arg("i"),
          "(k,) style weights of stroke i in [0, 1] (width and opacity factor; 1 for shading "
          "strokes, ConFIS fades towards its masks' borders)")
      .def_property_readonly("width", [](const PyStrokes& s) { return s.strokes->width; })
      .def_property_readonly("height", [](const PyStrokes& s) { return s.strokes->height; })
      .def_property_readonly("grid_depth", [](const PyStrokes& s) { return s.strokes->grid_depth; })
      .def_property_readonly("seed_depth", [](const PyStrokes& s) { return s.strokes->seed_depth; })
      .def_property_readonly("ridge_count",
                             [](const PyStrokes& s) { return s.strokes->ridges.size(); })
      .def("__repr__", [](const PyStrokes& s) {
        return "<fabrica.Strokes " + std::to_string(s.strokes->strokes.size()) + " strokes>";
      });

  m.def(
      "hatch",
      [](const py::object& mesh, const Camera& camera, const std::string& light, double threshold,
         int grid_depth, int seed_depth, bool uniform_depth, double stroke_width, double max_length,
         std::optional<double> min_length, bool ridge_removal, double ridge_angle,
         const std::string& method, double contour_margin, double convex_threshold,
         double concave_threshold, double umbilic_threshold, double spacing, double min_weight,
         bool contours, bool features) {
        auto surface = as_surface(mesh);
        DrawHatchingOptions d;
        d.method = parse_hatching_method(method);
        d.light = light;
        hatching::ConfisOptions& c = d.confis;
        c.contour_margin = contour_margin;
        c.feature_regions.convex_threshold = convex_threshold;
        c.feature_regions.concave_threshold = concave_threshold;
        c.field.umbilic_threshold = umbilic_threshold;
        c.spacing_px = spacing;
        c.min_weight = min_weight;
        c.contours = contours;
        c.features = features;
        c.stroke_width_px = stroke_width;
        c.max_length_px = max_length;
        if (min_length) c.min_length_px = *min_length;
        hatching::HatchingOptions& o = d.hatching;
        o.intensity_threshold = threshold;
        o.grid_depth = grid_depth;
        o.seed_depth = seed_depth;
        o.adaptive_depth = !uniform_depth;
        o.stroke_width_px = stroke_width;
        o.max_length_px = max_length;
        o.min_length_px = min_length.value_or(1.0);
        o.ridge_removal = ridge_removal;
        o.ridges.min_angle_deg = ridge_angle;
        validate_camera(camera, "camera");
        py::gil_scoped_release release;
        return PyStrokes{std::make_shared<const hatching::StrokeSet>(
            draw_hatching(*surface->surface, camera, d))};
      },
      py::arg("mesh"), py::arg("camera"), py::arg("light") = "eye", py::arg("threshold") = 1.0,
      py::arg("grid_depth") = -1, py::arg("seed_depth") = -1, py::arg("uniform_depth") = false,
      py::arg("stroke_width") = 1.0, py::arg("max_length") = 0.0,
      py::arg("min_length") = py::none(), py::arg("ridge_removal") = true,
      py::arg("ridge_angle") = 20.0, py::arg("method") = "shading", py::arg("contour_margin") = 0.3,
      py::arg("convex_threshold") = 0.1, py::arg("concave_threshold") = 0.1,
      py::arg("umbilic_threshold") = 0.01, py::arg("spacing") = 6.0, py::arg("min_weight") = 0.15,
      py::arg("contours") = true, py::arg("features") = true,
      "Hatching strokes as `fabrica hatch` makes them. method: shading (Singh & Schaefer 2010; "
      "light is eye, dir:X,Y,Z, view:X,Y,Z or point:X,Y,Z) or confis (ConFIS streamlines, "
      "Lawonn et al. 2013: contour_margin ... features as the --contour-margin ... "
      "--no-features flags, docs/confis.md). min_length defaults to 1 (shading) or 8 (confis). "
      "A Mesh is prepared (oriented outward) first.");
  m.def(
      "write_hatching_svg",
      [](const PyStrokes& s, const std::string& path, double stroke_width, bool draw_ridges,
         bool background) {
        hatching::SvgStyle style;
        style.stroke_width_px = stroke_width;
        style.draw_ridges = draw_ridges;
        style.background = background;
        py::gil_scoped_release release;
        hatching::write_hatching_svg(path, *s.strokes, style);
      },
      py::arg("strokes"), py::arg("path"), py::arg("stroke_width") = 1.0,
      py::arg("draw_ridges") = false, py::arg("background") = true,
      "Writes the strokes as SVG exactly as `fabrica hatch -o x.svg` (without --with-lines)");
}
#endif

#ifdef FABRICA_PY_HAVE_RENDER
py::array_t<std::uint8_t> to_numpy(render::Image&& image) {
  const auto h = static_cast<py::ssize_t>(image.height), w = static_cast<py::ssize_t>(image.width);
  return own_array(std::move(image.rgba), {h, w, 4});
}

render::StructureSpec structure(const std::string& name, render::Role role) {
  render::StructureSpec s;
  s.name = name;
  s.role = role;
  s.style = render::default_style(role);
  return s;
}

void bind_render(py::module_& m) {
  m.def(
      "render",
      [](const py::object& mesh, const Camera& camera, const std::string& style,
         const py::object& lines, const py::list& context, double context_opacity, bool hybrid,
         bool transparent, std::optional<double> line_width, int smooth,
         const std::string& backend, bool lic, double lic_length, double lic_noise_scale,
         double lic_strength) {
        render::SceneSurfaces scene;
        render::StructureSpec focus = structure("focus", render::Role::focus);
        const auto shading = render::parse_shading(style);
        if (!shading)
          throw InputError("style must be lambert, toon, flat or none (got \"" + style + "\")");
        focus.style.shading = *shading;
        focus.style.families = parse_families(lines, focus.style.families, true);
        focus.style.hybrid_apparent_ridges = hybrid;
        focus.style.lic = lic;
        render::LicOptions lic_options;
        lic_options.kernel_length = lic_length;
        lic_options.noise_scale = lic_noise_scale;
        lic_options.strength = lic_strength;
        render::validate(lic_options, "lic");
        if (line_width) focus.style.lines.width = *line_width;
        if (smooth < 0) throw InputError("smooth must be >= 0 (iterations; 0 = off)");
        focus.style.smooth = smooth;
        scene.add(focus, as_surface(mesh)->surface);
        for (const auto& c : context) {
          render::StructureSpec s = structure("context", render::Role::context);
          s.style.opacity = context_opacity;
          s.style.smooth = smooth;
          scene.add(s, as_surface(py::reinterpret_borrow<py::object>(c))->surface);
        }
        validate_camera(camera, "camera");
        const render::HeadlessOptions headless = render::headless_options(backend);
        render::RenderOptions options;
        options.transparent_background = transparent;
        options.lic = lic_options;
        render::Image image;
        {
          py::gil_scoped_release release;
          image = render::render_scene(scene, camera, options, headless).image;
        }
        return to_numpy(std::move(image));
      },
      py::arg("mesh"), py::arg("camera"), py::arg("style") = "lambert",
      py::arg("lines") = py::none(), py::arg("context") = py::list(),
      py::arg("context_opacity") = 0.25, py::arg("hybrid") = false, py::arg("transparent") = false,
      py::arg("line_width") = py::none(), py::arg("smooth") = 0, py::arg("backend") = "",
      py::arg("lic") = false, py::arg("lic_length") = 8.0, py::arg("lic_noise_scale") = 0.0,
      py::arg("lic_strength") = 0.8,
      "Renders a Mesh or Surface (the focus) and optional context meshes headless (EGL or "
      "OSMesa) as `fabrica render` does; returns an (height, width, 4) uint8 RGBA array. "
      "lic=True adds the surface LIC (docs/lic.md; lic_length in noise cells, "
      "lic_noise_scale in mm with 0 = automatic, lic_strength in [0, 1]). "
      "UnavailableError when no headless OpenGL can be created.");
  m.def(
      "render_scene",
      [](const std::string& path, std::optional<Camera> camera, const std::string& view,
         std::optional<int> width, std::optional<int> height, const std::string& backend,
         const std::string& frame_name) {
        render::SceneSpec spec = render::read_scene_spec(path);
        std::optional<render::Frame> frame_override;
        if (!frame_name.empty()) {
          frame_override = render::parse_frame(frame_name);
          if (!frame_override)
            throw InputError("frame must be focus or all (got \"" + frame_name + "\")");
        }
        const render::Frame frame = render::default_frame(spec, frame_override);
        const render::HeadlessOptions headless = render::headless_options(backend);
        render::Image image;
        {
          py::gil_scoped_release release;
          const render::SceneSurfaces scene = render::load_scene(spec);
          Camera c;
          if (camera) {
            c = *camera;
          } else if (view.empty() && spec.camera) {
            c = *spec.camera;
          } else {
            const std::string name = !view.empty() ? view
                                     : spec.view   ? to_string(*spec.view)
                                                   : "anterior";
            const auto v = parse_anatomical_view(name);
            if (!v) throw InputError("view: unknown view \"" + name + "\"");
            c = render::view_camera(scene, *v, frame, width.value_or(1024), height.value_or(1024));
          }
          if (width) c.width = *width;  // as --size: a camera keeps its framing
          if (height) c.height = *height;
          validate_camera(c, "camera");
          render::RenderOptions options;
          options.transparent_background = spec.transparent;
          options.lic = spec.lic;
          image = render::render_scene(scene, c, options, headless).image;
          // The scene's "annotation" (labels, legend, ...), as `fabrica render` draws it.
          render::draw_annotation(image, render::annotate_scene(scene, c, spec.annotation).overlay);
        }
        return to_numpy(std::move(image));
      },
      py::arg("path"), py::arg("camera") = py::none(), py::arg("view") = "",
      py::arg("width") = py::none(), py::arg("height") = py::none(), py::arg("backend") = "",
      py::arg("frame") = "",
      "Renders a scene JSON (the `fabrica render scene.json` format) to an (h, w, 4) uint8 "
      "array, as `fabrica render scene.json [--camera] [--view] [--size WxH] [--frame]`: the "
      "camera given, else the scene's, else its view (anterior by default), framing the focus "
      "when the scene has focus and context (frame='all' frames everything); a view is framed "
      "at width x height (default 1024), a camera keeps its framing and takes the size, as "
      "--size does.");
  m.def(
      "write_png",
      [](const py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>& a,
         const std::string& path) {
        if (a.ndim() != 3 || a.shape(2) != 4)
          throw InputError("write_png: expected an (h, w, 4) uint8 array");
        render::Image image(static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0)));
        std::copy(a.data(), a.data() + a.size(), image.rgba.begin());
        py::gil_scoped_release release;
        render::write_png(image, path);
      },
      py::arg("image"), py::arg("path"), "Writes an (h, w, 4) uint8 RGBA array as PNG");
}
#endif

}  // namespace

void bind_draw(py::module_& m) {
#ifdef FABRICA_PY_HAVE_HATCHING
  bind_hatching(m);
#endif
#ifdef FABRICA_PY_HAVE_RENDER
  bind_render(m);
#endif
  m.attr("has_hatching") =
#ifdef FABRICA_PY_HAVE_HATCHING
      true;
#else
      false;
#endif
  m.attr("has_render") =
#ifdef FABRICA_PY_HAVE_RENDER
      true;
#else
      false;
#endif
}

}  // namespace fabrica::python
