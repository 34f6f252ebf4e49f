// Private helpers shared by the mesh readers and writers (not installed).
#pragma once

#include <charconv>
#include <cstdint>
#include <cstring>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "fabrica/core/error.hpp"
#include "fabrica/io/mesh_io.hpp"

namespace fabrica::io::detail {

/// Most vertices or faces a mesh file may declare (docs/reliability.md): indices
/// are 32-bit, and a header declaring more is refused before allocating.
inline constexpr std::int64_t kMaxMeshElements = 1'000'000'000;

/// Throws InputError("<file>: <problem>").
[[noreturn]] void fail(const std::string& file, const std::string& problem);

/// Finds a 3D Slicer coordinate tag `SPACE=LPS` / `SPACE=RAS` (case-insensitive,
/// spaces around '=' allowed) in a header or comment.
std::optional<Space> find_space_tag(std::string_view text);

/// 1-based line number of `position` in `text` (for error messages only).
std::size_t line_number(std::string_view text, const char* position);

/// Fan-triangulates polygon `corners` (already converted to 0-based indices)
/// into `mesh`; counts it in info.triangulated_polygons when it has > 3 sides.
void add_polygon(const std::int32_t* corners, std::size_t count, TriangleMesh& mesh,
                 MeshFileInfo& info);

/// Welds bit-identical points (STL): returns the index of `p`, adding it to
/// `positions` at first appearance.
class PointWelder {
 public:
  explicit PointWelder(std::size_t expected_points);
  std::int32_t insert(const Vec3& p, std::vector<Vec3>& positions);

 private:
  void grow(const std::vector<Vec3>& positions);
  std::vector<std::int32_t> slots_;  // -1 = empty
  std::size_t mask_ = 0;
  std::size_t used_ = 0;
};

/// Cursor over an ASCII buffer; numbers parsed with std::from_chars.
struct TextCursor {
  const char* begin;
  const char* p;
  const char* end;

  explicit TextCursor(std::string_view text)
      : begin(text.data()), p(text.data()), end(text.data() + text.size()) {}

  bool at_end() const { return p >= end; }
  static bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
  }
  static bool is_blank(char c) { return is_space(c) || c == '\n'; }
  /// Skips spaces and tabs on the current line.
  void skip_spaces() {
    while (p < end && is_space(*p)) ++p;
  }
  /// Skips all whitespace including newlines.
  void skip_blanks() {
    while (p < end && is_blank(*p)) ++p;
  }
  /// Skips whitespace and `#` comments up to the next token.
  void skip_blanks_and_comments() {
    for (;;) {
      skip_blanks();
      if (p < end && *p == '#')
        skip_line();
      else
        return;
    }
  }
  /// Moves past the next newline (or to the end).
  void skip_line() {
    const void* nl = p < end ? std::memchr(p, '\n', static_cast<std::size_t>(end - p)) : nullptr;
    p = nl ? static_cast<const char*>(nl) + 1 : end;
  }
  /// The rest of the current line (without the newline), cursor unchanged.
  std::string_view rest_of_line() const {
    const void* nl = p < end ? std::memchr(p, '\n', static_cast<std::size_t>(end - p)) : nullptr;
    const char* e = nl ? static_cast<const char*>(nl) : end;
    return {p, static_cast<std::size_t>(e - p)};
  }
  /// True at '\n', '#' or the end after skipping spaces on this line.
  bool at_line_end() {
    skip_spaces();
    return p >= end || *p == '\n' || *p == '#';
  }
  /// Next whitespace-delimited token (may cross lines); empty at the end.
  std::string_view token() {
    skip_blanks();
    const char* s = p;
    while (p < end && !is_blank(*p)) ++p;
    return {s, static_cast<std::size_t>(p - s)};
  }
  bool token_ends_here() const { return p >= end || is_blank(*p) || *p == '#'; }

  /// Skips the whitespace before a number (crossing lines when
  /// `cross_lines`) and returns where its digits start (after a '+').
  const char* number_start(bool cross_lines) {
    if (cross_lines)
      skip_blanks();
    else
      skip_spaces();
    const char* s = p;
    if (s < end && *s == '+') ++s;
    return s;
  }
  /// Parses a number at the cursor (after leading whitespace, crossing lines
  /// when `cross_lines`), which must end at whitespace; false otherwise.
  bool parse_double(double& value, bool cross_lines = false) {
    const char* s = number_start(cross_lines);
    const auto r = std::from_chars(s, end, value);
    if (r.ec != std::errc() && r.ec != std::errc::result_out_of_range) return false;
    if (r.ec == std::errc::result_out_of_range) return false;
    p = r.ptr;
    return token_ends_here();
  }
  /// Parses an integer; stops at any non-digit (callers check what follows).
  bool parse_integer(std::int64_t& value, bool cross_lines = false) {
    const char* s = number_start(cross_lines);
    const auto r = std::from_chars(s, end, value);
    if (r.ec != std::errc()) return false;
    p = r.ptr;
    return true;
  }
};

/// Case-insensitive ASCII comparison.
bool iequals(std::string_view a, std::string_view b);

