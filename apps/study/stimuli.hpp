// fabrica-study: stimuli, drawn by the `fabrica` program of this build
// (the same engine as `fabrica render` / `lines` / `hatch`) and cached by
// stimulus id, or read from a folder of PNGs named STIMULUS_ID.png.
#pragma once

#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "study.hpp"

namespace fabrica::study {

/// Every stimulus id the study can show (technique x model x view).
std::set<std::string> all_stimuli(const Study& study);

/// The `fabrica` argument list that draws a stimulus into `png` (for the
/// lines command, into an SVG beside it, rasterised by rsvg-convert).
std::vector<std::string> stimulus_command(const Technique& t, const Model& m,
                                          const std::filesystem::path& camera,
                                          const std::filesystem::path& output);

/// Makes sure every stimulus in `ids` is a PNG in `out_dir`/stimuli (drawn
/// when missing or when its recorded command changed; cameras written to
/// `out_dir`/cameras). Returns id -> PNG path. With `from_dir` non-empty no
/// drawing happens: every PNG must be in `from_dir` or its stimuli/
/// subfolder (InputError naming the first missing one), at the study's size.
std::map<std::string, std::filesystem::path> prepare_stimuli(const Study& study,
                                                             const std::set<std::string>& ids,
                                                             const std::filesystem::path& out_dir,
                                                             const std::filesystem::path& from_dir,
                                                             bool quiet);

/// Runs a program (argv[0] looked up in PATH when it has no slash) and
/// waits; throws Error naming it when it cannot start or exits non-zero.
void run_program(const std::vector<std::string>& argv, const std::string& what);

/// The `fabrica` program: $FABRICA_BIN, else the one built with this
/// program, else `fabrica` beside this executable, else from PATH.
std::string fabrica_program();

}  // namespace fabrica::study
