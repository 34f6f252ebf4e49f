#include "fabrica/lines/visibility.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "parallel.hpp"
#include "projector.hpp"

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

namespace {

// Projected corner: pixel position and linear depth.
struct Corner {
  double x, y, z;
};

// Pixel centres x + 0.5 inside [lo, hi], clipped to [0, size - 1]; first >
// last when there are none. Exact: no rounding of lo - 0.5.
bool pixel_span(double lo, double hi, int size, int& first, int& last) {
  if (!(hi >= 0.0 && lo < static_cast<double>(size))) return false;  // also NaN
  const double flo = std::floor(std::max(lo, -1.0));
  const double fhi = std::floor(std::min(hi, static_cast<double>(size)));
  first = static_cast<int>(flo) + (flo + 0.5 < lo ? 1 : 0);
  last = static_cast<int>(fhi) - (fhi + 0.5 > hi ? 1 : 0);
  first = std::max(first, 0);
  last = std::min(last, size - 1);
  return first <= last;
}

}  // namespace

void render_depth(const TriangleMesh& mesh, const Camera& camera, DepthBuffer& buf) {
  buf.width = camera.width;
  buf.height = camera.height;
  buf.depth.resize(static_cast<std::size_t>(buf.width) * static_cast<std::size_t>(buf.height));
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.faces.size();
  std::vector<Corner> proj(nv);
  const detail::Projector project(camera);
  detail::parallel_range(nv, [&](std::size_t i) {
    const ProjectedPoint pp = project(mesh.positions[i]);
    proj[i] = {pp.pixel.x(), pp.pixel.y(), pp.depth};
  });
  const bool perspective = camera.projection == Projection::perspective;
  const double near_eps = 1e-9;
  // Which pixel rows and columns a triangle covers (pixel centres inside its
  // bounding box); false when none, or a corner is at or behind the eye.
  struct Span {
    int x0, x1, y0, y1;
  };
  auto span_of = [&](const Face& t, Span& sp) {
    const Corner &a = proj[t[0]], &b = proj[t[1]], &c = proj[t[2]];
    if (perspective && (a.z <= near_eps || b.z <= near_eps || c.z <= near_eps)) return false;
    return pixel_span(std::min({a.x, b.x, c.x}), std::max({a.x, b.x, c.x}), buf.width, sp.x0,
                      sp.x1) &&
           pixel_span(std::min({a.y, b.y, c.y}), std::max({a.y, b.y, c.y}), buf.height, sp.y0,
                      sp.y1);
  };
  // Bin triangles into horizontal bands, per fixed chunk of faces (in
  // parallel), then rasterise the bands in parallel, each taking the chunks
  // in face order: every pixel sees its triangles in face order at any
  // thread count.
  constexpr int kBand = 32;
  constexpr std::size_t kChunk = 16384;
  const int bands = (buf.height + kBand - 1) / kBand;
  const std::size_t chunks = (nf + kChunk - 1) / kChunk;
  std::vector<std::vector<std::int32_t>> binned(chunks * static_cast<std::size_t>(bands));
  detail::parallel_range(
      chunks,
      [&](std::size_t c) {
        std::vector<std::int32_t>* bins = binned.data() + c * static_cast<std::size_t>(bands);
        for (std::size_t f = c * kChunk; f < std::min(nf, (c + 1) * kChunk); ++f) {
          Span sp;
          if (!span_of(mesh.faces[f], sp)) continue;
          for (int k = sp.y0 / kBand; k <= sp.y1 / kBand; ++k)
            bins[k].push_back(static_cast<std::int32_t>(f));
        }
      },
      1);
  detail::parallel_range(
      static_cast<std::size_t>(bands),
      [&](std::size_t band) {
        const int y_lo = static_cast<int>(band) * kBand;
        const int y_hi = std::min(buf.height, y_lo + kBand) - 1;
        float* const rows = buf.depth.data() + static_cast<std::size_t>(y_lo) * buf.width;
        std::fill(rows, rows + static_cast<std::size_t>(y_hi - y_lo + 1) * buf.width, kInf);
        for (std::size_t c = 0; c < chunks; ++c)
          for (std::int32_t f : binned[c * static_cast<std::size_t>(bands) + band]) {
            const Face& t = mesh.faces[static_cast<std::size_t>(f)];
            Span sp;
            span_of(t, sp);
            const Corner p[3] = {proj[t[0]], proj[t[1]], proj[t[2]]};
            const double area =
                (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[1].y - p[0].y) * (p[2].x - p[0].x);
            if (area == 0.0) continue;
            const double inv_area = 1.0 / area;
            // Edge k runs from corner k+1 to corner k+2; its barycentric
            // weight at (px, py) is ((bx - ax)(py - ay) - (by - ay)(px - ax))
            // / area, evaluated term by term as before (same bits).
            double ax[3], ay[3], ex[3], ey[3];
            for (int k = 0; k < 3; ++k) {
              const Corner& ca = p[(k + 1) % 3];
              const Corner& cb = p[(k + 2) % 3];
              ax[k] = ca.x;
              ay[k] = ca.y;
              ex[k] = cb.x - ca.x;
              ey[k] = cb.y - ca.y;
            }
            const int ya = std::max(y_lo, sp.y0), yb = std::min(y_hi, sp.y1);
            for (int y = ya; y <= yb; ++y) {
              const double py = y + 0.5;
              double ry[3];
              for (int k = 0; k < 3; ++k) ry[k] = ex[k] * (py - ay[k]);
              float* const row = buf.depth.data() + static_cast<std::size_t>(y) * buf.width;
              for (int x = sp.x0; x <= sp.x1; ++x) {
                const double px = x + 0.5;
                const double w0 = (ry[0] - ey[0] * (px - ax[0])) * inv_area;
                const double w1 = (ry[1] - ey[1] * (px - ax[1])) * inv_area;
                const double w2 = (ry[2] - ey[2] * (px - ax[2])) * inv_area;
                if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) continue;
                const double d = perspective ? 1.0 / (w0 / p[0].z + w1 / p[1].z + w2 / p[2].z)
                                             : w0 * p[0].z + w1 * p[1].z + w2 * p[2].z;
                row[x] = std::min(row[x], static_cast<float>(d));
              }
            }
          }
      },
      1);
}

DepthBuffer render_depth(const TriangleMesh& mesh, const Camera& camera) {
  DepthBuffer buf;
  render_depth(mesh, camera, buf);
  return buf;
}

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
  const detail::Projector project(camera);
  const int W = depth->width, H = depth->height;
  const float* const z = depth->depth.data();
  // The 3x3 window's maximum (or minimum) depth around pixel (cx, cy), row
  // by row as DepthBuffer::max3x3 / min3x3; the bounds checks only near the
  // image border.
  auto window = [&](double x, double y) {
    const int cx = static_cast<int>(std::floor(x)), cy = static_cast<int>(std::floor(y));
    if (cx < 1 || cy < 1 || cx > W - 2 || cy > H - 2)
      return options.window_minimum ? depth->min3x3(x, y) : depth->max3x3(x, y);
    const float* r = z + static_cast<std::size_t>(cy - 1) * W + (cx - 1);
    if (options.window_minimum) {
      float m = kInf;
      for (int k = 0; k < 3; ++k, r += W) m = std::min({m, r[0], r[1], r[2]});
      return m;
    }
    float m = -kInf;
    for (int k = 0; k < 3; ++k, r += W) m = std::max({m, r[0], r[1], r[2]});
    return m;
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
