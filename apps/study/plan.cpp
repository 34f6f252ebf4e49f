#include "plan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "fabrica/core/error.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/repair.hpp"
#include "fabrica/lines/visibility.hpp"
#include "fabrica/render/scene.hpp"

namespace fabrica::study {

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t fnv1a64(const std::string& s) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : s) h = (h ^ c) * 0x100000001b3ULL;
  return h;
}

Rng::Rng(std::uint64_t seed) {
  for (auto& x : s_) x = splitmix64(seed);
}

std::uint64_t Rng::next() {
  auto rotl = [](std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); };
  const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
  const std::uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return result;
}

std::uint64_t Rng::below(std::uint64_t n) {
  const std::uint64_t limit =
      std::numeric_limits<std::uint64_t>::max() - std::numeric_limits<std::uint64_t>::max() % n;
  std::uint64_t x;
  do x = next();
  while (x >= limit);
  return x % n;
}

double Rng::uniform() {
  return static_cast<double>(next() >> 11) * 0x1.0p-53;
}

std::uint64_t participant_seed(std::uint64_t study_seed, const std::string& participant) {
  std::uint64_t state = study_seed ^ fnv1a64(participant);
  return splitmix64(state);
}

int latin_square_rows(int k) {
  return k % 2 == 0 ? k : 2 * k;
}

std::vector<int> latin_square_row(int k, int row) {
  // First row 0, 1, k-1, 2, k-2, ...; row r adds r (mod k); odd k: rows
  // k..2k-1 are the reverses of rows 0..k-1.
  std::vector<int> first;
  for (int i = 0, lo = 1, hi = k - 1; i < k; ++i)
    first.push_back(i == 0 ? 0 : (i % 2 == 1 ? lo++ : hi--));
  const int r = row % latin_square_rows(k);
  std::vector<int> out;
  for (int v : first) out.push_back((v + r) % k);
  if (r >= k) std::reverse(out.begin(), out.end());
  return out;
}

int participant_row(const std::string& participant, int rows) {
  std::size_t start = participant.size();
  while (start > 0 && std::isdigit(static_cast<unsigned char>(participant[start - 1]))) --start;
  std::uint64_t n = 0;
  if (start < participant.size() && participant.size() - start <= 18)
    n = std::stoull(participant.substr(start));
  else
    n = fnv1a64(participant);
  return static_cast<int>(n % static_cast<std::uint64_t>(rows));
}

std::string stimulus_id(const std::string& technique, const std::string& model,
                        const std::string& view) {
  return technique + "." + model + "." + view;
}

ModelGeometry load_model(const Model& model) {
  std::vector<std::pair<std::filesystem::path, bool>> meshes;  // path, carries gauges
  if (model.scene) {
    // The gauge sits on what the scene shows as solid: its focus structures
    // (ghosted context structures are see-through).
    const auto spec = render::read_scene_spec(model.path);
    const bool any_focus = std::any_of(spec.structures.begin(), spec.structures.end(),
                                       [](const auto& s) { return s.role == render::Role::focus; });
    for (const auto& s : spec.structures)
      meshes.push_back({s.mesh, !any_focus || s.role == render::Role::focus});
  } else {
    meshes.push_back({model.path, true});
  }
  ModelGeometry g;
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    auto file = io::read_mesh(meshes[i].first);
    io::prepare_for_lines(file.mesh);
    // The box of every structure (as `fabrica render --view` fits it).
    const BoundingBox b = bounding_box(file.mesh.positions);
    if (i == 0) {
      g.mesh.space = file.mesh.space;
      g.box = b;
    } else {
      g.box.min = g.box.min.cwiseMin(b.min);
      g.box.max = g.box.max.cwiseMax(b.max);
    }
    if (!meshes[i].second) continue;
    const auto base = static_cast<std::int32_t>(g.mesh.positions.size());
    g.mesh.positions.insert(g.mesh.positions.end(), file.mesh.positions.begin(),
                            file.mesh.positions.end());
    for (Face f : file.mesh.faces) g.mesh.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
  }
  g.normals = Surface(g.mesh).vertex_normals();
  return g;
}

