// Running a `fabrica batch` plan: shards, worker processes, one item after
// another in each worker (its input read and precomputed once), metadata
// sidecars for --resume, progress, and the report (docs/batch.md).
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <sstream>

#include "../cli_common.hpp"
#include "batch.hpp"
#include "fabrica/core/atomic_file.hpp"
#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/io/label_volume.hpp"
#include "fabrica/io/mesh_io.hpp"
#if __has_include("fabrica/render/scene.hpp")
#include "fabrica/render/scene.hpp"
#define FABRICA_BATCH_WITH_SCENES 1
#endif

#ifndef FABRICA_VERSION_STRING
#define FABRICA_VERSION_STRING "unknown"
#endif

extern char** environ;

namespace fabrica::cli::batch {
namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

constexpr int kRecordFd = 3;  // a worker's records go to its parent through this descriptor

struct Record {
  std::size_t index = 0;
  std::string status, reason;  ///< made, skipped or failed (+ reason)
  double seconds = 0.0;
  std::vector<std::string> outputs;
};

json to_json(const Record& r, const Plan& plan) {
  const Item item = plan.item(r.index);
  json j = {{"index", r.index},        {"input", item.input->name},
            {"view", item.view->name}, {"style", item.style->name},
            {"status", r.status},      {"seconds", std::round(r.seconds * 1000.0) / 1000.0},
            {"outputs", r.outputs}};
  if (!r.reason.empty()) j["reason"] = r.reason;
  return j;
}

Record record_from_json(const json& j) {
  Record r;
  r.index = j.at("index").get<std::size_t>();
  r.status = j.at("status").get<std::string>();
  r.reason = j.value("reason", "");
  r.seconds = j.value("seconds", 0.0);
  r.outputs = j.value("outputs", std::vector<std::string>{});
  return r;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& p, const std::string& text) {
  write_file_atomically(p, [&](std::ostream& out) { out << text; });
}

/// CPUs this process may use (affinity, e.g. a Slurm allocation).
int usable_cores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  int n = sched_getaffinity(0, sizeof set, &set) == 0 ? CPU_COUNT(&set) : 0;
  if (n <= 0) n = static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN));
  if (const char* c = std::getenv("SLURM_CPUS_PER_TASK"); c && std::atoi(c) > 0)
    n = std::min(n, std::atoi(c));
  return std::max(1, n);
}

std::optional<long> env_number(const char* name) {
  const char* v = std::getenv(name);
  if (!v || !*v) return std::nullopt;
  char* end = nullptr;
  const long n = std::strtol(v, &end, 10);
  if (*end != '\0')
    throw InputError(std::string("--shard auto: ") + name + "=\"" + v + "\" is not a number");
  return n;
}

/// --shard I/N or auto (Slurm job arrays, Kubernetes Indexed Jobs) -> {I, N}.
std::pair<long, long> resolve_shard(const Options& o) {
  long index = 0, count = 1;
  if (o.shard.empty()) return {0, 1};
  if (o.shard == "auto") {
    if (const auto id = env_number("SLURM_ARRAY_TASK_ID")) {
      const long min = env_number("SLURM_ARRAY_TASK_MIN").value_or(0);
      const long step = std::max(1L, env_number("SLURM_ARRAY_TASK_STEP").value_or(1));
      index = (*id - min) / step;
      if (const auto c = env_number("SLURM_ARRAY_TASK_COUNT")) {
        count = *c;
      } else if (const auto max = env_number("SLURM_ARRAY_TASK_MAX")) {
        count = (*max - min) / step + 1;
      } else {
        throw InputError(
            "--shard auto: SLURM_ARRAY_TASK_ID is set but neither SLURM_ARRAY_TASK_COUNT nor "
            "SLURM_ARRAY_TASK_MAX");
      }
    } else if (const auto k = env_number("JOB_COMPLETION_INDEX")) {
      if (o.shard_count <= 0)
        throw InputError(
            "--shard auto: JOB_COMPLETION_INDEX is set; give the Job's completions as "
            "--shard-count N");
      index = *k;
      count = o.shard_count;
    } else {
      throw InputError(
          "--shard auto: neither SLURM_ARRAY_TASK_ID (Slurm job array) nor JOB_COMPLETION_INDEX "
          "(Kubernetes Indexed Job) is set; use --shard I/N");
    }
  } else {
    char slash = 0;
    std::istringstream in(o.shard);
    std::string rest;
    if (!(in >> index >> slash >> count) || slash != '/' || (in >> rest))
      throw InputError("--shard: expected I/N (e.g. 0/3) or auto (got \"" + o.shard + "\")");
  }
  if (count < 1 || index < 0 || index >= count)
    throw InputError("--shard: index " + std::to_string(index) + " is not in 0.." +
                     std::to_string(count - 1));
  return {index, count};
}

