#include "cli_common.hpp"

#include <CLI/CLI.hpp>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdio>
#include <deque>
#include <mutex>
#include <set>
#include <sstream>

#include "fabrica/core/error.hpp"
#include "fabrica/core/heap.hpp"
#include "fabrica/core/suggest.hpp"
#include "fabrica/lines/extract.hpp"

namespace fabrica::cli {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::pair<int, int> parse_size(const std::string& text, int max_pixels, const std::string& option) {
  int w = 0, h = 0;
  char x = 0;
  std::istringstream in(lower(text));
  std::string rest;
  if (!(in >> w >> x >> h) || x != 'x' || (in >> rest) || w <= 0 || h <= 0 || w > max_pixels ||
      h > max_pixels)
    throw InputError(option + ": expected WIDTHxHEIGHT in pixels, each 1 to " +
                     std::to_string(max_pixels) + ", e.g. 2048x2048 (got \"" + text + "\")");
  return {w, h};
}

Space parse_space(const std::string& text, const std::string& option) {
  const std::string s = lower(text);
  if (s == "lps") return Space::lps;
  if (s == "ras") return Space::ras;
  throw InputError(option + ": use lps or ras (got \"" + text + "\")");
}

std::vector<LineFamily> parse_family_list(const std::string& text, const std::string& option,
                                          const std::vector<LineFamily>& default_set,
                                          bool allow_none) {
  const std::string t = lower(text);
  if (t == "default") return default_set;
  if (t == "all") return all_families();
  if (t == "reference" || t == "rtsc") return reference_families();
  if (allow_none && t == "none") return {};
  std::vector<LineFamily> out;
  std::stringstream in(t);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (item.empty()) continue;
    const auto f = parse_family(item);
    if (!f) {
      std::string names;
      std::vector<std::string> known;
      for (auto g : all_families()) {
        names += std::string(names.empty() ? "" : ", ") + family_name(g);
        known.emplace_back(family_name(g));
      }
      throw InputError(option + ": unknown line family \"" + item + "\"" +
                       did_you_mean(item, known) + " (known: " + names +
                       ", or default, reference, all" + (allow_none ? ", none)" : ")"));
    }
    if (std::find(out.begin(), out.end(), *f) == out.end()) out.push_back(*f);
  }
  if (out.empty() && !allow_none) throw InputError(option + ": no line family given");
  return out;
}

AnatomicalView parse_view(const std::string& text, const std::string& option) {
  if (const auto view = parse_anatomical_view(lower(text))) return *view;
  const std::vector<std::string> known = {"anterior", "posterior", "left",
                                          "right",    "superior",  "inferior"};
  throw InputError(option + ": unknown view \"" + text + "\"" + did_you_mean(text, known) +
                   " (anterior, posterior, left, right, superior, inferior)");
}

void warn_if_space_assumed(SpaceSource source, const std::string& path, const std::string& command,
                           bool quiet) {
  if (quiet || source != SpaceSource::default_assumed) return;
  std::fprintf(stderr,
               "fabrica %s: warning: %s has no coordinate-space tag: assumed LPS (DICOM, ITK); "
               "give --space ras for RAS meshes (3D Slicer, vmtk), or the views are mirrored\n",
               command.c_str(), path.c_str());
}

std::string parse_error_hint(CLI::App& app, int argc, char** argv) {
  if (argc < 2) return {};
  std::vector<std::string> commands;
  for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    commands.push_back(sub->get_name());
  const std::string first = argv[1];
  if (first.empty() || first[0] == '-') return {};
  if (std::find(commands.begin(), commands.end(), first) == commands.end()) {
    const std::string hint = did_you_mean(first, commands);
    return hint.empty() ? std::string() : "unknown command '" + first + "'" + hint;
  }
  std::vector<std::string> options{"--help"};
  for (const CLI::Option* opt : app.get_subcommand(first)->get_options()) {
    for (const auto& n : opt->get_lnames()) options.push_back("--" + n);
    for (const auto& n : opt->get_snames()) options.push_back("-" + n);
  }
  for (int i = 2; i < argc; ++i) {
    std::string token = argv[i];
    if (token.rfind("--", 0) != 0) continue;
    token = token.substr(0, token.find('='));
    if (std::find(options.begin(), options.end(), token) != options.end()) continue;
    const std::string hint = did_you_mean(token, options);
    return hint.empty() ? std::string() : "unknown option '" + token + "'" + hint;
  }
  return {};
}

