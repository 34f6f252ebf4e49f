// `fabrica extract` end to end: files named by label, skipped labels
// reported, the manifest, --space ras, exit codes for bad input.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "fabrica/io/label_volume.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "test_support.hpp"
#include "volume_test_util.hpp"

using namespace fabrica;

namespace {

using test::CommandRun;

CommandRun run_fabrica(const std::string& args, const std::filesystem::path& log) {
  return test::run_logged(std::string("\"") + FABRICA_EXE + "\" " + args, log);
}

std::filesystem::path totalseg() {
  return test::bundled_data() / "meshes" / "volumes" / "totalseg_example_seg.nii.gz";
}

}  // namespace

TEST(ExtractCommand, WritesOneMeshPerLabelAndSkipsAbsentOnes) {
  const auto dir = test::temp_dir("extract-cli");
  const auto out = dir / "new" / "organs";  // created with its parent
  const CommandRun r = run_fabrica("extract \"" + totalseg().string() + "\" -o \"" + out.string() +
                                       "\" --labels 5,2,999 --format ply",
                                   dir / "log.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(std::filesystem::exists(out / "liver.ply")) << r.output;
  EXPECT_TRUE(std::filesystem::exists(out / "kidney_right.ply")) << r.output;
  EXPECT_NE(r.output.find("skipped label_999"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("2 surface(s) written"), std::string::npos) << r.output;

  // The written liver is the library's liver (LPS, outward, closed).
  const io::LoadedMesh liver = io::read_mesh(out / "liver.ply");
  EXPECT_EQ(liver.mesh.space, Space::lps);
  EXPECT_GT(test::enclosed_volume(liver.mesh), 0.0);
  const auto surfaces = io::extract_surfaces(io::read_label_volume(totalseg()), [] {
    io::ExtractOptions o;
    o.labels = {5};
    return o;
  }());
  ASSERT_EQ(surfaces.size(), 1u);
  EXPECT_EQ(liver.mesh.face_count(), surfaces[0].mesh.face_count());
  EXPECT_LT((test::volume_centroid(liver.mesh) - test::volume_centroid(surfaces[0].mesh)).norm(),
            1e-6);

  // Manifest with names, labels and colours.
  std::ifstream manifest_file(out / "surfaces.json");
  const nlohmann::json manifest = nlohmann::json::parse(manifest_file);
  ASSERT_EQ(manifest["surfaces"].size(), 2u);
  EXPECT_EQ(manifest["surfaces"][0]["name"], "kidney_right");
  EXPECT_EQ(manifest["surfaces"][1]["label"], 5);
  EXPECT_EQ(manifest["surfaces"][1]["file"], "liver.ply");
  EXPECT_EQ(manifest["surfaces"][1]["color"].size(), 3u);
}

TEST(ExtractCommand, RasOutputAndNameTables) {
  const auto dir = test::temp_dir("extract-cli-ras");
  test::write_bytes(dir / "names.txt", "5 255 0 0 1 1 1 \"Liver (main)\"\n");
  const CommandRun r = run_fabrica(
      "extract \"" + totalseg().string() + "\" -o \"" + (dir / "out").string() +
          "\" --labels 5 --space ras --names \"" + (dir / "names.txt").string() + "\" --smooth 0",
      dir / "log.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // ITK-SNAP style name "Liver (main)", sanitised for the file name.
  ASSERT_TRUE(std::filesystem::exists(dir / "out" / "Liver_main.stl")) << r.output;
  const io::LoadedMesh ras = io::read_mesh(dir / "out" / "Liver_main.stl");
  EXPECT_EQ(ras.mesh.space, Space::ras);
  EXPECT_GT(test::enclosed_volume(ras.mesh), 0.0);  // still outward after x, y negation
  // Liver on the patient's right: in RAS (+x = right) right of the volume centre.
  const io::LabelVolume v = io::read_label_volume(totalseg());
  const Vec3 centre_lps = v.geometry.index_to_patient(
      Vec3(v.geometry.dims[0] - 1, v.geometry.dims[1] - 1, v.geometry.dims[2] - 1) / 2.0);
  EXPECT_GT(test::volume_centroid(ras.mesh).x(), -centre_lps.x());
}

TEST(ExtractCommand, ExitCodesForBadInput) {
  const auto dir = test::temp_dir("extract-cli-bad");
  CommandRun r = run_fabrica(
      "extract \"" + (dir / "missing.nii.gz").string() + "\" -o \"" + (dir / "out").string() + "\"",
      dir / "log.txt");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("not found"), std::string::npos) << r.output;
  r = run_fabrica(
      "extract \"" + totalseg().string() + "\" -o \"" + (dir / "out").string() + "\" --labels 12",
      dir / "log.txt");
  EXPECT_EQ(r.exit_code, 2) << r.output;  // label 12 is absent: nothing written
  EXPECT_NE(r.output.find("no voxels"), std::string::npos) << r.output;
  r = run_fabrica("extract \"" + totalseg().string() + "\" -o \"" + (dir / "out").string() +
                      "\" --decimate 1.5",
                  dir / "log.txt");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // The output folder cannot be created under a regular file.
  test::write_bytes(dir / "file", "x");
  r = run_fabrica("extract \"" + totalseg().string() + "\" -o \"" +
                      (dir / "file" / "sub").string() + "\" --labels 5",
                  dir / "log.txt");
  EXPECT_EQ(r.exit_code, 3) << r.output;
}