/// While it lives, the drawing commands of this process share one GL context.
struct OneGlContext {
#if __has_include("fabrica/render/renderer.hpp")
  OneGlContext() {
    keep_headless_renderer(true);
  }
  ~OneGlContext() {
    keep_headless_renderer(false);
  }
#endif
};

std::string report_name(long index, long count) {
  return count == 1
             ? "batch-report.json"
             : "batch-report-" + std::to_string(index) + "-of-" + std::to_string(count) + ".json";
}

/// Temporaries of `path` left by a killed run (core/atomic_file: PATH.tmp-PID-N).
void remove_temporaries(const fs::path& path) {
  std::error_code ec;
  const std::string prefix = path.filename().string() + ".tmp-";
  for (const auto& e : fs::directory_iterator(path.parent_path(), ec))
    if (e.path().filename().string().starts_with(prefix)) fs::remove(e.path(), ec);
}

/// One worker: runs items one after another; the mesh cache keeps the
/// current input's Surface between them.
class Worker {
 public:
  Worker(const Plan& plan, fs::path dir, bool resume)
      : plan_(plan), dir_(std::move(dir)), resume_(resume) {}

  Record run(std::size_t index) {
    const auto start = Clock::now();
    const Item item = plan_.item(index);
    Record r;
    r.index = index;
    r.outputs = item.outputs;
    try {
      r.status = make(item);
    } catch (const std::bad_alloc&) {
      r.status = "failed";
      r.reason = "out of memory";
    } catch (const std::exception& e) {
      r.status = "failed";
      r.reason = e.what();
      if (const auto nl = r.reason.find('\n'); nl != std::string::npos) r.reason.resize(nl);
    }
    r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return r;
  }

 private:
  const Plan& plan_;
  fs::path dir_;
  bool resume_;
  std::map<std::string, std::pair<std::string, std::string>> hashes_;  // path -> (stamp, hash)

  /// The file's hash, remembered while its size and time stay the same.
  std::string hash(const fs::path& p) {
    std::error_code ec;
    const auto size = fs::file_size(p, ec);
    const auto time = fs::last_write_time(p, ec);
    const std::string stamp =
        std::to_string(size) + ":" + std::to_string(time.time_since_epoch().count());
    auto& entry = hashes_[p.string()];
    if (ec || entry.first != stamp || entry.second.empty()) entry = {ec ? "" : stamp, file_hash(p)};
    if (hashes_.size() > 64) hashes_.clear();
    return entry.second;
  }

  const Style& style_of(const Item& item) const { return *item.style; }

  std::optional<std::string> style_text(const Item& item, const std::string& key) const {
    for (const auto& [k, v] : style_of(item).options)
      if (k == key && v.is_string()) return v.get<std::string>();
    return std::nullopt;
  }

  bool style_flag(const Item& item, const std::string& key) const {
    for (const auto& [k, v] : style_of(item).options)
      if (k == key && v.is_boolean()) return v.get<bool>();
    return false;
  }

