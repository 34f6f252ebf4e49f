// `fabrica hatch MESH -o OUT.svg|png`: shading strokes after Singh & Schaefer
// 2010 ("Suggestive Hatching", --method shading, the default) or ConFIS
// streamlines after Lawonn, Moench & Preim 2013 (--method confis), optionally
// with feature lines on top (docs/hatching.md, docs/confis.md).
#include <tbb/global_control.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/hatching/draw.hpp"
#include "fabrica/hatching/svg_writer.hpp"
#include "fabrica/io/prepare.hpp"

// `hatch` is built only with fabrica::render (apps/fabrica/CMakeLists.txt),
// which brings fabrica::lines.
#include "fabrica/lines/draw.hpp"
#include "fabrica/render/draw.hpp"

namespace fabrica::cli {
namespace {

struct HatchArgs {
  std::string method = "shading";
  std::string mesh;
  std::string camera_file;
  std::string view;
  std::string size;
  std::string space;
  std::string output;
  std::string with_lines;
  std::string frame;
  /// The method's options, bound to the flags (their defaults are the
  /// option structs' own: hatching::HatchingOptions, hatching::ConfisOptions;
  /// --stroke-width, --min-length and --max-length set both methods').
  DrawHatchingOptions drawing;
  /// The flags given on the command line (e.g. "--spacing"): a scene's
  /// structures[].hatching keys yield to them.
  std::set<std::string> given;
  /// The method-specific flags given, per method (an error when no
  /// structure is hatched with that method).
  std::vector<std::string> confis_given, shading_given;
  bool draw_ridges = false;
  double line_width = 1.5;
  bool transparent = false;
  bool keep_orientation = false;
  std::string backend;
  int threads = 0;
  bool quiet = false;
};

/// The visible runs of `line` projected to image pixels, appended to `out`.
void append_visible_runs(const Polyline& line, const Camera& camera,
                         std::vector<std::vector<Vec2>>& out) {
  std::vector<Vec2> run;
  auto flush = [&] {
    if (run.size() >= 2) out.push_back(run);
    run.clear();
  };
  const std::size_t n = line.vertices.size();
  for (std::size_t k = 0; k < n + (line.closed ? 1 : 0); ++k) {
    const LineVertex& v = line.vertices[k % n];
    if (!v.visible) {
      flush();
      continue;
    }
    run.push_back(project(camera, v.position).pixel);
  }
  flush();
}

/// The feature lines of --with-lines (chained; visible parts only with
/// `visibility`, else every vertex marked visible for the renderer).
LineSet feature_lines(const Surface& surface, const Camera& camera, const std::string& list,
                      std::vector<LineFamily>& families, bool visibility) {
  DrawLinesOptions options;
  options.lines.families.clear();
  std::istringstream in(list);
  std::string name;
  while (std::getline(in, name, ',')) {
    if (name.empty()) continue;
    const auto family = parse_family(lower(name));
    if (!family) throw InputError("--with-lines: unknown line family \"" + name + "\"");
    options.lines.families.push_back(*family);
  }
  families = options.lines.families;
  if (families.empty()) return {};
  options.min_length_px = 0.0;
  options.visibility = visibility;
  return draw_lines(surface, camera, options).lines;
}

std::vector<hatching::SvgLayer> feature_line_layers(const Surface& surface, const Camera& camera,
                                                    const std::string& list, double width) {
  std::vector<LineFamily> families;
  const LineSet lines = feature_lines(surface, camera, list, families, true);
  if (families.empty()) return {};
  std::vector<hatching::SvgLayer> layers;
  for (const LineFamily family : families) {
    hatching::SvgLayer layer;
    layer.name = std::string("lines-") + family_name(family);
    layer.width_px = width;
    for (const Polyline& line : lines.polylines) {
      if (line.family != family) continue;
      append_visible_runs(line, camera, layer.polylines);
    }
    layers.push_back(std::move(layer));
  }
  return layers;
}

/// The PNG through render::render_scene (as `fabrica render` draws): the
/// scene's structures as build_scene makes them, each hatched one as white
/// paper (flat, opaque, so it hides what is behind it) carrying its strokes
/// in black at the SVG's widths (image pixels), its ridges (red) and its
/// feature lines above them. `strokes[i]` are structure i's (none when it is
/// not hatched). For a single mesh (`mesh_lines`) the feature lines are
/// --with-lines at --line-width in image pixels; a scene's keep their scene
/// style. Returns the backend's name.
std::string write_hatching_png(const HatchArgs& args, const render::SceneSurfaces& scene,
                               render::Scene drawn, const Camera& camera,
                               const std::vector<std::optional<hatching::StrokeSet>>& strokes,
                               bool mesh_lines) {
  const render::HeadlessOptions headless = render::headless_options(args.backend);
  render::RenderOptions options;
  options.transparent_background = args.transparent || scene.spec.transparent;
  // A single mesh: widths in image pixels, as in the SVG. A scene keeps its
  // lines scaled with the image; the strokes are scaled back to image pixels.
  options.scale_lines_with_image = !mesh_lines;
  const double to_image =
      mesh_lines ? 1.0 : options.line_reference_size / std::min(camera.width, camera.height);
  auto plain = [&](double width, render::Color color) {
    render::LineStyle style;
    style.color = color;
    style.width = width * to_image;
    style.contour_width_factor = 1.0;
    style.taper = 0.0;  // the SVG's strokes are not tapered either
    style.fade_by_strength = false;
    return style;
  };
  for (std::size_t i = 0; i < drawn.structures.size(); ++i) {
    if (!strokes[i]) continue;
    render::Structure& structure = drawn.structures[i];
    structure.style.shading = render::Shading::flat;
    structure.style.color = {1.0f, 1.0f, 1.0f, 1.0f};
    structure.style.opacity = 1.0;
    // One layer per stroke weight (ConFIS fades towards its masks' borders;
    // shading strokes are all weight 1), lightest first, as the SVG's runs.
    std::map<double, render::PolylineLayer> by_weight;
    for (const hatching::Stroke& stroke : strokes[i]->strokes) {
      for (const hatching::WeightedRun& run : hatching::weighted_runs(stroke)) {
        auto it = by_weight.find(run.weight);
        if (it == by_weight.end()) {
          const float w = static_cast<float>(run.weight);
          it = by_weight
                   .emplace(
                       run.weight,
                       render::PolylineLayer{
                           "strokes",
                           plain(args.drawing.hatching.stroke_width_px * run.weight, {0, 0, 0, w}),
                           {}})
                   .first;
        }
        std::vector<Vec3> points;
        for (std::size_t k = run.first; k <= run.last; ++k)
          points.push_back(stroke.vertices[k].position);
        it->second.polylines.push_back(std::move(points));
      }
    }
    for (auto& [weight, layer] : by_weight) structure.polyline_layers.push_back(std::move(layer));
    if (args.draw_ridges) {
      render::PolylineLayer ridges{
          "ridges", plain(args.drawing.hatching.stroke_width_px, {0.84f, 0.15f, 0.16f, 1}), {}};
      for (const auto& r : strokes[i]->ridges)
        ridges.polylines.push_back({r[0].position, r[1].position});
      structure.polyline_layers.push_back(std::move(ridges));
    }
    if (!mesh_lines) continue;
    structure.style.families.clear();
    structure.style.lines = plain(args.line_width, {0, 0, 0, 1});
    if (!args.with_lines.empty())
      structure.lines = feature_lines(*scene.surfaces[i], camera, args.with_lines,
                                      structure.style.families, false);
  }

  std::shared_ptr<render::Renderer> renderer;  // one GL context per `fabrica batch` worker
  try {
    renderer = headless_renderer(headless);
  } catch (const Error& e) {
    if (e.kind() != ErrorKind::unavailable) throw;
    throw Error(ErrorKind::unavailable, "-o " + args.output +
                                            ": PNG output needs a headless OpenGL backend (EGL "
                                            "or OSMesa) and none could be created (" +
                                            e.what() + "); write .svg instead");
  }
  const render::RenderedScene picture =
      render::render_scene(*renderer, std::move(drawn), camera, options);
  render::write_png(picture.image, args.output);
  return render::to_string(picture.backend);
}

/// A scene's vector lines (render::vector_layers, as `render --svg` draws
/// them) as layers of the hatching SVG: each structure's visible runs in its
/// line colour at its width in image pixels.
std::vector<hatching::SvgLayer> scene_line_layers(const render::SceneSurfaces& scene,
                                                  const render::Scene& drawn,
                                                  const Camera& camera) {
  std::vector<hatching::SvgLayer> out;
  for (const LineLayer& layer : render::vector_layers(scene, drawn, camera)) {
    hatching::SvgLayer svg;
    svg.name = "lines-";  // a class name: letters, digits, '-' and '_'
    for (const char c : layer.name)
      svg.name += std::isalnum(static_cast<unsigned char>(c)) || c == '_' ? c : '-';
    svg.color = layer.color;
    svg.width_px = layer.style.width_px * std::min(camera.width, camera.height) /
                   std::max(1.0, layer.style.reference_size);
    for (const Polyline& line : layer.lines.polylines)
      append_visible_runs(line, camera, svg.polylines);
    out.push_back(std::move(svg));
  }
  return out;
}

/// Every hatched structure's strokes as one set (in structure order) for the
/// SVG and the summary.
hatching::StrokeSet merged_strokes(const std::vector<std::optional<hatching::StrokeSet>>& sets,
                                   const Camera& camera) {
  hatching::StrokeSet all;
  all.width = camera.width;
  all.height = camera.height;
  bool first = true;
  for (const auto& s : sets) {
    if (!s) continue;
    if (first) {
      all.grid_depth = s->grid_depth;
      all.seed_depth = s->seed_depth;
      first = false;
    }
    all.strokes.insert(all.strokes.end(), s->strokes.begin(), s->strokes.end());
    all.ridges.insert(all.ridges.end(), s->ridges.begin(), s->ridges.end());
    all.stats.candidates += s->stats.candidates;
    all.stats.seeds += s->stats.seeds;
    all.stats.short_strokes += s->stats.short_strokes;
    all.stats.ridge_segments += s->stats.ridge_segments;
    for (std::size_t k = 0; k < all.stats.ends.size(); ++k) all.stats.ends[k] += s->stats.ends[k];
  }
  return all;
}

/// Structure `index`'s hatching options: the command line's, with the
/// scene's structures[].hatching keys for the flags not given (docs/scene.md).
DrawHatchingOptions structure_hatching(const HatchArgs& args, const DrawHatchingOptions& base,
                                       const render::SceneSpec& spec, std::size_t index) {
  const render::HatchingSpec& h = spec.structures[index].hatching_options;
  DrawHatchingOptions o = base;
  auto given = [&](const std::string& key) {
    std::string flag = "--" + key;
    std::replace(flag.begin(), flag.end(), '_', '-');
    return args.given.count(flag) > 0;
  };
  if (!h.method.empty() && !given("method")) o.method = parse_hatching_method(h.method);
  hatching::ConfisOptions& c = o.confis;
  const std::map<std::string, double*> confis_numbers = {
      {"contour_margin", &c.contour_margin},
      {"convex_threshold", &c.feature_regions.convex_threshold},
      {"concave_threshold", &c.feature_regions.concave_threshold},
      {"umbilic_threshold", &c.field.umbilic_threshold},
      {"spacing", &c.spacing_px},
      {"min_weight", &c.min_weight}};
  const std::map<std::string, std::pair<double*, double*>> common = {
      {"min_length", {&o.hatching.min_length_px, &c.min_length_px}},
      {"max_length", {&o.hatching.max_length_px, &c.max_length_px}}};
  const std::string where = "structures[" + std::to_string(index) + "].hatching.";
  for (const auto& [key, value] : h.numbers) {
    if (o.method != HatchingMethod::confis && confis_numbers.count(key))
      throw InputError(where + key + ": only for method confis (structure \"" +
                       spec.structures[index].name + "\" is hatched with " + to_string(o.method) +
                       ")");
    if (given(key)) continue;
    if (const auto it = confis_numbers.find(key); it != confis_numbers.end()) *it->second = value;
    if (const auto it = common.find(key); it != common.end())
      *it->second.first = *it->second.second = value;
  }
  for (const auto& [key, value] : h.flags) {
    if (o.method != HatchingMethod::confis)
      throw InputError(where + key + ": only for method confis (structure \"" +
                       spec.structures[index].name + "\" is hatched with " + to_string(o.method) +
                       ")");
    if (given(key)) continue;
    (key == "no_contours" ? c.contours : c.features) = !value;
  }
  return o;
}

int run_hatch(const HatchArgs& args) {
  const HatchingMethod method = parse_hatching_method(args.method);
  std::unique_ptr<tbb::global_control> threads;
  if (args.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(args.threads));
  const std::string ext = lower(std::filesystem::path(args.output).extension().string());
  if (ext != ".svg" && ext != ".png")
    throw InputError("-o " + args.output + ": the output must end in .svg or .png");
  if (ext == ".png")
    render::headless_options(args.backend);  // a bad --backend fails before the work
  if (!(args.line_width > 0.0) || !std::isfinite(args.line_width))
    throw InputError("--line-width: must be a positive number of pixels");

  DrawHatchingOptions drawing = args.drawing;
  drawing.method = method;

  // What is hatched: a mesh (one focus structure, prepared as `fabrica
  // lines` prepares it, oriented outward unless --keep-orientation; cached
  // for `fabrica batch`), or a scene's structures with "hatching" on (by
  // default its focus), each with its scene style.
  const bool scene_input = is_scene_file(args.mesh);
  render::SceneSurfaces scene;
  render::Frame frame = render::Frame::all;
  if (scene_input) {
    if (args.keep_orientation)
      throw InputError(
          "--keep-orientation: a scene's meshes are always oriented outward (as "
          "`fabrica render` prepares them); hatch the mesh itself instead");
    render::SceneSpec spec = render::read_scene_spec(args.mesh);
    const bool any = std::any_of(spec.structures.begin(), spec.structures.end(),
                                 [](const render::StructureSpec& s) { return s.hatched(); });
    if (!any)
      throw InputError(args.mesh +
                       ": no structure to hatch: set \"hatching\": true on a structure (by "
                       "default the focus structures are hatched)");
    for (auto& s : spec.structures) {
      if (!args.space.empty()) s.space = parse_space(args.space);
      if (s.hatched() && !args.with_lines.empty())
        s.style.families = parse_family_list(args.with_lines, "--with-lines", {}, true);
    }
    frame = frame_option(args.frame, spec);
    scene = load_scene_surfaces(std::move(spec));
  } else {
    if (!args.frame.empty()) throw InputError("--frame: only for a scene input (SCENE.json)");
    PrepareOptions prepare;
    if (!args.space.empty()) prepare.space = parse_space(args.space);
    prepare.orient = !args.keep_orientation;
    const auto loaded = load_prepared_surface(args.mesh, prepare);
    if (!args.quiet)
      for (const auto& m : loaded->messages) std::fprintf(stderr, "fabrica hatch: %s\n", m.c_str());
    render::StructureSpec structure;
    structure.name = "surface";
    structure.mesh = args.mesh;
    structure.role = render::Role::focus;  // families empty: its lines are --with-lines
    if (loaded->surface->mesh().space_source == SpaceSource::default_assumed)
      scene.assumed_space.push_back(args.mesh);
    scene.add(std::move(structure), loaded->surface);
  }

  const ChosenCamera chosen = choose_scene_camera(scene, frame, args.camera_file, args.view,
                                                  args.size, {800, 800}, args.mesh);
  const Camera& camera = chosen.camera;

  // Each hatched structure's options (a scene's structures[].hatching) and
  // the methods in use: flags of a method no structure uses are an error.
  std::vector<std::optional<DrawHatchingOptions>> per_options(scene.surfaces.size());
  bool uses[2] = {false, false};
  for (std::size_t i = 0; i < scene.surfaces.size(); ++i) {
    if (scene_input && !scene.spec.structures[i].hatched()) continue;
    per_options[i] = scene_input ? structure_hatching(args, drawing, scene.spec, i) : drawing;
    uses[per_options[i]->method == HatchingMethod::confis] = true;
  }
  for (const auto& [used, options, name] : {std::tuple{uses[1], &args.confis_given, "confis"},
                                            std::tuple{uses[0], &args.shading_given, "shading"}})
    if (!used && !options->empty())
      throw InputError(options->front() + ": only for --method " + name + " (this run uses " +
                       (uses[1] ? "confis" : "shading") +
                       (scene_input ? " for every hatched structure)" : ")"));
  const char* methods = uses[0] && uses[1] ? "shading and confis" : uses[1] ? "confis" : "shading";

  std::vector<std::optional<hatching::StrokeSet>> per_structure(scene.surfaces.size());
  for (std::size_t i = 0; i < scene.surfaces.size(); ++i)
    if (per_options[i])
      per_structure[i] = draw_hatching(*scene.surfaces[i], camera, *per_options[i]);
  const hatching::StrokeSet strokes = merged_strokes(per_structure, camera);

  // The scene for the PNG or a scene's SVG lines, built once.
  render::Scene drawn;
  if (ext == ".png" || scene_input) drawn = render::build_scene(scene, camera);
  std::string via;
  if (ext == ".png") {
    via = write_hatching_png(args, scene, std::move(drawn), camera, per_structure, !scene_input);
  } else {
    const std::vector<hatching::SvgLayer> layers =
        scene_input ? scene_line_layers(scene, drawn, camera)
        : args.with_lines.empty()
            ? std::vector<hatching::SvgLayer>{}
            : feature_line_layers(*scene.surfaces[0], camera, args.with_lines, args.line_width);
    hatching::SvgStyle style;
    style.stroke_width_px = args.drawing.hatching.stroke_width_px;
    style.draw_ridges = args.draw_ridges;
    style.background = !(args.transparent || scene.spec.transparent);
    hatching::write_hatching_svg(args.output, strokes, style, layers);
  }
  if (!args.quiet) {
    std::size_t vertices = 0;
    for (const auto& s : strokes.strokes) vertices += s.vertices.size();
    std::printf(
        "%s: %s, %zu strokes (%zu vertices), %zu seeds tried of %zu candidates, %zu ridge "
        "segments; grid depth %d, seed depth %d%s%s\n",
        args.output.c_str(), methods, strokes.strokes.size(), vertices, strokes.stats.seeds,
        strokes.stats.candidates, strokes.ridges.size(), strokes.grid_depth, strokes.seed_depth,
        via.empty() ? "" : "; rendered via ", via.c_str());
  }
  if (!args.quiet) {
    std::printf("  stroke ends:");
    for (int k = 0; k < hatching::kStrokeEndCount; ++k)
      if (strokes.stats.ends[static_cast<std::size_t>(k)] > 0)
        std::printf(" %s %zu", hatching::to_string(static_cast<hatching::StrokeEnd>(k)),
                    strokes.stats.ends[static_cast<std::size_t>(k)]);
    std::printf("\n");
  }
  if (chosen.from_view)
    for (const auto& path : scene.assumed_space)
      warn_if_space_assumed(SpaceSource::default_assumed, path, "hatch", args.quiet);
  return 0;
}

}  // namespace

void add_hatch_command(CLI::App& app, Action& action) {
  auto args = std::make_shared<HatchArgs>();
  CLI::App* cmd = app.add_subcommand("hatch",
                                     "Shading strokes (Singh & Schaefer 2010, \"Suggestive "
                                     "Hatching\"), or ConFIS curvature streamlines with --method "
                                     "confis, as SVG or PNG; see docs/hatching.md, docs/confis.md");
  cmd->add_option("mesh", args->mesh,
                  "Input mesh (OBJ, PLY, STL, OFF, VTP, VTK) or scene .json (hatches the "
                  "structures with \"hatching\": true, by default the focus)")
      ->required();
  cmd->add_option("--method", args->method,
                  "shading (default: shading strokes, Singh & Schaefer 2010) or confis "
                  "(curvature streamlines in the contour margin and feature regions, Lawonn et "
                  "al. 2013; docs/confis.md)");
  cmd->add_option("-o,--output", args->output,
                  "Output OUT.svg, or OUT.png (rendered headless; needs the renderer and EGL or "
                  "OSMesa)")
      ->required();
  auto* camera =
      cmd->add_option("--camera", args->camera_file, "Camera JSON file (or a .seg file's header)");
  cmd->add_option("--view", args->view,
                  "Anatomical view: anterior (default), posterior, left, right, superior, inferior")
      ->excludes(camera);
  cmd->add_option(
      "--space", args->space,
      "Coordinate space of the mesh for --view: lps or ras (default: file tag, else LPS)");
  cmd->add_option("--size", args->size,
                  "Image size WxH in pixels (default 800x800, or the camera's)");
  DrawHatchingOptions& d = args->drawing;
  hatching::HatchingOptions& shading = d.hatching;
  hatching::ConfisOptions& confis = d.confis;
  // A length or width flag sets both methods' value.
  auto both = [args](double hatching::HatchingOptions::*s, double hatching::ConfisOptions::*c) {
    return [args, s, c](double v) {
      args->drawing.hatching.*s = v;
      args->drawing.confis.*c = v;
    };
  };
  cmd->add_option("--light", d.light,
                  "Light: eye (default), dir:X,Y,Z (world, towards the light), view:X,Y,Z (x "
                  "right, y up, z to the "
                  "viewer), point:X,Y,Z (world mm)");
  cmd->add_option("--threshold", shading.intensity_threshold,
                  "Strokes stop where the intensity exceeds this (1 = no threshold)");
  cmd->add_option("--grid-depth", shading.grid_depth,
                  "Deepest proximity-grid level (default: 20 at 800 px, +2 per doubling)");
  cmd->add_option("--seed-depth", shading.seed_depth,
                  "Deepest seeding level (default: grid depth - 2)");
  cmd->add_flag_callback(
      "--uniform-depth", [args] { args->drawing.hatching.adaptive_depth = false; },
      "Truncate every stroke at the grid depth, whatever the tone");
  cmd->add_option_function<double>(
      "--stroke-width",
      both(&hatching::HatchingOptions::stroke_width_px, &hatching::ConfisOptions::stroke_width_px),
      "Stroke width in pixels (also sets the density)");
  cmd->add_option_function<double>(
      "--max-length",
      both(&hatching::HatchingOptions::max_length_px, &hatching::ConfisOptions::max_length_px),
      "Maximum stroke length in pixels (0 = no limit)");
  cmd->add_option_function<double>(
      "--min-length",
      both(&hatching::HatchingOptions::min_length_px, &hatching::ConfisOptions::min_length_px),
      "Drop strokes shorter than this many pixels (default 1; confis 8)");
  cmd->add_flag_callback(
      "--no-ridge-removal", [args] { args->drawing.hatching.ridge_removal = false; },
      "Do not keep strokes away from intensity ridges");
  cmd->add_option("--ridge-angle", shading.ridges.min_angle_deg,
                  "Intensity ridges only where the gradients at an edge's ends differ by at "
                  "least this many degrees (default 20, the paper's)");
  cmd->add_flag("--draw-ridges", args->draw_ridges,
                "Also draw the detected intensity ridges (red), for inspection");
  cmd->add_option("--frame", args->frame,
                  "Scene input: what the view frames, focus (default with context) or all");
  cmd->add_option(
      "--with-lines", args->with_lines,
      "Comma-separated feature-line families drawn over the strokes, e.g. contour,suggestive");
  cmd->add_option("--line-width", args->line_width, "Width of the feature lines in pixels");
  cmd->add_flag("--transparent", args->transparent,
                "Transparent background (PNG: alpha 0 off the surface; SVG: no white rectangle)");
  cmd->add_option("--backend", args->backend,
                  "PNG only: headless GL backend egl or osmesa (default: FABRICA_GL_BACKEND, "
                  "else EGL then OSMesa)");
  // ConFIS (--method confis; docs/confis.md).
  std::vector<CLI::Option*> confis_only{
      cmd->add_option("--contour-margin", confis.contour_margin,
                      "confis: width of the contour margin on n.v, in (0, 1] (default 0.3): "
                      "streamlines where 0 <= n.v < this"),
      cmd->add_option("--convex-threshold", confis.feature_regions.convex_threshold,
                      "confis: feature regions where k1 * feature size >= this (strongly convex; "
                      "default 0.1)"),
      cmd->add_option("--concave-threshold", confis.feature_regions.concave_threshold,
                      "confis: feature regions where k1 * feature size <= -this (strongly "
                      "concave; default 0.1)"),
      cmd->add_option("--umbilic-threshold", confis.field.umbilic_threshold,
                      "confis: umbilic (no direction, no feature region) where |k1 - k2| * "
                      "feature size < this (default 0.01)"),
      cmd->add_option("--spacing", confis.spacing_px,
                      "confis: distance between streamlines in pixels (default 6)"),
      cmd->add_option("--min-weight", confis.min_weight,
                      "confis: width and opacity factor at the masks' borders, in [0, 1] "
                      "(default 0.15)"),
      cmd->add_flag_callback(
          "--no-contours", [args] { args->drawing.confis.contours = false; },
          "confis: no streamlines in the contour margin"),
      cmd->add_flag_callback(
          "--no-features", [args] { args->drawing.confis.features = false; },
          "confis: no streamlines in the feature regions")};
  std::vector<CLI::Option*> shading_only;
  for (const char* name :
       {"--light", "--threshold", "--grid-depth", "--seed-depth", "--uniform-depth",
        "--no-ridge-removal", "--ridge-angle", "--draw-ridges"})
    shading_only.push_back(cmd->get_option(name));
  cmd->add_option("--threads", args->threads,
                  "Worker threads (0 = all); the output does not depend on it");
  cmd->add_flag("--keep-orientation", args->keep_orientation,
                "Do not re-orient the mesh outward before hatching");
  cmd->add_flag("-q,--quiet", args->quiet, "No summary line");
  cmd->callback([args, cmd, &action, confis_only, shading_only] {
    // Options of the other method are an error (run_hatch names them once
    // --method is known to be valid).
    args->given.clear();
    args->confis_given.clear();
    args->shading_given.clear();
    for (const CLI::Option* o : cmd->get_options())
      if (o->count() > 0) args->given.insert(o->get_name());
    for (CLI::Option* o : confis_only)
      if (o->count() > 0) args->confis_given.push_back(o->get_name());
    for (CLI::Option* o : shading_only)
      if (o->count() > 0) args->shading_given.push_back(o->get_name());
    action = [args] { return run_hatch(*args); };
  });
}

}  // namespace fabrica::cli
