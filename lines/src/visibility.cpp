#include "fabrica/lines/visibility.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>

#include "fabrica/core/error.hpp"
#include "fabrica/core/projector.hpp"
#include "parallel.hpp"

namespace fabrica {

namespace {

// Barycentric coordinates of p in triangle (a, b, c) (least squares in the
// plane); used to anchor inserted vertices.
Vec3 barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1);
  const double d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double den = d00 * d11 - d01 * d01;
  if (!(std::abs(den) > 0.0)) return Vec3(1.0, 0.0, 0.0);
  const double v = (d11 * d20 - d01 * d21) / den;
  const double w = (d00 * d21 - d01 * d20) / den;
  return Vec3(1.0 - v - w, v, w);
}
// floor(v) for v well inside the int range (std::floor is a library call
// without SSE4.1).
inline int floor_int(double v) {
  const int i = static_cast<int>(v);
  return i - (static_cast<double>(i) > v ? 1 : 0);
}

}  // namespace

void compute_visibility(LineSet& lines, const Surface& surface, const Camera& camera,
                        const VisibilityOptions& options, const DepthBuffer* depth) {
  DepthBuffer own;
  if (!depth) {
    render_depth(surface.mesh(), camera, own);
    depth = &own;
  }
  const double eps = options.epsilon > 0.0 ? options.epsilon : 0.5 * surface.median_edge_length();
  const double spacing = options.sample_spacing_px > 0.0 ? options.sample_spacing_px : 1.0;
  const int hyst = std::max(1, options.hysteresis);
  const Projector project(camera);
  const int W = depth->width, H = depth->height;
  const float* const z = depth->depth.data();
  // The 3x3 window's maximum (or minimum) depth around pixel (cx, cy), row
  // by row as DepthBuffer::max3x3 / min3x3; the bounds checks only near the
  // image border.
  auto window = [&](double x, double y) {
    const int cx = floor_int(x), cy = floor_int(y);  // x, y inside the image
    if (cx < 1 || cy < 1 || cx > W - 2 || cy > H - 2)
      return options.window_minimum ? depth->min3x3(x, y) : depth->max3x3(x, y);
    const float* r = z + static_cast<std::size_t>(cy - 1) * W + (cx - 1);
    const float* r1 = r + W;
    const float* r2 = r1 + W;
    // No NaN in the buffer: the order of the comparisons does not matter.
    if (options.window_minimum)
      return std::min(std::min(std::min(std::min(r[0], r[1]), std::min(r[2], r1[0])),
                               std::min(std::min(r1[1], r1[2]), std::min(r2[0], r2[1]))),
                      r2[2]);
    return std::max(std::max(std::max(std::max(r[0], r[1]), std::max(r[2], r1[0])),
                             std::max(std::max(r1[1], r1[2]), std::max(r2[0], r2[1]))),
                    r2[2]);
  };
  auto raw_visible = [&](const ProjectedPoint& pp) {
    if (pp.depth <= 0.0) return false;
    if (pp.pixel.x() < 0 || pp.pixel.y() < 0 || pp.pixel.x() >= W || pp.pixel.y() >= H)
      return true;  // outside the image: nothing in front of it is drawn
    return pp.depth <= static_cast<double>(window(pp.pixel.x(), pp.pixel.y())) + eps;
  };
  struct Sample {
    std::uint32_t edge;  // polyline edge index
    bool vis;
    double t;  // position along the edge
  };
  const auto& mesh = surface.mesh();
  // Each polyline's result depends only on itself: deterministic at any
  // thread count. Scratch vectors are reused per thread.
  detail::parallel_range(
      lines.polylines.size(),
      [&](std::size_t li) {
        Polyline& pl = lines.polylines[li];
        const std::size_t n = pl.vertices.size();
        if (n == 0) return;
        thread_local std::vector<ProjectedPoint> vp;
        thread_local std::vector<Sample> samples;
        thread_local std::vector<std::uint8_t> filtered;
        vp.resize(n);
        for (std::size_t i = 0; i < n; ++i) vp[i] = project(pl.vertices[i].position);
        // Samples: each vertex, then points along each edge.
        samples.clear();
        const std::size_t edges = pl.closed ? n : n - 1;
        for (std::size_t i = 0; i < edges || (edges == 0 && i == 0); ++i) {
          const auto ei = static_cast<std::uint32_t>(i);
          samples.push_back({ei, raw_visible(vp[i]), 0.0});
          if (edges == 0) break;
          const std::size_t j = (i + 1) % n;
          const Vec3& a = pl.vertices[i].position;
          const Vec3& b = pl.vertices[j].position;
          const double len = (vp[j].pixel - vp[i].pixel).norm();
          const int k = std::min(4096, static_cast<int>(std::ceil(len / spacing)));
          for (int s = 1; s < k; ++s) {
            const double t = static_cast<double>(s) / k;
            samples.push_back({ei, raw_visible(project((1.0 - t) * a + t * b)), t});
          }
        }
        if (!pl.closed && n > 1)
          samples.push_back({static_cast<std::uint32_t>(n - 1), raw_visible(vp[n - 1]), 0.0});
        // Hysteresis.
        bool state = samples[0].vis;
        {
          // Start state: majority of the first `hyst` samples.
          int count = 0, total = 0;
          for (std::size_t i = 0; i < samples.size() && total < hyst; ++i, ++total)
            count += samples[i].vis;
          state = 2 * count >= total;
        }
        filtered.assign(samples.size(), 0);
        int run = 0;
        for (std::size_t i = 0; i < samples.size(); ++i) {
          if (samples[i].vis != state) {
            if (++run >= hyst) {
              state = samples[i].vis;
              // Switch at the first sample of the run.
              for (int r = 1; r < run; ++r) filtered[i - static_cast<std::size_t>(r)] = state;
              run = 0;
            }
          } else {
            run = 0;
          }
          filtered[i] = state;
        }
        // Fast path: no switch inside an edge, so the vertices stay and only
        // their flags change.
        bool inserts = false;
        for (std::size_t i = 1; i < samples.size() && !inserts; ++i)
          inserts = samples[i].t != 0.0 && filtered[i] != filtered[i - 1];
        if (!inserts) {
          for (std::size_t i = 0; i < samples.size(); ++i)
            pl.vertices[samples[i].edge].visible = filtered[i] != 0;
          return;
        }
        // Rebuild the polyline with a vertex inserted at each switch inside an edge.
        std::vector<LineVertex> verts;
        std::vector<std::int32_t> faces;
        const bool have_faces = pl.edge_faces.size() == edges && edges > 0;
        verts.reserve(n + 8);
        if (have_faces) faces.reserve(n + 8);
        bool prev_state = filtered[0] != 0;
        for (std::size_t i = 0; i < samples.size(); ++i) {
          const Sample& s = samples[i];
          const bool st = filtered[i] != 0;
          if (s.t == 0.0) {
            LineVertex v = pl.vertices[s.edge];
            v.visible = st;
            if (!verts.empty() && have_faces)
              faces.push_back(pl.edge_faces[s.edge == 0 ? 0 : s.edge - 1]);
            verts.push_back(v);
          } else if (st != prev_state) {
            const LineVertex& a = pl.vertices[s.edge];
            const LineVertex& b = pl.vertices[(s.edge + 1) % n];
            // The inserted vertex starts the new state (an edge takes the
            // visibility of its first vertex).
            LineVertex v;
            v.position = (1.0 - s.t) * a.position + s.t * b.position;
            v.strength = static_cast<float>((1.0 - s.t) * a.strength + s.t * b.strength);
            v.anchor = a.anchor;
            if (have_faces) {
              const auto f = pl.edge_faces[s.edge];
              const Face& tri = mesh.faces[static_cast<std::size_t>(f)];
              v.anchor.face = f;
              v.anchor.bary = barycentric(v.position, mesh.positions[tri[0]],
                                          mesh.positions[tri[1]], mesh.positions[tri[2]]);
            }
            v.visible = st;
            if (have_faces) faces.push_back(pl.edge_faces[s.edge]);
            verts.push_back(v);
          }
          prev_state = st;
        }
        if (pl.closed && have_faces && !verts.empty()) faces.push_back(pl.edge_faces[edges - 1]);
        pl.vertices = std::move(verts);
        if (have_faces) pl.edge_faces = std::move(faces);
      },
      1);
}

}  // namespace fabrica