  /// A volume label's surface, extracted once into DIR/.batch/volumes/.
  fs::path volume_mesh(const Input& in, const std::string& volume_hash) {
    const fs::path target = dir_ / ".batch" / "volumes" / (in.name + ".ply");
    const json want = {{"fabrica", FABRICA_VERSION_STRING},
                       {"volume", in.shown},
                       {"hash", volume_hash},
                       {"label", in.label}};
    fs::path meta = target;
    meta += ".meta.json";
    if (fs::exists(target) && read_text(meta) == want.dump(2) + "\n") return target;
    const io::LabelVolume volume = io::read_label_volume(in.path);
    io::ExtractOptions options;
    options.labels = {in.label};
    for (const io::ExtractedSurface& s : io::extract_surfaces(volume, options)) {
      if (s.mesh.empty()) continue;
      fs::create_directories(target.parent_path());
      io::write_mesh(s.mesh, target);
      write_text(meta, want.dump(2) + "\n");
      return target;
    }
    throw InputError(in.shown + ": label " + std::to_string(in.label) + " yields no surface");
  }

  /// The files the style's options name (is_path_option), each with its
  /// content hash: what the item depends on besides its input and camera.
  json style_files(const Item& item) {
    json files = json::array();
    for (const auto& [key, value] : item.style->options) {
      if (!is_path_option(key)) continue;
      for (const json& v : value.is_array() ? value : json::array({value}))
        if (v.is_string())
          files.push_back({{"option", key},
                           {"path", v.get<std::string>()},
                           {"hash", hash(plan_.base / v.get<std::string>())}});
    }
    return files;
  }

  /// What the item's result depends on besides the command line: the input's content.
  json input_record(const Item& item) {
    const Input& in = *item.input;
    json j = {{"path", in.shown}, {"hash", hash(in.path)}};
    if (in.kind == Input::Kind::volume_label) {
      j["label"] = in.label;
      volume_mesh(in, j["hash"].get<std::string>());
    }
#ifdef FABRICA_BATCH_WITH_SCENES
    if (in.kind == Input::Kind::scene) {
      json meshes = json::array();
      for (const auto& s : render::read_scene_spec(in.path).structures)
        meshes.push_back(
            {{"path", fs::path(s.mesh).lexically_relative(in.path.parent_path()).string()},
             {"hash", hash(s.mesh)}});
      j["meshes"] = meshes;
    }
#endif
    return j;
  }

  /// Step `step` of `steps` around the starting view's up axis through its
  /// centre: the centre the command's --view frames (a mesh's bounding box,
  /// a scene's framing centre: its focus or everything, per --frame).
  Camera orbit_camera(const Item& item) {
    std::pair<int, int> size = plan_.size.value_or(std::pair<int, int>{1024, 1024});
    if (const auto s = style_text(item, "size")) size = parse_size(*s);
    const AnatomicalView from = *parse_anatomical_view(item.view->anatomical);
    Camera c;
    if (item.input->kind == Input::Kind::scene) {
#ifdef FABRICA_BATCH_WITH_SCENES
      // The scene as the item's command reads it (cli_common: the same
      // loader, so the command finds the meshes in the cache).
      render::SceneSpec spec = render::read_scene_spec(item.input->path);
      if (const auto s = style_text(item, "space"))
        for (auto& st : spec.structures) st.space = parse_space(*s);
      const render::Frame frame = frame_option(style_text(item, "frame").value_or(""), spec);
      c = render::view_camera(load_scene_surfaces(std::move(spec)), from, frame, size.first,
                              size.second);
#else
      throw Error(ErrorKind::unavailable, "scene inputs need the renderer (fabrica::render)");
#endif
    } else {
      PrepareOptions prepare;
      if (const auto s = style_text(item, "space")) prepare.space = parse_space(*s);
      // The same preparation as the item's command (oriented unless
      // --keep-orientation), so the command finds it in the cache.
      prepare.orient = !style_flag(item, "keep-orientation");
      const auto mesh =
          load_prepared_surface(item.input->kind == Input::Kind::volume_label
                                    ? dir_ / ".batch" / "volumes" / (item.input->name + ".ply")
                                    : item.input->path,
                                prepare);
      c = anatomical_camera(from, bounding_box(mesh->surface->positions()),
                            mesh->surface->mesh().space, size.first, size.second);
    }
    if (item.view->step == 0) return c;
    const double angle = 2.0 * std::numbers::pi * item.view->step / item.view->steps;
    const Vec3 axis = c.true_up();
    auto turn = [&](const Vec3& v) {
      return Vec3(v * std::cos(angle) + axis.cross(v) * std::sin(angle) +
                  axis * axis.dot(v) * (1.0 - std::cos(angle)));
    };
    c.eye = c.center + turn(c.eye - c.center);
    c.up = turn(c.up);
    return c;
  }

