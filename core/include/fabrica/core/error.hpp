// Typed errors. Algorithms and readers throw these; the command line turns
// them into one-line messages and documented exit codes (docs/cli.md).
#pragma once

#include <stdexcept>
#include <string>

namespace fabrica {

/// What kind of failure; each maps to one exit code of the command line.
enum class ErrorKind {
  internal = 1,      ///< a bug: should never happen
  input = 2,         ///< bad input file or argument: unreadable, malformed, empty, NaN
  output = 3,        ///< an output could not be written
  unavailable = 4,   ///< a needed facility (GL backend, display) is missing
};

class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const { return kind_; }
  int exit_code() const { return static_cast<int>(kind_); }

 private:
  ErrorKind kind_;
};

/// Bad input: the message names the file (or argument) and what is wrong.
class InputError : public Error {
 public:
  explicit InputError(const std::string& message) : Error(ErrorKind::input, message) {}
};

/// An output could not be written (directory missing, disk full, ...).
class OutputError : public Error {
 public:
  explicit OutputError(const std::string& message) : Error(ErrorKind::output, message) {}
};

}  // namespace fabrica
