// `fabrica lines MESH [--camera FILE | --view NAME] [--size WxH] [--types LIST]
//  [--feature-size F] [--<family>-threshold T ...] [--no-visibility]
//  [--hidden omit|dashed] -o OUT.{svg,pdf,seg,json}`: object-space feature
// lines (docs/lines/).
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
#include "fabrica/lines/seg_io.hpp"
#include "fabrica/lines/smooth.hpp"
#include "fabrica/lines/visibility.hpp"
#include "fabrica/lines/writers.hpp"

namespace fabrica::cli {
namespace {

struct LinesArgs {
  std::string mesh, camera_file, view, size, types = "default", output, hidden = "omit", light;
  std::string space;
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

void check_threshold(const std::optional<double>& t, const char* name) {
  if (t && !(*t >= 0.0 && std::isfinite(*t)))
    throw InputError(std::string("--") + name + "-threshold must be a non-negative number");
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

int run_lines(const LinesArgs& a) {
  const std::filesystem::path out_path(a.output);
  const std::string ext = lower(out_path.extension().string());
  if (ext != ".svg" && ext != ".pdf" && ext != ".seg" && ext != ".json")
    throw InputError("-o " + a.output + ": output must end in .svg, .pdf, .seg or .json");
  if (ext == ".pdf" && !pdf_available())
    throw Error(ErrorKind::unavailable, "PDF output needs cairo, which this build lacks; use .svg");
  if (!a.camera_file.empty() && !a.view.empty())
    throw InputError("give either --camera FILE or --view NAME, not both");
  for (auto [t, n] : {std::pair{&a.suggestive_t, "suggestive"},
                      {&a.highlight_t, "highlight"},
                      {&a.ridge_t, "ridge"},
                      {&a.valley_t, "valley"},
                      {&a.apparent_t, "apparent"},
                      {&a.pel_t, "pel"},
                      {&a.laplacian_t, "laplacian"},
                      {&a.demarcating_t, "demarcating"}})
    check_threshold(*t, n);
  if (a.feature_size < 0.0 || !std::isfinite(a.feature_size))
    throw InputError("--feature-size must be a positive length in mesh units");
  if (a.smooth < 0) throw InputError("--smooth must be >= 0 (iterations; 0 = off)");

  io::ReadOptions ro;
  if (!a.space.empty()) ro.space = parse_space(a.space);
  // Mesh preparation the lines need (on by default, reported): STL welding
  // happened in read_mesh; orient consistently and outward (inward normals
  // make contours vanish and swap ridges with valleys); normals are always
  // computed from the geometry. Cached for `fabrica batch` (cli_common.hpp).
  const auto loaded = load_prepared_mesh(a.mesh, ro, !a.keep_normals_orientation);
  if (!a.quiet)
    for (const auto& c : loaded->changes) std::fprintf(stderr, "fabrica lines: %s\n", c.c_str());
  const TriangleMesh& mesh = loaded->surface.mesh();
  if (!a.quiet && loaded->info.welded_vertices > 0)
    std::fprintf(stderr, "fabrica lines: welded %zu coincident STL vertices\n",
                 loaded->info.welded_vertices);

  Camera camera;
  std::string camera_what;
  if (!a.camera_file.empty()) {
    camera = read_camera(a.camera_file);
    camera_what = a.camera_file;
  } else {
    const std::string vname = a.view.empty() ? "anterior" : lower(a.view);
    const auto view = parse_anatomical_view(vname);
    if (!view)
      throw InputError("--view: unknown view \"" + a.view +
                       "\" (anterior, posterior, left, right, superior, inferior)");
    camera = anatomical_camera(*view, bounding_box(mesh.positions), mesh.space);
    camera_what = "--view " + vname;
  }
  if (!a.size.empty()) std::tie(camera.width, camera.height) = parse_size(a.size);
  validate_camera(camera, camera_what);
  check_camera_sees_mesh(camera, mesh, camera_what);

  const Surface& surface = loaded->surface;
  LineOptions opt;
  opt.families = parse_family_list(a.types, "--types", LineOptions{}.families, false);
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
  if (!a.light.empty()) {
    opt.pel.light_direction = opt.laplacian.light_direction = parse_vec3(a.light, "--light");
  }
  LineExtractor extractor(surface, opt);
  const auto soups = extractor.extract(camera);

  ChainOptions chain;
  chain.camera = camera;
  chain.min_length_px = a.min_length_px >= 0.0 ? a.min_length_px : (ext == ".seg" ? 0.0 : 3.0);
  LineSet lines = chain_segments(soups, chain);
  if (a.smooth > 0) {  // on the surface, before visibility tests the positions
    LineSmoothingOptions so;
    so.iterations = a.smooth;
    smooth_lines(lines, surface, so);  // polylines it cannot smooth stay as they are
  }
  if (!a.no_visibility) compute_visibility(lines, surface, camera);

  std::size_t segments = 0;
  nlohmann::json counts = nlohmann::json::object(), types = nlohmann::json::array();
  for (const auto& s : soups) {
    segments += s.segments.size();
    counts[family_name(s.family)] = s.segments.size();
    types.push_back(family_name(s.family));
  }
  if (segments == 0 && !a.quiet) {
    std::string names;
    for (auto f : opt.families) names += std::string(names.empty() ? "" : ",") + family_name(f);
    std::fprintf(stderr,
                 "fabrica lines: warning: no lines of type %s from this view; the output is "
                 "empty (try another --view, lower --<family>-threshold, or --types all)\n",
                 names.c_str());
  }

  nlohmann::json header = camera_to_json(camera);
  header["mesh"] = std::filesystem::path(a.mesh).filename().string();
  header["nv"] = surface.vertex_count();
  header["nf"] = surface.face_count();
  header["feature_size"] = extractor.feature_size();
  header["thresholds"] = {{"suggestive", opt.suggestive.threshold},
                          {"highlight", opt.highlight.threshold},
                          {"ridge", opt.ridge.threshold},
                          {"valley", opt.valley.threshold},
                          {"apparent", opt.apparent.threshold},
                          {"pel", opt.pel.threshold},
                          {"laplacian", opt.laplacian.threshold},
                          {"demarcating", opt.demarcating.threshold},
                          {"crease_angle_deg", opt.crease.angle_deg}};
  header["types"] = types;
  header["segments"] = counts;
  header["visibility"] = !a.no_visibility;
  if (a.smooth > 0) header["smooth"] = a.smooth;
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
    std::size_t visible = 0, total = 0;
    for (const auto& p : lines.polylines)
      for (const auto& v : p.vertices) visible += v.visible, ++total;
    std::fprintf(stderr,
                 "fabrica lines: %zu segments, %zu polylines (%zu of %zu vertices visible) -> %s\n",
                 segments, lines.polylines.size(), visible, total, a.output.c_str());
  }
  return 0;
}

}  // namespace

void add_lines_command(CLI::App& app, Action& action) {
  auto args = std::make_shared<LinesArgs>();
  CLI::App* cmd = app.add_subcommand(
      "lines",
      "Object-space feature lines (contours, suggestive contours, ridges, ...) as "
      "SVG, PDF, .seg or JSON");
  cmd->add_option("mesh", args->mesh, "Input mesh (OBJ, PLY, STL, OFF, VTP, VTK)")->required();
  cmd->add_option("-o,--output", args->output, "Output file: .svg, .pdf, .seg or .json")
      ->required();
  cmd->add_option("--camera", args->camera_file, "Camera JSON (or a reference .seg header)");
  cmd->add_option(
      "--view", args->view,
      "Anatomical view: anterior (default), posterior, left, right, superior, inferior");
  cmd->add_option("--size", args->size, "Image size WxH in pixels (default: camera's, 1024x1024)");
  cmd->add_option("--space", args->space,
                  "Coordinate space of the mesh: lps or ras (default: file tag, else lps)");
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
      ->check(CLI::IsMember({"omit", "dashed"}));
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
  cmd->callback([&action, args]() { action = [args]() { return run_lines(*args); }; });
}

}  // namespace fabrica::cli