  std::string make(const Item& item) {
    json input;
    std::string unreadable;
    try {
      input = input_record(item);
    } catch (const Error& e) {
      unreadable = e.what();
    }
    // Camera and orbit views: the camera file the command reads (orbit
    // cameras are written under DIR/.batch/cameras/, named by content).
    json view = {{"name", item.view->name}};
    if (unreadable.empty() && item.view->kind == View::Kind::orbit) {
      const json cam = camera_to_json(orbit_camera(item));
      const std::string text = cam.dump(2) + "\n";
      const fs::path camera_file = dir_ / Plan::orbit_camera_file(item);
      if (read_text(camera_file) != text) {
        fs::create_directories(camera_file.parent_path());
        write_text(camera_file, text);
      }
      view["orbit"] = {
          {"from", item.view->anatomical}, {"step", item.view->step}, {"steps", item.view->steps}};
      view["camera"] = cam;
    } else if (item.view->kind == View::Kind::camera) {
      view["camera"] = camera_to_json(read_camera(item.view->camera));
    } else {
      view["anatomical"] = item.view->anatomical;
    }
    const std::vector<Run> runs = plan_.runs(item, dir_);
    if (!unreadable.empty()) {
      // The command's own message about the input, when it has one.
      if (item.input->kind != Input::Kind::volume_label) run_args(runs.front().args);
      throw InputError(unreadable);
    }
    json commands = json::array();
    for (const auto& run : runs) {
      json c = run.recorded;
      c.insert(c.begin(), "fabrica");
      commands.push_back(c);
    }
    json options = json::object();
    for (const auto& [k, v] : item.style->options) options[k] = v;
    json style = {
        {"name", item.style->name}, {"command", item.style->command}, {"options", options}};
    if (const json files = style_files(item); !files.empty()) style["files"] = files;
    const json meta = {{"fabrica", FABRICA_VERSION_STRING},
                       {"item", item.index},
                       {"input", input},
                       {"view", view},
                       {"style", style},
                       {"commands", commands},
                       {"outputs", item.outputs}};
    auto meta_path = [&](const std::string& rel) {
      fs::path p = dir_ / rel;
      p += ".meta.json";
      return p;
    };
    auto meta_text = [&](const std::string& rel) {
      json m = meta;
      m["output"] = rel;
      return m.dump(2) + "\n";
    };
    if (resume_ &&
        std::all_of(item.outputs.begin(), item.outputs.end(), [&](const std::string& rel) {
          return fs::exists(dir_ / rel) && read_text(meta_path(rel)) == meta_text(rel);
        }))
      return "skipped";
    for (const auto& rel : item.outputs) {
      std::error_code ec;
      fs::create_directories((dir_ / rel).parent_path(), ec);
      fs::remove(meta_path(rel), ec);  // no stale record while the output is being remade
      remove_temporaries(dir_ / rel);
      remove_temporaries(meta_path(rel));
    }
    // A failure leaves the folders made above; the parent removes the empty
    // ones once every worker is done (remove_empty_folders_of_failed_items):
    // removing them here raced with other workers' items writing there.
    for (const auto& run : runs) run_args(run.args);
    for (const auto& rel : item.outputs) write_text(meta_path(rel), meta_text(rel));
    return "made";
  }
};

