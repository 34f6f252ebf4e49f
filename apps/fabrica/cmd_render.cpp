// `fabrica render MESH_OR_SCENE [--camera FILE | --view NAME] [--style S]
//  [--lines LIST] [--hybrid-ar] [--lic [--lic-length L] [--lic-noise-scale MM]
//  [--lic-strength S]] [--cutaway [--cutaway-margin PX] [--cutaway-fade PX]
//  [--cutaway-rim]] [--context MESH ...] [--size WxH]
//  [--transparent] [--backend egl|osmesa] [--svg OUT.svg] [--pdf OUT.pdf]
//  [--labels] [--legend] [--scale-bar] [--orientation-marker] [--annotate]
//  [--font-size PX] -o OUT.png`:
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
#include "fabrica/lines/writers.hpp"
#include "fabrica/render/annotate.hpp"
#include "fabrica/render/draw.hpp"

namespace fabrica::cli {
namespace {

struct RenderArgs {
  std::string input, camera_file, view, style, lines, size, backend, output, svg, pdf, hidden,
      space;
  std::string save_scene, save_camera, frame;
  std::vector<std::string> context;
  std::optional<double> tau, lambda, threshold, line_width, context_opacity;
  std::optional<double> lic_length, lic_noise_scale, lic_strength;
  std::optional<double> cutaway_margin, cutaway_fade;
  bool cutaway = false, cutaway_rim = false;
  std::optional<int> smooth;
  std::optional<double> font_size;
  bool labels = false, legend = false, scale_bar = false, orientation = false, annotate = false;
  bool hybrid = false, lic = false, transparent = false, no_fade = false, per_fragment = false,
       sign_free = false, float_target = false, quiet = false;
};

int run_render(const RenderArgs& a) {
  const std::filesystem::path out_path(a.output);
  if (lower(out_path.extension().string()) != ".png")
    throw InputError("-o " + a.output + ": the image must end in .png");
  if (!a.svg.empty() && lower(std::filesystem::path(a.svg).extension().string()) != ".svg")
    throw InputError("--svg " + a.svg + ": must end in .svg");
  if (!a.pdf.empty() && lower(std::filesystem::path(a.pdf).extension().string()) != ".pdf")
    throw InputError("--pdf " + a.pdf + ": must end in .pdf");
  if (!a.pdf.empty() && !pdf_available())
    throw Error(ErrorKind::unavailable, "--pdf " + a.pdf +
                                            ": PDF output needs cairo; this fabrica was built "
                                            "without it (write --svg instead)");
  // Every output's folder must exist before any is written (no half set of outputs).
  for (const std::string& f : {a.output, a.svg, a.pdf, a.save_scene, a.save_camera}) {
    const auto parent = std::filesystem::path(f).parent_path();
    if (!f.empty() && !parent.empty() && !std::filesystem::is_directory(parent))
      throw OutputError(f + ": cannot write: folder " + parent.string() + " does not exist");
  }

  // 1. The scene description: a scene JSON, or the mesh as focus plus contexts.
  render::SceneSpec spec;
  if (is_scene_file(a.input)) {
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
    // Each context structure keeps a colour of its own: the palette's for a
    // known name, else the next of a cycle of pale hues.
    s.style.color =
        render::anatomical_color(s.name).value_or(render::cycle_color(spec.structures.size()));
    spec.structures.push_back(s);
  }
  const render::Frame frame = frame_option(a.frame, spec);
  std::optional<Space> space_override;
  if (!a.space.empty()) space_override = parse_space(a.space);
  if (a.smooth && *a.smooth < 0) throw InputError("--smooth must be >= 0 (iterations; 0 = off)");
  // LIC parameters: the scene's, then the options (validated before any mesh is read).
  if (!a.lic && (a.lic_length || a.lic_noise_scale || a.lic_strength) &&
      std::none_of(spec.structures.begin(), spec.structures.end(),
                   [](const render::StructureSpec& s) { return s.style.lic; }))
    throw InputError("--lic-length, --lic-noise-scale and --lic-strength need --lic");
  if (a.lic_length) {
    spec.lic.kernel_length = *a.lic_length;
    render::validate(spec.lic, "--lic-length");
  }
  if (a.lic_noise_scale) {
    spec.lic.noise_scale = *a.lic_noise_scale;
    render::validate(spec.lic, "--lic-noise-scale");
  }
  if (a.lic_strength) {
    spec.lic.strength = *a.lic_strength;
    render::validate(spec.lic, "--lic-strength");
  }
  // Cutaway: the options add to the scene's "cutaway".
  if (a.cutaway) spec.cutaway.enabled = true;
  if (!spec.cutaway.enabled && (a.cutaway_margin || a.cutaway_fade || a.cutaway_rim))
    throw InputError(
        "--cutaway-margin, --cutaway-fade and --cutaway-rim need --cutaway (or a scene whose "
        "cutaway is enabled)");
  auto cutaway_px = [](const std::optional<double>& v, const char* option, double& into) {
    if (!v) return;
    if (!(*v >= 0.0 && *v <= render::kCutawayMaxPx))
      throw InputError(std::string(option) + " must be between 0 and " +
                       std::to_string(static_cast<int>(render::kCutawayMaxPx)) +
                       " (pixels at 1024 px; got " + std::to_string(*v) + ")");
    into = *v;
  };
  cutaway_px(a.cutaway_margin, "--cutaway-margin", spec.cutaway.margin_px);
  cutaway_px(a.cutaway_fade, "--cutaway-fade", spec.cutaway.fade_px);
  if (a.cutaway_rim) spec.cutaway.rim = true;
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
    if (a.lic) s.style.lic = true;
    if (a.line_width) s.style.lines.width = *a.line_width;
    if (!a.hidden.empty()) {
      const auto h = render::parse_hidden_lines(a.hidden);
      if (!h) throw InputError("--hidden must be omit, dashed or show");
      s.style.lines.hidden = *h;
    }
  }
  if (a.transparent) spec.transparent = true;
  // Annotation (issue 17, item 5): the flags add to the scene's "annotation".
  render::AnnotationSpec& note = spec.annotation;
  note.labels = note.labels || a.labels || a.annotate;
  note.legend = note.legend || a.legend || a.annotate;
  note.scale_bar = note.scale_bar || a.scale_bar || a.annotate;
  note.orientation = note.orientation || a.orientation || a.annotate;
  if (a.font_size) {
    if (!(*a.font_size >= 4.0 && *a.font_size <= 200.0))
      throw InputError("--font-size must be between 4 and 200 (pixels at 1024 px)");
    note.font_size = *a.font_size;
  }

