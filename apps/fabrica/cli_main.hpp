// The end of every fabrica program's main (fabrica, fabrica-study): parse the
// command line, run the chosen action, and map what goes wrong to the exit
// codes of docs/cli.md with one line on stderr prefixed by the program's name:
// 2 for a malformed command line or bad input, the error's own code for a
// fabrica::Error, 1 for an internal error or out of memory.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <functional>
#include <new>
#include <string>

#include "fabrica/core/error.hpp"

namespace fabrica::cli {

/// `hint` (may be empty) gives a better line than the parser's for a parse
/// error, e.g. a "did you mean"; "" keeps the parser's message.
inline int parse_and_run(CLI::App& app, int argc, char** argv, const std::string& program,
                         const std::function<int()>& run,
                         const std::function<std::string()>& hint = {}) {
  if (argc < 2) {  // no command: the usage, on stderr, as a bad-arguments error
    std::fputs(app.help().c_str(), stderr);
    return 2;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    const std::string better = hint ? hint() : std::string();
    std::fprintf(stderr, "%s: %s (see %s --help)\n", program.c_str(),
                 better.empty() ? e.what() : better.c_str(), program.c_str());
    return 2;
  }
  try {
    return run();
  } catch (const Error& e) {
    std::fprintf(stderr, "%s: %s\n", program.c_str(), e.what());
    return e.exit_code();
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%s: out of memory\n", program.c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: internal error: %s\n", program.c_str(), e.what());
    return 1;
  }
}

}  // namespace fabrica::cli