/// Done/failed counts, rate and ETA: a bar on a terminal, plain lines otherwise.
class Progress {
 public:
  Progress(std::size_t total, bool quiet) : total_(total), quiet_(quiet), tty_(isatty(2) == 1) {}

  void add(const Record& r, const Plan& plan) {
    ++done_;
    if (r.status == "failed") {
      ++failed_;
      clear();
      std::fprintf(stderr, "fabrica batch: item %zu (%s) failed: %s\n", r.index,
                   plan.item(r.index).outputs.front().c_str(), r.reason.c_str());
    } else if (r.status == "skipped") {
      ++skipped_;
    }
    tick(false);
  }

  void tick(bool force) {
    if (quiet_ || (force && done_ == shown_ && !tty_)) return;
    const auto now = Clock::now();
    const double since = std::chrono::duration<double>(now - last_).count();
    const std::size_t tenth = std::max<std::size_t>(total_ / 10, 1);
    const bool due = tty_ ? since >= 0.1 || done_ == total_
                          : done_ != shown_ && (since >= 10.0 || done_ == total_ ||
                                                done_ / tenth != shown_ / tenth);
    if (!force && !due) return;
    last_ = now;
    shown_ = done_;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double rate = elapsed > 0.0 ? static_cast<double>(done_) / elapsed : 0.0;
    char eta[32] = "?";
    if (rate > 0.0)
      std::snprintf(eta, sizeof eta, "%.0f s", static_cast<double>(total_ - done_) / rate);
    if (tty_) {
      constexpr int width = 30;
      const int fill = total_ ? static_cast<int>(width * done_ / total_) : width;
      std::fprintf(stderr, "\r\033[K[%s%s] %zu/%zu done, %zu failed, %.2f items/s, ETA %s",
                   std::string(static_cast<std::size_t>(fill), '#').c_str(),
                   std::string(static_cast<std::size_t>(width - fill), '.').c_str(), done_, total_,
                   failed_, rate, eta);
      drawn_ = true;
    } else {
      std::fprintf(stderr, "fabrica batch: %zu/%zu items done, %zu failed, %.2f items/s, ETA %s\n",
                   done_, total_, failed_, rate, eta);
    }
    std::fflush(stderr);
  }

  void clear() {
    if (drawn_) std::fputs("\r\033[K", stderr);
    drawn_ = false;
  }

  std::size_t failed() const { return failed_; }
  std::size_t skipped() const { return skipped_; }

 private:
  std::size_t total_, done_ = 0, failed_ = 0, skipped_ = 0, shown_ = 0;
  bool quiet_, tty_, drawn_ = false;
  Clock::time_point start_ = Clock::now(), last_ = Clock::now() - std::chrono::hours(1);
};

/// Writes every byte of a line to the parent (one write per record when it fits).
void send_record(const std::string& line) {
  std::size_t sent = 0;
  while (sent < line.size()) {
    const ssize_t n = ::write(kRecordFd, line.data() + sent, line.size() - sent);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) std::_Exit(1);  // the parent is gone
    sent += static_cast<std::size_t>(n);
  }
}

struct Child {
  pid_t pid = -1;
  int fd = -1;
  std::string buffer;
  std::vector<std::size_t> items;
};

Child spawn_worker(const Options& o, long shard_index, long shard_count, int w, int jobs,
                   std::vector<std::size_t> items) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0)
    throw Error(ErrorKind::internal, "cannot create a pipe to a worker");
  std::vector<std::string> args = {"fabrica",
                                   "batch",
                                   fs::absolute(o.manifest).string(),
                                   "-o",
                                   fs::absolute(o.dir).string(),
                                   "--worker",
                                   std::to_string(w) + "/" + std::to_string(jobs),
                                   "--shard",
                                   std::to_string(shard_index) + "/" + std::to_string(shard_count),
                                   "--jobs",
                                   std::to_string(jobs),
                                   "--quiet"};
  if (o.resume) args.push_back("--resume");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], kRecordFd);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, "/proc/self/exe", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  if (rc != 0) {
    ::close(fds[0]);
    throw Error(ErrorKind::internal,
                std::string("cannot start a worker process: ") + std::strerror(rc));
  }
  Child c;
  c.pid = pid;
  c.fd = fds[0];
  c.items = std::move(items);
  return c;
}

