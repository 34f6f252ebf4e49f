// Fidelity against rtsc (the bundled tests/data/, reference/rtsc): for every reference file,
// the same mesh, eye and feature size; contours, suggestive contours,
// apparent ridges, ridges and valleys compared by length-weighted
// precision/recall/F at 0.5% of the reference bounding-box diagonal,
// sampled every 0.1% (the reference README's protocol). Target F >= 0.9.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/lines/compare.hpp"
#include "fabrica/lines/extract.hpp"
#include "reference_support.hpp"
#include "test_support.hpp"

using namespace fabrica;

namespace {

struct Row {
  std::string file;
  std::map<std::string, LineMatchScore> scores;
};

std::vector<Row> run_reference(const std::vector<std::string>& only = {}) {
  const auto ref_dir = test::bundled_reference() / "rtsc";
  const auto entries = test::read_reference_index(ref_dir / "index.tsv");
  std::vector<Row> rows;
  std::string loaded_path;
  std::unique_ptr<Surface> surface;
  for (const auto& e : entries) {
    if (!only.empty() && std::find(only.begin(), only.end(), e.file) == only.end()) continue;
    const SegFile ref = test::read_seg_xz(ref_dir / e.file);
    if (e.mesh_path != loaded_path) {
      auto loaded = io::read_mesh(test::bundled_data() / "meshes" / e.mesh_path);
      test::orient_like_reference(loaded.mesh);
      surface = std::make_unique<Surface>(std::move(loaded.mesh));
      surface->precompute();
      loaded_path = e.mesh_path;
    }
    Camera camera = camera_from_json(ref.header, e.file);
    LineOptions options;
    options.families = reference_families();
    options.feature_size = ref.header.at("feature_size").get<double>();
    LineExtractor extractor(*surface, options);
    const auto soups = extractor.extract(camera);
    std::vector<std::vector<Segment3>> refsets;
    std::vector<const std::vector<Segment3>*> ptrs;
    for (const auto& g : ref.groups) ptrs.push_back(&g.segments);
    const double D = segments_diagonal(ptrs);
    Row row;
    row.file = e.file;
    for (const auto& soup : soups) {
      const std::string name = family_name(soup.family);
      const SegGroup* g = ref.find(name);
      static const std::vector<Segment3> empty;
      const auto mine = segment_positions(soup);
      row.scores[name] = compare_segments(mine, g ? g->segments : empty, 0.005 * D, 0.001 * D);
    }
    rows.push_back(row);
  }
  return rows;
}

void write_table(const std::vector<Row>& rows, const std::filesystem::path& path) {
  std::ofstream out(path);
  out << "| file | contour | suggestive | apparent | ridge | valley |\n|---|---|---|---|---|---|\n";
  for (const auto& r : rows) {
    out << "| " << r.file;
    for (const char* f : {"contour", "suggestive", "apparent", "ridge", "valley"}) {
      char buf[64];
      const auto& s = r.scores.at(f);
      std::snprintf(buf, sizeof buf, " | %.3f", s.f);
      out << buf;
    }
    out << " |\n";
  }
}

}  // namespace

TEST(LinesReference, EveryFamilyMatchesRtscOnEveryFile) {
  const char* only_env = std::getenv("FABRICA_REFERENCE_ONLY");
  std::vector<std::string> only;
  if (only_env) only.push_back(only_env);
  const auto rows = run_reference(only);
  ASSERT_FALSE(rows.empty());
  write_table(rows, std::filesystem::path(FABRICA_BINARY_DIR) / "lines-fidelity.md");
  for (const auto& r : rows)
    for (const auto& [family, s] : r.scores) {
      std::printf("%-34s %-10s P=%.3f R=%.3f F=%.3f  len %.4g / %.4g\n", r.file.c_str(),
                  family.c_str(), s.precision, s.recall, s.f, s.test_length, s.reference_length);
      EXPECT_GE(s.f, 0.9) << r.file << " " << family;
    }
}
