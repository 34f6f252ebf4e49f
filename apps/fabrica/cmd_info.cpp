// `fabrica info MESH`: what the file is, what the reader did with it, which
// coordinate space is assumed and why, and the validation report
// (docs/validation.md). With --repair it repairs the mesh and reports what
// changed; with -o it writes the repaired mesh (vertex i stays vertex i).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/io/label_volume.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/io/validate.hpp"

namespace fabrica::cli {

namespace {

struct InfoOptions {
  std::string mesh;
  bool json = false;
  bool repair = false;
  bool self_intersections = false;
  std::string space;
  std::string output;
  int smooth = 0;
  double passband = 0.1;
};

std::string format_vec(const Vec3& v) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "(%.6g, %.6g, %.6g)", v.x(), v.y(), v.z());
  return buf;
}

std::string yes_no(bool b) {
  return b ? "yes" : "no";
}

std::string space_explanation(const TriangleMesh& mesh, const io::MeshFileInfo& info) {
  std::string s = std::string(to_string(mesh.space)) + ": " + to_string(mesh.space_source);
  if (mesh.space_source == SpaceSource::user_override && info.tagged_space &&
      *info.tagged_space != mesh.space)
    s += std::string(" (the file's tag says ") + to_string(*info.tagged_space) + ")";
  return s;
}

void print_validation(std::ostringstream& out, const io::ValidationReport& r, const char* indent) {
  auto row = [&](const char* name, const std::string& value) {
    const std::size_t width = std::string(name).size();
    out << indent << name << std::string(width < 22 ? 24 - width : 2, ' ') << value << "\n";
  };
  auto num = [](std::size_t n) { return std::to_string(n); };
  row("vertices", num(r.vertices));
  row("faces", num(r.faces));
  row("edges", num(r.edges));
  row("components", num(r.components));
  row("euler characteristic", std::to_string(r.euler_characteristic));
  row("closed", yes_no(r.closed));
  row("boundary edges / loops", num(r.boundary_edges) + " / " + num(r.boundary_loops));
  row("non-manifold edges", num(r.nonmanifold_edges));
  row("non-manifold vertices", num(r.nonmanifold_vertices));
  row("degenerate faces", num(r.degenerate_faces));
  row("duplicate faces", num(r.duplicate_faces));
  row("unreferenced vertices", num(r.unreferenced_vertices));
  row("consistently oriented",
      r.consistently_oriented ? "yes" : "no (" + num(r.inconsistent_edges) + " edges disagree)");
  row("outward",
      r.outward ? (*r.outward ? "yes"
                              : "NO (" + num(r.inward_pieces) +
                                    (r.inward_pieces == 1 ? " closed piece points"
                                                          : " closed pieces point") +
                                    " inward)")
      : r.inward_open_pieces > 0
          ? "NO (" + num(r.inward_open_pieces) +
                (r.inward_open_pieces == 1 ? " open piece points" : " open pieces point") +
                " inward: signed volume with boundary loops capped < 0)"
      : r.closed || !r.consistently_oriented || r.nonmanifold_edges > 0
          ? "n/a (needs a consistently oriented, edge-manifold mesh)"
          : "yes (open: signed volume with boundary loops capped >= 0, or flat)");
  if (r.self_intersecting_face_pairs)
    row("self-intersecting pairs", num(*r.self_intersecting_face_pairs));
  char buf[256];
  std::snprintf(buf, sizeof buf, "%.6g (units^2)", r.area);
  row("area", buf);
  std::snprintf(buf, sizeof buf, "%.6g (units^3)", r.signed_volume);
  row("signed volume", buf);
  std::snprintf(buf, sizeof buf, "%.6g", r.mean_edge_length);
  row("mean edge length", buf);
  const Vec3 size = r.bbox.max - r.bbox.min;
  row("bounding box", format_vec(r.bbox.min) + " .. " + format_vec(r.bbox.max));
  std::snprintf(buf, sizeof buf, ", diagonal %.6g", r.bbox.diagonal());
  row("size", format_vec(size) + buf);
  out << indent << (r.clean() ? "clean: no defects" : "problems:") << "\n";
  for (const auto& p : r.problems) out << indent << "  - " << p << "\n";
  if (!r.notes.empty()) out << indent << "notes:\n";
  for (const auto& n : r.notes) out << indent << "  - " << n << "\n";
}

