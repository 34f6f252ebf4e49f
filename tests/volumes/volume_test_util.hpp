// Test helpers for label volumes: writers for synthetic NRRD / MetaImage /
// NIfTI files (independent of the readers under test), mesh measurements
// (enclosed volume, volume centroid, closedness) and a grid-accelerated
// point-to-triangle distance.
#pragma once

#include <sys/wait.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/io/label_volume.hpp"

namespace fabrica::test {

/// Samples `shape` (LPS mm -> label) at every voxel centre of `g`.
inline std::vector<std::uint8_t> sample_labels(const io::VolumeGeometry& g,
                                               const std::function<int(const Vec3&)>& shape) {
  std::vector<std::uint8_t> v(g.voxel_count());
  std::size_t n = 0;
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i)
        v[n++] = static_cast<std::uint8_t>(shape(g.index_to_patient(Vec3(i, j, k))));
  return v;
}

inline std::string gzip_bytes(const std::string& raw) {
  z_stream zs{};
  deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);  // gzip wrapper
  std::string out(deflateBound(&zs, raw.size()) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
  zs.avail_in = static_cast<uInt>(raw.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  deflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

inline std::string zlib_bytes(const std::string& raw) {
  uLongf size = compressBound(raw.size());
  std::string out(size, '\0');
  compress2(reinterpret_cast<Bytef*>(out.data()), &size, reinterpret_cast<const Bytef*>(raw.data()),
            raw.size(), 6);
  out.resize(size);
  return out;
}

inline void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

template <class T>
std::string as_bytes(const std::vector<T>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

inline std::string vec_text(const Vec3& v) {
  std::ostringstream s;
  s.precision(17);
  s << "(" << v.x() << "," << v.y() << "," << v.z() << ")";
  return s.str();
}

/// NRRD with `space` ("left-posterior-superior" or "right-anterior-superior")
/// and the given per-axis vectors and origin IN THAT SPACE.
inline void write_nrrd(const std::filesystem::path& path, const std::array<int, 3>& dims,
                       const std::array<Vec3, 3>& axes, const Vec3& origin,
                       const std::string& space, const std::string& data, const std::string& type,
                       bool gzip, const std::string& extra = "", int layers = 1) {
  std::ostringstream h;
  h << "NRRD0004\n# written by a fabrica test\n";
  h << "type: " << type << "\n";
  h << "dimension: " << (layers > 1 ? 4 : 3) << "\n";
  h << "space: " << space << "\n";
  h << "sizes: ";
  if (layers > 1) h << layers << " ";
  h << dims[0] << " " << dims[1] << " " << dims[2] << "\n";
  h << "space directions: ";
  if (layers > 1) h << "none ";
  h << vec_text(axes[0]) << " " << vec_text(axes[1]) << " " << vec_text(axes[2]) << "\n";
  h << "kinds: " << (layers > 1 ? "list " : "") << "domain domain domain\n";
  h << "endian: little\n";
  h << "encoding: " << (gzip ? "gzip" : "raw") << "\n";
  h << "space origin: " << vec_text(origin) << "\n";
  h << extra;
  h << "\n";
  write_bytes(path, h.str() + (gzip ? gzip_bytes(data) : data));
}

/// MetaImage (.mha) with TransformMatrix rows = axis directions (ITK, LPS).
inline void write_mha(const std::filesystem::path& path, const io::VolumeGeometry& g,
                      const std::string& data, const std::string& element_type, bool compress) {
  std::ostringstream h;
  h.precision(17);
  const std::string payload = compress ? zlib_bytes(data) : data;
  h << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n";
  h << "CompressedData = " << (compress ? "True" : "False") << "\n";
  if (compress) h << "CompressedDataSize = " << payload.size() << "\n";
  h << "TransformMatrix =";
  for (int a = 0; a < 3; ++a)
    for (int r = 0; r < 3; ++r) h << " " << g.direction(r, a);
  h << "\nOffset = " << g.origin.x() << " " << g.origin.y() << " " << g.origin.z() << "\n";
  h << "CenterOfRotation = 0 0 0\nAnatomicalOrientation = RAI\n";
  h << "ElementSpacing = " << g.spacing.x() << " " << g.spacing.y() << " " << g.spacing.z() << "\n";
  h << "DimSize = " << g.dims[0] << " " << g.dims[1] << " " << g.dims[2] << "\n";
  h << "ElementType = " << element_type << "\nElementDataFile = LOCAL\n";
  write_bytes(path, h.str() + payload);
}

/// Single-file NIfTI-1 (uint8) with the given RAS sform (3x4) and optional
/// XML label-table extension; gzipped when `gz`.
inline void write_nifti(const std::filesystem::path& path, const std::array<int, 3>& dims,
                        const Eigen::Matrix<double, 3, 4>& sform_ras,
                        const std::vector<std::uint8_t>& data, bool gz,
                        const std::string& label_xml = "", int datatype = 2, int bitpix = 8,
                        const std::string& raw_data = "") {
  std::string hdr(348, '\0');
  auto put = [&](std::size_t off, auto value) { std::memcpy(&hdr[off], &value, sizeof value); };
  put(0, std::int32_t{348});
  put(40, std::int16_t{3});
  for (int a = 0; a < 3; ++a) put(42 + 2 * a, static_cast<std::int16_t>(dims[a]));
  for (int a = 3; a < 7; ++a) put(42 + 2 * a, std::int16_t{1});
  put(70, static_cast<std::int16_t>(datatype));
  put(72, static_cast<std::int16_t>(bitpix));
  put(76, 1.0f);  // qfac
  for (int a = 0; a < 3; ++a) put(80 + 4 * a, static_cast<float>(sform_ras.col(a).norm()));
  std::string ext;
  if (!label_xml.empty()) {
    std::string payload = label_xml;
    while ((payload.size() + 8) % 16 != 0) payload.push_back('\0');
    std::string e(8, '\0');
    const std::int32_t esize = static_cast<std::int32_t>(payload.size() + 8), ecode = 0;
    std::memcpy(&e[0], &esize, 4);
    std::memcpy(&e[4], &ecode, 4);
    ext = e + payload;
  }
  const float vox_offset = static_cast<float>(352 + ext.size());
  put(108, vox_offset);
  put(112, 1.0f);             // scl_slope
  put(252, std::int16_t{0});  // qform_code
  put(254, std::int16_t{2});  // sform_code (aligned)
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) put(280 + 16 * r + 4 * c, static_cast<float>(sform_ras(r, c)));
  std::memcpy(&hdr[344], "n+1\0", 4);
  std::string extender(4, '\0');
  if (!ext.empty()) extender[0] = 1;
  const std::string body = raw_data.empty() ? as_bytes(data) : raw_data;
  const std::string file = hdr + extender + ext + body;
  write_bytes(path, gz ? gzip_bytes(file) : file);
}

/// Single-file NIfTI-1 (uint8) oriented by its qform only (sform_code 0):
/// quaternion (b, c, d), qfac (+1 or -1), voxel sizes and offset, all RAS.
inline void write_nifti_qform(const std::filesystem::path& path, const std::array<int, 3>& dims,
                              const Eigen::Quaterniond& q, float qfac, const Vec3& pixdim,
                              const Vec3& qoffset, const std::vector<std::uint8_t>& data) {
  std::string hdr(352, '\0');
  auto put = [&](std::size_t off, auto value) { std::memcpy(&hdr[off], &value, sizeof value); };
  put(0, std::int32_t{348});
  put(40, std::int16_t{3});
  for (int a = 0; a < 3; ++a) put(42 + 2 * a, static_cast<std::int16_t>(dims[a]));
  put(70, std::int16_t{2});
  put(72, std::int16_t{8});
  put(76, qfac);
  for (int a = 0; a < 3; ++a) put(80 + 4 * a, static_cast<float>(pixdim[a]));
  put(108, 352.0f);
  put(252, std::int16_t{1});  // qform_code: scanner
  put(254, std::int16_t{0});  // no sform
  const Eigen::Quaterniond u = q.w() < 0 ? Eigen::Quaterniond(-q.coeffs()) : q;
  put(256, static_cast<float>(u.x()));
  put(260, static_cast<float>(u.y()));
  put(264, static_cast<float>(u.z()));
  for (int a = 0; a < 3; ++a) put(268 + 4 * a, static_cast<float>(qoffset[a]));
  std::memcpy(&hdr[344], "n+1\0", 4);
  write_bytes(path, hdr + as_bytes(data));
}

// ---------------------------------------------------------------- measurements

/// Signed enclosed volume (positive when faces point outward).
inline double enclosed_volume(const TriangleMesh& m) {
  double v6 = 0.0;
  for (const Face& f : m.faces)
    v6 += m.positions[f[0]].dot(m.positions[f[1]].cross(m.positions[f[2]]));
  return v6 / 6.0;
}

/// Centroid of the enclosed solid.
inline Vec3 volume_centroid(const TriangleMesh& m) {
  double v = 0.0;
  Vec3 c = Vec3::Zero();
  for (const Face& f : m.faces) {
    const Vec3 &a = m.positions[f[0]], &b = m.positions[f[1]], &d = m.positions[f[2]];
    const double t = a.dot(b.cross(d)) / 6.0;
    v += t;
    c += t * (a + b + d) / 4.0;
  }
  return c / v;
}

/// Number of undirected edges used by an odd number of faces (0 = closed).
/// Also counts directed half-edges used twice (inconsistent orientation).
inline std::pair<std::size_t, std::size_t> open_and_misoriented_edges(const TriangleMesh& m) {
  std::map<std::pair<int, int>, int> directed;
  for (const Face& f : m.faces)
    for (int k = 0; k < 3; ++k) ++directed[{f[k], f[(k + 1) % 3]}];
  std::size_t open = 0, misoriented = 0;
  for (const auto& [e, n] : directed) {
    const auto it = directed.find({e.second, e.first});
    const int reverse = it == directed.end() ? 0 : it->second;
    if (n != reverse) ++open;
    if (n > 1 && reverse == 0) ++misoriented;
  }
  return {open, misoriented};
}

/// Undirected edges with more than two faces (non-manifold edges).
inline std::size_t nonmanifold_edges(const TriangleMesh& m) {
  std::map<std::pair<int, int>, int> count;
  for (const Face& f : m.faces)
    for (int k = 0; k < 3; ++k) {
      const int a = f[k], b = f[(k + 1) % 3];
      ++count[{std::min(a, b), std::max(a, b)}];
    }
  std::size_t n = 0;
  for (const auto& [e, c] : count) n += c > 2 ? 1 : 0;
  return n;
}

inline double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Closest point on triangle (Ericson, Real-Time Collision Detection 5.1.5).
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return (p - a).norm();
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return (p - b).norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (p - (a + ab * (d1 / (d1 - d3)))).norm();
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return (p - c).norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (p - (a + ac * (d2 / (d2 - d6)))).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).norm();
  const double denom = 1.0 / (va + vb + vc);
  return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}