Camera stimulus_camera(const Study& study, const Model&, const View& view,
                       const ModelGeometry& geometry) {
  Camera camera;
  if (!view.camera.empty()) {
    camera = read_camera(view.camera);
  } else {
    camera =
        anatomical_camera(*parse_anatomical_view(view.name), geometry.box, geometry.mesh.space);
  }
  camera.width = study.width;
  camera.height = study.height;
  validate_camera(camera, "view " + view.name);
  return camera;
}

std::vector<GaugePoint> sample_gauge_points(const ModelGeometry& geometry, const Camera& camera,
                                            int n, Rng& rng) {
  const DepthBuffer depth = render_depth(geometry.mesh, camera);
  const TriangleMesh& mesh = geometry.mesh;
  std::vector<ProjectedPoint> proj;
  proj.reserve(mesh.positions.size());
  for (const auto& p : mesh.positions) proj.push_back(project(camera, p));
  const int margin = 3;
  auto covered = [&](int x, int y) {
    for (int dy = -margin; dy <= margin; ++dy)
      for (int dx = -margin; dx <= margin; ++dx) {
        const int xx = x + dx, yy = y + dy;
        if (xx < 0 || yy < 0 || xx >= depth.width || yy >= depth.height ||
            !std::isfinite(depth.at(xx, yy)))
          return false;
      }
    return true;
  };
  // The nearest triangle under a pixel centre and its interpolated normal.
  auto surface_at = [&](const Vec2& c, Vec3& normal, double& z) {
    z = std::numeric_limits<double>::infinity();
    for (const Face& f : mesh.faces) {
      const ProjectedPoint& a = proj[f[0]];
      const ProjectedPoint& b = proj[f[1]];
      const ProjectedPoint& d = proj[f[2]];
      if (a.depth <= 0 || b.depth <= 0 || d.depth <= 0) continue;
      const double area = (b.pixel - a.pixel).x() * (d.pixel - a.pixel).y() -
                          (b.pixel - a.pixel).y() * (d.pixel - a.pixel).x();
      if (area == 0.0) continue;
      auto edge = [&](const Vec2& p, const Vec2& q) {
        return ((q - p).x() * (c - p).y() - (q - p).y() * (c - p).x()) / area;
      };
      const double l0 = edge(b.pixel, d.pixel), l1 = edge(d.pixel, a.pixel),
                   l2 = edge(a.pixel, b.pixel);
      if (l0 < 0 || l1 < 0 || l2 < 0) continue;
      const double w0 = l0 / a.depth, w1 = l1 / b.depth, w2 = l2 / d.depth, sum = w0 + w1 + w2;
      const double zz = 1.0 / sum;
      if (zz >= z) continue;
      z = zz;
      normal = (w0 * geometry.normals[f[0]] + w1 * geometry.normals[f[1]] +
                w2 * geometry.normals[f[2]]) /
               sum;
    }
    return std::isfinite(z) && normal.norm() > 0.5;
  };
  const Vec3 right = camera.right(), up = camera.true_up(), toward = -camera.forward();
  const double spacing = 0.1 * std::min(camera.width, camera.height);
  std::vector<GaugePoint> out;
  for (int attempt = 0; attempt < 200000 && static_cast<int>(out.size()) < n; ++attempt) {
    const int x = static_cast<int>(rng.below(static_cast<std::uint64_t>(depth.width)));
    const int y = static_cast<int>(rng.below(static_cast<std::uint64_t>(depth.height)));
    if (!covered(x, y)) continue;
    const Vec2 c(x + 0.5, y + 0.5);
    // Spread the points out; relax after many tries (small silhouettes).
    const double need = attempt < 20000 ? spacing : 0.0;
    if (std::any_of(out.begin(), out.end(),
                    [&](const GaugePoint& g) { return (g.pixel - c).norm() < need; }))
      continue;
    Vec3 normal = Vec3::Zero();
    double z = 0;
    if (!surface_at(c, normal, z)) continue;
    if (std::abs(z - depth.at(x, y)) > 1e-3 * std::max(1.0, z)) continue;  // hidden: depth test
    normal.normalize();
    Vec3 view(normal.dot(right), normal.dot(up), normal.dot(toward));
    if (view.z() < 0.15) continue;  // grazing or back-facing: a gauge cannot show it
    // Six decimals: the same bytes on every machine; renormalised.
    for (int i = 0; i < 3; ++i) view[i] = std::round(view[i] * 1e6) / 1e6;
    out.push_back({c, view.normalized()});
  }
  if (static_cast<int>(out.size()) < n)
    throw InputError(
        "gauge: found only " + std::to_string(out.size()) + " of " + std::to_string(n) +
        " visible surface points for the camera; lower points_per_stimulus or check the view");
  return out;
}