int run_info(const InfoOptions& o) {
  io::ReadOptions read_options;
  if (!o.space.empty()) read_options.space = parse_space(o.space);
  io::LoadedMesh loaded = io::read_mesh(o.mesh, read_options);
  const TriangleMesh& mesh = loaded.mesh;
  const io::MeshFileInfo& info = loaded.info;

  io::ValidateOptions validate_options;
  validate_options.self_intersections = o.self_intersections;
  const io::ValidationReport report = io::validate_mesh(mesh, validate_options);

  const bool repair = o.repair || !o.output.empty() || o.smooth > 0;
  std::optional<TriangleMesh> repaired;
  std::optional<io::RepairReport> repair_report;
  std::optional<io::ValidationReport> after;
  if (repair) {
    repaired = mesh;
    repair_report = io::repair_mesh(*repaired);
    if (o.smooth > 0) {
      io::smooth_surface(*repaired, o.smooth, o.passband);
      repair_report->changes.push_back("smoothed (windowed sinc, " + std::to_string(o.smooth) +
                                       " iterations, pass band " + std::to_string(o.passband) +
                                       "): vertices moved, enclosed volume nearly kept");
    }
    after = io::validate_mesh(*repaired, validate_options);
    if (!o.output.empty()) io::write_mesh(*repaired, o.output);
  }

  if (o.json) {
    nlohmann::json j;
    j["file"] = {{"path", info.path},
                 {"format", info.format},
                 {"binary", info.binary},
                 {"file_vertices", info.file_vertices},
                 {"file_polygons", info.file_polygons},
                 {"triangulated_polygons", info.triangulated_polygons},
                 {"welded_vertices", info.welded_vertices},
                 {"tagged_space", info.tagged_space ? nlohmann::json(to_string(*info.tagged_space))
                                                    : nlohmann::json(nullptr)},
                 {"notes", info.notes}};
    j["space"] = {{"name", to_string(mesh.space)}, {"source", to_string(mesh.space_source)}};
    j["units"] = "mm (assumed, never scaled)";
    j["validation"] = io::to_json(report);
    if (repair) {
      j["repair"] = io::to_json(*repair_report);
      j["after_repair"] = io::to_json(*after);
      j["output"] = o.output.empty() ? nlohmann::json(nullptr) : nlohmann::json(o.output);
    }
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }

  std::ostringstream out;
  out << "file            " << info.path << "\n";
  out << "format          " << info.format << (info.binary ? " (binary)" : " (ascii)") << "\n";
  out << "read            " << info.file_vertices << " vertex records, " << info.file_polygons
      << " polygons -> " << mesh.vertex_count() << " vertices, " << mesh.face_count() << " faces\n";
  if (info.welded_vertices > 0)
    out << "                welded " << info.welded_vertices
        << " coincident points (STL stores each triangle's corners separately)\n";
  if (info.triangulated_polygons > 0)
    out << "                fan-triangulated " << info.triangulated_polygons
        << " polygons with more than three sides\n";
  for (const auto& n : info.notes) out << "                " << n << "\n";
  out << "space           " << space_explanation(mesh, info) << "\n";
  out << "units           mm assumed (coordinates are never scaled)\n";
  out << "validation\n";
  print_validation(out, report, "  ");
  if (repair) {
    out << "repair\n";
    if (!repair_report->changed()) out << "  nothing to change\n";
    for (const auto& c : repair_report->changes) out << "  - " << c << "\n";
    for (const auto& w : repair_report->warnings) out << "  ! " << w << "\n";
    out << "after repair\n";
    if (after->clean()) {
      out << "  clean: no defects\n";
    } else {
      for (const auto& p : after->problems) out << "  - " << p << "\n";
    }
    if (!o.output.empty())
      out << "written         " << o.output << " (" << repaired->vertex_count() << " vertices, "
          << repaired->face_count() << " faces)\n";
  }
  std::fputs(out.str().c_str(), stdout);
  return 0;
}

}  // namespace

void add_info_command(CLI::App& app, Action& action) {
  auto* cmd = app.add_subcommand(
      "info",
      "Describe a mesh: format, counts, coordinate space, and defects (docs/validation.md)");
  auto o = std::make_shared<InfoOptions>();
  cmd->add_option("MESH", o->mesh,
                  "mesh file: OBJ, PLY, STL, OFF, VTP, VTK, GIfTI (.gii, .gii.gz), MNI .obj, "
                  "FreeSurfer surfaces (docs/formats.md)")
      ->required();
  cmd->add_flag("--json", o->json, "print the report as JSON");
  cmd->add_flag("--repair", o->repair,
                "repair a copy (weld, drop degenerate/duplicate faces, split non-manifold "
                "vertices and edges, orient outward) and report what changed");
  cmd->add_flag("--self-intersections", o->self_intersections,
                "also count intersecting face pairs (CGAL; slower)");
  cmd->add_option(
      "--space", o->space,
      "coordinate space of the file, overriding its SPACE tag (default: tag, else LPS)");
  cmd->add_option("--smooth", o->smooth,
                  "also smooth the repaired copy: N windowed-sinc iterations (volume "
                  "preserving; removes a voxel staircase, e.g. 20); implies --repair")
      ->check(CLI::Range(0, 10000));
  cmd->add_option("--passband", o->passband, "smoothing pass band in (0,2); smaller is smoother")
      ->capture_default_str();
  cmd->add_option("-o,--output", o->output,
                  "write the repaired mesh here (.obj .ply .off .stl); implies --repair");
  cmd->callback([o, &action] { action = [o] { return run_info(*o); }; });
}

}  // namespace fabrica::cli