/// Items [w*n/J, (w+1)*n/J) of the shard's list: contiguous, so a worker's
/// items share inputs (items are numbered input-major).
std::vector<std::size_t> chunk(const std::vector<std::size_t>& items, int w, int jobs) {
  const std::size_t n = items.size();
  return {items.begin() + static_cast<std::ptrdiff_t>(n * static_cast<std::size_t>(w) /
                                                      static_cast<std::size_t>(jobs)),
          items.begin() + static_cast<std::ptrdiff_t>(n * static_cast<std::size_t>(w + 1) /
                                                      static_cast<std::size_t>(jobs))};
}

std::string describe_exit(int status) {
  if (WIFSIGNALED(status)) return "was killed by signal " + std::to_string(WTERMSIG(status));
  return "exited with code " + std::to_string(WEXITSTATUS(status));
}

/// Empty folders that failed items' outputs would have gone into, strictly
/// inside `dir` (never `dir` itself), innermost first.
void remove_empty_folders_of_failed_items(const fs::path& dir,
                                          const std::map<std::size_t, Record>& records) {
  const fs::path root = dir.lexically_normal();
  for (const auto& [index, r] : records) {
    if (r.status != "failed") continue;
    for (const auto& rel : r.outputs) {
      for (fs::path f = (root / rel).parent_path(); f != root && f.has_relative_path();
           f = f.parent_path()) {
        const auto inside = f.lexically_relative(root);
        if (inside.empty() || *inside.begin() == "..") break;
        std::error_code ec;
        if (!fs::is_directory(f, ec) || !fs::is_empty(f, ec) || !fs::remove(f, ec)) break;
      }
    }
  }
}

json report_json(const Plan& plan, const std::map<std::size_t, Record>& records, long shard_index,
                 long shard_count, double seconds) {
  json items = json::array();
  std::map<std::string, std::size_t> summary = {{"made", 0}, {"skipped", 0}, {"failed", 0}};
  for (const auto& [index, r] : records) {
    items.push_back(to_json(r, plan));
    ++summary[r.status];
  }
  return {{"fabrica", FABRICA_VERSION_STRING},
          {"manifest", fs::absolute(plan.manifest).lexically_normal().string()},
          {"manifest_hash", plan.manifest_hash},
          {"total_items", plan.item_count()},
          {"shard", {{"index", shard_index}, {"count", shard_count}}},
          {"seconds", std::round(seconds * 1000.0) / 1000.0},
          {"summary", summary},
          {"items", items}};
}

}  // namespace

