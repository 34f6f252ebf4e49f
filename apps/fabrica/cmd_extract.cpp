// `fabrica extract VOLUME -o DIR`: one surface mesh per label of a label
// volume (NIfTI, NRRD / .seg.nrrd, MetaImage), or one iso-surface of a scalar
// volume (--iso), in LPS patient millimetres (docs/volumes.md). Each mesh is
// named after its label (sanitised for file names) or label_<N>; a label that
// yields no surface is reported and skipped. Also writes DIR/surfaces.json
// (name, label, layer, colour, file, counts) so colours survive.
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/suggest.hpp"
#include "fabrica/io/label_volume.hpp"
#include "fabrica/io/mesh_io.hpp"
#if __has_include("fabrica/render/scene.hpp")
#include "fabrica/render/scene.hpp"
#define FABRICA_EXTRACT_SCENE 1
#endif

namespace fabrica::cli {

namespace {

struct ExtractCommandOptions {
  std::string volume;
  std::string output;
  std::vector<int> labels;
  std::optional<int> smooth;
  double passband = 0.1;
  double decimate = 0.0;
  std::optional<double> iso;
  std::string format = "stl";
  std::string names;
  std::string space = "lps";
  std::string min_island = "0";
  bool largest_component = false;
  std::vector<std::string> focus;
  bool quiet = false;
};

#ifdef FABRICA_EXTRACT_SCENE
/// Opacity of the context structures in DIR/scene.json (default_style's 0.25
/// suits a few; a segmentation has dozens that overlap).
constexpr double kContextOpacity = 0.15;
#endif

/// --min-island: "N" or "Nvox" voxels, "Nmm3" cubic millimetres (converted
/// with the volume's voxel size, rounded up).
std::size_t parse_min_island(const std::string& text, const io::VolumeGeometry& g) {
  std::string number = text, unit;
  const auto split = text.find_first_not_of("0123456789.eE+");
  if (split != std::string::npos) {
    number = text.substr(0, split);
    unit = lower(text.substr(split));
  }
  double value = -1.0;
  try {
    std::size_t used = 0;
    value = std::stod(number, &used);
    if (used != number.size()) value = -1.0;
  } catch (const std::exception&) {
    value = -1.0;
  }
  if (!(value >= 0.0) || !std::isfinite(value) ||
      !(unit.empty() || unit == "vox" || unit == "voxels" || unit == "mm3" || unit == "mm^3"))
    throw InputError(
        "--min-island: expected a number of voxels (e.g. 20) or a volume in mm3 "
        "(e.g. 500mm3), got \"" +
        text + "\"");
  if (unit.rfind("mm", 0) == 0) value /= g.spacing[0] * g.spacing[1] * g.spacing[2];
  return static_cast<std::size_t>(std::ceil(value - 1e-9));
}

/// Keeps letters, digits, '-', '_' and '.'; everything else becomes '_'
/// (runs collapsed); no leading dots, no empty names.
std::string sanitize_file_name(const std::string& name, const std::string& fallback) {
  std::string out;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    const bool keep = std::isalnum(u) || c == '-' || c == '_' || c == '.';
    if (keep) {
      out.push_back(c);
    } else if (!out.empty() && out.back() != '_') {
      out.push_back('_');
    }
  }
  while (!out.empty() && (out.back() == '_' || out.back() == '.')) out.pop_back();
  while (!out.empty() && (out.front() == '.' || out.front() == '_')) out.erase(out.begin());
  if (out.size() > 120) out.resize(120);
  return out.empty() ? fallback : out;
}

std::string dims_text(const io::VolumeGeometry& g) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%dx%dx%d voxels, spacing %.4gx%.4gx%.4g mm", g.dims[0], g.dims[1],
                g.dims[2], g.spacing[0], g.spacing[1], g.spacing[2]);
  return buf;
}