namespace {

nlohmann::json vec(const Vec3& v) {
  return {v.x(), v.y(), v.z()};
}

/// A random unit vector towards the viewer (z >= 0.3): the gauge's start.
Vec3 random_start(Rng& rng) {
  for (;;) {
    const Vec3 v(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, rng.uniform());
    const double len = v.norm();
    if (len > 0.2 && len <= 1.0 && v.z() / len >= 0.3) {
      Vec3 u = v / len;
      for (int i = 0; i < 3; ++i) u[i] = std::round(u[i] * 1e6) / 1e6;
      return u.normalized();
    }
  }
}

struct Planner {
  const Study& study;
  Rng rng;
  std::vector<std::string> technique_order;  // the participant's Latin-square order
  std::map<std::pair<std::size_t, std::size_t>, std::vector<GaugePoint>> gauge_points;
  nlohmann::json cameras = nlohmann::json::object();  // MODEL.VIEW -> camera, for gauge trials
  nlohmann::json trials = nlohmann::json::array();

  std::vector<std::string> ordered(const Block& b) const {
    std::vector<std::string> out;
    for (const auto& t : technique_order)
      if (std::find(b.techniques.begin(), b.techniques.end(), t) != b.techniques.end())
        out.push_back(t);
    return out;
  }

  const std::vector<GaugePoint>& points(std::size_t m, std::size_t v, int n) {
    auto it = gauge_points.find({m, v});
    if (it != gauge_points.end()) return it->second;
    // Points depend on the study only: every participant and technique
    // judges the same surface points (Cole et al. 2009).
    const Model& model = study.models[m];
    const View& view = study.views[v];
    std::uint64_t state =
        study.seed ^ fnv1a64("gauge/" + model.name + "/" + view.name + "/" + std::to_string(n));
    Rng point_rng(splitmix64(state));
    const ModelGeometry g = load_model(model);
    try {
      const Camera camera = stimulus_camera(study, model, view, g);
      cameras[model.name + "." + view.name] = camera_to_json(camera);
      return gauge_points[{m, v}] = sample_gauge_points(g, camera, n, point_rng);
    } catch (const InputError& e) {
      throw InputError(study.file.string() + ": model " + model.name + ", view " + view.name +
                       ": " + e.what());
    }
  }

  nlohmann::json base(int block, const Block& b, std::size_t m, std::size_t v) const {
    return {{"task", task_name(b.task)},
            {"block", block},
            {"practice", false},
            {"attention", false},
            {"model", study.models[m].name},
            {"view", study.views[v].name},
            {"question", b.question}};
  }

  nlohmann::json gauge(int block, const Block& b, const std::string& t, std::size_t m,
                       std::size_t v, const GaugePoint& p) {
    nlohmann::json j = base(block, b, m, v);
    j["technique"] = t;
    j["stimulus"] = stimulus_id(t, study.models[m].name, study.views[v].name);
    j["pixel"] = {p.pixel.x(), p.pixel.y()};
    j["true_normal"] = vec(p.normal);
    j["initial_normal"] = vec(random_start(rng));
    return j;
  }

