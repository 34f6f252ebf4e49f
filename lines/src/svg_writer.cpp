#include <algorithm>
#include <cctype>
#include <cstdio>
#include <set>
#include <sstream>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/lines/writers.hpp"

namespace fabrica {

namespace {

void write_header(std::ostream& out, const Camera& camera, const char* extra_ns) {
  char buf[320];
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  std::snprintf(buf, sizeof buf,
                "<svg xmlns=\"http://www.w3.org/2000/svg\"%s version=\"1.1\" width=\"%d\" "
                "height=\"%d\" viewBox=\"0 0 %d %d\">\n",
                extra_ns, camera.width, camera.height, camera.width, camera.height);
  out << buf;
}

/// One stroke piece as a <path>; hidden pieces dashed `dash_on`/`dash_off`
/// unless the style draws them solid. A
/// piece's own opacity (< 1) is multiplied by `group_opacity`, the opacity
/// it would otherwise inherit from its group.
void write_path(std::ostream& out, const StrokePiece& p, HiddenLines hidden, double dash_on,
                double dash_off, double group_opacity = 1.0) {
  char buf[256];
  out << "<path";
  if (p.hidden) {
    out << " class=\"hidden\"";
    if (hidden != HiddenLines::solid) {
      std::snprintf(buf, sizeof buf, " stroke-dasharray=\"%.2f %.2f\"", dash_on, dash_off);
      out << buf;
    }
  }
  std::snprintf(buf, sizeof buf, " stroke-width=\"%.2f\"", p.width);
  out << buf;
  if (p.opacity < 1.0) {
    std::snprintf(buf, sizeof buf, " stroke-opacity=\"%.2f\"", p.opacity * group_opacity);
    out << buf;
  }
  out << " d=\"";
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%.2f %.2f", i == 0 ? "M" : (i == 1 ? " L" : " "),
                  p.points[i].x(), p.points[i].y());
    out << buf;
  }
  if (p.closed) out << " Z";
  out << "\"/>\n";
}

bool has_family(const std::vector<StrokePiece>& pieces, LineFamily fam) {
  for (const auto& p : pieces)
    if (p.family == fam) return true;
  return false;
}

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// An XML id from a name: letters, digits, '-' and '_' kept (others become
/// '-'), prefixed "structure-", made unique with a number.
std::string layer_id(const std::string& name, std::set<std::string>& used) {
  std::string base = "structure-";
  for (unsigned char c : name)
    base += (std::isalnum(c) || c == '-' || c == '_') ? static_cast<char>(c) : '-';
  std::string id = base;
  for (int n = 2; !used.insert(id).second; ++n) id = base + "-" + std::to_string(n);
  return id;
}

}  // namespace

namespace {

// The SVG of stroke pieces, written to `out` (a string, or the file itself:
// a drawing's SVG, several MB, is then never held in memory whole).
void write_svg_pieces(std::ostream& out, const std::vector<StrokePiece>& pieces,
                      const Camera& camera, const LineStyle& style) {
  char buf[256];
  write_header(out, camera, "");
  out << "<!-- fabrica lines: one group per line family; transparent background -->\n";
  const double scale = std::min(camera.width, camera.height) / std::max(style.reference_size, 1.0);
  for (LineFamily fam : draw_order()) {
    if (!has_family(pieces, fam)) continue;
    const char* name = family_name(fam);
    std::snprintf(buf, sizeof buf,
                  "<g id=\"%s\" class=\"%s\" fill=\"none\" stroke=\"%s\" "
                  "stroke-linecap=\"round\" stroke-linejoin=\"round\">\n",
                  name, name, family_color(fam));
    out << buf;
    for (const auto& p : pieces)
      if (p.family == fam) write_path(out, p, style.hidden, 4.0 * scale, 3.0 * scale);
    out << "</g>\n";
  }
  out << "</svg>\n";
}

}  // namespace

std::string svg_string(const LineSet& lines, const Camera& camera, const LineStyle& style) {
  std::ostringstream out;
  write_svg_pieces(out, stroke_pieces(lines, camera, style), camera, style);
  return out.str();
}

void write_svg(const std::filesystem::path& path, const LineSet& lines, const Camera& camera,
               const LineStyle& style) {
  // (The pieces first: an error there leaves no file, as before.)
  const auto pieces = stroke_pieces(lines, camera, style);
  write_file_atomically(path,
                        [&](std::ostream& out) { write_svg_pieces(out, pieces, camera, style); });
}

