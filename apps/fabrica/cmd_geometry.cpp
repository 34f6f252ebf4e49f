// `fabrica geometry MESH -o FILE.csv`: per-vertex differential geometry as
// CSV, one row per vertex in file order (docs/geometry.md): position, unit
// normal, mixed Voronoi area, principal curvatures and directions, mean and
// Gaussian curvature, curvature-derivative tensor, validity flag.
#include <CLI/CLI.hpp>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <memory>
#include <ostream>
#include <string>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"

namespace fabrica::cli {

namespace {

struct GeometryOptions {
  std::string mesh;
  std::string output;
  std::string normals = "max";
  int smooth = 0;
  std::string space;
};

/// The CSV columns, in order (documented in docs/geometry.md).
constexpr const char* kHeader =
    "x,y,z,nx,ny,nz,area,k1,k2,e1x,e1y,e1z,e2x,e2y,e2z,mean,gaussian,a,b,c,d,valid\n";

/// Appends the shortest decimal that reads back as exactly `v`.
void append_number(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

int run_geometry(const GeometryOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  // The mesh as stored (no welding, no orienting): this command reports the
  // file's own vertices and orientation.
  io::ReadOptions read_options;
  if (!o.space.empty()) read_options.space = parse_space(o.space);
  io::LoadedMesh loaded = io::read_mesh(o.mesh, read_options);

  SurfaceOptions options;
  options.normal_weighting = o.normals == "area"    ? NormalWeighting::area
                             : o.normals == "angle" ? NormalWeighting::angle
                                                    : NormalWeighting::max;
  options.curvature_smoothing_passes = o.smooth;
  options.derivative_smoothing_passes = o.smooth;
  const Space space = loaded.mesh.space;
  const SpaceSource space_source = loaded.mesh.space_source;
  Surface surface(std::move(loaded.mesh), options);
  surface.precompute();

  const auto& p = surface.positions();
  const auto& n = surface.vertex_normals();
  const auto& area = surface.vertex_areas();
  const auto& curv = surface.curvature();
  const auto& der = surface.curvature_derivatives();
  std::size_t invalid = 0;

  write_file_atomically(o.output, [&](std::ostream& out) {
    std::string buf;
    buf.reserve(1 << 20);
    buf += kHeader;
    for (std::size_t v = 0; v < surface.vertex_count(); ++v) {
      const bool valid = curv.valid[v] && der.valid[v];
      invalid += valid ? 0 : 1;
      const double row[] = {p[v].x(),         p[v].y(),       p[v].z(),       n[v].x(),
                            n[v].y(),         n[v].z(),       area[v],        curv.k1[v],
                            curv.k2[v],       curv.e1[v].x(), curv.e1[v].y(), curv.e1[v].z(),
                            curv.e2[v].x(),   curv.e2[v].y(), curv.e2[v].z(), curv.mean(v),
                            curv.gaussian(v), der.a[v],       der.b[v],       der.c[v],
                            der.d[v]};
      for (double x : row) {
        append_number(buf, x);
        buf += ',';
      }
      buf += valid ? "1\n" : "0\n";
      if (buf.size() > (1 << 20) - 1024) {
        out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
        buf.clear();
      }
    }
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  });

  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "%s: %zu vertices, %zu faces (%s, %s); normals %s, smoothing passes %d\n"
      "feature size %.6g, median edge %.6g, bounding sphere radius %.6g (mm)\n"
      "%zu vertices without valid curvature (isolated or only degenerate faces): zeros, valid=0\n"
      "wrote %s in %.2f s\n",
      o.mesh.c_str(), surface.vertex_count(), surface.face_count(), to_string(space),
      to_string(space_source), o.normals.c_str(), o.smooth, surface.feature_size(),
      surface.median_edge_length(), surface.bounding_sphere_radius(), invalid, o.output.c_str(),
      seconds);
  return 0;
}

}  // namespace

void add_geometry_command(CLI::App& app, Action& action) {
  auto* cmd = app.add_subcommand(
      "geometry",
      "Per-vertex normals, areas, principal curvatures and directions, mean and Gaussian "
      "curvature and curvature derivatives as CSV (docs/geometry.md)");
  auto o = std::make_shared<GeometryOptions>();
  cmd->add_option("MESH", o->mesh,
                  "mesh file: OBJ, PLY, STL, OFF, VTP, VTK, GIfTI (.gii, .gii.gz), MNI .obj, "
                  "FreeSurfer surfaces (docs/formats.md)")
      ->required();
  cmd->add_option("-o,--output", o->output, "CSV file to write, one row per vertex in file order")
      ->required();
  cmd->add_option("--normals", o->normals,
                  "vertex-normal weights: max (Max 1999, as trimesh2/rtsc; default), area, angle")
      ->transform(CLI::IsMember({"max", "area", "angle"}, CLI::ignore_case));
  cmd->add_option("--smooth", o->smooth,
                  "passes of rtsc-style smoothing of curvature and its derivatives "
                  "(Gaussian of one median edge length; default 0)")
      ->check(CLI::Range(0, 100));
  cmd->add_option("--space", o->space,
                  "coordinate space of the file, overriding its SPACE tag (default: tag, else "
                  "LPS); only reported, coordinates are written as stored");
  cmd->callback([o, &action] { action = [o] { return run_geometry(*o); }; });
}

}  // namespace fabrica::cli