int run_batch(const Options& o) {
  const auto start = Clock::now();
  const Plan plan = read_plan(o.manifest);
  const auto [shard_index, shard_count] = resolve_shard(o);
  std::vector<std::size_t> items;
  for (std::size_t k = static_cast<std::size_t>(shard_index); k < plan.item_count();
       k += static_cast<std::size_t>(shard_count))
    items.push_back(k);

  if (o.dry_run) {
    std::printf("# %zu item(s) of %zu (shard %ld/%ld); outputs relative to the output folder\n",
                items.size(), plan.item_count(), shard_index, shard_count);
    for (const std::size_t k : items) {
      const Item item = plan.item(k);
      for (const auto& run : plan.runs(item, {})) {
        std::printf("%zu\tfabrica", k);
        for (const auto& a : run.recorded) std::printf(" %s", a.c_str());
        std::printf("\n");
      }
    }
    return 0;
  }

  std::error_code ec;
  fs::create_directories(o.dir, ec);
  if (!fs::is_directory(o.dir))
    throw OutputError(o.dir.string() + ": cannot create the output folder" +
                      (ec ? " (" + ec.message() + ")" : std::string()));

  const int cores = usable_cores();
  // Every process of a batch draws several items of an input in a row: its
  // line precompute is kept with the cached mesh (cli_common.hpp).
  keep_line_drawers(true);
  if (!o.worker.empty()) {  // a worker process: run our chunk, report each item to the parent
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() == 1) return 1;
    int w = 0, jobs = 1;
    char slash = 0;
    std::istringstream in(o.worker);
    if (!(in >> w >> slash >> jobs) || slash != '/' || jobs < 1 || w < 0 || w >= jobs)
      throw InputError("--worker: expected W/J");
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(std::max(1, cores / jobs)));
    const OneGlContext gl;
    Worker worker(plan, o.dir, o.resume);
    for (const std::size_t k : chunk(items, w, jobs)) {
      const Record r = worker.run(k);
      send_record(to_json(r, plan).dump() + "\n");
    }
    return 0;
  }

  int jobs = o.jobs > 0 ? o.jobs : cores;
  jobs = static_cast<int>(std::clamp<std::size_t>(static_cast<std::size_t>(jobs), 1,
                                                  std::max<std::size_t>(items.size(), 1)));
  Progress progress(items.size(), o.quiet);
  std::map<std::size_t, Record> records;
  if (!o.quiet)
    std::fprintf(
        stderr, "fabrica batch: %zu item(s)%s, %d worker(s) x %d thread(s) -> %s\n", items.size(),
        shard_count > 1
            ? (" (shard " + std::to_string(shard_index) + "/" + std::to_string(shard_count) + ")")
                  .c_str()
            : "",
        jobs, std::max(1, cores / jobs), o.dir.string().c_str());
  if (jobs == 1) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(cores));
    const OneGlContext gl;
    Worker worker(plan, o.dir, o.resume);
    for (const std::size_t k : items) {
      records[k] = worker.run(k);
      progress.add(records[k], plan);
    }
  } else {
    std::vector<Child> children;
    for (int w = 0; w < jobs; ++w)
      children.push_back(spawn_worker(o, shard_index, shard_count, w, jobs, chunk(items, w, jobs)));
    std::size_t open = children.size();
    while (open > 0) {
      std::vector<pollfd> fds;
      for (const auto& c : children)
        if (c.fd >= 0) fds.push_back({c.fd, POLLIN, 0});
      if (::poll(fds.data(), fds.size(), 1000) <= 0) {
        progress.tick(false);
        continue;
      }
      for (auto& c : children) {
        if (c.fd < 0) continue;
        const auto it =
            std::find_if(fds.begin(), fds.end(), [&](const pollfd& p) { return p.fd == c.fd; });
        if (it == fds.end() || !(it->revents & (POLLIN | POLLHUP | POLLERR))) continue;
        char buf[65536];
        const ssize_t n = ::read(c.fd, buf, sizeof buf);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
          ::close(c.fd);
          c.fd = -1;
          --open;
          continue;
        }
        c.buffer.append(buf, static_cast<std::size_t>(n));
        for (std::size_t nl = c.buffer.find('\n'); nl != std::string::npos;
             nl = c.buffer.find('\n')) {
          const std::string line = c.buffer.substr(0, nl);
          c.buffer.erase(0, nl + 1);
          try {
            const Record r = record_from_json(json::parse(line));
            records[r.index] = r;
            progress.add(r, plan);
          } catch (const std::exception&) {
          }
        }
      }
    }
    for (std::size_t w = 0; w < children.size(); ++w) {
      int status = 0;
      ::waitpid(children[w].pid, &status, 0);
      for (const std::size_t k : children[w].items)
        if (!records.count(k)) {
          Record r;
          r.index = k;
          r.status = "failed";
          r.reason = "worker " + std::to_string(w) + " " + describe_exit(status) +
                     " before this item finished";
          r.outputs = plan.item(k).outputs;
          records[k] = r;
          progress.add(r, plan);
        }
    }
  }
  progress.tick(true);
  progress.clear();
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  remove_empty_folders_of_failed_items(o.dir, records);
  const fs::path report = o.dir / report_name(shard_index, shard_count);
  write_text(report, report_json(plan, records, shard_index, shard_count, seconds).dump(2) + "\n");
  const std::size_t failed = progress.failed(), skipped = progress.skipped();
  if (!o.quiet || failed > 0)
    std::fprintf(stderr,
                 "fabrica batch: %zu item(s): %zu made, %zu skipped, %zu failed in %.1f s (%.2f "
                 "items/s); report %s\n",
                 items.size(), items.size() - failed - skipped, skipped, failed, seconds,
                 seconds > 0 ? static_cast<double>(items.size()) / seconds : 0.0,
                 report.string().c_str());
  return failed > 0 ? 5 : 0;
}