  nlohmann::json single(int block, const Block& b, const std::string& t, std::size_t m,
                        std::size_t v) const {
    nlohmann::json j = base(block, b, m, v);
    j["technique"] = t;
    j["stimulus"] = stimulus_id(t, study.models[m].name, study.views[v].name);
    j["scale"] = b.scale;
    return j;
  }

  nlohmann::json multi(int block, const Block& b, std::vector<std::string> ts, std::size_t m,
                       std::size_t v) {
    rng.shuffle(ts);  // also the left/right order of a 2afc pair
    nlohmann::json j = base(block, b, m, v);
    j["techniques"] = ts;
    j["stimuli"] = nlohmann::json::array();
    for (const auto& t : ts)
      j["stimuli"].push_back(stimulus_id(t, study.models[m].name, study.views[v].name));
    return j;
  }

  /// The block's main trials, in the participant's order.
  std::vector<nlohmann::json> main_trials(int block, const Block& b) {
    std::vector<nlohmann::json> out;
    const std::size_t nm = study.models.size(), nv = study.views.size();
    const auto techniques = ordered(b);
    switch (b.task) {
      case Task::gauge:
      case Task::likert:
        // Grouped by technique in Latin-square order, shuffled within.
        for (const auto& t : techniques) {
          std::vector<nlohmann::json> group;
          for (std::size_t m = 0; m < nm; ++m)
            for (std::size_t v = 0; v < nv; ++v) {
              if (b.task == Task::likert) {
                group.push_back(single(block, b, t, m, v));
                continue;
              }
              for (const auto& p : points(m, v, b.points_per_stimulus))
                group.push_back(gauge(block, b, t, m, v, p));
            }
          rng.shuffle(group);
          out.insert(out.end(), group.begin(), group.end());
        }
        break;
      case Task::afc2:
        for (int r = 0; r < b.repeats; ++r)
          for (std::size_t i = 0; i < techniques.size(); ++i)
            for (std::size_t k = i + 1; k < techniques.size(); ++k)
              for (std::size_t m = 0; m < nm; ++m)
                for (std::size_t v = 0; v < nv; ++v)
                  out.push_back(multi(block, b, {techniques[i], techniques[k]}, m, v));
        rng.shuffle(out);
        break;
      case Task::ranking:
        for (std::size_t m = 0; m < nm; ++m)
          for (std::size_t v = 0; v < nv; ++v) out.push_back(multi(block, b, techniques, m, v));
        rng.shuffle(out);
        break;
    }
    return out;
  }

  nlohmann::json attention_check(const Block& b, const nlohmann::json& like) {
    nlohmann::json j = like;
    j["attention"] = true;
    switch (b.task) {
      case Task::gauge:
        j["question"] = "Attention check: turn the gauge so that it points straight at you.";
        j["expected"] = {0.0, 0.0, 1.0};
        break;
      case Task::afc2: {
        const int side = static_cast<int>(rng.below(2));
        j["question"] =
            std::string("Attention check: choose the ") + (side ? "RIGHT" : "LEFT") + " picture.";
        j["expected"] = side;
        break;
      }
      case Task::likert: {
        const int k = 1 + static_cast<int>(rng.below(static_cast<std::uint64_t>(b.scale)));
        j["question"] = "Attention check: choose " + std::to_string(k) + ".";
        j["expected"] = k;
        break;
      }
      case Task::ranking:
        break;
    }
    return j;
  }

