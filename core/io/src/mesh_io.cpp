// Format dispatch, file loading, coordinate-space tags and shared helpers of
// the mesh readers and writers (see fabrica/io/mesh_io.hpp).
#include "fabrica/io/mesh_io.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/input_file.hpp"
#include "mesh_io_internal.hpp"

namespace fabrica::io {

namespace detail {

void fail(const std::string& file, const std::string& problem) {
  throw InputError(file + ": " + problem);
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  return true;
}

std::optional<Space> find_space_tag(std::string_view text) {
  for (std::size_t i = 0; i + 5 <= text.size(); ++i) {
    if (!iequals(text.substr(i, 5), "SPACE")) continue;
    std::size_t j = i + 5;
    while (j < text.size() && (text[j] == ' ' || text[j] == '\t')) ++j;
    if (j >= text.size() || (text[j] != '=' && text[j] != ':')) continue;
    ++j;
    while (j < text.size() && (text[j] == ' ' || text[j] == '\t')) ++j;
    if (j + 3 > text.size()) continue;
    const auto value = text.substr(j, 3);
    const bool ends =
        j + 3 == text.size() || !std::isalnum(static_cast<unsigned char>(text[j + 3]));
    if (!ends) continue;
    if (iequals(value, "LPS")) return Space::lps;
    if (iequals(value, "RAS")) return Space::ras;
  }
  return std::nullopt;
}

std::size_t line_number(std::string_view text, const char* position) {
  const char* b = text.data();
  const char* e = std::clamp(position, b, b + text.size());
  return 1 + static_cast<std::size_t>(std::count(b, e, '\n'));
}

void add_polygon(const std::int32_t* corners, std::size_t count, TriangleMesh& mesh,
                 MeshFileInfo& info) {
  for (std::size_t k = 1; k + 1 < count; ++k)
    mesh.faces.push_back({corners[0], corners[k], corners[k + 1]});
  if (count > 3) ++info.triangulated_polygons;
}

std::string space_tag(const TriangleMesh& mesh) {
  return std::string("SPACE=") + to_string(mesh.space);
}

// ---- PointWelder: open addressing on the bit patterns of the coordinates.

namespace {
std::uint64_t hash_point(const Vec3& p) {
  std::uint64_t bits[3];
  std::memcpy(bits, p.data(), sizeof bits);
  std::uint64_t h = 0x9E3779B97F4A7C15ull;
  for (std::uint64_t b : bits) {
    h ^= b + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 31;
  }
  return h;
}
bool same_bits(const Vec3& a, const Vec3& b) {
  return std::memcmp(a.data(), b.data(), 24) == 0;
}
}  // namespace

PointWelder::PointWelder(std::size_t expected_points) {
  std::size_t capacity = 64;
  while (capacity < 2 * expected_points) capacity *= 2;
  slots_.assign(capacity, -1);
  mask_ = capacity - 1;
}

void PointWelder::grow(const std::vector<Vec3>& positions) {
  std::vector<std::int32_t> old;
  old.swap(slots_);
  slots_.assign(old.size() * 2, -1);
  mask_ = slots_.size() - 1;
  for (std::int32_t index : old) {
    if (index < 0) continue;
    std::size_t s = hash_point(positions[static_cast<std::size_t>(index)]) & mask_;
    while (slots_[s] >= 0) s = (s + 1) & mask_;
    slots_[s] = index;
  }
}

std::int32_t PointWelder::insert(const Vec3& p, std::vector<Vec3>& positions) {
  std::size_t s = hash_point(p) & mask_;
  while (slots_[s] >= 0) {
    if (same_bits(positions[static_cast<std::size_t>(slots_[s])], p)) return slots_[s];
    s = (s + 1) & mask_;
  }
  const auto index = static_cast<std::int32_t>(positions.size());
  positions.push_back(p);
  slots_[s] = index;
  if (2 * ++used_ > slots_.size()) grow(positions);
  return index;
}

}  // namespace detail

namespace {

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

const char* kKnownRead =
    ".obj (Wavefront or MNI), .ply, .stl, .off, .vtp, .vtk, .gii, .gii.gz or FreeSurfer "
    "surfaces (lh.pial, rh.white, *.inflated, *.sphere, ...)";
const char* kKnownWrite = ".obj, .ply, .stl or .off";

using FilePtr = std::unique_ptr<std::FILE, int (*)(std::FILE*)>;

/// Opens the file for reading; InputError when missing, a folder, not a
/// regular file (FIFO, device), unreadable or empty.
FilePtr open_for_reading(const std::filesystem::path& path, const std::string& name) {
  if (require_regular_file(path, name) == 0) detail::fail(name, "file is empty");
  FilePtr file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) detail::fail(name, std::string("cannot open: ") + std::strerror(errno));
  return file;
}

/// Reads the whole file (see open_for_reading for the errors).
std::string read_whole_file(const std::filesystem::path& path, const std::string& name) {
  std::string data = read_input_file(path, name);
  if (data.empty()) detail::fail(name, "file is empty");
  return data;
}

/// FreeSurfer surfaces often have names that say nothing (lh.pial.T1): look
/// for the magic bytes.
bool starts_with_freesurfer_magic(const std::filesystem::path& path, const std::string& name) {
  FilePtr file = open_for_reading(path, name);
  char head[3] = {};
  const std::size_t got = std::fread(head, 1, sizeof head, file.get());
  return detail::has_freesurfer_magic(std::string_view(head, got));
}

}  // namespace

