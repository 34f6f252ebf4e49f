#include "log.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include "fabrica/core/error.hpp"

namespace fabrica::study {

const std::vector<std::string>& log_columns() {
  static const std::vector<std::string> columns = {
      "participant", "session",    "trial",      "block",      "task",     "practice",
      "attention",   "model",      "view",       "technique",  "stimulus", "technique_a",
      "technique_b", "stimulus_a", "stimulus_b", "techniques", "stimuli",  "pixel_x",
      "pixel_y",     "true_nx",    "true_ny",    "true_nz",    "question", "expected",
      "response",    "normal_x",   "normal_y",   "normal_z",   "choice",   "chosen_technique",
      "rating",      "order",      "rt_ms",      "wall_time"};
  return columns;
}

std::string join(const std::vector<std::string>& parts, const std::string& separator) {
  std::string out;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    if (i) out += separator;
    out += parts[i];
  }
  return out;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += (c == '\n' || c == '\r') ? ' ' : c;
  }
  return out + "\"";
}

std::vector<std::string> csv_split(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        out.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        out.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

namespace {

void write_all(int fd, const std::string& text, const std::filesystem::path& path) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      throw OutputError(path.string() + ": cannot append the response: " + std::strerror(errno) +
                        " (disk full?)");
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0)
    throw OutputError(path.string() + ": fsync failed: " + std::strerror(errno));
}

void fsync_folder(const std::filesystem::path& folder) {
  const int d = ::open(folder.empty() ? "." : folder.c_str(), O_RDONLY | O_DIRECTORY);
  if (d >= 0) {
    ::fsync(d);
    ::close(d);
  }
}

}  // namespace

ResponseLog::ResponseLog(const std::filesystem::path& path, bool resume) : path_(path) {
  const bool exists = std::filesystem::exists(path);
  if (exists && !resume)
    throw InputError(path.string() +
                     ": this participant already has a response log; it is never overwritten. "
                     "Continue the session with --resume, or use another --participant");
  if (exists) {
    // Read back complete rows; cut a torn last line (no newline) off.
    std::ifstream in(path, std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t complete = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
    if (complete < text.size()) std::filesystem::resize_file(path, complete);
    text.resize(complete);
    std::size_t pos = text.find('\n');
    if (pos == std::string::npos || csv_split(text.substr(0, pos)) != log_columns())
      throw InputError(path.string() + ": not a fabrica-study response log (header differs)");
    int max_session = 0;
    for (std::size_t start = pos + 1; start < text.size();) {
      const std::size_t end = text.find('\n', start);
      const auto f = csv_split(text.substr(start, end - start));
      start = end + 1;
      if (f.size() != log_columns().size())
        throw InputError(path.string() + ": a row has " + std::to_string(f.size()) +
                         " fields, expected " + std::to_string(log_columns().size()));
      max_session = std::max(max_session, std::stoi(f[1]));
      answered_.insert(std::stoi(f[2]));
    }
    session_ = max_session + 1;
  }
  fd_ = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw OutputError(path.string() + ": cannot open the response log: " + std::strerror(errno));
  if (!exists) {
    write_all(fd_, join(log_columns(), ",") + "\n", path_);
    fsync_folder(path.parent_path());
  }
}

ResponseLog::~ResponseLog() {
  if (fd_ >= 0) ::close(fd_);
}

void ResponseLog::append(const std::vector<std::string>& values) {
  if (values.size() != log_columns().size())
    throw Error(ErrorKind::internal, "response row has the wrong number of fields");
  std::vector<std::string> fields;
  for (const auto& v : values) fields.push_back(csv_field(v));
  write_all(fd_, join(fields, ",") + "\n", path_);  // one write, then fsync
  answered_.insert(std::stoi(values[2]));
}

}  // namespace fabrica::study
