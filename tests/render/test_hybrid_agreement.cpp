// Agreement of the hybrid (image-space, seed 000) apparent ridges with the
// object-space apparent ridges of fabrica::lines (Judd et al. 2007, as rtsc)
// on real meshes (issue 4 item 5). Both are drawn at the same camera and
// resolution (512 x 512): the hybrid image is binarised (every inked pixel),
// the visible object-space polylines are rasterised 1 px wide. Scores: pixel
// precision (hybrid pixels within 2 px of an object-space pixel), recall
// (object-space pixels within 2 px of a hybrid pixel), F, and the symmetric
// chamfer distance (mean of the two mean nearest distances, in pixels, by an
// exact Euclidean distance transform); and the same away from the outline,
// where the silhouette-adjacent ridges do not dominate. The thresholds guard the measured
// numbers with a margin (docs/rendering.md lists them).
//
// FABRICA_HYBRID_FIGURE=path.png writes the side-by-side figure
// (docs/images/render-hybrid-vs-object.png); FABRICA_HYBRID_SWEEP=1 prints a
// parameter sweep of tau offset, lambda and threshold.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/chain.hpp"
#include "fabrica/lines/extract.hpp"
#include "fabrica/lines/visibility.hpp"
#include "fabrica/render/renderer.hpp"
#include "render_test_util.hpp"
#include "test_support.hpp"

namespace fr = fabrica::render;
using fabrica::Camera;
using fabrica::Vec3;

namespace {

constexpr int kSize = 512;

using fabrica::test::renderer;

struct Case {
  const char* name;
  const char* path;  // under bundled_data()
  fabrica::AnatomicalView view;
  double min_f;           // guard: a bit below the measured F
  double max_chamfer;     // guard: a bit above the measured chamfer distance (px)
  double min_interior_f;  // guard on F away from the outline (0: too few pixels to guard)
};

// Binary image, row 0 at the top.
struct Mask {
  int w = 0, h = 0;
  std::vector<std::uint8_t> on;
  std::size_t count() const {
    return static_cast<std::size_t>(std::count(on.begin(), on.end(), 1));
  }
};

// Exact squared Euclidean distance transform (Felzenszwalb & Huttenlocher 2012).
std::vector<double> distance_transform(const Mask& m) {
  const double inf = 1e20;
  const int n = std::max(m.w, m.h);
  std::vector<double> f(n), d(n), z(n + 1);
  std::vector<int> v(n);
  auto dt1 = [&](int len) {
    int k = 0;
    v[0] = 0;
    z[0] = -inf;
    z[1] = inf;
    for (int q = 1; q < len; ++q) {
      double s = 0.0;
      while (true) {
        s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k]);
        if (s <= z[k] && k > 0)
          --k;
        else
          break;
      }
      if (s <= z[k]) {  // k == 0: replace
        v[0] = q;
        z[0] = -inf;
        z[1] = inf;
        continue;
      }
      ++k;
      v[k] = q;
      z[k] = s;
      z[k + 1] = inf;
    }
    k = 0;
    for (int q = 0; q < len; ++q) {
      while (z[k + 1] < q) ++k;
      d[q] = (q - v[k]) * (q - v[k]) + f[v[k]];
    }
  };
  std::vector<double> g(static_cast<std::size_t>(m.w) * m.h);
  for (int x = 0; x < m.w; ++x) {
    for (int y = 0; y < m.h; ++y) f[y] = m.on[static_cast<std::size_t>(y) * m.w + x] ? 0.0 : inf;
    dt1(m.h);
    for (int y = 0; y < m.h; ++y) g[static_cast<std::size_t>(y) * m.w + x] = d[y];
  }
  for (int y = 0; y < m.h; ++y) {
    for (int x = 0; x < m.w; ++x) f[x] = g[static_cast<std::size_t>(y) * m.w + x];
    dt1(m.w);
    for (int x = 0; x < m.w; ++x) g[static_cast<std::size_t>(y) * m.w + x] = d[x];
  }
  return g;
}

struct Agreement {
  double precision = 0, recall = 0, f = 0, chamfer = 0;
  std::size_t hybrid_pixels = 0, object_pixels = 0;
};

Agreement compare(const Mask& hybrid, const Mask& object, double tolerance = 2.0) {
  Agreement a;
  a.hybrid_pixels = hybrid.count();
  a.object_pixels = object.count();
  if (a.hybrid_pixels == 0 || a.object_pixels == 0) {
    a.chamfer = std::numeric_limits<double>::infinity();
    return a;
  }
  const auto d_obj = distance_transform(object);
  const auto d_hyb = distance_transform(hybrid);
  const double t2 = tolerance * tolerance;
  double sum_h = 0, sum_o = 0;
  std::size_t hit_h = 0, hit_o = 0;
  for (std::size_t i = 0; i < hybrid.on.size(); ++i) {
    if (hybrid.on[i]) {
      sum_h += std::sqrt(d_obj[i]);
      hit_h += d_obj[i] <= t2;
    }
    if (object.on[i]) {
      sum_o += std::sqrt(d_hyb[i]);
      hit_o += d_hyb[i] <= t2;
    }
  }
  a.precision = static_cast<double>(hit_h) / a.hybrid_pixels;
  a.recall = static_cast<double>(hit_o) / a.object_pixels;
  a.f = a.precision + a.recall > 0 ? 2 * a.precision * a.recall / (a.precision + a.recall) : 0.0;
  a.chamfer = 0.5 * (sum_h / a.hybrid_pixels + sum_o / a.object_pixels);
  return a;
}

