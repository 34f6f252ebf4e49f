// Script mode: one command a line (docs/viewer.md), '#' starts a comment.
// A bad command or argument stops the script with exit 2 naming the line; a
// file that cannot be opened is reported (panel and stderr) and the script
// goes on, as it would in an interactive session.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "viewer.hpp"

namespace fabrica::viewer {

/// The words of a script line: whitespace separated, "double quotes" group
/// words with spaces; throws InputError for an unclosed quote.
std::vector<std::string> split_script_line(const std::string& line);

/// Runs `path` line by line against `viewer`. Returns the exit code (0 after
/// `quit` or the end of the script); a failing command throws Error with
/// "SCRIPT:LINE: " before its message.
int run_script(Viewer& viewer, const std::filesystem::path& path);

}  // namespace fabrica::viewer