  void add(nlohmann::json trial, nlohmann::json before = nlohmann::json::array()) {
    const int number = static_cast<int>(trials.size()) + 1;
    if (study.break_every > 0 && number > 1 && (number - 1) % study.break_every == 0)
      before.insert(
          before.begin(),
          nlohmann::json{{"screen", "break"},
                         {"text", "Time for a short break. " + std::to_string(number - 1) +
                                      " trials done. Continue when you are ready."}});
    nlohmann::json t = {{"trial", number}};
    t.update(trial);
    if (!before.empty()) t["before"] = before;
    trials.push_back(t);
  }
};

std::string default_instructions(const Block& b) {
  switch (b.task) {
    case Task::gauge:
      return "A gauge (a disc with a stick) sits on the surface. Drag with the mouse to turn it "
             "until the disc lies flat on the surface and the stick points straight out of it. "
             "Then press Next.";
    case Task::afc2:
      return "Two pictures of the same shape. Click the one that answers the question.";
    case Task::likert:
      return "Rate each picture on the scale.";
    case Task::ranking:
      return "Order the pictures by dragging them, best on the left, worst on the right.";
  }
  return {};
}

}  // namespace

nlohmann::json make_plan(const Study& study, const std::string& participant) {
  if (!valid_name(participant))
    throw InputError("--participant \"" + participant +
                     "\": use 1 to 64 of A-Z a-z 0-9 _ - (e.g. P01)");
  const std::uint64_t seed = participant_seed(study.seed, participant);
  Planner p{study, Rng(seed), {}, {}, nlohmann::json::object(), nlohmann::json::array()};
  const int k = static_cast<int>(study.techniques.size());
  const int row = participant_row(participant, latin_square_rows(k));
  for (int i : latin_square_row(k, row)) p.technique_order.push_back(study.techniques[i].name);

  for (std::size_t bi = 0; bi < study.blocks.size(); ++bi) {
    const Block& b = study.blocks[bi];
    const int block = static_cast<int>(bi) + 1;
    std::vector<nlohmann::json> main = p.main_trials(block, b);
    if (main.empty()) continue;
    // Practice: random trials of the block's kind, flagged (analysis skips them).
    std::vector<nlohmann::json> practice;
    for (int i = 0; i < b.practice; ++i) {
      nlohmann::json t = main[p.rng.below(main.size())];
      t["practice"] = true;
      practice.push_back(t);
    }
    for (int i = 0; i < b.attention_checks && b.task != Task::ranking; ++i) {
      const auto& like = main[p.rng.below(main.size())];
      const std::size_t at = p.rng.below(main.size() + 1);
      main.insert(main.begin() + static_cast<std::ptrdiff_t>(at), p.attention_check(b, like));
    }
    nlohmann::json before = nlohmann::json::array();
    if (bi == 0) before.push_back({{"screen", "welcome"}, {"text", study.welcome}});
    before.push_back({{"screen", "instructions"},
                      {"text", b.instructions.empty() ? default_instructions(b) : b.instructions}});
    if (!practice.empty())
      before.push_back({{"screen", "practice"},
                        {"text", "First " + std::to_string(practice.size()) +
                                     " practice trial(s); they do not count."}});
    bool first = true;
    for (auto& t : practice) {
      p.add(t, first ? before : nlohmann::json::array());
      first = false;
    }
    for (std::size_t i = 0; i < main.size(); ++i) {
      nlohmann::json here = nlohmann::json::array();
      if (first) here = before;
      if (i == 0 && !practice.empty())
        here.push_back(
            {{"screen", "instructions"}, {"text", "Practice is over: now the real trials."}});
      p.add(main[i], here);
      first = false;
    }
  }
  char seed_hex[17];
  std::snprintf(seed_hex, sizeof seed_hex, "%016llx", static_cast<unsigned long long>(seed));
  return {{"format", "fabrica-study plan 1"},
          {"study", study.name},
          {"participant", participant},
          {"seed", seed_hex},
          {"latin_square_row", row},
          {"technique_order", p.technique_order},
          {"size", {study.width, study.height}},
          {"goodbye", study.goodbye},
          {"cameras", p.cameras},
          {"trials", p.trials}};
}

}  // namespace fabrica::study
