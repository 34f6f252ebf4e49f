#include "loader.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "fabrica/core/error.hpp"
#include "fabrica/io/label_volume.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/prepare.hpp"
#include "fabrica/io/repair.hpp"

namespace fabrica::viewer {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

struct Cancelled {};

/// A label table beside a volume: NAME.txt or NAME.ctbl or NAME_labels.txt
/// (NAME without extensions); empty when there is none.
std::vector<io::LabelInfo> label_table_beside(const std::filesystem::path& path) {
  const std::string stem = structure_name_from_file(path);
  for (const std::string& candidate : {stem + ".txt", stem + ".ctbl", stem + "_labels.txt"}) {
    const auto p = path.parent_path() / candidate;
    if (std::filesystem::is_regular_file(p)) return io::read_label_names(p);
  }
  return {};
}

}  // namespace

// Handed the topology the preparation built (fabrica::to_surface) instead of
// building it again.
std::shared_ptr<Surface> prepared_surface(TriangleMesh mesh) {
  PreparedMesh prepared;
  prepared.mesh = std::move(mesh);
  prepared.repair = io::prepare_for_lines(prepared.mesh, {}, prepared.topology);
  return std::make_shared<Surface>(to_surface(std::move(prepared)));
}

bool is_volume_file(const std::filesystem::path& path) {
  const std::string n = lower(path.filename().string());
  for (const char* ext : {".nii", ".nii.gz", ".nrrd", ".nhdr", ".mha", ".mhd"})
    if (ends_with(n, ext)) return true;
  return false;
}

std::string structure_name_from_file(const std::filesystem::path& path) {
  const std::string n = path.filename().string();
  const auto dot = n.find('.', 1);
  return dot == std::string::npos ? n : n.substr(0, dot);
}

render::Color distinct_color(std::size_t i) {
  // Golden-angle hues at moderate saturation: neighbours differ, none is garish.
  const double h = std::fmod(0.08 + 0.381966 * static_cast<double>(i), 1.0) * 6.0;
  const double s = 0.45, v = 0.9;
  const double c = v * s, x = c * (1.0 - std::fabs(std::fmod(h, 2.0) - 1.0)), m = v - c;
  double r = 0, g = 0, b = 0;
  switch (static_cast<int>(h)) {
    case 0:
      r = c, g = x;
      break;
    case 1:
      r = x, g = c;
      break;
    case 2:
      g = c, b = x;
      break;
    case 3:
      g = x, b = c;
      break;
    case 4:
      r = x, b = c;
      break;
    default:
      r = c, b = x;
      break;
  }
  return {static_cast<float>(r + m), static_cast<float>(g + m), static_cast<float>(b + m), 1.0f};
}

Loader::Loader() : thread_([this] { run(); }) {}

Loader::~Loader() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cancel_ = true;
  wake_.notify_all();
  thread_.join();
}

void Loader::open(const std::filesystem::path& path) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back(path);
  }
  wake_.notify_all();
}

std::vector<LoadedFile> Loader::take_finished() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<LoadedFile> out = std::move(finished_);
  finished_.clear();
  return out;
}

bool Loader::busy() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return running_ || !queue_.empty() || !finished_.empty();
}

std::pair<std::string, double> Loader::progress() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {current_, fraction_};
}

void Loader::cancel() {
  std::lock_guard<std::mutex> lock(mutex_);
  queue_.clear();
  if (running_) cancel_ = true;
}

void Loader::set_progress(double fraction) {
  std::lock_guard<std::mutex> lock(mutex_);
  fraction_ = fraction;
}

void Loader::run() {
  for (;;) {
    std::filesystem::path path;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      path = queue_.front();
      queue_.pop_front();
      running_ = true;
      current_ = path.filename().string();
      fraction_ = 0.0;
      cancel_ = false;
    }
    LoadedFile file;
    try {
      file = load(path);
    } catch (const Cancelled&) {
      file = LoadedFile{};
      file.path = path;
      file.error = path.string() + ": loading cancelled";
    } catch (const std::exception& e) {
      file = LoadedFile{};
      file.path = path;
      file.error = e.what();
    }
    std::lock_guard<std::mutex> lock(mutex_);
    finished_.push_back(std::move(file));
    running_ = false;
    current_.clear();
  }
}

// A prepared surface of `mesh` with its line precomputation.
std::shared_ptr<LineSource> Loader::line_source(TriangleMesh mesh) {
  auto source = std::make_shared<LineSource>();
  auto surface = prepared_surface(std::move(mesh));
  surface->precompute();
  if (cancelled()) throw Cancelled{};
  source->drawer = std::make_unique<LineDrawer>(*surface);
  source->surface = std::move(surface);
  return source;
}

