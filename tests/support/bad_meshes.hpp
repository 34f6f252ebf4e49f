// Malformed mesh files of every kind the readers must refuse (issue 15):
// each case makes its file in a folder and returns its path. Shared by the
// CLI's e2e tests (every mesh command and `batch`) and the viewer's (`open`).
#pragma once

#include <sys/stat.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace fabrica::test {

namespace fs = std::filesystem;

inline void write_bytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string le32(std::uint32_t v) {
  std::string s(4, '\0');
  for (int i = 0; i < 4; ++i) s[i] = static_cast<char>((v >> (8 * i)) & 0xff);
  return s;
}

inline std::string le_float(float f) {
  std::uint32_t u = 0;
  std::memcpy(&u, &f, 4);
  return le32(u);
}

/// A valid-looking small PNG (signature, IHDR, IDAT, IEND), 207 bytes.
inline std::string png_bytes() {
  std::string s("\x89PNG\r\n\x1a\n", 8);
  auto chunk = [&s](const std::string& type, const std::string& data) {
    const auto n = static_cast<std::uint32_t>(data.size());
    s += std::string{static_cast<char>(n >> 24), static_cast<char>(n >> 16),
                     static_cast<char>(n >> 8), static_cast<char>(n)};
    s += type + data + std::string("\x12\x34\x56\x78", 4);
  };
  chunk("IHDR", std::string("\0\0\0\x10\0\0\0\x10\x08\x02\0\0\0", 13));
  std::string idat;
  std::uint32_t x = 12345;
  for (int i = 0; i < 150; ++i) {
    x = x * 1664525u + 1013904223u;
    idat.push_back(static_cast<char>(x >> 24));
  }
  chunk("IDAT", idat);
  chunk("IEND", "");
  return s;
}

/// Binary STL announcing `announced` triangles but holding only `present`.
inline std::string truncated_stl(const std::string& header_start, std::uint32_t announced,
                                 int present) {
  std::string s = header_start;
  s.resize(80, ' ');
  s += le32(announced);
  for (int t = 0; t < present; ++t) {
    for (int k = 0; k < 12; ++k) s += le_float(static_cast<float>(t + k));
    s += std::string(2, '\0');
  }
  return s;
}

