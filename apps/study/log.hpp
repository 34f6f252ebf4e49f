// fabrica-study: the response log, a tidy CSV that loses nothing. Each
// answered trial is one row, written with one write() on an O_APPEND file
// and fsync'ed before the next trial is shown; a session killed at any
// moment leaves only complete rows (a torn last line, should one ever be
// left, is cut off when the participant resumes).
#pragma once

#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace fabrica::study {

/// The columns, in order (docs/study.md "The response log").
const std::vector<std::string>& log_columns();

/// The strings joined with `separator` between them.
std::string join(const std::vector<std::string>& parts, const std::string& separator);

/// Quotes a CSV field when it holds a comma, quote or newline.
std::string csv_field(const std::string& s);
/// Splits one CSV line (RFC 4180 quoting, no embedded newlines).
std::vector<std::string> csv_split(const std::string& line);

class ResponseLog {
 public:
  /// Opens `path`. A new log gets the header (fsync'ed, with its folder).
  /// An existing log is an InputError unless `resume`; when resuming, the
  /// answered trials and the last session number are read back.
  ResponseLog(const std::filesystem::path& path, bool resume);
  ~ResponseLog();
  ResponseLog(const ResponseLog&) = delete;
  ResponseLog& operator=(const ResponseLog&) = delete;

  const std::set<int>& answered() const { return answered_; }
  int session() const { return session_; }
  /// Appends one row (values in log_columns() order) and fsyncs.
  void append(const std::vector<std::string>& values);

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  std::set<int> answered_;
  int session_ = 1;
};

}  // namespace fabrica::study