LoadedStructure Loader::build(TriangleMesh mesh, const std::string& name) {
  if (cancelled()) throw Cancelled{};
  LoadedStructure s;
  s.name = name;
  s.lines = line_source(std::move(mesh));
  s.surface = s.lines->surface;
  s.mesh = std::make_shared<render::RenderMesh>(render::make_render_mesh(*s.surface, false));
  if (s.surface->mesh().face_count() > kLodMinFaces) {
    s.lines_lod = line_source(render::cluster_simplify(s.surface->mesh(), kLodFaces));
    auto lod_mesh = render::make_render_mesh(*s.lines_lod->surface, false);
    // The full mesh's edge length: the renderer's depth tolerance for lines
    // stays what the still picture uses.
    lod_mesh.mean_edge_length = s.mesh->mean_edge_length;
    s.mesh_lod = std::make_shared<render::RenderMesh>(std::move(lod_mesh));
  }
  // Levels for an opaque structure while moving, each clustered from the
  // one before. Drawn with normals from the clustered mesh alone; the
  // level's surface and line precomputation are left to the lines worker,
  // which makes them the first time it draws the level's lines (only with
  // coarse lines while moving; LineSource::unprepared): loading pays for
  // the clustering only.
  const TriangleMesh* source = &s.surface->mesh();
  std::shared_ptr<const TriangleMesh> level;
  while (source->face_count() / kMovingLevelFactor >= kMovingLevelMinFaces) {
    if (cancelled()) throw Cancelled{};
    auto next = std::make_shared<const TriangleMesh>(
        render::cluster_simplify(*source, source->face_count() / kMovingLevelFactor));
    if (next->face_count() >= source->face_count()) break;
    MovingLevel m;
    m.lines = std::make_shared<LineSource>();
    m.lines->unprepared = next;
    render::RenderMesh drawn = render::make_render_mesh(*next);
    // Its own edge length: the lines' depth tolerance grows with it while
    // moving (the full mesh's lines lie within about an edge of it).
    // Clustering leaves a closed mesh nearly closed (the igea's first level:
    // 0.6 % of its edges without their twin): culled as the full mesh is, a
    // moving frame may show the background through a pinhole of a few
    // pixels, for half the triangles drawn.
    drawn.closed_outward = s.mesh->closed_outward;
    m.mesh = std::make_shared<render::RenderMesh>(std::move(drawn));
    s.moving_levels.push_back(std::move(m));
    level = std::move(next);
    source = level.get();
  }
  return s;
}

LoadedFile Loader::load(const std::filesystem::path& path) {
  LoadedFile file;
  file.path = path;
  if (!std::filesystem::exists(path))
    throw InputError(path.string() + ": no such file; check the path");
  const std::string ext = lower(path.extension().string());
  if (ext == ".json") {
    render::SceneSpec spec = render::read_scene_spec(path);
    for (std::size_t i = 0; i < spec.structures.size(); ++i) {
      const auto& st = spec.structures[i];
      io::ReadOptions ro;
      ro.space = st.space;
      LoadedStructure s = build(io::read_mesh(st.mesh, ro).mesh, st.name);
      s.mesh_file = st.mesh;
      s.space = st.space;
      s.role = st.role;
      s.style = st.style;
      s.role_from_file = true;
      file.structures.push_back(std::move(s));
      set_progress(static_cast<double>(i + 1) / static_cast<double>(spec.structures.size()));
    }
    file.scene = std::move(spec);
  } else if (is_volume_file(path)) {
    io::LabelVolume volume = io::read_label_volume(path);
    if (volume.labels.empty()) volume.labels = label_table_beside(path);
    set_progress(0.1);
    io::ExtractOptions eo;
    eo.progress = [this](std::size_t done, std::size_t total) {
      set_progress(0.1 + 0.6 * static_cast<double>(done) /
                             static_cast<double>(std::max<std::size_t>(total, 1)));
      return !cancelled();
    };
    auto surfaces = io::extract_surfaces(volume, eo);
    if (cancelled()) throw Cancelled{};
    std::size_t index = 0, done = 0;
    for (auto& e : surfaces) {
      ++done;
      if (e.mesh.faces.empty()) continue;
      LoadedStructure s = build(std::move(e.mesh), e.name);
      s.style = render::default_style(render::Role::context);
      s.style.color = e.color ? render::Color{static_cast<float>((*e.color)[0]),
                                              static_cast<float>((*e.color)[1]),
                                              static_cast<float>((*e.color)[2]), 1.0f}
                              : distinct_color(index);
      ++index;
      file.structures.push_back(std::move(s));
      set_progress(0.7 + 0.3 * static_cast<double>(done) / static_cast<double>(surfaces.size()));
    }
    if (file.structures.empty())
      throw InputError(path.string() + ": the volume has no label with a surface");
  } else {
    auto mesh = io::read_mesh(path);
    set_progress(0.5);
    LoadedStructure s = build(std::move(mesh.mesh), structure_name_from_file(path));
    s.mesh_file = path;
    s.role = render::Role::focus;
    s.style = render::default_style(render::Role::focus);
    file.structures.push_back(std::move(s));
  }
  set_progress(1.0);
  return file;
}

}  // namespace fabrica::viewer