namespace {

void write_points(std::ostringstream& out, const std::vector<Vec2>& points, bool closed) {
  char buf[96];
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%.2f %.2f", i == 0 ? "M" : (i == 1 ? " L" : " "),
                  points[i].x(), points[i].y());
    out << buf;
  }
  if (closed) out << " Z";
}

void write_overlay(std::ostringstream& out, const VectorOverlay& overlay) {
  char buf[320];
  const std::string name = xml_escape(overlay.name);
  out << "<g id=\"" << name << "\" inkscape:groupmode=\"layer\" inkscape:label=\"" << name
      << "\" data-role=\"annotation\">\n";
  for (const OverlayItem& it : overlay.items) {
    std::string attrs = " data-role=\"" + xml_escape(it.role) + "\"";
    if (!it.name.empty()) attrs += " data-name=\"" + xml_escape(it.name) + "\"";
    if (it.opacity < 1.0) {
      std::snprintf(buf, sizeof buf, " opacity=\"%.2f\"", it.opacity);
      attrs += buf;
    }
    if (it.kind == OverlayItem::Kind::path) {
      out << "<path" << attrs << " fill=\"" << (it.fill.empty() ? "none" : xml_escape(it.fill))
          << "\"";
      if (it.stroke.empty()) {
        out << " stroke=\"none\"";
      } else {
        std::snprintf(buf, sizeof buf,
                      " stroke=\"%s\" stroke-width=\"%.2f\" stroke-linecap=\"round\" "
                      "stroke-linejoin=\"round\"",
                      xml_escape(it.stroke).c_str(), it.stroke_width);
        out << buf;
      }
      out << " d=\"";
      write_points(out, it.points, it.closed);
      out << "\"/>\n";
    } else {
      std::snprintf(buf, sizeof buf,
                    " x=\"%.2f\" y=\"%.2f\" font-size=\"%.2f\" textLength=\"%.2f\" "
                    "lengthAdjust=\"spacingAndGlyphs\" data-box=\"%.2f %.2f %.2f %.2f\"",
                    it.position.x(), it.position.y(), it.font_size, it.text_width, it.box[0],
                    it.box[1], it.box[2], it.box[3]);
      out << "<text" << attrs << buf << " fill=\"" << xml_escape(it.text_color)
          << "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">" << xml_escape(it.text)
          << "</text>\n";
    }
  }
  out << "</g>\n";
}

}  // namespace

std::string layered_svg_string(const std::vector<LineLayer>& layers, const Camera& camera,
                               const VectorOverlay* overlay) {
  std::ostringstream out;
  char buf[256];
  write_header(out, camera, " xmlns:inkscape=\"http://www.inkscape.org/namespaces/inkscape\"");
  out << "<!-- fabrica render: one group (layer) per structure, context first, focus drawn "
         "over it; one group per line family inside; transparent background -->\n";
  std::set<std::string> used;
  for (const LineLayer& layer : layers) {
    const auto pieces = stroke_pieces(layer.lines, camera, layer.style);
    const double scale =
        std::min(camera.width, camera.height) / std::max(layer.style.reference_size, 1.0);
    const double opacity = std::clamp(layer.opacity, 0.0, 1.0);
    const std::string name = xml_escape(layer.name);
    out << "<g id=\"" << layer_id(layer.name, used)
        << "\" inkscape:groupmode=\"layer\" inkscape:label=\"" << name << "\" data-name=\"" << name
        << "\"";
    if (!layer.role.empty()) out << " data-role=\"" << xml_escape(layer.role) << "\"";
    std::snprintf(buf, sizeof buf,
                  " fill=\"none\" stroke=\"%s\" stroke-opacity=\"%.2f\" "
                  "stroke-linecap=\"round\" stroke-linejoin=\"round\">\n",
                  xml_escape(layer.color).c_str(), opacity);
    out << buf;
    for (LineFamily fam : draw_order()) {
      if (!has_family(pieces, fam)) continue;
      const char* fname = family_name(fam);
      out << "<g data-family=\"" << fname << "\" class=\"" << fname << "\">\n";
      for (const auto& p : pieces)
        if (p.family == fam)
          write_path(out, p, layer.style.hidden, layer.dash * scale, layer.dash * scale, opacity);
      out << "</g>\n";
    }
    out << "</g>\n";
  }
  if (overlay) write_overlay(out, *overlay);
  out << "</svg>\n";
  return out.str();
}

void write_layered_svg(const std::filesystem::path& path, const std::vector<LineLayer>& layers,
                       const Camera& camera, const VectorOverlay* overlay) {
  const std::string text = layered_svg_string(layers, camera, overlay);
  write_file_atomically(path, [&](std::ostream& out) { out << text; });
}

}  // namespace fabrica
