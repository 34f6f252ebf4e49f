#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/lines/writers.hpp"

#ifdef FABRICA_HAVE_CAIRO
#include <cairo-pdf.h>
#include <cairo.h>
#endif

namespace fabrica {

bool pdf_available() {
#ifdef FABRICA_HAVE_CAIRO
  return true;
#else
  return false;
#endif
}

#ifdef FABRICA_HAVE_CAIRO
namespace {
cairo_status_t append_to_string(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

void parse_color(const char* hex, double& r, double& g, double& b) {
  unsigned v = 0;
  std::sscanf(hex + 1, "%06x", &v);
  r = ((v >> 16) & 0xff) / 255.0;
  g = ((v >> 8) & 0xff) / 255.0;
  b = (v & 0xff) / 255.0;
}
}  // namespace
#endif

#ifdef FABRICA_HAVE_CAIRO
namespace {

/// Strokes `pieces` on `cr`: in the family colour, or in `color` ("#rrggbb")
/// when given; every opacity multiplied by `opacity`; hidden pieces dashed
/// unless `hidden` is solid.
void stroke_all(cairo_t* cr, const std::vector<StrokePiece>& pieces, HiddenLines hidden,
                double dash_on, double dash_off, const char* color, double opacity) {
  for (const auto& p : pieces) {
    double r, g, b;
    parse_color(color ? color : family_color(p.family), r, g, b);
    cairo_set_source_rgba(cr, r, g, b, p.opacity * opacity);
    cairo_set_line_width(cr, p.width);
    if (p.hidden && hidden != HiddenLines::solid) {
      const double dashes[2] = {dash_on, dash_off};
      cairo_set_dash(cr, dashes, 2, 0.0);
    } else {
      cairo_set_dash(cr, nullptr, 0, 0.0);
    }
    cairo_new_path(cr);
    for (std::size_t i = 0; i < p.points.size(); ++i) {
      if (i == 0)
        cairo_move_to(cr, p.points[i].x(), p.points[i].y());
      else
        cairo_line_to(cr, p.points[i].x(), p.points[i].y());
    }
    if (p.closed) cairo_close_path(cr);
    cairo_stroke(cr);
  }
}

/// A PDF page of the camera's size drawn by `draw(cr)`, written atomically.
template <class Draw>
void pdf_page(const std::filesystem::path& path, const Camera& camera, Draw draw) {
  std::string data;
  // One pixel = one PDF point (1/72 inch).
  cairo_surface_t* surface =
      cairo_pdf_surface_create_for_stream(append_to_string, &data, camera.width, camera.height);
  // No creation date (cairo writes the current time): the same lines give
  // the same bytes, on every run and at any thread count (issue 15).
  cairo_pdf_surface_set_metadata(surface, CAIRO_PDF_METADATA_CREATE_DATE, "");
  cairo_t* cr = cairo_create(surface);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  draw(cr);
  cairo_destroy(cr);
  cairo_surface_finish(surface);
  const cairo_status_t status = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  if (status != CAIRO_STATUS_SUCCESS)
    throw OutputError(path.string() +
                      ": cairo could not produce the PDF: " + cairo_status_to_string(status));
  write_file_atomically(
      path,
      [&](std::ostream& out) { out.write(data.data(), static_cast<std::streamsize>(data.size())); },
      true);
}

}  // namespace
#endif

#ifndef FABRICA_HAVE_CAIRO
namespace {
[[noreturn]] void no_cairo(const std::filesystem::path& path) {
  throw Error(ErrorKind::unavailable,
              path.string() +
                  ": PDF output needs cairo; this fabrica was built without it "
                  "(install libcairo2-dev and rebuild, or write .svg)");
}
}  // namespace
#endif

void write_pdf(const std::filesystem::path& path, const LineSet& lines, const Camera& camera,
               const LineStyle& style) {
#ifdef FABRICA_HAVE_CAIRO
  const double scale = std::min(camera.width, camera.height) / std::max(style.reference_size, 1.0);
  pdf_page(path, camera, [&](cairo_t* cr) {
    stroke_all(cr, stroke_pieces(lines, camera, style), style.hidden, 4.0 * scale, 3.0 * scale,
               nullptr, 1.0);
  });
#else
  (void)lines;
  (void)camera;
  (void)style;
  no_cairo(path);
#endif
}

#ifdef FABRICA_HAVE_CAIRO
namespace {

void trace(cairo_t* cr, const std::vector<Vec2>& points, bool closed) {
  cairo_new_path(cr);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (i == 0)
      cairo_move_to(cr, points[i].x(), points[i].y());
    else
      cairo_line_to(cr, points[i].x(), points[i].y());
  }
  if (closed) cairo_close_path(cr);
}

/// The overlay's items in order: paths filled then stroked, texts as their
/// glyph strokes.
void draw_overlay(cairo_t* cr, const VectorOverlay& overlay) {
  cairo_set_dash(cr, nullptr, 0, 0.0);
  double r, g, b;
  for (const OverlayItem& it : overlay.items) {
    if (it.kind == OverlayItem::Kind::path) {
      if (!it.fill.empty()) {
        parse_color(it.fill.c_str(), r, g, b);
        cairo_set_source_rgba(cr, r, g, b, it.opacity);
        trace(cr, it.points, true);
        cairo_fill(cr);
      }
      if (!it.stroke.empty()) {
        parse_color(it.stroke.c_str(), r, g, b);
        cairo_set_source_rgba(cr, r, g, b, it.opacity);
        cairo_set_line_width(cr, it.stroke_width);
        trace(cr, it.points, it.closed);
        cairo_stroke(cr);
      }
    } else {
      parse_color(it.text_color.c_str(), r, g, b);
      cairo_set_source_rgba(cr, r, g, b, it.opacity);
      cairo_set_line_width(cr, it.glyph_stroke_width);
      for (const auto& stroke : it.glyph_strokes) {
        trace(cr, stroke, false);
        cairo_stroke(cr);
      }
    }
  }
}

}  // namespace
#endif

void write_layered_pdf(const std::filesystem::path& path, const std::vector<LineLayer>& layers,
                       const Camera& camera, const VectorOverlay* overlay) {
#ifdef FABRICA_HAVE_CAIRO
  pdf_page(path, camera, [&](cairo_t* cr) {
    for (const LineLayer& layer : layers) {
      const double scale =
          std::min(camera.width, camera.height) / std::max(layer.style.reference_size, 1.0);
      stroke_all(cr, stroke_pieces(layer.lines, camera, layer.style), layer.style.hidden,
                 layer.dash * scale, layer.dash * scale, layer.color.c_str(),
                 std::clamp(layer.opacity, 0.0, 1.0));
    }
    if (overlay) draw_overlay(cr, *overlay);
  });
#else
  (void)layers;
  (void)camera;
  (void)overlay;
  no_cairo(path);
#endif
}

}  // namespace fabrica
