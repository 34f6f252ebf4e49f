// fabrica-study: the study definition (docs/study.md), strictly validated.
// Every key is checked; an unknown or mistyped key is an InputError naming
// its JSON path (e.g. "study.json: blocks[1].repeat: unknown key").
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace fabrica::study {

/// One drawing technique: a `fabrica` command and its options by CLI name
/// (without the leading dashes), e.g. {"types": "contour,suggestive"}.
struct Technique {
  std::string name;
  std::string command;  ///< render | lines | hatch
  nlohmann::json options = nlohmann::json::object();
};

struct Model {
  std::string name;  ///< "name" key, else the file stem
  std::filesystem::path path;
  bool scene = false;  ///< a `fabrica render` scene JSON instead of a mesh
};

struct View {
  std::string name;              ///< preset name, or the camera file's stem
  std::filesystem::path camera;  ///< empty for a preset
};

enum class Task { gauge, afc2, likert, ranking };
const char* task_name(Task task);

struct Block {
  Task task = Task::gauge;
  std::string question;
  std::string instructions;             ///< shown before the block (empty: a default text)
  int points_per_stimulus = 4;          ///< gauge
  int repeats = 1;                      ///< 2afc: each pair this many times
  int scale = 7;                        ///< likert: ratings 1..scale
  int practice = 0;                     ///< practice trials before the block (logged, flagged)
  int attention_checks = 0;             ///< attention-check trials mixed into the block
  std::vector<std::string> techniques;  ///< subset by name (empty: all)
};

struct Study {
  std::filesystem::path file;  ///< the definition's path (relative paths resolve from its folder)
  std::string name;
  std::uint64_t seed = 0;
  std::vector<Technique> techniques;
  std::vector<Model> models;
  std::vector<View> views;
  int width = 512, height = 512;
  std::vector<Block> blocks;
  std::string welcome;  ///< first screen
  std::string goodbye;  ///< last screen
  int break_every = 0;  ///< a break screen after every N trials (0: none)

  const Technique& technique(const std::string& name) const;
  std::size_t technique_index(const std::string& name) const;
};

/// Reads and validates a study file; InputError (exit 2) naming the JSON
/// path of the first problem.
Study read_study(const std::filesystem::path& path);
Study parse_study(const nlohmann::json& j, const std::filesystem::path& file);

/// Names: [A-Za-z0-9_-]{1,64} (participant ids, technique and model names).
bool valid_name(const std::string& s);

}  // namespace fabrica::study
