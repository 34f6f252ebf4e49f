// Test helpers for the rtsc reference files: decompress a .seg.xz (through
// `xz -dc`), read index.tsv, and prepare a mesh exactly as the reference
// README describes (STL welded by read_mesh, faces flipped when the signed
// volume about the bounding-box centre is negative, file normals ignored).
#pragma once

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/lines/seg_io.hpp"

namespace fabrica::test {

inline SegFile read_seg_xz(const std::filesystem::path& path) {
  const std::string cmd = "xz -dc '" + path.string() + "'";
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) throw std::runtime_error("cannot run " + cmd);
  std::string text;
  char buf[1 << 16];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) text.append(buf, n);
  const int rc = pclose(pipe);
  if (rc != 0 || text.empty()) throw std::runtime_error("xz failed on " + path.string());
  std::istringstream in(text);
  return read_seg(in, path.string());
}

struct ReferenceEntry {
  std::string file, mesh_path, view;
};

inline std::vector<ReferenceEntry> read_reference_index(const std::filesystem::path& tsv) {
  std::ifstream in(tsv);
  if (!in) throw std::runtime_error("cannot open " + tsv.string());
  std::vector<ReferenceEntry> out;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    ReferenceEntry e;
    std::getline(ls, e.file, '\t');
    std::getline(ls, e.mesh_path, '\t');
    std::getline(ls, e.view, '\t');
    if (!e.file.empty()) out.push_back(e);
  }
  return out;
}

/// Flips every face when the signed volume about the bounding-box centre is
/// negative (the reference README's orientation rule). Returns true if flipped.
inline bool orient_like_reference(TriangleMesh& mesh) {
  const Vec3 c = bounding_box(mesh.positions).center();
  double vol = 0.0;
  for (const auto& f : mesh.faces) {
    const Vec3 a = mesh.positions[f[0]] - c, b = mesh.positions[f[1]] - c,
               d = mesh.positions[f[2]] - c;
    vol += a.dot(b.cross(d));
  }
  if (vol >= 0.0) return false;
  for (auto& f : mesh.faces) std::swap(f[1], f[2]);
  return true;
}

}  // namespace fabrica::test