int merge_reports(const std::vector<fs::path>& dirs, const std::string& output, bool quiet) {
  std::vector<fs::path> files;
  for (const auto& d : dirs) {
    if (!fs::is_directory(d))
      throw InputError(d.string() + ": not a folder (give the output folders of the shards)");
    std::vector<fs::path> here;
    for (const auto& e : fs::directory_iterator(d)) {
      const std::string name = e.path().filename().string();
      if (name.starts_with("batch-report") && name.ends_with(".json")) here.push_back(e.path());
    }
    std::sort(here.begin(), here.end());
    files.insert(files.end(), here.begin(), here.end());
  }
  if (files.empty()) throw InputError("no batch-report*.json in the given folder(s)");
  json first;
  std::map<std::size_t, json> items;
  json sources = json::array();
  auto rank = [](const json& item) { return item.value("status", "") == "failed" ? 0 : 1; };
  for (const auto& f : files) {
    json r;
    try {
      r = json::parse(read_text(f));
    } catch (const json::parse_error& e) {
      throw InputError(f.string() + ": not a batch report (" + e.what() + ")");
    }
    if (!r.is_object() || !r.contains("items") || !r.contains("manifest_hash"))
      throw InputError(f.string() + ": not a batch report");
    if (first.is_null()) first = r;
    if (r["manifest_hash"] != first["manifest_hash"] || r["total_items"] != first["total_items"])
      throw InputError(f.string() + ": made from another manifest than " + files.front().string() +
                       "; not merged");
    sources.push_back(f.string());
    for (json item : r["items"]) {
      const auto index = item.at("index").get<std::size_t>();
      item["folder"] = f.parent_path().string();
      if (!items.count(index) || rank(item) > rank(items[index])) items[index] = item;
    }
  }
  const auto total = first["total_items"].get<std::size_t>();
  std::map<std::string, std::size_t> summary = {
      {"made", 0}, {"skipped", 0}, {"failed", 0}, {"missing", 0}};
  json list = json::array();
  for (std::size_t k = 0; k < total; ++k) {
    if (!items.count(k)) {
      ++summary["missing"];
      list.push_back(
          {{"index", k}, {"status", "missing"}, {"reason", "in none of the merged reports"}});
      continue;
    }
    ++summary[items[k].value("status", "failed")];
    list.push_back(items[k]);
  }
  const json merged = {{"fabrica", FABRICA_VERSION_STRING},
                       {"manifest", first["manifest"]},
                       {"manifest_hash", first["manifest_hash"]},
                       {"total_items", total},
                       {"merged_from", sources},
                       {"summary", summary},
                       {"items", list}};
  const fs::path out = output.empty() ? dirs.front() / "batch-report.json" : fs::path(output);
  write_text(out, merged.dump(2) + "\n");
  if (!quiet)
    std::fprintf(stderr,
                 "fabrica batch merge: %zu report(s), %zu item(s): %zu made, %zu skipped, %zu "
                 "failed, %zu missing -> %s\n",
                 files.size(), total, summary["made"], summary["skipped"], summary["failed"],
                 summary["missing"], out.string().c_str());
  return summary["failed"] + summary["missing"] > 0 ? 5 : 0;
}

}  // namespace fabrica::cli::batch