/// Buffered output of numbers and text to a stream (to_chars: shortest
/// representation that reads back to the same double).
class TextWriter {
 public:
  explicit TextWriter(std::ostream& out) : out_(out) { buffer_.reserve(kChunk + 256); }
  ~TextWriter() = default;
  TextWriter& text(std::string_view s) {
    buffer_.append(s);
    maybe_flush();
    return *this;
  }
  TextWriter& number(double v) {
    char tmp[32];
    const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
    buffer_.append(tmp, r.ptr);
    return *this;
  }
  TextWriter& number(float v) {
    char tmp[32];
    const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
    buffer_.append(tmp, r.ptr);
    return *this;
  }
  TextWriter& integer(std::int64_t v) {
    char tmp[24];
    const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
    buffer_.append(tmp, r.ptr);
    return *this;
  }
  TextWriter& bytes(const void* data, std::size_t size) {
    buffer_.append(static_cast<const char*>(data), size);
    maybe_flush();
    return *this;
  }
  void flush() {
    out_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }

 private:
  static constexpr std::size_t kChunk = 1 << 20;
  void maybe_flush() {
    if (buffer_.size() >= kChunk) flush();
  }
  std::ostream& out_;
  std::string buffer_;
};

/// Appends a little-endian value to a byte buffer.
template <typename T>
void put_le(TextWriter& w, T value) {
  static_assert(std::is_trivially_copyable_v<T>);
  w.bytes(&value, sizeof value);  // x86-64 and every platform we target are little endian
}

std::string space_tag(const TriangleMesh& mesh);  // "SPACE=LPS" / "SPACE=RAS"

/// The vertex lines "x y z" and the face lines "3 i j k" shared by ASCII OFF
/// and ASCII PLY.
inline void write_ascii_vertices_and_faces(TextWriter& w, const TriangleMesh& mesh) {
  for (const Vec3& p : mesh.positions)
    w.number(p.x()).text(" ").number(p.y()).text(" ").number(p.z()).text("\n");
  for (const Face& f : mesh.faces)
    w.text("3 ").integer(f[0]).text(" ").integer(f[1]).text(" ").integer(f[2]).text("\n");
}

// Readers: fill out.mesh (positions, faces) and out.info (format, binary,
// counts, tagged_space, notes, file_normals). `name` is used in messages.
void read_obj(std::string_view data, const std::string& name, const ReadOptions& options,
              LoadedMesh& out);
void read_off(std::string_view data, const std::string& name, const ReadOptions& options,
              LoadedMesh& out);
void read_ply(std::string_view data, const std::string& name, const ReadOptions& options,
              LoadedMesh& out);
void read_stl(std::string_view data, const std::string& name, const ReadOptions& options,
              LoadedMesh& out);
void read_vtk_legacy(std::string_view data, const std::string& name, const ReadOptions& options,
                     LoadedMesh& out);
/// Refuses a .vtp whose XML declares counts (points, cells, components,
/// tuples, array byte counts) that are negative, not integers, or larger
/// than the file's bytes can hold: VTK trusts them (InputError naming `name`).
void check_vtp_declarations(std::string_view data, const std::string& name);
void read_vtp(const std::filesystem::path& path, const std::string& name,
              const ReadOptions& options, LoadedMesh& out);

// Neuroimaging surfaces: GIfTI (.gii, .gii.gz), MNI BIC .obj, FreeSurfer
// binary triangle surfaces. Their coordinates are RAS by the format's
// convention: the readers set info.tagged_space = Space::ras.
void read_gifti(std::string_view data, const std::string& name, const ReadOptions& options,
                LoadedMesh& out);
void read_mni_obj(std::string_view data, const std::string& name, const ReadOptions& options,
                  LoadedMesh& out);
void read_freesurfer(std::string_view data, const std::string& name, const ReadOptions& options,
                     LoadedMesh& out);
/// An .obj file that starts with an MNI object letter and a number (`P 0.3 ...`),
/// or a binary MNI object, rather than Wavefront records.
bool looks_like_mni_obj(std::string_view data);
/// Starts with FF FF FE (triangle surface) or FF FF FF / FF FF FD (quadrangle
/// surface or per-vertex data, refused by read_freesurfer with a message).
bool has_freesurfer_magic(std::string_view data);
/// Extensions of FreeSurfer surface names (lh.pial -> ".pial"), lower case.
bool is_freesurfer_surface_extension(std::string_view lower_ext);
/// Inflates zlib or gzip data (concatenated gzip members joined). With
/// `expected` (not SIZE_MAX), the result must have exactly that size.
/// InputError "<name>: <what>: ..." on corrupt or truncated data.
std::string inflate_zlib_or_gzip(std::string_view compressed, std::size_t expected,
                                 const std::string& name, const std::string& what);

// Writers (the mesh has been checked; streams are opened by write_mesh).
void write_obj(const TriangleMesh& mesh, std::ostream& out, const WriteOptions& options);
void write_off(const TriangleMesh& mesh, std::ostream& out, const WriteOptions& options);
void write_ply(const TriangleMesh& mesh, std::ostream& out, const WriteOptions& options);
void write_stl(const TriangleMesh& mesh, std::ostream& out, const WriteOptions& options);

}  // namespace fabrica::io::detail