  // 2. Meshes -> prepared Surfaces (cached for `fabrica batch`, cli_common.hpp).
  const render::SceneSurfaces scene = load_scene_surfaces(spec);

  // 3. Camera: --camera, --view, the scene's camera or view, else anterior;
  // a view framed at --size (cli_common.hpp: choose_camera).
  const ChosenCamera chosen =
      choose_scene_camera(scene, frame, a.camera_file, a.view, a.size, {1024, 1024}, a.input);
  const Camera& camera = chosen.camera;
  const bool view_from_space = chosen.from_view;

  // 4. Lines per structure and the picture (apparent ridges on the GPU with --hybrid-ar).
  const render::HeadlessOptions ho = render::headless_options(a.backend);
  render::RenderOptions ro;
  ro.transparent_background = spec.transparent;
  if (a.tau) ro.hybrid.tau = *a.tau;
  if (a.lambda) ro.hybrid.lambda = *a.lambda;
  if (a.threshold) ro.hybrid.threshold = *a.threshold;
  ro.hybrid.fade = !a.no_fade;
  ro.hybrid.per_fragment = a.per_fragment;
  ro.hybrid.sign_free = a.sign_free;
  ro.hybrid.float_target = a.float_target;
  ro.lic = spec.lic;
  const auto renderer = headless_renderer(ho);  // one GL context per `fabrica batch` worker
  render::RenderedScene picture = render::render_scene(*renderer, scene, camera, ro);
  const render::Annotation annotation = render::annotate_scene(scene, camera, spec.annotation);
  render::draw_annotation(picture.image, annotation.overlay);
  render::write_png(picture.image, out_path);
  const VectorOverlay* overlay = spec.annotation.any() ? &annotation.overlay : nullptr;

