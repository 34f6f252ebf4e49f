// FreeSurfer binary triangle surface reader (lh.pial, rh.white, *.inflated,
// *.sphere, ...). Layout (all numbers big endian):
//
//   FF FF FE                         magic (triangle file)
//   "created by USER on DATE\n\n"    comment, ends at the first blank line
//   int32 nvertices, int32 nfaces
//   float32 x y z  x nvertices
//   int32 v0 v1 v2 x nfaces           (zero-based)
//   optional trailer: [int32 2, int32 useRealRAS] int32 20 and text lines
//   "valid = 1 ...", "filename = ...", "volume = ...", "voxelsize = ...",
//   "xras/yras/zras = ...", "cras = ..." (volume geometry), then tagged
//   command lines.
//
// Coordinates are tkr-RAS millimetres (surface RAS of the conformed volume;
// scanner RAS = tkr-RAS + c_ras), or scanner RAS when useRealRAS = 1: the
// mesh is labelled RAS and coordinates are kept as stored. The trailer only
// feeds MeshFileInfo::notes. Quadrangle surfaces and per-vertex data files
// (curv, thickness: magic FF FF FF) are refused with a message.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "mesh_io_internal.hpp"

namespace fabrica::io::detail {

namespace {

std::int32_t load_int32_be(const char* p) {
  unsigned char b[4];
  std::memcpy(b, p, 4);
  return static_cast<std::int32_t>((std::uint32_t{b[0]} << 24) | (std::uint32_t{b[1]} << 16) |
                                   (std::uint32_t{b[2]} << 8) | std::uint32_t{b[3]});
}

float load_float_be(const char* p) {
  const auto bits = static_cast<std::uint32_t>(load_int32_be(p));
  float v;
  std::memcpy(&v, &bits, 4);
  return v;
}

std::string printable(std::string_view s, std::size_t limit) {
  std::string out;
  for (char ch : s.substr(0, limit)) {
    const auto u = static_cast<unsigned char>(ch);
    out.push_back(u >= 0x20 && u < 0x7f ? ch : ' ');
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

/// Reads the volume-geometry text lines of the trailer; returns the notes.
void read_trailer(std::string_view tail, MeshFileInfo& info) {
  std::size_t pos = 0;
  auto int_at = [&](std::size_t at) { return load_int32_be(tail.data() + at); };
  bool recognised = false;
  if (tail.size() >= pos + 8 && int_at(pos) == 2) {  // TAG_OLD_USEREALRAS
    const std::int32_t real_ras = int_at(pos + 4);
    info.notes.push_back(real_ras == 1 ? "FreeSurfer useRealRAS = 1: coordinates are scanner RAS"
                                       : "FreeSurfer useRealRAS = 0: coordinates are tkr-RAS");
    pos += 8;
    recognised = true;
  }
  if (tail.size() >= pos + 4 && int_at(pos) == 20) {  // TAG_OLD_SURF_GEOM
    pos += 4;
    recognised = true;
    std::string valid, c_ras, volume;
    // "key = value" lines, as many as follow.
    while (pos < tail.size()) {
      const std::size_t nl = tail.find('\n', pos);
      const std::string_view line =
          tail.substr(pos, (nl == std::string_view::npos ? tail.size() : nl) - pos);
      const std::size_t eq = line.find('=');
      if (eq == std::string_view::npos || eq > 16) break;
      std::string_view key = line.substr(0, eq);
      while (!key.empty() && key.back() == ' ') key.remove_suffix(1);
      if (key.empty() || !std::all_of(key.begin(), key.end(), [](char ch) {
            return (ch >= 'a' && ch <= 'z') || ch == '_';
          }))
        break;
      std::string_view value = line.substr(eq + 1);
      const std::size_t hash = value.find('#');
      if (hash != std::string_view::npos) value = value.substr(0, hash);
      const std::string text = printable(value, 200);
      const std::string clean = text.substr(std::min(text.find_first_not_of(' '), text.size()));
      if (key == "valid") valid = clean;
      if (key == "cras" || key == "c_ras") c_ras = clean;
      if (key == "volume") volume = clean;
      pos = nl == std::string_view::npos ? tail.size() : nl + 1;
    }
    std::string note = "FreeSurfer volume geometry: valid = " + (valid.empty() ? "?" : valid);
    if (!volume.empty()) note += ", volume = " + volume;
    if (!c_ras.empty())
      note += ", c_ras = " + c_ras + " (scanner RAS = tkr-RAS + c_ras; coordinates kept as stored)";
    info.notes.push_back(note);
  }
  // Tagged command lines: int32 tag 3, int64 length, text.
  while (recognised && tail.size() >= pos + 12 && int_at(pos) == 3) {
    std::uint64_t length = 0;
    for (int k = 0; k < 8; ++k)
      length =
          (length << 8) | static_cast<unsigned char>(tail[pos + 4 + static_cast<std::size_t>(k)]);
    if (length > tail.size() - pos - 12) break;
    info.notes.push_back("FreeSurfer command line: " +
                         printable(tail.substr(pos + 12, static_cast<std::size_t>(length)), 200));
    pos += 12 + static_cast<std::size_t>(length);
  }
  if (!recognised && !tail.empty())
    info.notes.push_back(std::to_string(tail.size()) +
                         " bytes after the triangles not recognised (ignored)");
}

}  // namespace

bool has_freesurfer_magic(std::string_view data) {
  if (data.size() < 3) return false;
  const auto b = [&](std::size_t i) { return static_cast<unsigned char>(data[i]); };
  return b(0) == 0xff && b(1) == 0xff && (b(2) == 0xfe || b(2) == 0xff || b(2) == 0xfd);
}

bool is_freesurfer_surface_extension(std::string_view lower_ext) {
  for (const char* e : {".pial", ".white", ".inflated", ".sphere", ".orig", ".smoothwm", ".qsphere",
                        ".midthickness", ".graymid"})
    if (lower_ext == e) return true;
  return false;
}

void read_freesurfer(std::string_view data, const std::string& name, const ReadOptions&,
                     LoadedMesh& out) {
  TriangleMesh& mesh = out.mesh;
  MeshFileInfo& info = out.info;
  info.format = "freesurfer";
  info.binary = true;
  if (!has_freesurfer_magic(data))
    fail(name,
         "not a FreeSurfer surface: the file does not start with the triangle-surface "
         "magic bytes FF FF FE");
  const auto kind = static_cast<unsigned char>(data[2]);
  if (kind != 0xfe)
    fail(name,
         "a FreeSurfer quadrangle surface or per-vertex data file (curv, thickness, sulc; "
         "magic bytes FF FF " +
             std::string(kind == 0xff ? "FF" : "FD") +
             "): fabrica reads FreeSurfer triangle surfaces (magic FF FF FE); convert "
             "quadrangle surfaces with 'mris_convert' first");
  // The comment ends at the first blank line ("\n\n").
  const std::size_t search = std::min<std::size_t>(data.size(), 3 + 64 * 1024);
  const std::size_t blank = data.substr(0, search).find("\n\n", 3);
  if (blank == std::string_view::npos)
    fail(name, data.size() < 3 + 64 * 1024
                   ? "truncated FreeSurfer surface: the file ends in the comment line"
                   : "damaged FreeSurfer surface: no end of the comment line (\"\\n\\n\") in "
                     "the first 64 KiB");
  const std::string comment = printable(data.substr(3, blank - 3), 200);
  if (!comment.empty()) info.notes.push_back("FreeSurfer comment: " + comment);
  std::size_t pos = blank + 2;
  if (data.size() < pos + 8)
    fail(name, "truncated FreeSurfer surface: the file ends before the vertex and face counts");
  const std::int32_t nv = load_int32_be(data.data() + pos);
  const std::int32_t nf = load_int32_be(data.data() + pos + 4);
  pos += 8;
  if (nv > kMaxMeshElements || nf > kMaxMeshElements)
    fail(name, "the header declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                   " faces, more than the " + std::to_string(kMaxMeshElements) + " fabrica reads");
  if (nv < 0 || nf < 0)
    fail(name, "damaged FreeSurfer surface: negative counts (" + std::to_string(nv) +
                   " vertices, " + std::to_string(nf) + " faces)");
  const std::uint64_t needed =
      12 * static_cast<std::uint64_t>(nv) + 12 * static_cast<std::uint64_t>(nf);
  const std::uint64_t available = data.size() - pos;
  if (available < needed)
    fail(name, "truncated FreeSurfer surface: the header declares " + std::to_string(nv) +
                   " vertices and " + std::to_string(nf) + " triangles (" + std::to_string(needed) +
                   " bytes of data) but only " + std::to_string(available) +
                   " bytes follow the header");
  info.file_vertices = static_cast<std::size_t>(nv);
  info.file_polygons = static_cast<std::size_t>(nf);
  mesh.positions.resize(static_cast<std::size_t>(nv));
  const char* p = data.data() + pos;
  for (std::size_t i = 0; i < mesh.positions.size(); ++i, p += 12)
    mesh.positions[i] = Vec3(load_float_be(p), load_float_be(p + 4), load_float_be(p + 8));
  mesh.faces.resize(static_cast<std::size_t>(nf));
  for (std::size_t f = 0; f < mesh.faces.size(); ++f, p += 12)
    for (std::size_t k = 0; k < 3; ++k) {
      const std::int32_t v = load_int32_be(p + 4 * k);
      if (v < 0 || v >= nv)
        fail(name, "triangle " + std::to_string(f) + " refers to vertex " + std::to_string(v) +
                       ", but the file has " + std::to_string(nv) + " vertices (0 to " +
                       std::to_string(static_cast<std::int64_t>(nv) - 1) + ")");
      mesh.faces[f][k] = v;
    }
  read_trailer(data.substr(pos + static_cast<std::size_t>(needed)), info);
  // FreeSurfer surfaces are in (tkr-)RAS millimetres.
  info.tagged_space = Space::ras;
}

}  // namespace fabrica::io::detail
