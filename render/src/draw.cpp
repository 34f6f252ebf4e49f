#include "fabrica/render/draw.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

#include "cutaway_field.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/io/prepare.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/visibility.hpp"

namespace fabrica::render {

void SceneSurfaces::add(StructureSpec structure, std::shared_ptr<const Surface> surface) {
  const BoundingBox b = bounding_box(surface->positions());
  if (surfaces.empty()) {
    box = b;
    space = surface->mesh().space;
  } else {
    box.min = box.min.cwiseMin(b.min);
    box.max = box.max.cwiseMax(b.max);
  }
  if (structure.role == Role::focus) {
    focus_box =
        has_focus ? BoundingBox{focus_box.min.cwiseMin(b.min), focus_box.max.cwiseMax(b.max)} : b;
    has_focus = true;
  }
  spec.structures.push_back(std::move(structure));
  surfaces.push_back(std::move(surface));
}

SceneSurfaces load_scene(SceneSpec spec, const SurfaceLoader& loader) {
  SceneSurfaces scene;
  std::vector<StructureSpec> structures = std::move(spec.structures);
  scene.spec = std::move(spec);
  scene.spec.structures.clear();
  for (StructureSpec& s : structures) {
    std::shared_ptr<const Surface> surface = loader(s);
    if (surface->mesh().space_source == SpaceSource::default_assumed)
      scene.assumed_space.push_back(s.mesh.string());
    scene.add(std::move(s), std::move(surface));
  }
  return scene;
}

SceneSurfaces load_scene(SceneSpec spec) {
  return load_scene(std::move(spec), [](const StructureSpec& s) {
    PrepareOptions options;
    options.space = s.space;
    return std::make_shared<const Surface>(to_surface(prepare_mesh(s.mesh, options)));
  });
}

Camera view_camera(const SceneSurfaces& scene, AnatomicalView view, Frame frame, int width,
                   int height) {
  if (frame == Frame::focus && scene.has_focus)
    return fit_camera(view, scene.focus_box, scene.space, width, height);
  return anatomical_camera(view, scene.box, scene.space, width, height);
}

std::vector<LineFamily> object_space_families(const StructureStyle& style) {
  std::vector<LineFamily> families = style.families;
  if (style.hybrid_apparent_ridges)
    families.erase(std::remove(families.begin(), families.end(), LineFamily::apparent),
                   families.end());
  return families;
}

DrawLinesOptions structure_line_options(const StructureStyle& style,
                                        const LineOptions& thresholds) {
  DrawLinesOptions options;
  options.lines = thresholds;
  options.lines.families = object_space_families(style);
  options.min_length_px = 3.0;
  options.smooth = style.smooth;
  options.visibility = false;  // the renderer tests depth on the GPU
  return options;
}

Scene build_scene(const SceneSurfaces& scene, const Camera& camera) {
  Scene out;
  out.background = scene.spec.background;
  for (std::size_t i = 0; i < scene.surfaces.size(); ++i) {
    const StructureSpec& spec = scene.spec.structures[i];
    const Surface& surface = *scene.surfaces[i];
    Structure st;
    st.name = spec.name;
    st.role = spec.role;
    st.style = spec.style;
    auto mesh =
        std::make_shared<RenderMesh>(make_render_mesh(surface, st.style.hybrid_apparent_ridges));
    if (st.style.lic) set_lic_field(*mesh, scene.surfaces[i]);
    st.mesh = std::move(mesh);
    const DrawLinesOptions options = structure_line_options(st.style);
    if (!options.lines.families.empty()) st.lines = draw_lines(surface, camera, options).lines;
    st.style.families = options.lines.families;
    out.structures.push_back(std::move(st));
  }
  out.clip = scene.spec.clip;
  out.cutaway = scene.spec.cutaway;
  return out;
}

HeadlessOptions headless_options(const std::string& backend) {
  HeadlessOptions headless;
  if (!backend.empty()) {
    headless.backend = parse_backend(backend);
    if (!headless.backend || *headless.backend == Backend::glfw)
      throw InputError("--backend must be egl or osmesa (got \"" + backend + "\")");
  }
  return headless;
}

RenderedScene render_scene(Renderer& renderer, Scene drawn, const Camera& camera,
                           const RenderOptions& options) {
  RenderedScene out;
  out.scene = std::move(drawn);
  out.image = renderer.render(out.scene, camera, options);
  out.backend = renderer.context().backend();
  return out;
}

RenderedScene render_scene(Renderer& renderer, const SceneSurfaces& scene, const Camera& camera,
                           const RenderOptions& options) {
  return render_scene(renderer, build_scene(scene, camera), camera, options);
}

RenderedScene render_scene(const SceneSurfaces& scene, const Camera& camera,
                           const RenderOptions& options, const HeadlessOptions& headless) {
  Renderer renderer(create_headless_context(headless));
  return render_scene(renderer, scene, camera, options);
}

namespace {

/// The parts of `lines` whose vertices `keeps`: a polyline is cut where
/// its vertices leave the kept region (a clipping plane's side, as the GPU
/// clips the line quads; outside the cutaway).
template <typename Keeps>
LineSet keep_lines(const LineSet& lines, const Keeps& keeps) {
  LineSet out;
  for (const Polyline& pl : lines.polylines) {
    const std::size_t n = pl.vertices.size();
    std::size_t kept = 0;
    for (const auto& v : pl.vertices) kept += keeps(v.position);
    if (kept == n) {
      out.polylines.push_back(pl);
      continue;
    }
    for (std::size_t i = 0; i < n;) {
      if (!keeps(pl.vertices[i].position)) {
        ++i;
        continue;
      }
      std::size_t j = i;
      while (j < n && keeps(pl.vertices[j].position)) ++j;
      if (j - i >= 2) {
        Polyline part;
        part.family = pl.family;
        part.vertices.assign(pl.vertices.begin() + static_cast<std::ptrdiff_t>(i),
                             pl.vertices.begin() + static_cast<std::ptrdiff_t>(j));
        if (pl.edge_faces.size() + 1 >= n && pl.edge_faces.size() >= j - 1)
          part.edge_faces.assign(pl.edge_faces.begin() + static_cast<std::ptrdiff_t>(i),
                                 pl.edge_faces.begin() + static_cast<std::ptrdiff_t>(j - 1));
        out.polylines.push_back(std::move(part));
      }
      i = j;
    }
  }
  return out;
}

/// The cutaway of `drawn` for vector output (docs/algorithms.md §15), or
/// none when it does not apply (off, or no focus or no context).
std::unique_ptr<detail::CutawayField> cutaway_field(const SceneSurfaces& scene, const Scene& drawn,
                                                    const Camera& camera, double reference_size) {
  if (!drawn.cutaway.enabled) return nullptr;
  TriangleMesh focus;
  bool context = false;
  for (std::size_t i = 0; i < scene.surfaces.size(); ++i) {
    if (drawn.structures[i].role != Role::focus) {
      context = true;
      continue;
    }
    const TriangleMesh& m = scene.surfaces[i]->mesh();
    const auto base = static_cast<std::int32_t>(focus.positions.size());
    focus.positions.insert(focus.positions.end(), m.positions.begin(), m.positions.end());
    for (Face f : m.faces) focus.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
  }
  if (focus.faces.empty() || !context) return nullptr;
  const double scale = std::min(camera.width, camera.height) / std::max(1.0, reference_size);
  return std::make_unique<detail::CutawayField>(render_depth(focus, camera), camera, drawn.cutaway,
                                                scale);
}

/// Each drawn structure's lines with CPU visibility: a focus (opaque)
/// structure's lines hidden by the opaque structures, a ghosted one's by
/// every surface. With a cutaway, context lines are removed where it keeps
/// less than half of the surface, and context faces cut at all hide nothing
/// (as the GPU's depth passes drop them).
std::vector<LineSet> visible_lines(const SceneSurfaces& scene, const Scene& drawn,
                                   const Camera& camera, double reference_size) {
  const auto cut = cutaway_field(scene, drawn, camera, reference_size);
  TriangleMesh opaque, all;
  // A clipped (context) structure hides with the faces whose centroid the
  // plane keeps (and the cutaway keeps whole).
  auto append = [&](TriangleMesh& dst, const TriangleMesh& src, const ClipPlane* clip,
                    bool context) {
    const auto base = static_cast<std::int32_t>(dst.positions.size());
    dst.positions.insert(dst.positions.end(), src.positions.begin(), src.positions.end());
    for (Face f : src.faces) {
      const Vec3 centroid = (src.positions[f[0]] + src.positions[f[1]] + src.positions[f[2]]) / 3.0;
      if (clip != nullptr && !clip->keeps(centroid)) continue;
      if (cut && context && cut->keep(centroid) < 1.0) continue;
      dst.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
    }
  };
  auto clip_of = [&](std::size_t i) {
    return drawn.clip && drawn.structures[i].role == Role::context ? &*drawn.clip : nullptr;
  };
  for (std::size_t i = 0; i < scene.surfaces.size(); ++i) {
    const bool context = drawn.structures[i].role == Role::context;
    append(all, scene.surfaces[i]->mesh(), clip_of(i), context);
    if (drawn.structures[i].style.opacity >= 0.999)
      append(opaque, scene.surfaces[i]->mesh(), clip_of(i), context);
  }
  // When every structure is opaque (a single mesh, say) the two buffers are
  // the same: rasterise once (at 2048² this pass was a tenth of an item).
  const bool all_opaque = opaque.faces.size() == all.faces.size();
  DepthBuffer depth_all = render_depth(all, camera);
  const DepthBuffer depth_opaque =
      opaque.faces.empty() || all_opaque ? DepthBuffer{} : render_depth(opaque, camera);
  const DepthBuffer& opaque_depth = opaque.faces.empty() || all_opaque ? depth_all : depth_opaque;
  std::vector<LineSet> out;
  for (std::size_t i = 0; i < scene.surfaces.size(); ++i) {
    LineSet ls = clip_of(i) ? keep_lines(drawn.structures[i].drawn_lines(),
                                         [&](const Vec3& p) { return clip_of(i)->keeps(p); })
                            : drawn.structures[i].drawn_lines();
    if (cut && drawn.structures[i].role == Role::context)
      ls = keep_lines(ls, [&](const Vec3& p) { return cut->keep(p) >= 0.5; });
    compute_visibility(ls, *scene.surfaces[i], camera, {},
                       drawn.structures[i].style.opacity >= 0.999 ? &opaque_depth : &depth_all);
    out.push_back(std::move(ls));
  }
  return out;
}

}  // namespace

LineSet vector_lines(const SceneSurfaces& scene, const Scene& drawn, const Camera& camera) {
  LineSet merged;
  for (const LineSet& ls : visible_lines(scene, drawn, camera, 1024.0))
    merged.polylines.insert(merged.polylines.end(), ls.polylines.begin(), ls.polylines.end());
  return merged;
}

std::vector<LineLayer> vector_layers(const SceneSurfaces& scene, const Scene& drawn,
                                     const Camera& camera, double reference_size) {
  std::vector<LineSet> lines = visible_lines(scene, drawn, camera, reference_size);
  std::vector<LineLayer> out;
  for (Role role : {Role::context, Role::focus}) {
    for (std::size_t i = 0; i < drawn.structures.size(); ++i) {
      const Structure& st = drawn.structures[i];
      if (st.role != role) continue;
      const render::LineStyle& ls = st.style.lines;
      LineLayer layer;
      layer.name = st.name;
      layer.role = to_string(st.role);
      layer.color = to_hex(ls.color);
      layer.opacity = std::clamp(static_cast<double>(ls.color.a), 0.0, 1.0);
      layer.dash = ls.dash;
      layer.style.width_px = ls.width;
      layer.style.reference_size = reference_size;
      layer.style.contour_factor = ls.contour_width_factor;
      layer.style.width_from_strength = ls.width_by_strength;
      layer.style.opacity_from_strength = ls.fade_by_strength;
      layer.style.taper_fraction = ls.taper;
      layer.style.hidden_opacity = ls.hidden_opacity;
      // As the line shader: dashed or shown (solid) at the hidden opacity.
      layer.style.hidden = ls.hidden == HiddenLines::dashed ? fabrica::HiddenLines::dashed
                           : ls.hidden == HiddenLines::show ? fabrica::HiddenLines::solid
                                                            : fabrica::HiddenLines::omit;
      layer.lines = std::move(lines[i]);
      out.push_back(std::move(layer));
    }
  }
  return out;
}

void write_scene_svg(const std::filesystem::path& path, const SceneSurfaces& scene,
                     const Scene& drawn, const Camera& camera, double reference_size,
                     const VectorOverlay* overlay) {
  write_layered_svg(path, vector_layers(scene, drawn, camera, reference_size), camera, overlay);
}

void write_scene_pdf(const std::filesystem::path& path, const SceneSurfaces& scene,
                     const Scene& drawn, const Camera& camera, double reference_size,
                     const VectorOverlay* overlay) {
  write_layered_pdf(path, vector_layers(scene, drawn, camera, reference_size), camera, overlay);
}

}  // namespace fabrica::render