// The same scores restricted to pixels farther than `band` px from the
// object's outline (the coverage boundary): what remains after the strong
// ridges next to the silhouette, which dominate both drawings.
Agreement compare_interior(const Mask& hybrid, const Mask& object, const Mask& covered,
                           double band) {
  Mask outside{covered.w, covered.h, covered.on};
  for (auto& v : outside.on) v = v ? 0 : 1;
  const auto d_out = distance_transform(outside);
  Mask h = hybrid, o = object;
  for (std::size_t i = 0; i < d_out.size(); ++i)
    if (d_out[i] <= band * band) h.on[i] = o.on[i] = 0;
  return compare(h, o);
}

struct Loaded {
  std::unique_ptr<fabrica::Surface> surface;
  std::shared_ptr<const fr::RenderMesh> mesh;
  Camera camera;
  Mask object;
};

Loaded load(const Case& c) {
  Loaded l;
  fabrica::io::ReadOptions ro;
  if (std::string(c.name) == "pial") ro.space = fabrica::Space::ras;  // FreeSurfer: RAS
  auto file = fabrica::io::read_mesh(fabrica::test::bundled_data() / c.path, ro);
  fabrica::io::prepare_for_lines(file.mesh);
  const auto box = fabrica::bounding_box(file.mesh.positions);
  const auto space = file.mesh.space;
  l.surface = std::make_unique<fabrica::Surface>(std::move(file.mesh));
  l.mesh = std::make_shared<fr::RenderMesh>(fr::make_render_mesh(*l.surface, true));
  l.camera = fabrica::anatomical_camera(c.view, box, space, kSize, kSize);

  // Object-space apparent ridges (rtsc defaults), visible parts, rasterised 1 px.
  fabrica::LineOptions lo;
  lo.families = {fabrica::LineFamily::apparent};
  fabrica::LineExtractor extractor(*l.surface, lo);
  fabrica::LineSet lines = fabrica::chain_segments(extractor.extract(l.camera));
  fabrica::compute_visibility(lines, *l.surface, l.camera);
  l.object = {kSize, kSize, std::vector<std::uint8_t>(kSize * kSize, 0)};
  auto plot = [&](double x, double y) {
    const int ix = static_cast<int>(std::floor(x)), iy = static_cast<int>(std::floor(y));
    if (ix >= 0 && iy >= 0 && ix < kSize && iy < kSize) l.object.on[iy * kSize + ix] = 1;
  };
  for (const auto& p : lines.polylines) {
    const std::size_t n = p.vertices.size();
    const std::size_t edges = p.closed ? n : (n > 0 ? n - 1 : 0);
    for (std::size_t i = 0; i < edges; ++i) {
      if (!p.vertices[i].visible) continue;
      const auto a = fabrica::project(l.camera, p.vertices[i].position).pixel;
      const auto b = fabrica::project(l.camera, p.vertices[(i + 1) % n].position).pixel;
      const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * (b - a).norm())));
      for (int s = 0; s <= steps; ++s) {
        const auto q = a + (b - a) * (static_cast<double>(s) / steps);
        plot(q.x(), q.y());
      }
    }
  }
  return l;
}

Mask hybrid_mask(const fr::Image& img) {
  Mask m{img.width, img.height, std::vector<std::uint8_t>(img.rgba.size() / 4, 0)};
  for (std::size_t i = 0; i < m.on.size(); ++i) m.on[i] = img.rgba[4 * i + 3] > 0;
  return m;
}

Agreement measure(const Loaded& l, const fr::HybridOptions& o) {
  const fr::Image img = renderer().render_hybrid(l.mesh, l.camera, o, /*transparent=*/true);
  return compare(hybrid_mask(img), l.object);
}

