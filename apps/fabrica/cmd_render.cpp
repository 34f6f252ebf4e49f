// `fabrica render MESH_OR_SCENE [--camera FILE | --view NAME] [--style S]
//  [--lines LIST] [--hybrid-ar] [--context MESH ...] [--size WxH]
//  [--transparent] [--backend egl|osmesa] [--svg OUT.svg] -o OUT.png`:
// headless illustration (docs/rendering.md). A mesh is drawn as the focus
// structure, each --context mesh as a ghosted context structure; a scene
// JSON describes several structures with their roles and styles.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/smooth.hpp"
#include "fabrica/lines/visibility.hpp"
#include "fabrica/lines/writers.hpp"
#include "fabrica/render/renderer.hpp"

namespace fabrica::cli {
namespace {

struct RenderArgs {
  std::string input, camera_file, view, style, lines, size, backend, output, svg, hidden, space;
  std::string save_scene, save_camera;
  std::vector<std::string> context;
  std::optional<double> tau, lambda, threshold, line_width, context_opacity;
  std::optional<int> smooth;
  bool hybrid = false, transparent = false, no_fade = false, per_fragment = false,
       sign_free = false, float_target = false, quiet = false;
};

struct Loaded {
  render::StructureSpec spec;
  std::shared_ptr<const Surface> surface;
  render::Structure structure;
};

int run_render(const RenderArgs& a) {
  const std::filesystem::path out_path(a.output);
  if (lower(out_path.extension().string()) != ".png")
    throw InputError("-o " + a.output + ": the image must end in .png");
  if (!a.svg.empty() && lower(std::filesystem::path(a.svg).extension().string()) != ".svg")
    throw InputError("--svg " + a.svg + ": must end in .svg");
  if (!a.camera_file.empty() && !a.view.empty())
    throw InputError("give either --camera FILE or --view NAME, not both");
  // Every output's folder must exist before any is written (no half set of outputs).
  for (const std::string& f : {a.output, a.svg, a.save_scene, a.save_camera}) {
    const auto parent = std::filesystem::path(f).parent_path();
    if (!f.empty() && !parent.empty() && !std::filesystem::is_directory(parent))
      throw OutputError(f + ": cannot write: folder " + parent.string() + " does not exist");
  }

  // 1. The scene description: a scene JSON, or the mesh as focus plus contexts.
  render::SceneSpec spec;
  const std::string ext = lower(std::filesystem::path(a.input).extension().string());
  if (ext == ".json") {
    spec = render::read_scene_spec(a.input);
  } else {
    render::StructureSpec focus;
    focus.mesh = a.input;
    focus.name = focus.mesh.stem().string();
    focus.role = render::Role::focus;
    focus.style = render::default_style(render::Role::focus);
    spec.structures.push_back(focus);
  }
  for (const auto& c : a.context) {
    render::StructureSpec s;
    s.mesh = c;
    s.name = s.mesh.stem().string();
    s.role = render::Role::context;
    s.style = render::default_style(render::Role::context);
    spec.structures.push_back(s);
  }
  std::optional<Space> space_override;
  if (!a.space.empty()) space_override = parse_space(a.space);
  if (a.smooth && *a.smooth < 0) throw InputError("--smooth must be >= 0 (iterations; 0 = off)");
  for (auto& s : spec.structures) {
    if (space_override) s.space = space_override;
    if (a.smooth) s.style.smooth = *a.smooth;
    if (s.role != render::Role::focus) {
      if (a.context_opacity) s.style.opacity = *a.context_opacity;
      continue;
    }
    if (!a.style.empty()) {
      const auto sh = render::parse_shading(a.style);
      if (!sh)
        throw InputError("--style must be lambert, toon, flat or none (got \"" + a.style + "\")");
      s.style.shading = *sh;
    }
    if (!a.lines.empty())
      s.style.families = parse_family_list(a.lines, "--lines", s.style.families, true);
    if (a.hybrid) s.style.hybrid_apparent_ridges = true;
    if (a.line_width) s.style.lines.width = *a.line_width;
    if (!a.hidden.empty()) {
      const auto h = render::parse_hidden_lines(a.hidden);
      if (!h) throw InputError("--hidden must be omit, dashed or show");
      s.style.lines.hidden = *h;
    }
  }
  if (a.transparent) spec.transparent = true;

  // 2. Meshes -> Surfaces -> render meshes.
  std::vector<Loaded> loaded;
  BoundingBox box;
  bool first = true;
  Space space = Space::lps;
  for (const auto& s : spec.structures) {
    io::ReadOptions ro;
    ro.space = s.space;
    const auto file = load_prepared_mesh(s.mesh, ro, true);
    const BoundingBox b = bounding_box(file->surface.positions());
    if (first) {
      box = b;
      space = file->surface.mesh().space;
      first = false;
    } else {
      box.min = box.min.cwiseMin(b.min);
      box.max = box.max.cwiseMax(b.max);
    }
    Loaded l;
    l.spec = s;
    l.surface = std::shared_ptr<const Surface>(file, &file->surface);
    loaded.push_back(std::move(l));
  }

  // 3. Camera: --camera, --view, the scene's camera or view, else anterior.
  Camera camera;
  std::string camera_what;
  if (!a.camera_file.empty()) {
    camera = read_camera(a.camera_file);
    camera_what = a.camera_file;
  } else if (a.view.empty() && spec.camera) {
    camera = *spec.camera;
    camera_what = a.input + ": camera";
  } else {
    std::string name = a.view;
    if (name.empty()) name = spec.view ? to_string(*spec.view) : "anterior";
    const auto view = parse_anatomical_view(lower(name));
    if (!view)
      throw InputError("--view: unknown view \"" + name +
                       "\" (anterior, posterior, left, right, superior, inferior)");
    camera = anatomical_camera(*view, box, space);
    camera_what = "--view " + name;
  }
  if (!a.size.empty()) std::tie(camera.width, camera.height) = parse_size(a.size);
  validate_camera(camera, camera_what);

  // 4. Lines per structure (object space; apparent ridges on the GPU with --hybrid-ar).
  render::Scene scene;
  scene.background = spec.background;
  for (auto& l : loaded) {
    render::Structure& st = l.structure;
    st.name = l.spec.name;
    st.role = l.spec.role;
    st.style = l.spec.style;
    std::vector<LineFamily> families = st.style.families;
    if (st.style.hybrid_apparent_ridges)
      families.erase(std::remove(families.begin(), families.end(), LineFamily::apparent),
                     families.end());
    st.mesh = std::make_shared<render::RenderMesh>(
        render::make_render_mesh(*l.surface, st.style.hybrid_apparent_ridges));
    if (!families.empty()) {
      LineOptions lo;
      lo.families = families;
      LineExtractor extractor(*l.surface, lo);
      ChainOptions chain;
      chain.camera = camera;
      chain.min_length_px = 3.0;
      st.lines = chain_segments(extractor.extract(camera), chain);
      if (st.style.smooth > 0) {
        LineSmoothingOptions so;
        so.iterations = st.style.smooth;
        smooth_lines(st.lines, *l.surface, so);
      }
    }
    st.style.families = families;
    scene.structures.push_back(st);
  }

  // 5. The picture.
  render::HeadlessOptions ho;
  if (!a.backend.empty()) {
    ho.backend = render::parse_backend(a.backend);
    if (!ho.backend || *ho.backend == render::Backend::glfw)
      throw InputError("--backend must be egl or osmesa (got \"" + a.backend + "\")");
  }
  const auto kept = headless_renderer(ho);  // one GL context per `fabrica batch` worker
  render::Renderer& renderer = *kept;
  render::RenderOptions ro;
  ro.transparent_background = spec.transparent;
  if (a.tau) ro.hybrid.tau = *a.tau;
  if (a.lambda) ro.hybrid.lambda = *a.lambda;
  if (a.threshold) ro.hybrid.threshold = *a.threshold;
  ro.hybrid.fade = !a.no_fade;
  ro.hybrid.per_fragment = a.per_fragment;
  ro.hybrid.sign_free = a.sign_free;
  ro.hybrid.float_target = a.float_target;
  const render::Image image = renderer.render(scene, camera, ro);
  render::write_png(image, out_path);

  // 6. Vector lines: focus lines hidden by opaque structures, context lines by every surface.
  if (!a.svg.empty()) {
    TriangleMesh opaque, all;
    auto append = [](TriangleMesh& dst, const TriangleMesh& src) {
      const auto base = static_cast<std::int32_t>(dst.positions.size());
      dst.positions.insert(dst.positions.end(), src.positions.begin(), src.positions.end());
      for (Face f : src.faces) dst.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
    };
    for (const auto& l : loaded) {
      append(all, l.surface->mesh());
      if (l.structure.style.opacity >= 0.999) append(opaque, l.surface->mesh());
    }
    const DepthBuffer depth_all = render_depth(all, camera);
    const DepthBuffer depth_opaque =
        opaque.faces.empty() ? depth_all : render_depth(opaque, camera);
    LineSet merged;
    for (auto& l : loaded) {
      LineSet ls = l.structure.lines;
      compute_visibility(ls, *l.surface, camera, {},
                         l.structure.style.opacity >= 0.999 ? &depth_opaque : &depth_all);
      merged.polylines.insert(merged.polylines.end(), ls.polylines.begin(), ls.polylines.end());
    }
    fabrica::LineStyle style;
    if (!a.hidden.empty() && lower(a.hidden) == "dashed")
      style.hidden = fabrica::HiddenLines::dashed;
    write_svg(a.svg, merged, camera, style);
  }
  if (!a.save_scene.empty()) {
    render::SceneSpec saved = spec;
    saved.camera = camera;
    render::write_scene_spec(saved, a.save_scene);
  }
  if (!a.save_camera.empty()) write_camera(camera, a.save_camera);
  if (!a.quiet) {
    std::size_t polylines = 0;
    for (const auto& s : scene.structures) polylines += s.lines.polylines.size();
    std::fprintf(stderr, "fabrica render: %zu structure(s), %zu polylines, %dx%d via %s -> %s\n",
                 scene.structures.size(), polylines, camera.width, camera.height,
                 render::to_string(renderer.context().backend()), a.output.c_str());
  }
  return 0;
}

}  // namespace

void add_render_command(CLI::App& app, Action& action) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Draw a mesh or a focus-and-context scene to PNG headless (EGL or OSMesa)");
  cmd->add_option("input", args->input, "Mesh file (focus) or scene .json")->required();
  cmd->add_option("-o,--output", args->output, "Output PNG")->required();
  cmd->add_option("--camera", args->camera_file, "Camera JSON file");
  cmd->add_option("--view", args->view,
                  "Anatomical view: anterior, posterior, left, right, superior, inferior");
  cmd->add_option("--size", args->size, "Image size WxH in pixels (tiled above the GL limit)");
  cmd->add_option("--style", args->style, "Focus shading: lambert (default), toon, flat, none");
  cmd->add_option("--lines", args->lines,
                  "Focus line families, comma separated (default contour,boundary,apparent), "
                  "or none, reference, all");
  cmd->add_flag("--hybrid-ar", args->hybrid,
                "Apparent ridges by the hybrid GPU method (seed 000) instead of object space");
  cmd->add_option("--tau", args->tau, "Hybrid: q = 2^tau q1 (default from the feature size)");
  cmd->add_option("--lambda", args->lambda, "Hybrid: direction weight of the filter (1.5)");
  cmd->add_option("--threshold", args->threshold, "Hybrid: filter threshold (0.2)");
  cmd->add_flag("--no-fade", args->no_fade, "Hybrid: black lines instead of grey 1 - v");
  cmd->add_flag("--per-fragment", args->per_fragment, "Hybrid: q1, t1 per fragment (Phong-like)");
  cmd->add_flag("--sign-free", args->sign_free, "Hybrid: store t1 as a double angle");
  cmd->add_flag("--float-target", args->float_target, "Hybrid: 32-bit float render target");
  cmd->add_option("--context", args->context, "Context mesh (repeatable): ghosted, silhouettes");
  cmd->add_option("--context-opacity", args->context_opacity,
                  "Opacity of context structures (0.25)");
  cmd->add_option("--smooth", args->smooth,
                  "Smooth every structure's lines on the surface, N iterations (0 = off)");
  cmd->add_option("--line-width", args->line_width, "Focus line width in pixels at 1024 px (2)");
  cmd->add_option("--hidden", args->hidden, "Hidden lines: omit (default), dashed, show");
  cmd->add_flag("--transparent", args->transparent, "Transparent background");
  cmd->add_option("--backend", args->backend,
                  "Headless GL backend: egl or osmesa (default: egl, "
                  "then osmesa; or FABRICA_GL_BACKEND)");
  cmd->add_option("--svg", args->svg, "Also write the object-space lines as vector SVG");
  cmd->add_option("--space", args->space, "Coordinate space of untagged meshes: lps or ras");
  cmd->add_option("--save-scene", args->save_scene, "Write the scene (with its camera) as JSON");
  cmd->add_option("--save-camera", args->save_camera, "Write the camera as JSON");
  cmd->add_flag("-q,--quiet", args->quiet, "No summary on stderr");
  cmd->callback([args, &action] { action = [args] { return run_render(*args); }; });
}

}  // namespace fabrica::cli