namespace {

/// What identifies a loaded mesh: the file as it is now and how it was read.
struct MeshKey {
  std::string path;
  std::uintmax_t size = 0;
  std::filesystem::file_time_type mtime;
  std::optional<Space> space;
  bool oriented = false;
  bool operator==(const MeshKey&) const = default;
};

struct MeshCache {
  std::mutex mutex;
  std::deque<std::pair<MeshKey, std::shared_ptr<const LoadedSurface>>> entries;  // newest first
  /// The files of the current input when it is a scene (load_scene_surfaces):
  /// its meshes stay together instead of evicting one another.
  std::set<std::string> group;
  std::size_t capacity() const { return 2 * std::max<std::size_t>(1, group.size()); }
};

std::string cache_path(const std::filesystem::path& path) {
  return std::filesystem::absolute(path).lexically_normal().string();
}

MeshCache& mesh_cache() {
  static MeshCache cache;
  return cache;
}

}  // namespace

namespace {
std::atomic<bool> keep_drawers{false};
}  // namespace

std::shared_ptr<const LoadedSurface> load_prepared_surface(const std::filesystem::path& path,
                                                           const PrepareOptions& options) {
  std::error_code ec_size, ec_time;
  MeshKey key;
  key.path = cache_path(path);
  key.size = std::filesystem::file_size(path, ec_size);
  key.mtime = std::filesystem::last_write_time(path, ec_time);
  key.space = options.space;
  key.oriented = options.orient;
  const bool cacheable = !ec_size && !ec_time;  // a missing file: the reader names the problem
  MeshCache& cache = mesh_cache();
  if (cacheable) {
    const std::lock_guard<std::mutex> lock(cache.mutex);
    for (const auto& [k, mesh] : cache.entries)
      if (k == key) return mesh;
    // Another input: let go of the previous one before reading (flat memory).
    if (!cache.group.count(key.path)) cache.group.clear();
    std::erase_if(cache.entries, [&](const auto& e) {
      return e.first.path != key.path && !cache.group.count(e.first.path);
    });
  }
  PreparedMesh prepared = prepare_mesh(path, options);
  auto loaded = std::make_shared<LoadedSurface>();
  loaded->messages = prepared.messages();
  loaded->info = std::move(prepared.info);
  // One drawing per load (`fabrica lines`, hatch): the topology's opposite
  // corners and edges' faces (12 bytes per corner on a closed mesh) are not
  // kept; the one-shot line extraction reads neither (its tangent ring reads
  // the faces), and a reader that asks rebuilds them (Topology::
  // release_derived_parts). A drawer kept for many views keeps them (its
  // ring reads them at every first view).
  if (!keep_drawers.load() && prepared.topology) prepared.topology->release_derived_parts();
  // The reader's arrays as long as their contents: a reader reserves ahead
  // (igea's face array held 4.5 MB for 3.2 of faces), and the Surface keeps
  // the mesh through every later phase. The same values (a copy, while
  // little else is alive).
  prepared.mesh.positions.shrink_to_fit();
  prepared.mesh.faces.shrink_to_fit();
  // With the topology the preparation built: the Surface does not build it again.
  loaded->surface = std::make_shared<const Surface>(to_surface(std::move(prepared)));
  if (!keep_drawers.load()) {
    // One drawing: the edges' vertex pairs are not kept either (8 bytes per
    // edge; chaining finds an edge's ends from its face, hidden-line removal
    // reads the edge-length statistics computed before), and the pages that
    // reading and preparing freed (~25 MB on igea: the file, the reader's
    // arrays, the repair's scratch) go back to the system instead of
    // counting in every later phase.
    loaded->surface->release_topology_edges();
    return_free_heap_pages();
  }
  if (cacheable) {
    const std::lock_guard<std::mutex> lock(cache.mutex);
    cache.entries.emplace_front(key, loaded);
    while (cache.entries.size() > cache.capacity()) cache.entries.pop_back();
  }
  return loaded;
}

void keep_line_drawers(bool keep) {
  keep_drawers = keep;
}