// Measured at 512 x 512 with the defaults (llvmpipe; EGL and OSMesa give the
// same pixels): aneurysm F 0.977 / chamfer 0.45 px, femur 0.945 / 0.83,
// liver 0.941 / 0.66, pial 0.917 / 0.81; away from the outline (> 4 px):
// femur F 0.727, pial 0.896 (aneurysm 0.809 on only ~120 px, liver has no
// object-space ridges there). Guards a little below / above.
const Case kCases[] = {
    {"aneurysm", "meshes/anatomy/vessels/sofa_aneurysm3D_1.off", fabrica::AnatomicalView::anterior,
     0.95, 0.60, 0.0},
    {"femur", "meshes/anatomy/bones/jigsaw_femur.stl", fabrica::AnatomicalView::anterior, 0.92,
     1.00, 0.68},
    {"liver", "meshes/anatomy/liver/sofa_liver2.obj", fabrica::AnatomicalView::anterior, 0.91, 0.85,
     0.0},
    {"pial", "meshes/anatomy/brain/fsaverage5/pial_left.off", fabrica::AnatomicalView::left, 0.89,
     1.00, 0.87},
};

class HybridAgreement : public ::testing::TestWithParam<Case> {};

TEST_P(HybridAgreement, AgreesWithObjectSpaceApparentRidges) {
  const Case& c = GetParam();
  const Loaded l = load(c);
  ASSERT_GT(l.object.count(), 100u)
      << c.name << ": object-space apparent ridges are (nearly) empty";
  const Agreement a = measure(l, {});
  std::printf("%-9s hybrid %6zu px, object %6zu px: P %.3f R %.3f F %.3f chamfer %.2f px\n", c.name,
              a.hybrid_pixels, a.object_pixels, a.precision, a.recall, a.f, a.chamfer);
  const fr::Image buffer = renderer().render_hybrid_buffer(l.mesh, l.camera, {});
  Mask covered{kSize, kSize, std::vector<std::uint8_t>(kSize * kSize, 0)};
  for (std::size_t i = 0; i < covered.on.size(); ++i) covered.on[i] = buffer.rgba[4 * i + 3] > 127;
  const Agreement in = compare_interior(
      hybrid_mask(renderer().render_hybrid(l.mesh, l.camera, {}, true)), l.object, covered, 4.0);
  std::printf(
      "%-9s interior (> 4 px from the outline): hybrid %zu px, object %zu px: P %.3f R %.3f "
      "F %.3f chamfer %.2f px\n",
      c.name, in.hybrid_pixels, in.object_pixels, in.precision, in.recall, in.f, in.chamfer);
  if (c.min_interior_f > 0.0) {
    EXPECT_GE(in.f, c.min_interior_f) << c.name << " (interior)";
  }
  RecordProperty("F", std::to_string(a.f));
  RecordProperty("chamfer_px", std::to_string(a.chamfer));
  EXPECT_GE(a.f, c.min_f) << c.name;
  EXPECT_LE(a.chamfer, c.max_chamfer) << c.name;

  if (const char* figure = std::getenv("FABRICA_HYBRID_FIGURE")) {
    // Row per mesh: hybrid | object space | overlay (hybrid red, object blue, both black).
    static fr::Image fig(3 * kSize, static_cast<int>(std::size(kCases)) * kSize);
    int row = 0;
    while (std::string(kCases[row].name) != c.name) ++row;
    const Mask h = hybrid_mask(renderer().render_hybrid(l.mesh, l.camera, {}, true));
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x) {
        const bool hb = h.on[y * kSize + x], ob = l.object.on[y * kSize + x];
        const std::uint8_t px[3][3] = {
            {std::uint8_t(hb ? 0 : 255), std::uint8_t(hb ? 0 : 255), std::uint8_t(hb ? 0 : 255)},
            {std::uint8_t(ob ? 0 : 255), std::uint8_t(ob ? 0 : 255), std::uint8_t(ob ? 0 : 255)},
            {std::uint8_t(hb && !ob    ? 220
                          : (ob || hb) ? 0
                                       : 255),
             std::uint8_t(hb || ob ? 0 : 255),
             std::uint8_t(ob && !hb    ? 220
                          : (ob || hb) ? 0
                                       : 255)}};
        for (int k = 0; k < 3; ++k) {
          std::uint8_t* q = fig.pixel(k * kSize + x, row * kSize + y);
          q[0] = px[k][0], q[1] = px[k][1], q[2] = px[k][2], q[3] = 255;
        }
      }
    fr::write_png(fig, figure);
  }

  if (std::getenv("FABRICA_HYBRID_SWEEP")) {
    const double tau0 = fr::default_tau(l.mesh->feature_size);
    for (double dt : {-2.0, -1.0, 0.0, 1.0, 2.0})
      for (double lambda : {0.0, 0.5, 1.5, 3.0})
        for (double th : {0.05, 0.1, 0.2, 0.4}) {
          fr::HybridOptions o;
          o.tau = tau0 + dt;
          o.lambda = lambda;
          o.threshold = th;
          const Agreement s = measure(l, o);
          std::printf("sweep %-9s dtau %+.0f lambda %.1f thr %.2f: P %.3f R %.3f F %.3f ch %.2f\n",
                      c.name, dt, lambda, th, s.precision, s.recall, s.f, s.chamfer);
        }
  }
}

INSTANTIATE_TEST_SUITE_P(RealMeshes, HybridAgreement, ::testing::ValuesIn(kCases),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
