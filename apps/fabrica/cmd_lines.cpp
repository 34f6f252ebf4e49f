// `fabrica lines MESH [--camera FILE | --view NAME] [--size WxH] [--types LIST]
//  [--feature-size F] [--<family>-threshold T ...] [--no-visibility]
//  [--hidden omit|dashed] -o OUT.{svg,pdf,seg,json}`: object-space feature
// lines (docs/lines/).
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/prepare.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/seg_io.hpp"
#include "fabrica/lines/writers.hpp"
#if __has_include("fabrica/render/draw.hpp")
#include "fabrica/render/draw.hpp"
#define FABRICA_LINES_WITH_SCENES 1
#endif

namespace fabrica::cli {
namespace {

struct LinesArgs {
  std::string mesh, camera_file, view, size, types = "default", output, hidden = "omit", light;
  std::string space, frame;
  std::set<std::string> given;  ///< the options given on the command line (long names)
  double feature_size = 0.0;
  std::optional<double> suggestive_t, highlight_t, ridge_t, valley_t, apparent_t, pel_t,
      laplacian_t, demarcating_t, crease_angle;
  double min_length_px = -1.0;
  double width = 1.2;
  int smooth = 0;
  bool no_visibility = false, mesh_edge_contours = false, no_fade = false, no_taper = false;
  bool keep_normals_orientation = false, quiet = false;
};

Vec3 parse_vec3(const std::string& text, const std::string& what) {
  Vec3 v;
  char c1 = 0, c2 = 0;
  std::istringstream in(text);
  if (!(in >> v.x() >> c1 >> v.y() >> c2 >> v.z()) || c1 != ',' || c2 != ',' || !v.allFinite() ||
      v.norm() == 0.0)
    throw InputError(what + ": expected a non-zero direction X,Y,Z (got \"" + text + "\")");
  return v;
}

/// A camera that sees no vertex of the mesh is an error the user must fix.
void check_camera_sees_mesh(const Camera& camera, const TriangleMesh& mesh,
                            const std::string& what) {
  for (const auto& p : mesh.positions) {
    const auto pp = project(camera, p);
    if (pp.depth > 0.0 && pp.pixel.x() >= 0 && pp.pixel.y() >= 0 && pp.pixel.x() < camera.width &&
        pp.pixel.y() < camera.height)
      return;
  }
  throw InputError(what +
                   ": the camera sees none of the mesh (eye inside or behind it, or "
                   "looking away); use --view NAME or fix eye/center");
}

/// The drawing options the arguments name (validated: InputError).
DrawLinesOptions drawing_options(const LinesArgs& a, const std::string& ext) {
  DrawLinesOptions d;
  LineOptions& opt = d.lines;
  opt.feature_size = a.feature_size;
  opt.contour.mesh_edges = a.mesh_edge_contours;
  if (a.suggestive_t) opt.suggestive.threshold = *a.suggestive_t;
  if (a.highlight_t) opt.highlight.threshold = *a.highlight_t;
  if (a.ridge_t) opt.ridge.threshold = *a.ridge_t;
  if (a.valley_t) opt.valley.threshold = *a.valley_t;
  if (a.apparent_t) opt.apparent.threshold = *a.apparent_t;
  if (a.pel_t) opt.pel.threshold = *a.pel_t;
  if (a.laplacian_t) opt.laplacian.threshold = *a.laplacian_t;
  if (a.demarcating_t) opt.demarcating.threshold = *a.demarcating_t;
  if (a.crease_angle) opt.crease.angle_deg = *a.crease_angle;
  if (a.no_fade) opt.suggestive.fade = opt.highlight.fade = 0.0;
  d.min_length_px = a.min_length_px >= 0.0 ? a.min_length_px : (ext == ".seg" ? 0.0 : 3.0);
  d.smooth = a.smooth;
  d.visibility = !a.no_visibility;
  validate(d);
  return d;
}

/// `fabrica lines SCENE.json`: every structure's lines in its scene style,
/// the layers `fabrica render SCENE.json --svg` writes (render::vector_layers):
/// context first, focus over it, each structure's colour, width, opacity and
/// hidden lines. --types, --width, --hidden set the focus structures' lines,
/// --smooth every structure's, as render's --lines, --line-width, --hidden
/// and --smooth do.
int run_lines_scene(const LinesArgs& a, const std::string& ext) {
#ifdef FABRICA_LINES_WITH_SCENES
  if (ext != ".svg" && ext != ".pdf")
    throw InputError("-o " + a.output +
                     ": a scene's lines are written as .svg or .pdf (a layer per structure); "
                     ".seg and .json hold the lines of one mesh");
  for (const char* mesh_only :
       {"--feature-size", "--suggestive-threshold", "--highlight-threshold", "--ridge-threshold",
        "--valley-threshold", "--apparent-threshold", "--pel-threshold", "--laplacian-threshold",
        "--demarcating-threshold", "--crease-angle", "--light", "--mesh-edge-contours",
        "--no-visibility", "--min-length", "--no-fade", "--no-taper", "--keep-orientation"})
    if (a.given.count(mesh_only))
      throw InputError(std::string(mesh_only) + ": only for a mesh input; a scene's structures " +
                       "are drawn in their scene style (" + a.mesh + ")");
  if (a.smooth < 0) throw InputError("--smooth must be >= 0 (iterations; 0 = off)");
  if (!(a.width > 0.0) || !std::isfinite(a.width))
    throw InputError("--width: must be a positive number of pixels");
  render::SceneSpec spec = render::read_scene_spec(a.mesh);
  for (auto& s : spec.structures) {
    if (!a.space.empty()) s.space = parse_space(a.space);
    if (a.given.count("--smooth")) s.style.smooth = a.smooth;
    if (s.role != render::Role::focus) continue;
    if (a.given.count("--types"))
      s.style.families = parse_family_list(a.types, "--types", LineOptions{}.families, false);
    if (a.given.count("--width")) s.style.lines.width = a.width;
    if (a.given.count("--hidden"))
      s.style.lines.hidden = *render::parse_hidden_lines(lower(a.hidden));
  }
  const render::Frame frame = frame_option(a.frame, spec);
  const render::SceneSurfaces scene = load_scene_surfaces(spec);
  const ChosenCamera chosen =
      choose_scene_camera(scene, frame, a.camera_file, a.view, a.size, {1024, 1024}, a.mesh);
  const Camera& camera = chosen.camera;
  const render::Scene drawn = render::build_scene(scene, camera);
  const std::vector<LineLayer> layers = render::vector_layers(scene, drawn, camera);
  if (ext == ".svg")
    write_layered_svg(a.output, layers, camera);
  else
    write_layered_pdf(a.output, layers, camera);
  if (!a.quiet) {
    std::size_t polylines = 0;
    for (const auto& l : layers) polylines += l.lines.polylines.size();
    std::fprintf(stderr, "fabrica lines: %zu structure(s), %zu polylines -> %s\n", layers.size(),
                 polylines, a.output.c_str());
  }
  if (chosen.from_view)
    for (const auto& path : scene.assumed_space)
      warn_if_space_assumed(SpaceSource::default_assumed, path, "lines", a.quiet);
  return 0;
#else
  (void)ext;
  throw Error(ErrorKind::unavailable, a.mesh +
                                          ": a scene input needs the renderer library "
                                          "(fabrica::render), which this build lacks");
#endif
}

int run_lines(const LinesArgs& a) {
  const std::filesystem::path out_path(a.output);
  const std::string ext = lower(out_path.extension().string());
  if (ext != ".svg" && ext != ".pdf" && ext != ".seg" && ext != ".json")
    throw InputError("-o " + a.output + ": output must end in .svg, .pdf, .seg or .json");
  if (ext == ".pdf" && !pdf_available())
    throw Error(ErrorKind::unavailable, "PDF output needs cairo, which this build lacks; use .svg");
  if (!a.camera_file.empty() && !a.view.empty())
    throw InputError("give either --camera FILE or --view NAME, not both");
  if (is_scene_file(a.mesh)) return run_lines_scene(a, ext);
  if (!a.frame.empty()) throw InputError("--frame: only for a scene input (SCENE.json)");
  DrawLinesOptions options = drawing_options(a, ext);

  // Mesh preparation the lines need (on by default, reported): STL welding
  // happens in the reader; orient consistently and outward (inward normals
  // make contours vanish and swap ridges with valleys); normals are always
  // computed from the geometry. Cached for `fabrica batch` (cli_common.hpp).
  PrepareOptions prepare;
  if (!a.space.empty()) prepare.space = parse_space(a.space);
  prepare.orient = !a.keep_normals_orientation;
  const auto loaded = load_prepared_surface(a.mesh, prepare);
  if (!a.quiet)
    for (const auto& m : loaded->messages) std::fprintf(stderr, "fabrica lines: %s\n", m.c_str());
  const Surface& surface = *loaded->surface;
  const TriangleMesh& mesh = surface.mesh();

  const ChosenCamera chosen = choose_camera(
      a.camera_file, a.view, a.size, {1024, 1024}, [&](AnatomicalView v, int w, int h) {
        return anatomical_camera(v, bounding_box(mesh.positions), mesh.space, w, h);
      });
  const Camera& camera = chosen.camera;
  // Warned about once the work is done.
  const SpaceSource assumed_space = chosen.from_view ? mesh.space_source : SpaceSource::file_tag;
  check_camera_sees_mesh(camera, mesh, chosen.what);

  options.lines.families = parse_family_list(a.types, "--types", LineOptions{}.families, false);
  if (!a.light.empty()) {
    options.lines.pel.light_direction = options.lines.laplacian.light_direction =
        parse_vec3(a.light, "--light");
  }
  const LineDrawing drawing = loaded->draw_lines(camera, options);
  const LineSet& lines = drawing.lines;

  const std::size_t segments = drawing.segment_count();
  if (segments == 0 && !a.quiet) {
    std::string names;
    for (auto f : options.lines.families)
      names += std::string(names.empty() ? "" : ",") + family_name(f);
    std::fprintf(stderr,
                 "fabrica lines: warning: no lines of type %s from this view; the output is "
                 "empty (try another --view, lower --<family>-threshold, or --types all)\n",
                 names.c_str());
  }

  nlohmann::json header = drawing_header(drawing, surface, camera, options);
  header["mesh"] = std::filesystem::path(a.mesh).filename().string();
  header["source"] = "fabrica lines";

  LineStyle style;
  style.width_px = a.width;
  style.hidden = lower(a.hidden) == "dashed" ? HiddenLines::dashed : HiddenLines::omit;
  if (a.no_taper) style.taper_fraction = 0.0;
  if (ext == ".svg")
    write_svg(out_path, lines, camera, style);
  else if (ext == ".pdf")
    write_pdf(out_path, lines, camera, style);
  else if (ext == ".seg")
    write_seg(out_path, header, lines, !a.no_visibility);
  else
    write_lines_json(out_path, lines, header);
  if (!a.quiet) {
    const auto [total, visible] = drawing.visible_vertices();
    std::fprintf(stderr,
                 "fabrica lines: %zu segments, %zu polylines (%zu of %zu vertices visible) -> %s\n",
                 segments, lines.polylines.size(), visible, total, a.output.c_str());
  }
  warn_if_space_assumed(assumed_space, a.mesh, "lines", a.quiet);
  return 0;
}

}  // namespace

void add_lines_command(CLI::App& app, Action& action) {
  auto args = std::make_shared<LinesArgs>();
  CLI::App* cmd = app.add_subcommand(
      "lines",
      "Object-space feature lines (contours, suggestive contours, ridges, ...) as "
      "SVG, PDF, .seg or JSON");
  cmd->add_option("mesh", args->mesh,
                  "Input mesh (OBJ, PLY, STL, OFF, VTP, VTK), or a scene .json (every "
                  "structure's lines in its scene style, as render --svg)")
      ->required();
  cmd->add_option("-o,--output", args->output, "Output file: .svg, .pdf, .seg or .json")
      ->required();
  cmd->add_option("--camera", args->camera_file, "Camera JSON (or a reference .seg header)");
  cmd->add_option(
      "--view", args->view,
      "Anatomical view: anterior (default), posterior, left, right, superior, inferior");
  cmd->add_option("--size", args->size, "Image size WxH in pixels (default: camera's, 1024x1024)");
  cmd->add_option("--space", args->space,
                  "Coordinate space of the mesh: lps or ras (default: file tag, else lps)");
  cmd->add_option("--frame", args->frame,
                  "Scene input: what the view frames, focus (default with context) or all");
  cmd->add_option("--types", args->types,
                  "Comma-separated families: contour, boundary, crease, suggestive, highlight, "
                  "ridge, valley, apparent, pel, laplacian, demarcating; or default "
                  "(contour,boundary,suggestive), reference, all");
  cmd->add_option("--feature-size", args->feature_size,
                  "Feature size in mesh units (default: rtsc's rule from curvature)");
  cmd->add_option("--suggestive-threshold", args->suggestive_t,
                  "Default 0.01 (x 1/feature_size^2)");
  cmd->add_option("--highlight-threshold", args->highlight_t, "Default 0.02 (x 1/feature_size^2)");
  cmd->add_option("--ridge-threshold", args->ridge_t, "Default 0.1 (x 1/feature_size)");
  cmd->add_option("--valley-threshold", args->valley_t, "Default 0.1 (x 1/feature_size)");
  cmd->add_option("--apparent-threshold", args->apparent_t, "Default 0.1 (x 1/feature_size^2)");
  cmd->add_option("--pel-threshold", args->pel_t, "Default 0.2 (x 1/feature_size)");
  cmd->add_option("--laplacian-threshold", args->laplacian_t, "Default 0.2 (x 1/feature_size)");
  cmd->add_option("--demarcating-threshold", args->demarcating_t,
                  "Default 0.05 (x 1/feature_size^2)");
  cmd->add_option("--crease-angle", args->crease_angle,
                  "Crease normal deviation in degrees (default 60)");
  cmd->add_option("--light", args->light,
                  "Light direction X,Y,Z for pel/laplacian (default: headlight)");
  cmd->add_flag("--mesh-edge-contours", args->mesh_edge_contours,
                "Contours along mesh edges instead of interpolated");
  cmd->add_flag("--no-visibility", args->no_visibility,
                "Keep hidden lines (no hidden-line removal)");
  cmd->add_option("--hidden", args->hidden, "Hidden lines: omit (default) or dashed")
      ->transform(CLI::IsMember({"omit", "dashed"}, CLI::ignore_case));
  cmd->add_option("--min-length", args->min_length_px,
                  "Drop chains shorter than this many pixels (default 3; 0 for .seg)");
  cmd->add_option("--smooth", args->smooth,
                  "Smooth lines on the surface with N iterations (default 0 = off; try 3)");
  cmd->add_option("--width", args->width, "Stroke width in pixels at 1024 px (default 1.2)");
  cmd->add_flag("--no-fade", args->no_fade, "Do not fade suggestive contours/highlights");
  cmd->add_flag("--no-taper", args->no_taper, "Do not taper line ends");
  cmd->add_flag("--keep-orientation", args->keep_normals_orientation,
                "Do not re-orient the mesh outward before extraction");
  cmd->add_flag("-q,--quiet", args->quiet, "No messages on stderr except errors");
  cmd->callback([&action, args, cmd]() {
    args->given.clear();
    for (const CLI::Option* o : cmd->get_options())
      if (o->count() > 0 && !o->get_lnames().empty()) args->given.insert("--" + o->get_lnames()[0]);
    action = [args]() { return run_lines(*args); };
  });
}

}  // namespace fabrica::cli
