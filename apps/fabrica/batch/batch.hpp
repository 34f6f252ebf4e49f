// `fabrica batch` (docs/batch.md): a manifest of inputs x views x styles
// becomes numbered items; each item is what one `fabrica lines|render|hatch`
// command line would make, run in-process through that command's own parser.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace fabrica::cli::batch {

/// One input of the expanded manifest (a glob gives several, a volume one per label).
struct Input {
  enum class Kind { mesh, scene, volume_label };
  Kind kind = Kind::mesh;
  std::string name;            ///< {input} in output names, unique
  std::string shown;           ///< the path as the manifest gives it (relative to it)
  std::filesystem::path path;  ///< resolved file (volume_label: the volume)
  int label = 0;               ///< volume_label only
  std::string json_path;       ///< e.g. inputs[2]
};

/// One view: an anatomical preset, a camera file, or one step of an orbit.
struct View {
  enum class Kind { anatomical, camera, orbit };
  Kind kind = Kind::anatomical;
  std::string name;              ///< {view} in output names, unique
  std::string anatomical;        ///< anatomical: the preset; orbit: the starting preset
  std::string shown;             ///< camera: the file as the manifest gives it
  std::filesystem::path camera;  ///< camera: resolved file
  int step = 0, steps = 1;       ///< orbit: step of steps (360/steps degrees apart)
  std::string json_path;
};

/// One style: a command and its options (option names without "--").
struct Style {
  std::string name, command, json_path;
  std::vector<std::pair<std::string, nlohmann::json>> options;  ///< in manifest order
  std::vector<std::string> formats;                             ///< output extensions
};

/// One run of a command inside an item (lines and hatch write one file per
/// run; render writes its PNG and, with "svg", the --svg file in one run).
struct Run {
  std::vector<std::string> args;      ///< real paths, ready to parse
  std::vector<std::string> recorded;  ///< the same with paths as the manifest / DIR name them
  std::vector<std::string> outputs;   ///< relative to DIR
};

struct Item {
  std::size_t index = 0;
  const Input* input = nullptr;
  const View* view = nullptr;
  const Style* style = nullptr;
  std::vector<std::string> outputs;  ///< relative to DIR, every run's
};

/// The expanded manifest. Items are numbered input-major:
/// index = (input * views + view) * styles + style.
struct Plan {
  std::filesystem::path manifest, base;  ///< the file and its folder
  std::string manifest_hash;
  std::vector<Input> inputs;
  std::vector<View> views;
  std::vector<Style> styles;
  std::optional<std::pair<int, int>> size;
  std::string output = "{input}/{style}-{view}.{ext}";

  std::size_t item_count() const { return inputs.size() * views.size() * styles.size(); }
  Item item(std::size_t index) const;
  /// The command runs of an item; `dir` is the output folder.
  std::vector<Run> runs(const Item& item, const std::filesystem::path& dir) const;
  /// Orbit views: the camera file the item's commands read, relative to DIR
  /// (.batch/cameras/INPUT-VIEW-STYLE.json, written by the worker).
  static std::string orbit_camera_file(const Item& item);
};

/// Style options whose values name files (resolved against the manifest's
/// folder; their contents are hashed into each item's record, so --resume
/// remakes the items whose files changed).
bool is_path_option(const std::string& key);

/// Reads and checks a manifest; every problem found (with its JSON path) is
/// listed in one InputError (exit 2) before any work.
Plan read_plan(const std::filesystem::path& manifest);

/// 64-bit FNV-1a of a file's bytes as "fnv1a64:<16 hex>"; throws InputError.
std::string file_hash(const std::filesystem::path& path);

/// Runs an argument list (args[0] = command name) through that command's
/// CLI11 parser; returns an error message, empty when the list parses.
std::string check_args(const std::vector<std::string>& args);
/// Parses and runs it; throws what the command throws.
void run_args(const std::vector<std::string>& args);

struct Options {
  std::filesystem::path manifest, dir;
  int jobs = 0;  ///< 0: every core
  bool resume = false, dry_run = false, quiet = false;
  std::string shard;  ///< "I/N", "auto" or empty
  int shard_count = 0;
  std::string worker;  ///< hidden: "W/J" when this process is worker W of J
};

int run_batch(const Options& options);
int merge_reports(const std::vector<std::filesystem::path>& dirs, const std::string& output,
                  bool quiet);

}  // namespace fabrica::cli::batch
