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
#include <sstream>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/hatching/draw.hpp"
#include "fabrica/hatching/svg_writer.hpp"
#include "fabrica/io/prepare.hpp"

#if __has_include("fabrica/lines/draw.hpp")
#include "fabrica/lines/draw.hpp"
#define FABRICA_HATCH_WITH_LINES 1
#endif
#if __has_include("fabrica/render/draw.hpp")
#include "fabrica/render/draw.hpp"
#include "fabrica/render/render_mesh.hpp"
#define FABRICA_HATCH_WITH_RENDER 1
#endif

namespace fabrica::cli {
namespace {

struct HatchArgs {
  std::string method = "shading";
  std::string mesh;
  std::string camera_file;
  std::string view;
  std::string light = "eye";
  std::string size;
  std::string space;
  std::string output;
  std::string with_lines;
  double threshold = 1.0;
  int grid_depth = -1;
  int seed_depth = -1;
  bool uniform_depth = false;
  double stroke_width = 1.0;
  double max_length = 0.0;
  std::optional<double> min_length;  ///< default 1 (shading), 8 (confis)
  // ConFIS (--method confis)
  double contour_margin = 0.3;
  double convex_threshold = 0.1;
  double concave_threshold = 0.1;
  double umbilic_threshold = 0.01;
  double spacing = 6.0;
  double min_weight = 0.15;
  bool no_contours = false;
  bool no_features = false;
  /// Options of the other method that were given (an error).
  std::vector<std::string> misplaced;
  bool no_ridge_removal = false;
  double ridge_angle = 20.0;
  bool draw_ridges = false;
  double line_width = 1.5;
  bool transparent = false;
  bool keep_orientation = false;
  std::string backend;
  int threads = 0;
  bool quiet = false;
};

#ifdef FABRICA_HATCH_WITH_LINES
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
      std::vector<Vec2> run;
      auto flush = [&] {
        if (run.size() >= 2) layer.polylines.push_back(run);
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
    layers.push_back(std::move(layer));
  }
  return layers;
}
#endif

#ifdef FABRICA_HATCH_WITH_RENDER
/// The PNG: the surface as white paper (flat, opaque, so it hides what is
/// behind it), the strokes in black at the SVG's widths (image pixels), the
/// ridges (red) and feature lines above them, through the renderer's
/// line-quad pipeline. Returns the backend's name.
std::string write_hatching_png(const HatchArgs& args, const Surface& surface, const Camera& camera,
                               const hatching::StrokeSet& strokes) {
  const render::HeadlessOptions headless = render::headless_options(args.backend);
  render::Structure structure;
  structure.name = "surface";
  structure.style.shading = render::Shading::flat;
  structure.style.color = {1.0f, 1.0f, 1.0f, 1.0f};
  structure.style.opacity = 1.0;
  structure.mesh = std::make_shared<render::RenderMesh>(render::make_render_mesh(surface, false));
  auto plain = [](double width, render::Color color) {
    render::LineStyle style;
    style.color = color;
    style.width = width;
    style.contour_width_factor = 1.0;
    style.taper = 0.0;  // the SVG's strokes are not tapered either
    style.fade_by_strength = false;
    return style;
  };
  // One layer per style weight (ConFIS fades towards its masks' borders;
  // shading strokes are all weight 1), lightest first, as the SVG's runs.
  std::map<double, render::PolylineLayer> by_weight;
  for (const hatching::Stroke& stroke : strokes.strokes) {
    for (const hatching::WeightedRun& run : hatching::weighted_runs(stroke)) {
      auto it = by_weight.find(run.weight);
      if (it == by_weight.end()) {
        const float w = static_cast<float>(run.weight);
        it = by_weight
                 .emplace(run.weight,
                          render::PolylineLayer{
                              "strokes", plain(args.stroke_width * run.weight, {0, 0, 0, w}), {}})
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
    render::PolylineLayer ridges{"ridges", plain(args.stroke_width, {0.84f, 0.15f, 0.16f, 1}), {}};
    for (const auto& r : strokes.ridges) ridges.polylines.push_back({r[0].position, r[1].position});
    structure.polyline_layers.push_back(std::move(ridges));
  }
  structure.style.families.clear();
  structure.style.lines = plain(args.line_width, {0, 0, 0, 1});
#ifdef FABRICA_HATCH_WITH_LINES
  if (!args.with_lines.empty())
    structure.lines =
        feature_lines(surface, camera, args.with_lines, structure.style.families, false);
#endif
  render::Scene scene;
  scene.structures.push_back(std::move(structure));

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
  render::RenderOptions options;
  options.transparent_background = args.transparent;
  options.scale_lines_with_image = false;  // widths in image pixels, as in the SVG
  const render::Image image = renderer->render(scene, camera, options);
  render::write_png(image, args.output);
  return render::to_string(renderer->context().backend());
}
#endif

int run_hatch(const HatchArgs& args) {
  const HatchingMethod method = parse_hatching_method(args.method);
  for (const std::string& option : args.misplaced)
    throw InputError(option + ": only for --method " +
                     (method == HatchingMethod::confis ? "shading" : "confis") +
                     " (this run uses --method " + to_string(method) + ")");
  std::unique_ptr<tbb::global_control> threads;
  if (args.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(args.threads));
  const std::string ext = lower(std::filesystem::path(args.output).extension().string());
  if (ext != ".svg" && ext != ".png")
    throw InputError("-o " + args.output + ": the output must end in .svg or .png");
#ifndef FABRICA_HATCH_WITH_RENDER
  if (ext == ".png")
    throw Error(ErrorKind::unavailable,
                "-o " + args.output +
                    ": PNG output of hatching needs the renderer (fabrica::render), which this "
                    "build lacks; write .svg (and rasterise it, e.g. with rsvg-convert)");
#else
  if (ext == ".png")
    render::headless_options(args.backend);  // a bad --backend fails before the work
#endif
  if (!(args.line_width > 0.0) || !std::isfinite(args.line_width))
    throw InputError("--line-width: must be a positive number of pixels");

  // The same preparation as `fabrica lines`: oriented outward (inward
  // normals would turn the light's shading inside out). Cached for `fabrica
  // batch` (cli_common.hpp).
  PrepareOptions prepare;
  if (!args.space.empty()) prepare.space = parse_space(args.space);
  prepare.orient = !args.keep_orientation;
  const auto loaded = load_prepared_surface(args.mesh, prepare);
  if (!args.quiet)
    for (const auto& m : loaded->messages) std::fprintf(stderr, "fabrica hatch: %s\n", m.c_str());
  const Surface& surface = *loaded->surface;
  const Space space = surface.mesh().space;

  std::optional<std::pair<int, int>> size;
  if (!args.size.empty()) size = parse_size(args.size);
  Camera camera;
  SpaceSource assumed_space = SpaceSource::file_tag;  // warned about once the work is done
  if (!args.camera_file.empty()) {
    camera = read_camera(args.camera_file);
    if (size) std::tie(camera.width, camera.height) = *size;
  } else {
    const AnatomicalView view = parse_view(args.view.empty() ? "anterior" : args.view);
    const auto [w, h] = size.value_or(std::pair<int, int>{800, 800});
    camera = anatomical_camera(view, bounding_box(surface.positions()), space, w, h);
    assumed_space = surface.mesh().space_source;
  }
  validate_camera(camera, args.camera_file.empty() ? "camera" : args.camera_file);

  DrawHatchingOptions drawing;
  drawing.method = method;
  drawing.light = args.light;
  hatching::ConfisOptions& confis = drawing.confis;
  confis.contour_margin = args.contour_margin;
  confis.contours = !args.no_contours;
  confis.features = !args.no_features;
  confis.feature_regions.convex_threshold = args.convex_threshold;
  confis.feature_regions.concave_threshold = args.concave_threshold;
  confis.field.umbilic_threshold = args.umbilic_threshold;
  confis.spacing_px = args.spacing;
  confis.min_weight = args.min_weight;
  confis.stroke_width_px = args.stroke_width;
  confis.max_length_px = args.max_length;
  if (args.min_length) confis.min_length_px = *args.min_length;
  hatching::HatchingOptions& options = drawing.hatching;
  options.intensity_threshold = args.threshold;
  options.grid_depth = args.grid_depth;
  options.seed_depth = args.seed_depth;
  options.adaptive_depth = !args.uniform_depth;
  options.stroke_width_px = args.stroke_width;
  options.max_length_px = args.max_length;
  options.min_length_px = args.min_length.value_or(1.0);
  options.ridge_removal = !args.no_ridge_removal;
  options.ridges.min_angle_deg = args.ridge_angle;
  const hatching::StrokeSet strokes = draw_hatching(surface, camera, drawing);

#ifndef FABRICA_HATCH_WITH_LINES
  if (!args.with_lines.empty())
    throw Error(ErrorKind::unavailable,
                "--with-lines: this build has no line engine (fabrica::lines)");
#endif
  std::string via;
  if (ext == ".png") {
#ifdef FABRICA_HATCH_WITH_RENDER
    via = write_hatching_png(args, surface, camera, strokes);
#endif
  } else {
    std::vector<hatching::SvgLayer> layers;
#ifdef FABRICA_HATCH_WITH_LINES
    if (!args.with_lines.empty())
      layers = feature_line_layers(surface, camera, args.with_lines, args.line_width);
#endif
    hatching::SvgStyle style;
    style.stroke_width_px = args.stroke_width;
    style.draw_ridges = args.draw_ridges;
    style.background = !args.transparent;
    hatching::write_hatching_svg(args.output, strokes, style, layers);
  }
  if (!args.quiet) {
    std::size_t vertices = 0;
    for (const auto& s : strokes.strokes) vertices += s.vertices.size();
    std::printf(
        "%s: %s, %zu strokes (%zu vertices), %zu seeds tried of %zu candidates, %zu ridge "
        "segments; grid depth %d, seed depth %d%s%s\n",
        args.output.c_str(), to_string(method), strokes.strokes.size(), vertices,
        strokes.stats.seeds, strokes.stats.candidates, strokes.ridges.size(), strokes.grid_depth,
        strokes.seed_depth, via.empty() ? "" : "; rendered via ", via.c_str());
  }
  if (!args.quiet) {
    std::printf("  stroke ends:");
    for (int k = 0; k < hatching::kStrokeEndCount; ++k)
      if (strokes.stats.ends[static_cast<std::size_t>(k)] > 0)
        std::printf(" %s %zu", hatching::to_string(static_cast<hatching::StrokeEnd>(k)),
                    strokes.stats.ends[static_cast<std::size_t>(k)]);
    std::printf("\n");
  }
  warn_if_space_assumed(assumed_space, args.mesh, "hatch", args.quiet);
  return 0;
}

}  // namespace

void add_hatch_command(CLI::App& app, Action& action) {
  auto args = std::make_shared<HatchArgs>();
  CLI::App* cmd = app.add_subcommand("hatch",
                                     "Shading strokes (Singh & Schaefer 2010, \"Suggestive "
                                     "Hatching\"), or ConFIS curvature streamlines with --method "
                                     "confis, as SVG or PNG; see docs/hatching.md, docs/confis.md");
  cmd->add_option("mesh", args->mesh, "Input mesh (OBJ, PLY, STL, OFF, VTP, VTK)")->required();
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
  cmd->add_option("--light", args->light,
                  "Light: eye (default), dir:X,Y,Z (world, towards the light), view:X,Y,Z (x "
                  "right, y up, z to the "
                  "viewer), point:X,Y,Z (world mm)");
  cmd->add_option("--threshold", args->threshold,
                  "Strokes stop where the intensity exceeds this (1 = no threshold)");
  cmd->add_option("--grid-depth", args->grid_depth,
                  "Deepest proximity-grid level (default: 20 at 800 px, +2 per doubling)");
  cmd->add_option("--seed-depth", args->seed_depth,
                  "Deepest seeding level (default: grid depth - 2)");
  cmd->add_flag("--uniform-depth", args->uniform_depth,
                "Truncate every stroke at the grid depth, whatever the tone");
  cmd->add_option("--stroke-width", args->stroke_width,
                  "Stroke width in pixels (also sets the density)");
  cmd->add_option("--max-length", args->max_length,
                  "Maximum stroke length in pixels (0 = no limit)");
  cmd->add_option("--min-length", args->min_length,
                  "Drop strokes shorter than this many pixels (default 1; confis 8)");
  cmd->add_flag("--no-ridge-removal", args->no_ridge_removal,
                "Do not keep strokes away from intensity ridges");
  cmd->add_option("--ridge-angle", args->ridge_angle,
                  "Intensity ridges only where the gradients at an edge's ends differ by at "
                  "least this many degrees (default 20, the paper's)");
  cmd->add_flag("--draw-ridges", args->draw_ridges,
                "Also draw the detected intensity ridges (red), for inspection");
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
      cmd->add_option("--contour-margin", args->contour_margin,
                      "confis: width of the contour margin on n.v, in (0, 1] (default 0.3): "
                      "streamlines where 0 <= n.v < this"),
      cmd->add_option("--convex-threshold", args->convex_threshold,
                      "confis: feature regions where k1 * feature size >= this (strongly convex; "
                      "default 0.1)"),
      cmd->add_option("--concave-threshold", args->concave_threshold,
                      "confis: feature regions where k1 * feature size <= -this (strongly "
                      "concave; default 0.1)"),
      cmd->add_option("--umbilic-threshold", args->umbilic_threshold,
                      "confis: umbilic (no direction, no feature region) where |k1 - k2| * "
                      "feature size < this (default 0.01)"),
      cmd->add_option("--spacing", args->spacing,
                      "confis: distance between streamlines in pixels (default 6)"),
      cmd->add_option("--min-weight", args->min_weight,
                      "confis: width and opacity factor at the masks' borders, in [0, 1] "
                      "(default 0.15)"),
      cmd->add_flag("--no-contours", args->no_contours,
                    "confis: no streamlines in the contour margin"),
      cmd->add_flag("--no-features", args->no_features,
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
  cmd->callback([args, &action, confis_only, shading_only] {
    // Options of the other method are an error (run_hatch names them once
    // --method is known to be valid).
    args->misplaced.clear();
    const bool confis = lower(args->method) == "confis";
    for (CLI::Option* o : confis ? shading_only : confis_only)
      if (o->count() > 0) args->misplaced.push_back(o->get_name());
    action = [args] { return run_hatch(*args); };
  });
}

}  // namespace fabrica::cli