int run_extract(const ExtractCommandOptions& o) {
  const Space space = parse_space(o.space);  // a bad value fails before any work
  io::LabelVolume volume = io::read_label_volume(o.volume);
  if (!o.names.empty()) {
    for (const io::LabelInfo& entry : io::read_label_names(o.names)) {
      bool replaced = false;
      for (io::LabelInfo& info : volume.labels)
        if (info.value == entry.value) {
          info.name = entry.name;
          if (entry.color) info.color = entry.color;
          replaced = true;
        }
      if (!replaced) volume.labels.push_back(entry);
    }
  }
  std::printf("read %s: %s, %s\n", o.volume.c_str(), volume.format.c_str(),
              dims_text(volume.geometry).c_str());
  std::printf("  orientation: %s\n", volume.orientation_source.c_str());
  for (const std::string& note : volume.notes) std::printf("  note: %s\n", note.c_str());

  io::ExtractOptions options;
  options.labels = o.labels;
  options.min_island_voxels = parse_min_island(o.min_island, volume.geometry);
  options.largest_component = o.largest_component;
  // Progress on a terminal (labels are extracted in parallel).
  const bool terminal = !o.quiet && isatty(fileno(stderr)) != 0;
  if (terminal)
    options.progress = [](std::size_t done, std::size_t total) {
      std::fprintf(stderr, "\rfabrica extract: %zu/%zu labels", done, total);
      if (done == total) std::fprintf(stderr, "\n");
      return true;
    };
  options.smoothing_iterations = o.smooth;
  options.smoothing_passband = o.passband;
  options.decimate = o.decimate;
  options.iso_value = o.iso;
  const std::vector<io::ExtractedSurface> surfaces = io::extract_surfaces(volume, options);

  // --focus names must be structures of this volume (checked before writing).
  std::vector<std::string> names;
  for (const io::ExtractedSurface& s : surfaces)
    if (!s.mesh.empty()) names.push_back(s.name);
  std::vector<std::uint8_t> is_focus(surfaces.size(), 0);
  for (const std::string& f : o.focus) {
    bool found = false;
    for (std::size_t i = 0; i < surfaces.size(); ++i)
      if (!surfaces[i].mesh.empty() &&
          (lower(surfaces[i].name) == lower(f) ||
           sanitize_file_name(lower(surfaces[i].name), "") == lower(f))) {
        is_focus[i] = found = true;
      }
    if (!found)
      throw InputError("--focus: no structure named \"" + f + "\" in " + o.volume +
                       did_you_mean(f, names) + " (see the names in the label table)");
  }

  const std::filesystem::path dir(o.output);
  std::error_code ec;
  // Only a run with a surface to write creates the folder (a failed run leaves nothing).
  const bool any = std::any_of(surfaces.begin(), surfaces.end(),
                               [](const io::ExtractedSurface& s) { return !s.mesh.empty(); });
  if (any) std::filesystem::create_directories(dir, ec);
  if (any && (ec || !std::filesystem::is_directory(dir)))
    throw OutputError("cannot create output folder '" + dir.string() +
                      "': " + (ec ? ec.message() : std::string("not a folder")));

  std::set<std::string> used;
  nlohmann::json manifest = nlohmann::json::array();
  std::size_t written = 0, skipped = 0, write_failures = 0, islands = 0;
#ifdef FABRICA_EXTRACT_SCENE
  render::SceneSpec scene;
  scene.view = AnatomicalView::anterior;
#endif
  for (std::size_t index = 0; index < surfaces.size(); ++index) {
    const io::ExtractedSurface& s = surfaces[index];
    islands += s.islands_removed;
    const std::string fallback = "label_" + std::to_string(s.label);
    std::string base = sanitize_file_name(s.name, fallback);
    if (used.count(base) != 0) base += "_" + std::to_string(s.label);
    if (used.count(base) != 0) base += "_layer" + std::to_string(s.layer);
    for (int n = 2; used.count(base) != 0; ++n) base += "_" + std::to_string(n);
    if (s.mesh.empty()) {
      ++skipped;
      std::printf("  skipped %s (label %d): %s\n", s.name.c_str(), s.label, s.problem.c_str());
      continue;
    }
    used.insert(base);
    const std::filesystem::path file = dir / (base + "." + o.format);
    TriangleMesh mesh = s.mesh;
    if (space == Space::ras) {
      // RAS = LPS with x and y negated: a rotation, so winding stays outward.
      for (Vec3& p : mesh.positions) p = Vec3(-p.x(), -p.y(), p.z());
      mesh.space = Space::ras;
      mesh.space_source = SpaceSource::user_override;
    }
    try {
      io::write_mesh(mesh, file);
    } catch (const Error& e) {
      ++write_failures;
      std::fprintf(stderr, "fabrica: %s\n", e.what());
      continue;
    }
    ++written;
    std::printf("  wrote %s  (label %d%s, %zu voxels, %zu vertices, %zu faces)\n",
                file.string().c_str(), s.label,
                s.layer > 0 ? (", layer " + std::to_string(s.layer)).c_str() : "", s.voxel_count,
                mesh.vertex_count(), mesh.face_count());
    nlohmann::json entry = {{"name", s.name},
                            {"label", s.label},
                            {"layer", s.layer},
                            {"file", file.filename().string()},
                            {"voxels", s.voxel_count},
                            {"vertices", mesh.vertex_count()},
                            {"faces", mesh.face_count()},
                            {"space", to_string(mesh.space)}};
    if (s.color) entry["color"] = {(*s.color)[0], (*s.color)[1], (*s.color)[2]};
    if (s.islands_removed > 0) {
      entry["islands_removed"] = s.islands_removed;
      entry["island_voxels_removed"] = s.island_voxels_removed;
    }
    manifest.push_back(std::move(entry));
#ifdef FABRICA_EXTRACT_SCENE
    // One structure per label: context unless named by --focus; the
    // palette's colour for a known name, else the file's, else a cycle.
    render::StructureSpec st;
    st.name = s.name;
    st.mesh = file.filename();
    st.role = is_focus[index] ? render::Role::focus : render::Role::context;
    st.style = render::default_style(st.role);
    // A label map has many structures: lighter ghosts keep the layers readable.
    if (st.role == render::Role::context) st.style.opacity = kContextOpacity;
    if (const auto c = render::anatomical_color(s.name)) {
      st.style.color = *c;
    } else if (s.color) {
      st.style.color = {static_cast<float>((*s.color)[0]), static_cast<float>((*s.color)[1]),
                        static_cast<float>((*s.color)[2]), 1.0f};
    } else {
      st.style.color = render::cycle_color(scene.structures.size());
    }
    scene.structures.push_back(std::move(st));
#endif
  }
  if (written > 0) {
    const nlohmann::json doc = {{"volume", o.volume},
                                {"format", volume.format},
                                {"orientation", volume.orientation_source},
                                {"surfaces", manifest}};
    write_file_atomically(dir / "surfaces.json",
                          [&](std::ostream& out) { out << doc.dump(2) << "\n"; });
#ifdef FABRICA_EXTRACT_SCENE
    // Focus structures are drawn last, over the context.
    std::stable_partition(
        scene.structures.begin(), scene.structures.end(),
        [](const render::StructureSpec& st) { return st.role != render::Role::focus; });
    render::write_scene_spec(scene, dir / "scene.json");
    std::printf("  wrote %s  (%zu structures, %zu focus; fabrica render %s -o FIGURE.png)\n",
                (dir / "scene.json").string().c_str(), scene.structures.size(), o.focus.size(),
                (dir / "scene.json").string().c_str());
#endif
  }
  if (islands > 0)
    std::printf("  dropped %zu island(s) below --min-island%s\n", islands,
                o.largest_component ? " or outside the largest piece" : "");
  std::printf("%zu surface(s) written to %s", written, dir.string().c_str());
  if (skipped > 0) std::printf(", %zu label(s) skipped", skipped);
  if (write_failures > 0) std::printf(", %zu could not be written", write_failures);
  std::printf("\n");
  if (written == 0) {
    if (write_failures > 0) throw OutputError("no surface could be written to " + dir.string());
    throw InputError(o.volume + ": no label yielded a surface (see the reasons above)");
  }
  return 0;
}

}  // namespace

