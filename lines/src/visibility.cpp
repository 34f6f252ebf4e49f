#include "fabrica/lines/visibility.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "parallel.hpp"

namespace fabrica {

namespace {
constexpr float kInf = std::numeric_limits<float>::infinity();

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
}  // namespace

float DepthBuffer::min3x3(double x, double y) const {
  const int cx = static_cast<int>(std::floor(x)), cy = static_cast<int>(std::floor(y));
  float m = kInf;
  for (int yy = std::max(cy - 1, 0); yy <= std::min(cy + 1, height - 1); ++yy)
    for (int xx = std::max(cx - 1, 0); xx <= std::min(cx + 1, width - 1); ++xx)
      m = std::min(m, at(xx, yy));
  return m;
}

float DepthBuffer::max3x3(double x, double y) const {
  const int cx = static_cast<int>(std::floor(x)), cy = static_cast<int>(std::floor(y));
  float m = -kInf;
  for (int yy = cy - 1; yy <= cy + 1; ++yy)
    for (int xx = cx - 1; xx <= cx + 1; ++xx) {
      if (xx < 0 || yy < 0 || xx >= width || yy >= height) return kInf;
      m = std::max(m, at(xx, yy));
    }
  return m;
}

DepthBuffer render_depth(const TriangleMesh& mesh, const Camera& camera) {
  DepthBuffer buf;
  buf.width = camera.width;
  buf.height = camera.height;
  buf.depth.assign(static_cast<std::size_t>(buf.width) * buf.height, kInf);
  const std::size_t nv = mesh.positions.size();
  std::vector<ProjectedPoint> proj(nv);
  detail::parallel_range(nv, [&](std::size_t i) { proj[i] = project(camera, mesh.positions[i]); });
  const bool perspective = camera.projection == Projection::perspective;
  // Bin triangles into horizontal bands, then rasterise bands in parallel.
  constexpr int kBand = 32;
  const int bands = (buf.height + kBand - 1) / kBand;
  std::vector<std::vector<std::int32_t>> binned(static_cast<std::size_t>(bands));
  const double near_eps = 1e-9;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const Face& t = mesh.faces[f];
    const auto &a = proj[t[0]], &b = proj[t[1]], &c = proj[t[2]];
    if (perspective && (a.depth <= near_eps || b.depth <= near_eps || c.depth <= near_eps))
      continue;
    const double ymin = std::min({a.pixel.y(), b.pixel.y(), c.pixel.y()});
    const double ymax = std::max({a.pixel.y(), b.pixel.y(), c.pixel.y()});
    const double xmin = std::min({a.pixel.x(), b.pixel.x(), c.pixel.x()});
    const double xmax = std::max({a.pixel.x(), b.pixel.x(), c.pixel.x()});
    if (ymax < 0 || ymin >= buf.height || xmax < 0 || xmin >= buf.width) continue;
    const int b0 = std::max(0, static_cast<int>(std::floor(ymin)) / kBand);
    const int b1 = std::min(bands - 1, static_cast<int>(std::floor(ymax)) / kBand);
    for (int k = b0; k <= b1; ++k)
      binned[static_cast<std::size_t>(k)].push_back(static_cast<std::int32_t>(f));
  }
  detail::parallel_range(
      static_cast<std::size_t>(bands),
      [&](std::size_t band) {
        const int y_lo = static_cast<int>(band) * kBand;
        const int y_hi = std::min(buf.height, y_lo + kBand) - 1;
        for (std::int32_t f : binned[band]) {
          const Face& t = mesh.faces[static_cast<std::size_t>(f)];
          const Vec2 p[3] = {proj[t[0]].pixel, proj[t[1]].pixel, proj[t[2]].pixel};
          const double z[3] = {proj[t[0]].depth, proj[t[1]].depth, proj[t[2]].depth};
          const double area =
              (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
          if (area == 0.0) continue;
          const double inv_area = 1.0 / area;
          const int x0 =
              std::max(0, static_cast<int>(std::floor(std::min({p[0].x(), p[1].x(), p[2].x()}))));
          const int x1 =
              std::min(buf.width - 1,
                       static_cast<int>(std::floor(std::max({p[0].x(), p[1].x(), p[2].x()}))));
          const int ya = std::max(
              y_lo, static_cast<int>(std::floor(std::min({p[0].y(), p[1].y(), p[2].y()}))));
          const int yb = std::min(
              y_hi, static_cast<int>(std::floor(std::max({p[0].y(), p[1].y(), p[2].y()}))));
          for (int y = ya; y <= yb; ++y) {
            const double py = y + 0.5;
            for (int x = x0; x <= x1; ++x) {
              const double px = x + 0.5;
              double w[3];
              for (int k = 0; k < 3; ++k) {
                const Vec2& a = p[(k + 1) % 3];
                const Vec2& b = p[(k + 2) % 3];
                w[k] = ((b.x() - a.x()) * (py - a.y()) - (b.y() - a.y()) * (px - a.x())) * inv_area;
              }
              if (w[0] < 0.0 || w[1] < 0.0 || w[2] < 0.0) continue;
              double d;
              if (perspective)
                d = 1.0 / (w[0] / z[0] + w[1] / z[1] + w[2] / z[2]);
              else
                d = w[0] * z[0] + w[1] * z[1] + w[2] * z[2];
              float& dst = buf.depth[static_cast<std::size_t>(y) * buf.width + x];
              dst = std::min(dst, static_cast<float>(d));
            }
          }
        }
      },
      1);
  return buf;
}

void compute_visibility(LineSet& lines, const Surface& surface, const Camera& camera,
                        const VisibilityOptions& options, const DepthBuffer* depth) {
  DepthBuffer own;
  if (!depth) {
    own = render_depth(surface.mesh(), camera);
    depth = &own;
  }
  const double eps = options.epsilon > 0.0 ? options.epsilon : 0.5 * surface.median_edge_length();
  const double spacing = options.sample_spacing_px > 0.0 ? options.sample_spacing_px : 1.0;
  const int hyst = std::max(1, options.hysteresis);
  auto raw_visible = [&](const Vec3& p) {
    const ProjectedPoint pp = project(camera, p);
    if (pp.depth <= 0.0) return false;
    if (pp.pixel.x() < 0 || pp.pixel.y() < 0 || pp.pixel.x() >= depth->width ||
        pp.pixel.y() >= depth->height)
      return true;  // outside the image: nothing in front of it is drawn
    const float m = options.window_minimum ? depth->min3x3(pp.pixel.x(), pp.pixel.y())
                                           : depth->max3x3(pp.pixel.x(), pp.pixel.y());
    return pp.depth <= static_cast<double>(m) + eps;
  };
  const auto& mesh = surface.mesh();
  detail::parallel_range(
      lines.polylines.size(),
      [&](std::size_t li) {
        Polyline& pl = lines.polylines[li];
        const std::size_t n = pl.vertices.size();
        if (n == 0) return;
        // Samples: each vertex, then points along each edge.
        struct Sample {
          std::size_t edge;  // polyline edge index
          double t;          // position along the edge
          bool vis;
        };
        std::vector<Sample> samples;
        const std::size_t edges = pl.closed ? n : n - 1;
        for (std::size_t i = 0; i < edges || (edges == 0 && i == 0); ++i) {
          const Vec3& a = pl.vertices[i].position;
          samples.push_back({i, 0.0, raw_visible(a)});
          if (edges == 0) break;
          const Vec3& b = pl.vertices[(i + 1) % n].position;
          const double len = (project(camera, b).pixel - project(camera, a).pixel).norm();
          const int k = std::min(4096, static_cast<int>(std::ceil(len / spacing)));
          for (int s = 1; s < k; ++s) {
            const double t = static_cast<double>(s) / k;
            samples.push_back({i, t, raw_visible((1.0 - t) * a + t * b)});
          }
        }
        if (!pl.closed && n > 1)
          samples.push_back({n - 1, 0.0, raw_visible(pl.vertices[n - 1].position)});
        // Hysteresis.
        bool state = samples[0].vis;
        {
          // Start state: majority of the first `hyst` samples.
          int count = 0, total = 0;
          for (std::size_t i = 0; i < samples.size() && total < hyst; ++i, ++total)
            count += samples[i].vis;
          state = 2 * count >= total;
        }
        std::vector<bool> filtered(samples.size());
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
        // Rebuild the polyline with a vertex inserted at each switch inside an edge.
        std::vector<LineVertex> verts;
        std::vector<std::int32_t> faces;
        const bool have_faces = pl.edge_faces.size() == edges && edges > 0;
        bool prev_state = filtered[0];
        for (std::size_t i = 0; i < samples.size(); ++i) {
          const Sample& s = samples[i];
          const bool st = filtered[i];
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
