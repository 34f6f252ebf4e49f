#include "fabrica/core/atomic_file.hpp"
#include "fabrica/lines/writers.hpp"

namespace fabrica {

nlohmann::json lines_to_json(const LineSet& lines, const nlohmann::json& extra) {
  nlohmann::json j = extra.is_object() ? extra : nlohmann::json::object();
  j["format"] = "fabrica-lines";
  j["version"] = 1;
  auto& arr = j["polylines"] = nlohmann::json::array();
  for (const auto& pl : lines.polylines) {
    nlohmann::json p;
    p["family"] = family_name(pl.family);
    p["closed"] = pl.closed;
    auto& verts = p["vertices"] = nlohmann::json::array();
    for (const auto& v : pl.vertices) {
      verts.push_back({{"face", v.anchor.face},
                       {"bary", {v.anchor.bary[0], v.anchor.bary[1], v.anchor.bary[2]}},
                       {"position", {v.position.x(), v.position.y(), v.position.z()}},
                       {"strength", v.strength},
                       {"visible", v.visible}});
    }
    arr.push_back(std::move(p));
  }
  return j;
}

void write_lines_json(const std::filesystem::path& path, const LineSet& lines,
                      const nlohmann::json& extra) {
  const std::string text = lines_to_json(lines, extra).dump(1);
  write_file_atomically(path, [&](std::ostream& out) { out << text << '\n'; });
}

}  // namespace fabrica