inline std::string truncated_ply() {
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
      "property float y\nproperty float z\nelement face 4\n"
      "property list uchar int vertex_indices\nend_header\n";
  const float v[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (const auto& p : v)
    for (float c : p) s += le_float(c);
  const int f[2][3] = {{0, 2, 1}, {0, 1, 3}};  // 2 of the 4 announced faces
  for (const auto& t : f) {
    s.push_back('\x03');
    for (int i : t) s += le32(static_cast<std::uint32_t>(i));
  }
  return s;
}

inline const char* kTetraObj =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
inline const char* kTetraOffBody =
    "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

/// A small .vtp (a tetrahedron) with `piece` as the Piece's point count and
/// `components` components of its points, in `format` (ascii or binary).
inline std::string vtp_with(const std::string& piece, const std::string& components,
                            const std::string& format) {
  const std::string points = format == "binary" ? "AAAAAA==" : "0 0 0 1 0 0 0 1 0 0 0 1";
  return "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" "
         "byte_order=\"LittleEndian\">\n<PolyData>\n<Piece " +
         piece +
         " NumberOfPolys=\"1\">\n<Points>\n<DataArray type=\"Float32\" "
         "NumberOfComponents=\"" +
         components + "\" format=\"" + format + "\">\n" + points +
         "\n</DataArray>\n</Points>\n<Polys>\n<DataArray type=\"Int32\" Name=\"connectivity\" "
         "format=\"ascii\">0 1 2</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\" "
         "format=\"ascii\">3</DataArray>\n</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n";
}

struct BadMesh {
  std::string name;
  std::function<fs::path(const fs::path& dir)> make;  ///< creates the file, returns its path
};

inline const std::vector<BadMesh>& bad_meshes() {
  static const std::vector<BadMesh> cases{
      {"nonexistent", [](const fs::path& d) { return d / "does_not_exist.obj"; }},
      {"empty_file",
       [](const fs::path& d) {
         write_bytes(d / "empty.off", "");
         return d / "empty.off";
       }},
      {"png_renamed_stl",
       [](const fs::path& d) {
         write_bytes(d / "picture.stl", png_bytes());
         return d / "picture.stl";
       }},
      {"truncated_binary_stl",
       [](const fs::path& d) {
         write_bytes(d / "cut.stl", truncated_stl("binary STL from a scanner", 20, 5));
         return d / "cut.stl";
       }},
      {"truncated_binary_stl_solid_header",  // many binary STLs start with "solid"
       [](const fs::path& d) {
         write_bytes(d / "cut_solid.stl", truncated_stl("solid part", 20, 5));
         return d / "cut_solid.stl";
       }},
      {"truncated_binary_ply",
       [](const fs::path& d) {
         write_bytes(d / "cut.ply", truncated_ply());
         return d / "cut.ply";
       }},
      {"off_counts_too_large",
       [](const fs::path& d) {
         write_bytes(d / "short.off", std::string("OFF\n8 6 0\n") + kTetraOffBody);
         return d / "short.off";
       }},
      {"off_counts_too_small",
       [](const fs::path& d) {
         write_bytes(d / "long.off", std::string("OFF\n3 1 0\n") + kTetraOffBody);
         return d / "long.off";
       }},
      {"obj_nan_coordinate",
       [](const fs::path& d) {
         write_bytes(d / "nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n");
         return d / "nan.obj";
       }},
      {"obj_inf_coordinate",
       [](const fs::path& d) {
         write_bytes(d / "inf.obj", "v 0 0 0\nv 1 0 0\nv 0 inf 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n");
         return d / "inf.obj";
       }},
      {"obj_huge_coordinates",  // areas and normals would overflow to inf
       [](const fs::path& d) {
         write_bytes(d / "huge.obj",
                     "v 0 0 0\nv 1e300 0 0\nv 0 1e300 0\nv 0 0 1e300\n"
                     "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
         return d / "huge.obj";
       }},
      {"stl_triangle_count_overflow",  // 84 + 50 n wraps to the file size in 32 bits
       [](const fs::path& d) {
         write_bytes(d / "wrap.stl", truncated_stl("binary", 2147483650u, 2));
         return d / "wrap.stl";
       }},
      {"ply_huge_vertex_count",
       [](const fs::path& d) {
         write_bytes(d / "huge.ply",
                     "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
                     "property float x\nproperty float y\nproperty float z\nelement face 1\n"
                     "property list uchar int vertex_indices\nend_header\n" +
                         std::string(40, '\0'));
         return d / "huge.ply";
       }},
      {"obj_face_index_out_of_range",
       [](const fs::path& d) {
         write_bytes(d / "index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 9\n");
         return d / "index.obj";
       }},
      {"obj_negative_index_out_of_range",
       [](const fs::path& d) {
         write_bytes(d / "negindex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -7\n");
         return d / "negindex.obj";
       }},
      {"truncated_freesurfer_surface",  // magic FF FF FE, big-endian counts, cut short
       [](const fs::path& d) {
         std::string s("\xff\xff\xfe", 3);
         s += "created by fabrica tests\n\n";
         s += std::string("\0\0\0\x04\0\0\0\x04", 8);  // 4 vertices, 4 triangles
         s += std::string(20, '\0');                   // of 96 bytes of data
         write_bytes(d / "lh.pial", s);
         return d / "lh.pial";
       }},
      {"truncated_gifti",
       [](const fs::path& d) {
         write_bytes(d / "cut.gii",
                     "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<GIFTI Version=\"1.0\" "
                     "NumberOfDataArrays=\"2\">\n<DataArray Intent=\"NIFTI_INTENT_POINTSET\" "
                     "DataType=\"NIFTI_TYPE_FLOAT32\" Dimensionality=\"2\" Dim0=\"4\" "
                     "Dim1=\"3\" Encoding=\"ASCII\">\n<Data>0 0 0 1 0");
         return d / "cut.gii";
       }},
      {"truncated_mni_obj",
       [](const fs::path& d) {
         write_bytes(d / "surface_mni.obj", "P 0.3 0.3 0.4 10 1 4\n0 0 0\n1 0 0\n");
         return d / "surface_mni.obj";
       }},
      {"unknown_extension",
       [](const fs::path& d) {
         write_bytes(d / "tetra.xyz", kTetraObj);
         return d / "tetra.xyz";
       }},
      {"directory",
       [](const fs::path& d) {
         fs::create_directories(d / "folder.stl");
         return d / "folder.stl";
       }},
      // Issue 15's adversarial findings: not a regular file, VTP counts VTK
      // would trust, headers declaring billions of elements, NaN coordinates.
      {"fifo",
       [](const fs::path& d) {
         ::mkfifo((d / "pipe.obj").c_str(), 0644);
         return d / "pipe.obj";
       }},
      {"vtp_negative_point_count",
       [](const fs::path& d) {
         write_bytes(d / "neg.vtp", vtp_with("NumberOfPoints=\"-1\"", "3", "binary"));
         return d / "neg.vtp";
       }},
      {"vtp_huge_component_count",
       [](const fs::path& d) {
         write_bytes(d / "comps.vtp", vtp_with("NumberOfPoints=\"4\"", "4294967295", "ascii"));
         return d / "comps.vtp";
       }},
      {"vtp_points_with_six_components",  // fuzz_vtp finding: VTK leaked its arrays
       [](const fs::path& d) {
         write_bytes(d / "six.vtp", vtp_with("NumberOfPoints=\"4\"", "6", "ascii"));
         return d / "six.vtp";
       }},
      {"vtp_huge_last_offset",  // fuzz_vtp finding 3 (as found): VTK allocated 5.9 GB
       [](const fs::path& d) {
         write_bytes(d / "offsets.vtp",
                     "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" "
                     "byte_order=\"LittleEndian\" header_type=\"UInt32\">\n<PolyData>\n<Piece "
                     "NumberOfPoints=\"4\" NumberOfPolys=\"4\">\n<Points>\n<DataArray "
                     "type=\"Float32\" NumberOfComponents=\"3\" format=\"binary\">"
                     "MAAAAAAAAAAAAAAAAA2\"AAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAAAAAACAPw=="
                     "</DataArray>\n</Points>\n<Polys>\n<DataArray type=\"Int32\" "
                     "Name=\"connectivity\" format=\"binary\">MAAAAAAAAAACAAAAAQAAAAAAAAABAAAAAw"
                     "AAAAAAAAADAAAAAgAAAAEAAAACAAAAAwAAAA==</DataArray>\n<DataArray "
                     "type=\"Int32\" Name=\"offsets\" format=\"binary\">EAAAAAMAAAAGAAAACQAAA/"
                     "VTKFi=</DataArray>\n</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n");
         return d / "offsets.vtp";
       }},
      {"vtp_huge_point_count",
       [](const fs::path& d) {
         write_bytes(d / "huge.vtp", vtp_with("NumberOfPoints=\"900000000\"", "3", "ascii"));
         return d / "huge.vtp";
       }},
      {"ply_billions_of_vertices",
       [](const fs::path& d) {
         write_bytes(d / "big.ply",
                     "ply\nformat ascii 1.0\nelement vertex 3000000000\nproperty float x\n"
                     "property float y\nproperty float z\nelement face 1\n"
                     "property list uchar int vertex_indices\nend_header\n0 0 0\n");
         return d / "big.ply";
       }},
      {"off_billions_of_faces",
       [](const fs::path& d) {
         write_bytes(d / "big.off", std::string("OFF\n4 4000000000 0\n") + kTetraOffBody);
         return d / "big.off";
       }},
      {"vtk_billions_of_points",
       [](const fs::path& d) {
         write_bytes(d / "big.vtk",
                     "# vtk DataFile Version 3.0\nbig\nBINARY\nDATASET POLYDATA\n"
                     "POINTS 2000000000 float\n");
         return d / "big.vtk";
       }},
      {"stl_billions_of_triangles",
       [](const fs::path& d) {
         write_bytes(d / "big.stl", truncated_stl("binary", 4000000000u, 2));
         return d / "big.stl";
       }},
      {"nan_coordinates",
       [](const fs::path& d) {
         write_bytes(d / "nan.obj",
                     "v 0 0 0\nv nan 0 0\nv 0 1 0\nv 0 0 1\n"
                     "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
         return d / "nan.obj";
       }},
  };
  return cases;
}

inline std::vector<std::string> bad_mesh_names() {
  std::vector<std::string> names;
  for (const auto& c : bad_meshes()) names.push_back(c.name);
  return names;
}

inline const BadMesh& bad_mesh(const std::string& name) {
  for (const auto& c : bad_meshes())
    if (c.name == name) return c;
  throw std::logic_error("no bad mesh " + name);
}

}  // namespace fabrica::test
