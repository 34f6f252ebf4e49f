// Option parsing shared by the drawing commands (lines, render, hatch), so
// every command accepts the same spellings and reports the same errors.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/lines/line_set.hpp"

namespace CLI {
class App;
}

namespace fabrica::cli {

/// ASCII lower case (option values are case-insensitive).
std::string lower(std::string s);

/// "WIDTHxHEIGHT" in pixels, each between 1 and max_pixels; throws
/// InputError naming `option` otherwise.
std::pair<int, int> parse_size(const std::string& text, int max_pixels = 16384,
                               const std::string& option = "--size");

/// "lps" or "ras" (any case) for --space; throws InputError otherwise.
Space parse_space(const std::string& text, const std::string& option = "--space");

/// A comma-separated list of line family names (docs/lines/), or a keyword:
/// "default" (= default_set), "reference"/"rtsc" (the families of the rtsc
/// reference files), "all", and "none" when allow_none. Duplicates are
/// dropped, order is kept. Throws InputError naming `option` for an unknown
/// name, or for an empty list unless allow_none.
std::vector<LineFamily> parse_family_list(const std::string& text, const std::string& option,
                                          const std::vector<LineFamily>& default_set,
                                          bool allow_none);

/// An anatomical view name (any case) for --view; throws InputError naming
/// `option`, the known views and the closest one ("did you mean").
AnatomicalView parse_view(const std::string& text, const std::string& option = "--view");

/// One line on stderr when a mesh (read with `source`) had no coordinate-space tag and LPS was
/// assumed (the anatomical views depend on it): "fabrica COMMAND: warning:
/// PATH has no space tag: assumed LPS ...". Nothing when quiet.
void warn_if_space_assumed(SpaceSource source, const std::string& path, const std::string& command,
                           bool quiet = false);

/// After a command-line parse error: "did you mean" for an unknown command
/// (argv[1]) or the first unknown --option of the chosen command, e.g.
/// "unknown option '--veiw' (did you mean '--view'?)"; "" when nothing is close.
std::string parse_error_hint(CLI::App& app, int argc, char** argv);

}  // namespace fabrica::cli