  // 5. Vector lines: one layer per structure in its line style, focus over
  // context (render::write_scene_svg); focus lines hidden by opaque
  // structures, context lines by every surface.
  if (!a.svg.empty())
    render::write_scene_svg(a.svg, scene, picture.scene, camera, ro.line_reference_size, overlay);
  if (!a.pdf.empty())
    render::write_scene_pdf(a.pdf, scene, picture.scene, camera, ro.line_reference_size, overlay);
  if (!a.save_scene.empty()) {
    render::SceneSpec saved = spec;
    saved.camera = camera;
    render::write_scene_spec(saved, a.save_scene);
  }
  if (!a.save_camera.empty()) write_camera(camera, a.save_camera);
  if (!a.quiet) {
    std::size_t polylines = 0;
    for (const auto& s : picture.scene.structures) polylines += s.lines.polylines.size();
    std::fprintf(stderr, "fabrica render: %zu structure(s), %zu polylines, %dx%d via %s -> %s\n",
                 picture.scene.structures.size(), polylines, camera.width, camera.height,
                 render::to_string(picture.backend), a.output.c_str());
  }
  if (!a.quiet)
    for (const auto& why : annotation.skipped)
      std::fprintf(stderr, "fabrica render: warning: no label for %s\n", why.c_str());
  for (const auto& path : scene.assumed_space)
    if (view_from_space)
      warn_if_space_assumed(SpaceSource::default_assumed, path, "render", a.quiet);
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
  cmd->add_flag("--lic", args->lic,
                "Surface LIC: noise smeared along the maximal-curvature direction in the "
                "feature regions, blended with the focus shading (docs/lic.md)");
  cmd->add_option("--lic-length", args->lic_length,
                  "LIC: half length of the kernel in noise cells, in (0, 64] (8)");
  cmd->add_option("--lic-noise-scale", args->lic_noise_scale,
                  "LIC: noise cell size on the surface in mm (0 = bounding radius / 200)");
  cmd->add_option("--lic-strength", args->lic_strength,
                  "LIC: how much of the shading the texture replaces, in [0, 1] (0.8)");
  cmd->add_flag("--cutaway", args->cutaway,
                "Cut away the context in front of the focus near its outline (docs/rendering.md)");
  cmd->add_option("--cutaway-margin", args->cutaway_margin,
                  "Cutaway: fully cut up to this distance from the focus outline, pixels at "
                  "1024 px, in [0, 256] (12)");
  cmd->add_option("--cutaway-fade", args->cutaway_fade,
                  "Cutaway: the context fades back in over this many more pixels, in [0, 256] (8)");
  cmd->add_flag("--cutaway-rim", args->cutaway_rim, "Cutaway: draw the cut's border as a line");
  cmd->add_option("--context", args->context, "Context mesh (repeatable): ghosted, silhouettes");
  cmd->add_option("--frame", args->frame,
                  "What the view frames: focus (default when there is context) or all");
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
  cmd->add_option("--svg", args->svg,
                  "Also write the object-space lines as vector SVG (a layer per structure)");
  cmd->add_option("--pdf", args->pdf,
                  "Also write the object-space lines as vector PDF (each structure's colour)");
  cmd->add_option("--space", args->space, "Coordinate space of untagged meshes: lps or ras");
  cmd->add_option("--save-scene", args->save_scene, "Write the scene (with its camera) as JSON");
  cmd->add_option("--save-camera", args->save_camera, "Write the camera as JSON");
  cmd->add_flag("--labels", args->labels,
                "Annotate: a label per structure with a leader line (scene: label per structure)");
  cmd->add_flag("--legend", args->legend, "Annotate: legend of the structures' colours");
  cmd->add_flag("--scale-bar", args->scale_bar,
                "Annotate: scale bar in mm (perspective: at the focus depth)");
  cmd->add_flag("--orientation-marker", args->orientation,
                "Annotate: the patient axes (A/P, L/R, S/I) as seen in this view");
  cmd->add_flag("--annotate", args->annotate,
                "All four: --labels --legend --scale-bar --orientation-marker");
  cmd->add_option("--font-size", args->font_size,
                  "Annotation text size in pixels at 1024 px (18; scaled with the picture)");
  cmd->add_flag("-q,--quiet", args->quiet, "No summary on stderr");
  cmd->callback([args, &action] { action = [args] { return run_render(*args); }; });
}

}  // namespace fabrica::cli
