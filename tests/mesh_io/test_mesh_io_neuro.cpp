// Neuroimaging surface formats: GIfTI (.gii, .gii.gz), MNI BIC .obj and
// FreeSurfer binary surfaces. Real files agree with their OFF conversions in
// the bundled data (same vertex order and faces); files written here in every
// encoding/endianness/order read back exactly; malformed files give an
// InputError naming the file.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "fabrica/io/mesh_io.hpp"
#include "mesh_io_test_util.hpp"
#include "sanitized.hpp"
#include "test_support.hpp"

namespace fabrica {
namespace {

using test::expect_input_error;
using test::read_bytes;
using test::write_bytes;

std::filesystem::path brain(const std::string& relative) {
  return test::bundled_data() / "meshes" / "anatomy" / "brain" / relative;
}

bool has_note(const io::MeshFileInfo& info, const std::string& fragment) {
  return std::any_of(info.notes.begin(), info.notes.end(),
                     [&](const std::string& n) { return n.find(fragment) != std::string::npos; });
}

std::string gunzip(const std::string& gz) {
  z_stream zs{};
  EXPECT_EQ(inflateInit2(&zs, 15 + 16), Z_OK);
  std::string out(gz.size() * 8, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(gz.data()));
  zs.avail_in = static_cast<uInt>(gz.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(inflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  inflateEnd(&zs);
  return out;
}

/// zlib (windowBits 15) or gzip (windowBits 31) compression.
std::string deflate_bytes(const std::string& raw, int window_bits) {
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, 6, Z_DEFLATED, window_bits, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&zs, static_cast<uLong>(raw.size())) + 32, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
  zs.avail_in = static_cast<uInt>(raw.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

std::string base64(const std::string& bytes) {
  const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const auto v = (std::uint32_t{static_cast<unsigned char>(bytes[i])} << 16) |
                   (std::uint32_t{static_cast<unsigned char>(bytes[i + 1])} << 8) |
                   std::uint32_t{static_cast<unsigned char>(bytes[i + 2])};
    for (int s = 18; s >= 0; s -= 6) out.push_back(a[(v >> s) & 63]);
    if (out.size() % 77 == 76) out.push_back('\n');  // line breaks are allowed
  }
  if (i + 1 == bytes.size()) {
    const auto v = std::uint32_t{static_cast<unsigned char>(bytes[i])} << 16;
    out += {a[(v >> 18) & 63], a[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == bytes.size()) {
    const auto v = (std::uint32_t{static_cast<unsigned char>(bytes[i])} << 16) |
                   (std::uint32_t{static_cast<unsigned char>(bytes[i + 1])} << 8);
    out += {a[(v >> 18) & 63], a[(v >> 12) & 63], a[(v >> 6) & 63], '='};
  }
  return out;
}

template <typename T>
void append_value(std::string& out, T v, bool big_endian) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

struct GiftiStyle {
  std::string encoding = "Base64Binary";  // ASCII, Base64Binary, GZipBase64Binary
  bool big_endian = false;
  bool column_major = false;
};

/// One DataArray element: values is Dim0 x 3 in row-major order.
template <typename T>
std::string gifti_array(const char* intent, const char* type, const std::vector<T>& values,
                        const GiftiStyle& s) {
  const std::size_t rows = values.size() / 3;
  std::vector<T> stored(values.size());
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t j = 0; j < 3; ++j)
      stored[s.column_major ? j * rows + i : 3 * i + j] = values[3 * i + j];
  std::string payload;
  if (s.encoding == "ASCII") {
    for (std::size_t i = 0; i < stored.size(); ++i) {
      char tmp[40];
      // Floats printed as the exact double they hold: reads back bit-identical.
      const auto r = std::to_chars(tmp, tmp + sizeof tmp, static_cast<double>(stored[i]));
      payload.append(tmp, r.ptr).append(i % 3 == 2 ? "\n" : " ");
    }
  } else {
    std::string bytes;
    for (T v : stored) append_value(bytes, v, s.big_endian);
    if (s.encoding == "GZipBase64Binary") bytes = deflate_bytes(bytes, 15);
    payload = base64(bytes);
  }
  return std::string("<DataArray Intent=\"") + intent + "\" DataType=\"" + type +
         "\" ArrayIndexingOrder=\"" + (s.column_major ? "ColumnMajorOrder" : "RowMajorOrder") +
         "\" Dimensionality=\"2\" Dim0=\"" + std::to_string(rows) + "\" Dim1=\"3\" Encoding=\"" +
         s.encoding + "\" Endian=\"" + (s.big_endian ? "BigEndian" : "LittleEndian") +
         "\" ExternalFileName=\"\" ExternalFileOffset=\"\">\n<MetaData/>\n<Data>" + payload +
         "</Data>\n</DataArray>\n";
}

std::string make_gifti(const TriangleMesh& m, const GiftiStyle& s) {
  std::vector<float> xyz;
  for (const Vec3& p : m.positions)
    for (int k = 0; k < 3; ++k) xyz.push_back(static_cast<float>(p[k]));
  std::vector<std::int32_t> tri;
  for (const Face& f : m.faces) tri.insert(tri.end(), f.begin(), f.end());
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<!DOCTYPE GIFTI SYSTEM \"http://gifti.projects.nitrc.org/gifti.dtd\">\n"
         "<GIFTI Version=\"1.0\" NumberOfDataArrays=\"2\">\n<MetaData/>\n<LabelTable/>\n" +
         gifti_array("NIFTI_INTENT_POINTSET", "NIFTI_TYPE_FLOAT32", xyz, s) +
         gifti_array("NIFTI_INTENT_TRIANGLE", "NIFTI_TYPE_INT32", tri, s) + "</GIFTI>\n";
}

/// A test mesh with coordinates that are not short decimals.
TriangleMesh test_mesh() {
  TriangleMesh m = test::make_torus(30.0, 9.0, 12, 8, 0.2);
  for (Vec3& p : m.positions) p = p * 1.0000001 + Vec3(-12.3456789, 0.1, 100.0 / 3.0);
  return m;
}

void expect_same_float_mesh(const TriangleMesh& read, const TriangleMesh& written) {
  ASSERT_EQ(read.vertex_count(), written.vertex_count());
  ASSERT_EQ(read.face_count(), written.face_count());
  for (std::size_t i = 0; i < read.vertex_count(); ++i)
    for (int k = 0; k < 3; ++k)
      ASSERT_EQ(read.positions[i][k],
                static_cast<double>(static_cast<float>(written.positions[i][k])))
          << "vertex " << i;
  for (std::size_t f = 0; f < read.face_count(); ++f) ASSERT_EQ(read.faces[f], written.faces[f]);
}

/// Positions (up to float precision) and faces (exactly) agree.
void expect_same_mesh(const TriangleMesh& a, const TriangleMesh& b, double tolerance,
                      const std::string& what) {
  ASSERT_EQ(a.vertex_count(), b.vertex_count()) << what;
  ASSERT_EQ(a.face_count(), b.face_count()) << what;
  double worst = 0;
  for (std::size_t i = 0; i < a.vertex_count(); ++i)
    worst = std::max(worst, (a.positions[i] - b.positions[i]).cwiseAbs().maxCoeff());
  EXPECT_LE(worst, tolerance) << what;
  std::size_t differing = 0;
  for (std::size_t f = 0; f < a.face_count(); ++f) differing += a.faces[f] == b.faces[f] ? 0 : 1;
  EXPECT_EQ(differing, 0u) << what;
}

// ---------------------------------------------------------------- GIfTI

TEST(MeshIoGifti, Fsaverage5AgreesWithOffConversions) {
  for (const char* surface : {"pial_left", "white_left", "infl_left"}) {
    const auto gii = io::read_mesh(brain(std::string("fsaverage5/") + surface + ".gii.gz"));
    const auto off = io::read_mesh(brain(std::string("fsaverage5/") + surface + ".off"));
    EXPECT_EQ(gii.info.format, "gifti");
    EXPECT_TRUE(gii.info.binary);
    EXPECT_EQ(gii.mesh.vertex_count(), 10242u);
    EXPECT_EQ(gii.mesh.face_count(), 20480u);
    EXPECT_EQ(gii.info.file_vertices, 10242u);
    EXPECT_EQ(gii.info.file_polygons, 20480u);
    EXPECT_EQ(gii.mesh.space, Space::ras);
    EXPECT_EQ(gii.mesh.space_source, SpaceSource::file_tag);
    EXPECT_TRUE(has_note(gii.info, "TransformedSpace NIFTI_XFORM_TALAIRACH")) << surface;
    EXPECT_TRUE(has_note(gii.info, "identity matrix")) << surface;
    EXPECT_TRUE(has_note(gii.info, "AnatomicalStructurePrimary CortexLeft")) << surface;
    // The OFF copies print each float32 coordinate with 6 significant digits
    // (printf "%g"): every OFF value must be exactly the GIfTI value printed
    // that way, which checks vertex order and the decoded bits at once.
    std::size_t not_reproduced = 0;
    for (std::size_t i = 0; i < gii.mesh.vertex_count(); ++i)
      for (int k = 0; k < 3; ++k) {
        char text[32];
        std::snprintf(text, sizeof text, "%g", gii.mesh.positions[i][k]);
        double printed = 0;
        std::from_chars(text, text + std::strlen(text), printed);
        not_reproduced += printed == off.mesh.positions[i][k] ? 0 : 1;
      }
    EXPECT_EQ(not_reproduced, 0u) << surface;
    expect_same_mesh(gii.mesh, off.mesh, 5e-4, surface);  // 6 digits of values up to ~108
  }
  // SOURCES.md bounding box of the pial surface.
  const auto pial = io::read_mesh(brain("fsaverage5/pial_left.gii.gz"));
  const BoundingBox box = bounding_box(pial.mesh.positions);
  EXPECT_NEAR(box.min.x(), -68.7888, 1e-4);
  EXPECT_NEAR(box.max.y(), 68.9474, 1e-4);
  EXPECT_NEAR(box.max.z(), 78.124, 1e-4);
}

TEST(MeshIoGifti, OtherDataArraysOfAnyTypeAreIgnored) {
  const TriangleMesh mesh = test_mesh();
  std::string xml = make_gifti(mesh, GiftiStyle{});
  const std::string shape =
      "<DataArray Intent=\"NIFTI_INTENT_SHAPE\" DataType=\"NIFTI_TYPE_INT16\" "
      "Dimensionality=\"1\" Dim0=\"2\" Encoding=\"ASCII\" Endian=\"LittleEndian\">"
      "<Data>1 2</Data></DataArray>\n";
  xml.insert(xml.find("<DataArray"), shape);  // before the point set
  const auto dir = test::temp_dir("mesh_io_gifti_extra");
  write_bytes(dir / "with_shape.gii", xml);
  const auto r = io::read_mesh(dir / "with_shape.gii");
  expect_same_float_mesh(r.mesh, mesh);
  EXPECT_TRUE(has_note(r.info, "ignored DataArrays: NIFTI_INTENT_SHAPE"));
}

TEST(MeshIoGifti, UncompressedCopyAndUserOverride) {
  const auto dir = test::temp_dir("mesh_io_gifti_plain");
  const std::string xml = gunzip(read_bytes(brain("fsaverage5/white_left.gii.gz")));
  write_bytes(dir / "white_left.gii", xml);
  const auto plain = io::read_mesh(dir / "white_left.gii");
  const auto gz = io::read_mesh(brain("fsaverage5/white_left.gii.gz"));
  expect_same_mesh(plain.mesh, gz.mesh, 0.0, "plain vs gz");
  io::ReadOptions lps;
  lps.space = Space::lps;
  const auto overridden = io::read_mesh(dir / "white_left.gii", lps);
  EXPECT_EQ(overridden.mesh.space, Space::lps);
  EXPECT_EQ(overridden.mesh.space_source, SpaceSource::user_override);
  expect_same_mesh(overridden.mesh, gz.mesh, 0.0, "override changes no coordinate");
}

struct EncodingCase {
  const char* encoding;
  bool big_endian;
  bool column_major;
  bool whole_file_gzip;
};

class GiftiEncodings : public ::testing::TestWithParam<EncodingCase> {};

TEST_P(GiftiEncodings, ReadBackExactly) {
  const EncodingCase c = GetParam();
  const TriangleMesh mesh = test_mesh();
  GiftiStyle style;
  style.encoding = c.encoding;
  style.big_endian = c.big_endian;
  style.column_major = c.column_major;
  std::string bytes = make_gifti(mesh, style);
  const auto dir = test::temp_dir("mesh_io_gifti_encodings");
  std::string file = std::string("torus_") + c.encoding + (c.big_endian ? "_be" : "_le") +
                     (c.column_major ? "_col" : "_row") + ".gii";
  if (c.whole_file_gzip) {
    bytes = deflate_bytes(bytes, 31);
    file += ".gz";
  }
  write_bytes(dir / file, bytes);
  const auto r = io::read_mesh(dir / file);
  EXPECT_EQ(r.info.binary, std::string(c.encoding) != "ASCII");
  expect_same_float_mesh(r.mesh, mesh);
  EXPECT_EQ(r.mesh.space, Space::ras);
}

INSTANTIATE_TEST_SUITE_P(Variants, GiftiEncodings,
                         ::testing::Values(EncodingCase{"ASCII", false, false, false},
                                           EncodingCase{"ASCII", false, true, false},
                                           EncodingCase{"Base64Binary", false, false, false},
                                           EncodingCase{"Base64Binary", true, false, false},
                                           EncodingCase{"Base64Binary", true, true, false},
                                           EncodingCase{"GZipBase64Binary", false, false, false},
                                           EncodingCase{"GZipBase64Binary", true, true, true},
                                           EncodingCase{"Base64Binary", false, true, true}),
                         [](const auto& info) {
                           return std::string(info.param.encoding) +
                                  (info.param.big_endian ? "Big" : "Little") +
                                  (info.param.column_major ? "Col" : "Row") +
                                  (info.param.whole_file_gzip ? "Gz" : "");
                         });

/// Replaces the first occurrence of `from` (which must exist).
std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

class MalformedNeuro : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::temp_dir("mesh_io_neuro_errors"); }
  std::filesystem::path file(const std::string& name, const std::string& bytes) {
    write_bytes(dir_ / name, bytes);
    return dir_ / name;
  }
  std::filesystem::path dir_;
};

TEST_F(MalformedNeuro, Gifti) {
  const TriangleMesh mesh = test_mesh();
  GiftiStyle b64;
  const std::string good = make_gifti(mesh, b64);
  ASSERT_NO_THROW(io::read_mesh(file("good.gii", good)));

  // Whole-file gzip cut in half, and its bytes damaged.
  const std::string gz = read_bytes(brain("fsaverage5/pial_left.gii.gz"));
  expect_input_error(file("truncated.gii.gz", gz.substr(0, gz.size() / 2)), "ends early");
  std::string damaged = gz;
  for (std::size_t i = 200; i < 260; ++i) damaged[i] = static_cast<char>(damaged[i] ^ 0x5a);
  expect_input_error(file("damaged.gii.gz", damaged), "corrupt compressed data");
  // Not XML, broken XML, other root.
  expect_input_error(file("garbage.gii", "\x01\x02 this is not xml <<<>"), "not a valid GIfTI XML");
  expect_input_error(file("cut_xml.gii", good.substr(0, good.size() / 2)), "not a valid GIfTI XML");
  expect_input_error(file("other_root.gii", "<?xml version=\"1.0\"?><PLY/>"), "<GIFTI>");
  // Bad base64 (a '*' in the data) and base64 cut in the middle of a byte.
  const auto data_at = good.find("<Data>") + 6;
  std::string bad64 = good;
  bad64[data_at + 10] = '*';
  expect_input_error(file("bad_base64.gii", bad64), "invalid base64 character '*'");
  std::string cut64 = good;
  cut64.erase(data_at + 5, good.find("</Data>") - data_at - 5);
  expect_input_error(file("cut_base64.gii", cut64), "");
  // Wrong Dim: Dim1 of the point set, Dim0 larger than the data.
  expect_input_error(file("dim1.gii", replaced(good, "Dim1=\"3\"", "Dim1=\"2\"")), "Dim1=2");
  expect_input_error(
      file("dim0.gii", replaced(good, "Dim0=\"" + std::to_string(mesh.vertex_count()) + "\"",
                                "Dim0=\"" + std::to_string(mesh.vertex_count() + 1) + "\"")),
      "wrong Dim0/Dim1 or truncated");
  // Huge declared sizes are refused before anything that large is allocated.
  for (const char* encoding : {"Base64Binary", "GZipBase64Binary", "ASCII"}) {
    GiftiStyle st;
    st.encoding = encoding;
    expect_input_error(
        file(std::string("huge_") + encoding + ".gii",
             replaced(make_gifti(mesh, st), "Dim0=\"" + std::to_string(mesh.vertex_count()) + "\"",
                      "Dim0=\"2000000000\"")),
        "2000000000 x 3 values");
  }
  expect_input_error(file("dim0_text.gii", replaced(good, "Dim0=\"", "Dim0=\"x")),
                     "not a valid size");
  expect_input_error(
      file("dims3.gii", replaced(good, "Dimensionality=\"2\"", "Dimensionality=\"3\" Dim2=\"2\"")),
      "two-dimensional");
  // Triangle index out of range (ASCII so the index is easy to edit).
  GiftiStyle ascii;
  ascii.encoding = "ASCII";
  TriangleMesh bad_index = mesh;
  bad_index.faces[5][1] = static_cast<std::int32_t>(mesh.vertex_count());
  expect_input_error(file("index.gii", make_gifti(bad_index, ascii)),
                     "triangle 5 refers to vertex " + std::to_string(mesh.vertex_count()));
  bad_index.faces[5][1] = -1;
  expect_input_error(file("negative.gii", make_gifti(bad_index, ascii)), "refers to vertex -1");
  // ASCII value that is not a number; NaN coordinate.
  const std::string ascii_good = make_gifti(mesh, ascii);
  const auto ascii_data = ascii_good.find("<Data>") + 6;
  expect_input_error(file("ascii_word.gii", std::string(ascii_good).insert(ascii_data, "abc ")),
                     "is not a number");
  TriangleMesh nan_mesh = mesh;
  nan_mesh.positions[3].y() = std::nan("");
  expect_input_error(file("nan.gii", make_gifti(nan_mesh, b64)), "not a finite number");
  // Damaged zlib stream inside a GZipBase64Binary array.
  GiftiStyle zipped;
  zipped.encoding = "GZipBase64Binary";
  std::string zbad = make_gifti(mesh, zipped);
  const auto zdata = zbad.find("<Data>") + 6;
  for (std::size_t i = 8; i < 40; ++i) zbad[zdata + i] = zbad[zdata + i] == 'A' ? 'B' : 'A';
  expect_input_error(file("zlib_damaged.gii", zbad), "DataArray 0 (NIFTI_INTENT_POINTSET)");
  // External data files, unknown encoding, missing arrays.
  expect_input_error(file("external.gii", replaced(good, "ExternalFileName=\"\"",
                                                   "ExternalFileName=\"lh.pial.dat\"")),
                     "external data files not supported");
  expect_input_error(
      file("encoding.gii", replaced(good, "Encoding=\"Base64Binary\"", "Encoding=\"Base85\"")),
      "Encoding=\"Base85\" is not supported");
  expect_input_error(
      file("no_points.gii", replaced(good, "NIFTI_INTENT_POINTSET", "NIFTI_INTENT_SHAPE")),
      "no NIFTI_INTENT_POINTSET");
  expect_input_error(
      file("no_triangles.gii", replaced(good, "NIFTI_INTENT_TRIANGLE", "NIFTI_INTENT_LABEL")),
      "no NIFTI_INTENT_TRIANGLE");
  expect_input_error(file("endian.gii", replaced(good, "LittleEndian", "MiddleEndian")),
                     "Endian=\"MiddleEndian\"");
}

// ---------------------------------------------------------------- MNI .obj

TEST(MeshIoMni, BicSurfaceAgreesWithOffConversion) {
  const auto mni = io::read_mesh(brain("vtkdata_mni-surface-mesh.mni.obj"));
  const auto off = io::read_mesh(brain("vtkdata_mni-surface-mesh.off"));
  EXPECT_EQ(mni.info.format, "mni_obj");
  EXPECT_FALSE(mni.info.binary);
  EXPECT_EQ(mni.mesh.vertex_count(), 1558u);
  EXPECT_EQ(mni.mesh.face_count(), 3112u);
  EXPECT_EQ(mni.info.file_polygons, 3112u);
  EXPECT_EQ(mni.mesh.space, Space::ras);
  EXPECT_EQ(mni.mesh.space_source, SpaceSource::file_tag);
  expect_same_mesh(mni.mesh, off.mesh, 0.0, "mni obj vs off");
  io::ReadOptions ro;
  ro.keep_file_normals = true;
  const auto with_normals = io::read_mesh(brain("vtkdata_mni-surface-mesh.mni.obj"), ro);
  ASSERT_EQ(with_normals.info.file_normals.size(), 1558u);
  for (const Vec3& n : with_normals.info.file_normals) EXPECT_NEAR(n.norm(), 1.0, 1e-3);
}

/// Ascii MNI polygon object: unit square split into a quad and a triangle
/// (5 points), with the given colour block.
std::string mni_object(const std::string& colours, const std::string& indices = "0 1 2 3 1 4 2") {
  return "P 0.3 0.3 0.4 10 1 5\n"
         " 0 0 0\n 1 0 0\n 1 1 0\n 0 1 0\n 2 0.5 0\n\n"
         " 0 0 1\n 0 0 1\n 0 0 1\n 0 0 1\n 0 0 1\n\n"
         " 2\n" +
         colours + "\n\n 4 7\n\n " + indices + "\n";
}

TEST(MeshIoMni, PolygonsColourModesAndSeveralObjects) {
  const auto dir = test::temp_dir("mesh_io_mni");
  for (const std::string& colours :
       {std::string(" 0 1 1 1 1"), std::string(" 1 1 0 0 1 0 1 0 1"),
        std::string(" 2 1 0 0 1 0 1 0 1 0 0 1 1 1 1 1 1 0.5 0.5 0.5 1")}) {
    write_bytes(dir / "square.obj", mni_object(colours));
    const auto r = io::read_mesh(dir / "square.obj");
    EXPECT_EQ(r.info.format, "mni_obj");
    EXPECT_EQ(r.mesh.vertex_count(), 5u);
    ASSERT_EQ(r.mesh.face_count(), 3u) << colours;  // quad fan + triangle
    EXPECT_EQ(r.mesh.faces[0], (Face{0, 1, 2}));
    EXPECT_EQ(r.mesh.faces[1], (Face{0, 2, 3}));
    EXPECT_EQ(r.mesh.faces[2], (Face{1, 4, 2}));
    EXPECT_EQ(r.info.triangulated_polygons, 1u);
  }
  // Two objects: the second one's indices are offset by the first's points.
  write_bytes(dir / "two.obj", mni_object(" 0 1 1 1 1") + mni_object(" 0 1 1 1 1"));
  const auto two = io::read_mesh(dir / "two.obj");
  EXPECT_EQ(two.mesh.vertex_count(), 10u);
  ASSERT_EQ(two.mesh.face_count(), 6u);
  EXPECT_EQ(two.mesh.faces[5], (Face{6, 9, 7}));
  EXPECT_TRUE(has_note(two.info, "2 MNI polygon objects"));
  // A Wavefront file that happens to start with a comment stays Wavefront.
  write_bytes(dir / "wavefront.obj", "# P 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_EQ(io::read_mesh(dir / "wavefront.obj").info.format, "obj");
}

TEST_F(MalformedNeuro, MniObj) {
  const std::string good = mni_object(" 0 1 1 1 1");
  ASSERT_NO_THROW(io::read_mesh(file("good.obj", good)));
  expect_input_error(file("lines.obj", "L 1 3\n0 0 0\n1 0 0\n2 0 0\n0 1 1 1 1\n1\n3\n0 1 2\n"),
                     "holds lines");
  expect_input_error(file("truncated.obj", good.substr(0, good.size() - 8)), "truncated");
  expect_input_error(file("truncated_points.obj", good.substr(0, 40)), "point");
  expect_input_error(file("index.obj", mni_object(" 0 1 1 1 1", "0 1 2 3 1 5 2")),
                     "refers to point 5, but the object has 5 points");
  expect_input_error(file("flag.obj", mni_object(" 3 1 1 1 1")), "colour flag");
  expect_input_error(file("short_polygon.obj", replaced(good, " 4 7\n", " 2 7\n")),
                     "polygon 0 has 2 corners");
  expect_input_error(file("word.obj", replaced(good, " 1 1 0\n", " 1 one 0\n")),
                     "expected a number, found 'one");
  expect_input_error(file("leftover.obj", good + "junk\n"), "after the last polygon object");
  expect_input_error(file("binary.obj", std::string("p\x3e\x99\x99\x9a\x3e\x99", 7)),
                     "binary MNI .obj files are not supported");
}

// ---------------------------------------------------------------- FreeSurfer

void put_be32(std::string& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<char>((v >> s) & 0xff));
}

/// A FreeSurfer triangle surface as mris_convert writes it, optionally with
/// the volume-geometry trailer.
std::string freesurfer_bytes(const TriangleMesh& m, bool trailer) {
  std::string out("\xff\xff\xfe", 3);
  out += "created by fabrica_test on Tue Mar  4 10:00:00 2025\n\n";
  put_be32(out, static_cast<std::uint32_t>(m.vertex_count()));
  put_be32(out, static_cast<std::uint32_t>(m.face_count()));
  for (const Vec3& p : m.positions)
    for (int k = 0; k < 3; ++k) {
      const auto f = static_cast<float>(p[k]);
      std::uint32_t bits;
      std::memcpy(&bits, &f, 4);
      put_be32(out, bits);
    }
  for (const Face& f : m.faces)
    for (std::int32_t v : f) put_be32(out, static_cast<std::uint32_t>(v));
  if (trailer) {
    put_be32(out, 2);  // TAG_OLD_USEREALRAS
    put_be32(out, 0);
    put_be32(out, 20);  // TAG_OLD_SURF_GEOM
    out +=
        "valid = 1  # volume info valid\nfilename = ../mri/filled-pretess255.mgz\n"
        "volume = 256 256 256\nvoxelsize = 1.000000000000000e+00 1.000000000000000e+00 "
        "1.000000000000000e+00\nxras   = -1.000000000000000e+00 0.000000000000000e+00 "
        "0.000000000000000e+00\nyras   = 0.000000000000000e+00 0.000000000000000e+00 "
        "-1.000000000000000e+00\nzras   = 0.000000000000000e+00 1.000000000000000e+00 "
        "0.000000000000000e+00\ncras   = 5.250000000000000e+00 -1.800000000000000e+01 "
        "1.250000000000000e+01\n";
    const std::string cmd = "mris_convert lh.pial.gii lh.pial ProgramVersion: 7.4.1";
    put_be32(out, 3);  // TAG_CMDLINE, int64 length
    put_be32(out, 0);
    put_be32(out, static_cast<std::uint32_t>(cmd.size()));
    out += cmd;
  }
  return out;
}

TEST(MeshIoFreeSurfer, RoundTripOfFsaverage5WithAndWithoutTrailer) {
  const auto off = io::read_mesh(brain("fsaverage5/pial_left.off"));
  const auto dir = test::temp_dir("mesh_io_freesurfer");
  write_bytes(dir / "lh.pial", freesurfer_bytes(off.mesh, true));
  const auto r = io::read_mesh(dir / "lh.pial");
  EXPECT_EQ(r.info.format, "freesurfer");
  EXPECT_TRUE(r.info.binary);
  EXPECT_EQ(r.mesh.vertex_count(), 10242u);
  EXPECT_EQ(r.mesh.face_count(), 20480u);
  EXPECT_EQ(r.mesh.space, Space::ras);
  EXPECT_EQ(r.mesh.space_source, SpaceSource::file_tag);
  expect_same_float_mesh(r.mesh, off.mesh);
  EXPECT_TRUE(has_note(r.info,
                       "c_ras = 5.250000000000000e+00 -1.800000000000000e+01 "
                       "1.250000000000000e+01"));
  EXPECT_TRUE(has_note(r.info, "valid = 1"));
  EXPECT_TRUE(has_note(r.info, "useRealRAS = 0"));
  EXPECT_TRUE(has_note(r.info, "command line: mris_convert"));
  EXPECT_TRUE(has_note(r.info, "created by fabrica_test"));
  // Agrees with the GIfTI original of the same surface to float precision.
  const auto gii = io::read_mesh(brain("fsaverage5/pial_left.gii.gz"));
  expect_same_mesh(r.mesh, gii.mesh, 5e-4, "freesurfer vs gifti (6-digit OFF)");

  // No trailer; names that say nothing (magic bytes decide) and *.white.
  const TriangleMesh small = test_mesh();
  for (const char* name : {"rh.white", "lh.pial.T1", "surface", "brain.inflated", "lh.sphere"}) {
    write_bytes(dir / name, freesurfer_bytes(small, false));
    const auto s = io::read_mesh(dir / name);
    EXPECT_EQ(s.info.format, "freesurfer") << name;
    expect_same_float_mesh(s.mesh, small);
    EXPECT_FALSE(has_note(s.info, "volume geometry")) << name;
  }
}

TEST_F(MalformedNeuro, FreeSurfer) {
  const TriangleMesh mesh = test_mesh();
  const std::string good = freesurfer_bytes(mesh, true);
  ASSERT_NO_THROW(io::read_mesh(file("lh.good", good)));
  const std::size_t header = good.find("\n\n") + 2;
  expect_input_error(file("lh.pial", good.substr(0, header + 8 + 12 * 10)), "truncated FreeSurfer");
  expect_input_error(file("lh.white", good.substr(0, header + 4)), "before the vertex and face");
  expect_input_error(file("lh.inflated", good.substr(0, 20)), "ends in the comment line");
  std::string negative = good;
  negative[header + 4] = '\xff';
  expect_input_error(file("lh.sphere", negative), "negative counts");
  std::string index = good;
  const std::size_t faces_at = header + 8 + 12 * mesh.vertex_count();
  const std::string bad_index("\x00\x01\x00\x00", 4);  // vertex 65536
  index.replace(faces_at + 12 * 7 + 4, 4, bad_index);
  expect_input_error(file("rh.pial", index), "triangle 7 refers to vertex 65536");
  std::string nan = good;
  nan.replace(header + 8 + 12 * 3, 4, std::string("\x7f\xc0\x00\x00", 4));
  expect_input_error(file("rh.white", nan), "not a finite number");
  expect_input_error(
      file("lh.thickness", std::string("\xff\xff\xff\x00\x00\x0a", 6) + std::string(64, '\0')),
      "per-vertex data file");
  expect_input_error(file("lh.orig", "not a surface at all\n"), "magic bytes FF FF FE");
  // Unknown extension without the magic: the message lists what is read.
  const std::string message = expect_input_error(file("mesh.xyz", "1 2 3\n"), "unknown mesh file");
  EXPECT_NE(message.find(".gii"), std::string::npos) << message;
  EXPECT_NE(message.find("FreeSurfer"), std::string::npos) << message;
}

TEST(MeshIoNeuroRobustness, DamagedFilesGiveInputErrorsOnly) {
  // Seeded random damage (bytes changed, cut, inserted) to small files of
  // every new format: each read either succeeds with a valid mesh or throws
  // InputError naming the file; nothing else (run under ASan/UBSan too).
  const TriangleMesh mesh = test_mesh();
  GiftiStyle zipped;
  zipped.encoding = "GZipBase64Binary";
  GiftiStyle ascii;
  ascii.encoding = "ASCII";
  const std::vector<std::pair<std::string, std::string>> originals = {
      {"damaged.gii", make_gifti(mesh, GiftiStyle{})},
      {"damaged_zip.gii", make_gifti(mesh, zipped)},
      {"damaged_ascii.gii", make_gifti(mesh, ascii)},
      {"damaged.gii.gz", deflate_bytes(make_gifti(mesh, GiftiStyle{}), 31)},
      {"damaged.obj", mni_object(" 1 1 0 0 1 0 1 0 1") + mni_object(" 0 1 1 1 1")},
      {"lh.damaged", freesurfer_bytes(mesh, true)}};
  const auto dir = test::temp_dir("mesh_io_neuro_damage");
  std::uint64_t state = 0x9E3779B97F4A7C15ull;
  auto next = [&](std::uint64_t n) {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return state % n;
  };
  std::size_t read_ok = 0, rejected = 0;
  for (const auto& [name, original] : originals) {
    for (int trial = 0; trial < 150; ++trial) {
      std::string bytes = original;
      const auto kind = next(3);
      if (kind == 0) {
        for (std::uint64_t k = 0, n = 1 + next(4); k < n; ++k)
          bytes[next(bytes.size())] = static_cast<char>(next(256));
      } else if (kind == 1) {
        bytes.resize(1 + next(bytes.size() - 1));
      } else {
        bytes.insert(next(bytes.size()), std::string(1 + next(8), static_cast<char>(next(256))));
      }
      write_bytes(dir / name, bytes);
      try {
        const auto r = io::read_mesh(dir / name);
        check_mesh_indices_and_values(r.mesh, name);
        ++read_ok;
      } catch (const InputError& e) {
        ++rejected;
        ASSERT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      } catch (const std::exception& e) {
        FAIL() << name << " trial " << trial << ": not an InputError: " << e.what();
      }
    }
  }
  EXPECT_GT(rejected, 300u);  // most damage is detected
  std::cout << "[ damage ] " << read_ok << " read, " << rejected << " rejected\n";
}

TEST(MeshIoNeuroSpeed, GiftiMniAndFreeSurferReadQuickly) {
  // Generous bound for a shared 2-core machine; the measured time is printed.
  const auto dir = test::temp_dir("mesh_io_neuro_speed");
  write_bytes(dir / "lh.pial",
              freesurfer_bytes(io::read_mesh(brain("fsaverage5/pial_left.off")).mesh, true));
  for (const auto& path : {brain("fsaverage5/pial_left.gii.gz"),
                           brain("vtkdata_mni-surface-mesh.mni.obj"), dir / "lh.pial"}) {
    double best = 1e9;
    for (int repeat = 0; repeat < 3; ++repeat) {
      const auto start = std::chrono::steady_clock::now();
      const auto r = io::read_mesh(path);
      best = std::min(
          best, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                    .count());
      ASSERT_GT(r.mesh.face_count(), 0u);
    }
    std::cout << "[ timing ] read " << path.filename().string() << ": " << best << " ms\n";
    EXPECT_LT(best, 500.0 * test::kTimeScale) << path;
  }
}

}  // namespace
}  // namespace fabrica