/// Distance from points to a triangle mesh through a uniform grid of
/// triangle buckets, searched in growing shells until the best distance is
/// closer than the unsearched shell.
class TriangleDistance {
 public:
  TriangleDistance(const TriangleMesh& mesh, double cell) : mesh_(mesh), cell_(cell) {
    const BoundingBox box = bounding_box(mesh.positions);
    lo_ = box.min;
    for (int a = 0; a < 3; ++a)
      n_[a] = std::max(1, static_cast<int>(std::ceil((box.max[a] - lo_[a]) / cell_)) + 1);
    cells_.resize(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2]);
    for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
      Vec3 mn = mesh.positions[mesh.faces[f][0]], mx = mn;
      for (int k = 1; k < 3; ++k) {
        mn = mn.cwiseMin(mesh.positions[mesh.faces[f][k]]);
        mx = mx.cwiseMax(mesh.positions[mesh.faces[f][k]]);
      }
      const auto a = cell_of(mn), b = cell_of(mx);
      for (int k = a[2]; k <= b[2]; ++k)
        for (int j = a[1]; j <= b[1]; ++j)
          for (int i = a[0]; i <= b[0]; ++i) cells_[index(i, j, k)].push_back(f);
    }
  }

  double operator()(const Vec3& p) const {
    const auto c = cell_of(p);
    double best = std::numeric_limits<double>::max();
    const int max_ring = std::max({n_[0], n_[1], n_[2]});
    for (int r = 0; r <= max_ring; ++r) {
      for (int k = c[2] - r; k <= c[2] + r; ++k)
        for (int j = c[1] - r; j <= c[1] + r; ++j)
          for (int i = c[0] - r; i <= c[0] + r; ++i) {
            if (std::max({std::abs(i - c[0]), std::abs(j - c[1]), std::abs(k - c[2])}) != r)
              continue;
            if (i < 0 || j < 0 || k < 0 || i >= n_[0] || j >= n_[1] || k >= n_[2]) continue;
            for (std::size_t f : cells_[index(i, j, k)]) {
              const Face& t = mesh_.faces[f];
              best = std::min(
                  best, point_triangle_distance(p, mesh_.positions[t[0]], mesh_.positions[t[1]],
                                                mesh_.positions[t[2]]));
            }
          }
      // Everything outside the searched block is at least r * cell_ away
      // (for p inside the grid; outside, keep going until something is found).
      if (best <= r * cell_) break;
    }
    return best;
  }

 private:
  std::array<int, 3> cell_of(const Vec3& p) const {
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a)
      c[a] = std::clamp(static_cast<int>(std::floor((p[a] - lo_[a]) / cell_)), 0, n_[a] - 1);
    return c;
  }
  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * n_[1] + j) * n_[0] + i;
  }
  const TriangleMesh& mesh_;
  double cell_;
  Vec3 lo_;
  std::array<int, 3> n_{};
  std::vector<std::vector<std::size_t>> cells_;
};

/// Exit code and combined stdout + stderr of a shell command line, run with
/// its output sent to `log` (for the e2e tests of `fabrica extract`).
struct CommandRun {
  int exit_code;
  std::string output;
};
inline CommandRun run_logged(const std::string& command_line, const std::filesystem::path& log) {
  const std::string command = command_line + " > \"" + log.string() + "\" 2>&1";
  const int status = std::system(command.c_str());
  std::ifstream in(log);
  std::stringstream s;
  s << in.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, s.str()};
}

}  // namespace fabrica::test
