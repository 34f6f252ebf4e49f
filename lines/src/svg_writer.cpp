#include <cstdio>
#include <sstream>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/lines/writers.hpp"

namespace fabrica {

std::string svg_string(const LineSet& lines, const Camera& camera, const LineStyle& style) {
  const auto pieces = stroke_pieces(lines, camera, style);
  std::ostringstream out;
  char buf[256];
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  std::snprintf(buf, sizeof buf,
                "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"%d\" "
                "height=\"%d\" viewBox=\"0 0 %d %d\">\n",
                camera.width, camera.height, camera.width, camera.height);
  out << buf;
  out << "<!-- fabrica lines: one group per line family; transparent background -->\n";
  const double scale = std::min(camera.width, camera.height) / std::max(style.reference_size, 1.0);
  for (LineFamily fam : draw_order()) {
    bool any = false;
    for (const auto& p : pieces) any = any || p.family == fam;
    if (!any) continue;
    const char* name = family_name(fam);
    std::snprintf(buf, sizeof buf,
                  "<g id=\"%s\" class=\"%s\" fill=\"none\" stroke=\"%s\" "
                  "stroke-linecap=\"round\" stroke-linejoin=\"round\">\n",
                  name, name, family_color(fam));
    out << buf;
    for (const auto& p : pieces) {
      if (p.family != fam) continue;
      out << "<path";
      if (p.hidden) {
        std::snprintf(buf, sizeof buf, " class=\"hidden\" stroke-dasharray=\"%.2f %.2f\"",
                      4.0 * scale, 3.0 * scale);
        out << buf;
      }
      std::snprintf(buf, sizeof buf, " stroke-width=\"%.2f\"", p.width);
      out << buf;
      if (p.opacity < 1.0) {
        std::snprintf(buf, sizeof buf, " stroke-opacity=\"%.2f\"", p.opacity);
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
    out << "</g>\n";
  }
  out << "</svg>\n";
  return out.str();
}

void write_svg(const std::filesystem::path& path, const LineSet& lines, const Camera& camera,
               const LineStyle& style) {
  const std::string text = svg_string(lines, camera, style);
  write_file_atomically(path, [&](std::ostream& out) { out << text; });
}

}  // namespace fabrica