void add_extract_command(CLI::App& app, Action& action) {
  auto* cmd = app.add_subcommand(
      "extract",
      "Label volume (NIfTI, NRRD/.seg.nrrd, MetaImage) to one surface per label, in LPS mm "
      "(docs/volumes.md)");
  auto o = std::make_shared<ExtractCommandOptions>();
  cmd->add_option("VOLUME", o->volume, "volume file (.nii .nii.gz .nrrd .seg.nrrd .nhdr .mha .mhd)")
      ->required();
  cmd->add_option("-o,--output", o->output, "output folder (created if missing)")->required();
  cmd->add_option("--labels", o->labels,
                  "label values to extract, e.g. 1,2,5 (default: all nonzero)")
      ->delimiter(',');
  cmd->add_option("--smooth", o->smooth,
                  "windowed-sinc smoothing iterations (default 60 for labels, 0 for --iso)")
      ->check(CLI::Range(0, 10000));
  cmd->add_option("--passband", o->passband, "smoothing pass band in (0,2); smaller is smoother")
      ->capture_default_str();
  cmd->add_option("--decimate", o->decimate, "fraction of faces to remove, in [0,1)")
      ->check(CLI::Range(0.0, 0.999));
  cmd->add_option("--iso", o->iso,
                  "extract the iso-surface at this value (level sets, intensity images)");
  cmd->add_option("--format", o->format, "mesh format of the outputs")
      ->transform(CLI::IsMember({"stl", "obj", "ply", "off"}, CLI::ignore_case))
      ->capture_default_str();
  cmd->add_option("--names", o->names,
                  "label table naming labels: lines 'VALUE NAME [R G B]' (Slicer / ITK-SNAP)");
  cmd->add_option("--space", o->space, "coordinates of the outputs: lps (default) or ras");
  cmd->add_option("--min-island", o->min_island,
                  "drop pieces of a label smaller than this: voxels (20) or mm3 (500mm3)")
      ->capture_default_str();
  cmd->add_flag("--largest-component", o->largest_component,
                "keep only the largest piece of each label");
  cmd->add_option("--focus", o->focus,
                  "structures drawn as the focus in DIR/scene.json (names; the rest is context)")
      ->delimiter(',');
  cmd->add_flag("-q,--quiet", o->quiet, "no progress on stderr");
  cmd->callback([o, &action] { action = [o] { return run_extract(*o); }; });
}

}  // namespace fabrica::cli
