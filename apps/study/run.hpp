// fabrica-study run: the participant's window (GLFW + Dear ImGui).
#pragma once

#include <filesystem>
#include <string>

namespace fabrica::study {

struct RunOptions {
  std::filesystem::path study;
  std::string participant;
  std::filesystem::path out;
  std::filesystem::path auto_responses;  ///< --auto: answers by trial number
  std::filesystem::path stimuli;         ///< --stimuli: read PNGs instead of drawing
  std::filesystem::path screenshots;     ///< --screenshots: one PNG per kind of screen
  bool resume = false;
  bool quiet = false;
};

/// Runs (or resumes) a participant's session; returns the exit code.
int run_session(const RunOptions& options);

}  // namespace fabrica::study