LoadedMesh read_mesh(const std::filesystem::path& path, const ReadOptions& options) {
  const std::string name = path.string();
  const std::string ext = lower_extension(path);
  LoadedMesh out;
  out.info.path = name;
  if (ext == ".vtp") {
    // Check existence and emptiness ourselves: VTK's messages are not one-line.
    (void)open_for_reading(path, name);
    detail::read_vtp(path, name, options, out);
  } else {
    const bool gifti = ext == ".gii" || (ext == ".gz" && lower_extension(path.stem()) == ".gii");
    const bool known = gifti || detail::is_freesurfer_surface_extension(ext) || ext == ".obj" ||
                       ext == ".ply" || ext == ".stl" || ext == ".off" || ext == ".vtk";
    if (!known && !starts_with_freesurfer_magic(path, name))
      detail::fail(name,
                   "unknown mesh file extension '" + ext + "' (fabrica reads " + kKnownRead + ")");
    const std::string bytes = read_whole_file(path, name);
    std::string_view data = bytes;
    // Text written by some Windows tools starts with a UTF-8 byte-order mark.
    if (ext != ".stl" && data.substr(0, 3) == "\xEF\xBB\xBF") data.remove_prefix(3);
    if (gifti)
      detail::read_gifti(data, name, options, out);
    else if (ext == ".obj" && detail::looks_like_mni_obj(data))
      detail::read_mni_obj(data, name, options, out);
    else if (ext == ".obj")
      detail::read_obj(data, name, options, out);
    else if (ext == ".ply")
      detail::read_ply(data, name, options, out);
    else if (ext == ".stl")
      detail::read_stl(data, name, options, out);
    else if (ext == ".off")
      detail::read_off(data, name, options, out);
    else if (ext == ".vtk")
      detail::read_vtk_legacy(data, name, options, out);
    else
      detail::read_freesurfer(data, name, options, out);
  }
  if (out.mesh.faces.empty())
    detail::fail(name, "the file has no faces (" + std::to_string(out.mesh.positions.size()) +
                           " vertices, 0 triangles): fabrica needs a surface mesh");
  check_mesh_indices_and_values(out.mesh, name);
  if (!options.keep_file_normals) out.info.file_normals.clear();
  if (options.space) {
    out.mesh.space = *options.space;
    out.mesh.space_source = SpaceSource::user_override;
  } else if (out.info.tagged_space) {
    out.mesh.space = *out.info.tagged_space;
    out.mesh.space_source = SpaceSource::file_tag;
  } else {
    out.mesh.space = Space::lps;
    out.mesh.space_source = SpaceSource::default_assumed;
  }
  return out;
}

void write_mesh(const TriangleMesh& mesh, const std::filesystem::path& path,
                const WriteOptions& options) {
  const std::string name = path.string();
  const std::string ext = lower_extension(path);
  if (ext != ".obj" && ext != ".ply" && ext != ".stl" && ext != ".off")
    detail::fail(name, "cannot write mesh files with extension '" + ext + "' (fabrica writes " +
                           kKnownWrite + ")");
  if (mesh.faces.empty()) detail::fail(name, "cannot write a mesh with no faces");
  check_mesh_indices_and_values(mesh, name + " (mesh to write)");
  const bool binary = (ext == ".ply" || ext == ".stl") && options.binary;
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        if (ext == ".obj")
          detail::write_obj(mesh, out, options);
        else if (ext == ".ply")
          detail::write_ply(mesh, out, options);
        else if (ext == ".stl")
          detail::write_stl(mesh, out, options);
        else
          detail::write_off(mesh, out, options);
      },
      binary);
}

}  // namespace fabrica::io