LineDrawing LoadedSurface::draw_lines(const Camera& camera, const DrawLinesOptions& options) const {
  if (!keep_drawers) return fabrica::draw_lines(*surface, camera, options);
  const std::lock_guard<std::mutex> lock(drawer_mutex_);
  if (!drawer_)
    drawer_ = std::make_unique<LineDrawer>(*surface, options);
  else
    drawer_->set_options(options);
  return drawer_->draw(camera);
}

ChosenCamera choose_camera(const std::string& camera_file, const std::string& view,
                           const std::string& size, std::pair<int, int> default_size,
                           const ViewFramer& frame, const std::optional<Camera>& given,
                           const std::string& given_what, const std::string& default_view) {
  if (!camera_file.empty() && !view.empty())
    throw InputError("give either --camera FILE or --view NAME, not both");
  std::optional<std::pair<int, int>> wanted;
  if (!size.empty()) wanted = parse_size(size);
  ChosenCamera out;
  if (!camera_file.empty() || (view.empty() && given)) {
    // A camera keeps its framing; --size changes only the picture's size.
    out.camera = !camera_file.empty() ? read_camera(camera_file) : *given;
    out.what = !camera_file.empty() ? camera_file : given_what;
    if (wanted) std::tie(out.camera.width, out.camera.height) = *wanted;
  } else {
    const std::string name = view.empty() ? default_view : lower(view);
    const auto [w, h] = wanted.value_or(default_size);
    out.camera = frame(parse_view(name), w, h);
    out.what = "--view " + name;
    out.from_view = true;
  }
  validate_camera(out.camera, out.what);
  return out;
}

bool is_scene_file(const std::filesystem::path& path) {
  return lower(path.extension().string()) == ".json";
}

#if __has_include("fabrica/render/renderer.hpp")
render::SceneSurfaces load_scene_surfaces(render::SceneSpec spec) {
  {  // The scene is one input: its meshes are kept together.
    MeshCache& cache = mesh_cache();
    const std::lock_guard<std::mutex> lock(cache.mutex);
    cache.group.clear();
    for (const auto& s : spec.structures) cache.group.insert(cache_path(s.mesh));
  }
  return render::load_scene(std::move(spec), [](const render::StructureSpec& s) {
    PrepareOptions prepare;
    prepare.space = s.space;
    return load_prepared_surface(s.mesh, prepare)->surface;
  });
}

ChosenCamera choose_scene_camera(const render::SceneSurfaces& scene, render::Frame frame,
                                 const std::string& camera_file, const std::string& view,
                                 const std::string& size, std::pair<int, int> default_size,
                                 const std::string& input) {
  return choose_camera(
      camera_file, view, size, default_size,
      [&](AnatomicalView v, int w, int h) { return render::view_camera(scene, v, frame, w, h); },
      scene.spec.camera, input + ": camera",
      scene.spec.view ? to_string(*scene.spec.view) : "anterior");
}

render::Frame frame_option(const std::string& text, const render::SceneSpec& spec) {
  std::optional<render::Frame> frame;
  if (!text.empty()) {
    frame = render::parse_frame(lower(text));
    if (!frame) throw InputError("--frame must be focus or all (got \"" + text + "\")");
  }
  return render::default_frame(spec, frame);
}

namespace {
struct KeptRenderer {
  bool keep = false;
  std::optional<render::Backend> backend;
  std::shared_ptr<render::Renderer> renderer;
};
KeptRenderer& kept_renderer() {
  static KeptRenderer kept;
  return kept;
}
}  // namespace

std::shared_ptr<render::Renderer> headless_renderer(const render::HeadlessOptions& options) {
  KeptRenderer& kept = kept_renderer();
  if (kept.keep && kept.renderer && kept.backend == options.backend) {
    kept.renderer->context().make_current();
    return kept.renderer;
  }
  kept.renderer.reset();  // at most one context at a time
  auto renderer = std::make_shared<render::Renderer>(render::create_headless_context(options));
  if (kept.keep) {
    kept.renderer = renderer;
    kept.backend = options.backend;
  }
  return renderer;
}

void keep_headless_renderer(bool keep) {
  kept_renderer().keep = keep;
  if (!keep) kept_renderer().renderer.reset();
}
#endif

void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__) && defined(M_MMAP_THRESHOLD) && defined(M_TRIM_THRESHOLD)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
}

}  // namespace fabrica::cli
