#include "fabrica/lines/seg_io.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/input_file.hpp"

namespace fabrica {

const SegGroup* SegFile::find(const std::string& type) const {
  for (const auto& g : groups)
    if (g.type == type) return &g;
  return nullptr;
}

SegFile read_seg(std::istream& in, const std::string& what) {
  SegFile file;
  std::string line;
  std::size_t lineno = 0;
  SegGroup* current = nullptr;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty()) continue;
    if (line[0] == '#') {
      if (lineno == 1) {
        try {
          file.header = nlohmann::json::parse(line.substr(1));
        } catch (const nlohmann::json::exception& e) {
          throw InputError(what + ": line 1: header is not valid JSON: " + e.what());
        }
      }
      continue;
    }
    std::istringstream ls(line);
    std::string type;
    Segment3 s;
    ls >> type >> s[0].x() >> s[0].y() >> s[0].z() >> s[1].x() >> s[1].y() >> s[1].z();
    if (!ls || !s[0].allFinite() || !s[1].allFinite())
      throw InputError(what + ": line " + std::to_string(lineno) +
                       ": expected 'type x0 y0 z0 x1 y1 z1'");
    if (!current || current->type != type) {
      current = nullptr;
      for (auto& g : file.groups)
        if (g.type == type) current = &g;
      if (!current) {
        file.groups.push_back({type, {}});
        current = &file.groups.back();
      }
    }
    current->segments.push_back(s);
  }
  return file;
}

SegFile read_seg_file(const std::filesystem::path& path) {
  require_regular_file(path, path.string() + " (.seg file)");
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open .seg file");
  return read_seg(in, path.string());
}

std::vector<LineFamily> seg_family_order() {
  return {LineFamily::contour,   LineFamily::suggestive, LineFamily::apparent,
          LineFamily::ridge,     LineFamily::valley,     LineFamily::boundary,
          LineFamily::crease,    LineFamily::highlight,  LineFamily::pel,
          LineFamily::laplacian, LineFamily::demarcating};
}

namespace {

void write_segment(std::ostream& out, const char* type, const Vec3& a, const Vec3& b) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "%s %.7g %.7g %.7g %.7g %.7g %.7g\n", type, a.x(), a.y(), a.z(),
                b.x(), b.y(), b.z());
  out << buf;
}

}  // namespace

void write_seg(const std::filesystem::path& path, const nlohmann::json& header,
               const LineSet& lines, bool visible_only) {
  write_file_atomically(path, [&](std::ostream& out) {
    out << "# " << header.dump() << '\n';
    for (LineFamily fam : seg_family_order()) {
      const char* name = family_name(fam);
      for (const auto& pl : lines.polylines) {
        if (pl.family != fam) continue;
        const auto& v = pl.vertices;
        const std::size_t n = v.size();
        const std::size_t count = pl.closed ? n : (n > 0 ? n - 1 : 0);
        for (std::size_t i = 0; i < count; ++i) {
          const auto& a = v[i];
          const auto& b = v[(i + 1) % n];
          if (visible_only && !a.visible) continue;
          write_segment(out, name, a.position, b.position);
        }
      }
    }
  });
}

void write_seg(const std::filesystem::path& path, const nlohmann::json& header,
               const std::vector<SegmentSoup>& soups) {
  write_file_atomically(path, [&](std::ostream& out) {
    out << "# " << header.dump() << '\n';
    for (LineFamily fam : seg_family_order())
      for (const auto& soup : soups) {
        if (soup.family != fam) continue;
        for (const Segment3& s : segment_positions(soup))
          write_segment(out, family_name(fam), s[0], s[1]);
      }
  });
}

std::vector<Segment3> segment_positions(const SegmentSoup& soup) {
  std::vector<Segment3> out;
  if (soup.segments.empty()) return out;
  out.reserve(soup.segments.size());
  const SegmentGeometry geo = soup.geometry();
  for (const auto& s : soup.segments) out.push_back({geo.position(s, 0), geo.position(s, 1)});
  return out;
}

}  // namespace fabrica
