// VTK XML PolyData (.vtp) reader through vtkXMLPolyDataReader (legacy .vtk
// files are parsed in mesh_io_vtk_legacy.cpp). Polygons are fan-triangulated and triangle strips
// unrolled here (same rules as the PLY reader), so the file's point order is
// kept. Vertices and lines cells are ignored (noted). VTK's own messages are
// captured by observers and never printed.
#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkExecutive.h>
#include <vtkLogger.h>
#include <vtkNew.h>
#include <vtkOutputWindow.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>

#include <charconv>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "fabrica/core/input_file.hpp"
#include "mesh_io_internal.hpp"

namespace fabrica::io::detail {

namespace {

// VTK reports some problems (pipeline executive, generic warnings) through
// the process-wide output window rather than to observers of the reader.
// We install, once, an output window that stays silent while *this thread*
// is inside one of our reads and behaves exactly like VTK's default window
// otherwise, so other code keeps VTK's usual messages.
thread_local int t_quiet_depth = 0;

class QuietWhileReadingWindow : public vtkOutputWindow {
 public:
  vtkTypeMacro(QuietWhileReadingWindow, vtkOutputWindow) static QuietWhileReadingWindow* New() {
    auto* window = new QuietWhileReadingWindow;
    window->InitializeObjectBase();
    return window;
  }
  void DisplayText(const char* text) override {
    if (t_quiet_depth == 0) vtkOutputWindow::DisplayText(text);
  }
  void DisplayErrorText(const char* text) override {
    if (t_quiet_depth == 0) vtkOutputWindow::DisplayErrorText(text);
  }
  void DisplayWarningText(const char* text) override {
    if (t_quiet_depth == 0) vtkOutputWindow::DisplayWarningText(text);
  }
  void DisplayGenericWarningText(const char* text) override {
    if (t_quiet_depth == 0) vtkOutputWindow::DisplayGenericWarningText(text);
  }
  void DisplayDebugText(const char* text) override {
    if (t_quiet_depth == 0) vtkOutputWindow::DisplayDebugText(text);
  }

 protected:
  QuietWhileReadingWindow() = default;
  ~QuietWhileReadingWindow() override = default;
};

/// Silences VTK's output window on this thread for its lifetime.
class QuietVtk {
 public:
  QuietVtk() {
    static std::once_flag installed;
    std::call_once(installed, [] {
      // Replace only VTK's own default window; a window someone else
      // installed on purpose is left alone.
      vtkOutputWindow* current = vtkOutputWindow::GetInstance();
      if (current && std::string(current->GetClassName()) == "vtkOutputWindow") {
        vtkNew<QuietWhileReadingWindow> window;
        vtkOutputWindow::SetInstance(window);
      }
    });
    ++t_quiet_depth;
    // Some messages (vtkGenericWarningMacro) go straight
    // to vtkLogger's stderr sink: mute it while any of our reads runs.
    const std::lock_guard<std::mutex> lock(logger_mutex());
    if (logger_depth()++ == 0) {
      saved_verbosity() = vtkLogger::GetCurrentVerbosityCutoff();
      vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
    }
  }
  ~QuietVtk() {
    --t_quiet_depth;
    const std::lock_guard<std::mutex> lock(logger_mutex());
    if (--logger_depth() == 0) vtkLogger::SetStderrVerbosity(saved_verbosity());
  }
  QuietVtk(const QuietVtk&) = delete;
  QuietVtk& operator=(const QuietVtk&) = delete;

 private:
  static std::mutex& logger_mutex() {
    static std::mutex mutex;
    return mutex;
  }
  static int& logger_depth() {
    static int depth = 0;
    return depth;
  }
  static vtkLogger::Verbosity& saved_verbosity() {
    static vtkLogger::Verbosity verbosity = vtkLogger::VERBOSITY_INFO;
    return verbosity;
  }
};

/// Collects VTK error and warning events of the objects it observes.
class VtkMessages {
 public:
  VtkMessages() {
    command_->SetClientData(this);
    command_->SetCallback(&VtkMessages::on_event);
  }
  vtkCommand* command() { return command_; }
  void observe(vtkObject* object) {
    object->AddObserver(vtkCommand::ErrorEvent, command_);
    object->AddObserver(vtkCommand::WarningEvent, command_);
  }
  bool has_errors() const { return !errors_.empty(); }
  /// The first error, trimmed to one line without VTK's class/address prefix.
  std::string first_error() const {
    if (errors_.empty()) return {};
    std::string m = errors_.front();
    if (const auto colon = m.find("): "); colon != std::string::npos) m = m.substr(colon + 3);
    for (char& ch : m)
      if (ch == '\n' || ch == '\r') ch = ' ';
    while (!m.empty() && m.back() == ' ') m.pop_back();
    if (m.size() > 200) m = m.substr(0, 200) + "...";
    return m;
  }

 private:
  static void on_event(vtkObject*, unsigned long event, void* client, void* call) {
    auto* self = static_cast<VtkMessages*>(client);
    const char* text = static_cast<const char*>(call);
    if (event == vtkCommand::ErrorEvent) self->errors_.emplace_back(text ? text : "unknown error");
  }
  vtkNew<vtkCallbackCommand> command_;
  std::vector<std::string> errors_;
};

void convert(vtkPolyData* poly, const std::string& name, const ReadOptions& options,
             LoadedMesh& out) {
  TriangleMesh& mesh = out.mesh;
  MeshFileInfo& info = out.info;
  vtkPoints* points = poly->GetPoints();
  const vtkIdType np = points ? points->GetNumberOfPoints() : 0;
  if (np > std::numeric_limits<std::int32_t>::max()) fail(name, "too many points");
  mesh.positions.resize(static_cast<std::size_t>(np));
  for (vtkIdType i = 0; i < np; ++i)
    points->GetPoint(i, mesh.positions[static_cast<std::size_t>(i)].data());
  info.file_vertices = mesh.positions.size();

  auto check = [&](vtkIdType id, const char* what) {
    if (id < 0 || id >= np)
      fail(name, std::string(what) + " refers to point " + std::to_string(id) +
                     ", but the file has " + std::to_string(np) + " points");
    return static_cast<std::int32_t>(id);
  };
  std::vector<std::int32_t> polygon;
  vtkIdType n = 0;
  const vtkIdType* ids = nullptr;
  if (vtkCellArray* polys = poly->GetPolys()) {
    for (polys->InitTraversal(); polys->GetNextCell(n, ids);) {
      polygon.clear();
      for (vtkIdType k = 0; k < n; ++k) polygon.push_back(check(ids[k], "a polygon"));
      ++info.file_polygons;
      if (n < 3) fail(name, "a polygon has " + std::to_string(n) + " points (needs 3)");
      add_polygon(polygon.data(), polygon.size(), mesh, info);
    }
  }
  std::size_t degenerate = 0;
  if (vtkCellArray* strips = poly->GetStrips()) {
    for (strips->InitTraversal(); strips->GetNextCell(n, ids);) {
      for (vtkIdType k = 2; k < n; ++k) {
        const std::int32_t a = check(ids[k - 2], "a triangle strip");
        const std::int32_t b = check(ids[k - 1], "a triangle strip");
        const std::int32_t c = check(ids[k], "a triangle strip");
        ++info.file_polygons;
        if (a == b || b == c || a == c)
          ++degenerate;
        else if (k % 2 == 0)
          mesh.faces.push_back({a, b, c});
        else
          mesh.faces.push_back({a, c, b});
      }
    }
  }
  if (degenerate > 0)
    info.notes.push_back("skipped " + std::to_string(degenerate) +
                         " degenerate triangle-strip triangles (repeated vertex)");
  const vtkIdType others = (poly->GetVerts() ? poly->GetVerts()->GetNumberOfCells() : 0) +
                           (poly->GetLines() ? poly->GetLines()->GetNumberOfCells() : 0);
  if (others > 0)
    info.notes.push_back("ignored " + std::to_string(others) + " vertex and line cells");

  if (options.keep_file_normals) {
    vtkDataArray* normals = poly->GetPointData() ? poly->GetPointData()->GetNormals() : nullptr;
    if (normals && normals->GetNumberOfTuples() == np && normals->GetNumberOfComponents() == 3) {
      info.file_normals.resize(static_cast<std::size_t>(np));
      for (vtkIdType i = 0; i < np; ++i)
        normals->GetTuple(i, info.file_normals[static_cast<std::size_t>(i)].data());
    }
  }
}

// ---- Checks of the XML's declarations before VTK reads the file. VTK trusts
// the counts (a negative NumberOfPoints crashes its base64 reader, a huge
// NumberOfComponents makes it loop for minutes, huge counts make it allocate
// gigabytes), so every count and every data-array header must fit the bytes
// the file holds. zlib inflates at most ~1032:1, so no array can hold more
// than kInflateBound bytes per stored byte.
constexpr double kInflateBound = 1100.0;

/// name="value" pairs of one XML start tag (`tag` without '<' and '>').
std::vector<std::pair<std::string_view, std::string_view>> attributes(std::string_view tag) {
  std::vector<std::pair<std::string_view, std::string_view>> out;
  std::size_t i = 0;
  while (i < tag.size()) {
    const std::size_t eq = tag.find('=', i);
    if (eq == std::string_view::npos) break;
    std::size_t b = eq;
    while (b > i &&
           (tag[b - 1] == ' ' || tag[b - 1] == '\t' || tag[b - 1] == '\n' || tag[b - 1] == '\r'))
      --b;
    std::size_t a = b;
    while (a > i && tag[a - 1] != ' ' && tag[a - 1] != '\t' && tag[a - 1] != '\n' &&
           tag[a - 1] != '\r')
      --a;
    std::size_t q = eq + 1;
    while (q < tag.size() && tag[q] != '"' && tag[q] != '\'') ++q;
    if (q >= tag.size()) break;
    const std::size_t close = tag.find(tag[q], q + 1);
    if (close == std::string_view::npos) break;
    out.emplace_back(tag.substr(a, b - a), tag.substr(q + 1, close - q - 1));
    i = close + 1;
  }
  return out;
}

std::optional<std::string_view> attribute(std::string_view tag, std::string_view key) {
  for (const auto& [k, v] : attributes(tag))
    if (k == key) return v;
  return std::nullopt;
}

class VtpChecker {
 public:
  VtpChecker(std::string_view data, const std::string& name) : data_(data), name_(name) {}

  void run() {
    const std::size_t appended_tag = data_.find("<AppendedData");
    const std::string_view xml = data_.substr(0, appended_tag);
    if (appended_tag != std::string_view::npos) {
      const std::size_t gt = data_.find('>', appended_tag);
      if (gt == std::string_view::npos) bad("the AppendedData element is not closed");
      const std::string_view tag = data_.substr(appended_tag, gt - appended_tag);
      appended_base64_ = attribute(tag, "encoding").value_or("raw") == "base64";
      const std::size_t underscore = data_.find('_', gt);
      if (underscore == std::string_view::npos) bad("the AppendedData element has no '_' marker");
      appended_ = data_.substr(underscore + 1);
    }
    for (std::size_t pos = xml.find('<'); pos != std::string_view::npos;
         pos = xml.find('<', pos + 1)) {
      const std::size_t gt = xml.find('>', pos);
      if (gt == std::string_view::npos) break;
      const std::string_view tag = xml.substr(pos + 1, gt - pos - 1);
      if (tag.starts_with("VTKFile")) {
        const auto header = attribute(tag, "header_type").value_or("UInt32");
        if (header != "UInt32" && header != "UInt64")
          bad("header_type \"" + std::string(header) + "\" (expected UInt32 or UInt64)");
        header_bytes_ = header == "UInt64" ? 8 : 4;
        compressed_ = attribute(tag, "compressor").has_value();
      } else if (tag.starts_with("Piece")) {
        for (const char* key : {"NumberOfPoints", "NumberOfVerts", "NumberOfLines",
                                "NumberOfStrips", "NumberOfPolys"})
          if (const auto v = attribute(tag, key)) count(*v, key, 1.0);
      } else if (tag.starts_with("Points")) {
        in_points_ = true;
      } else if (tag.starts_with("/Points")) {
        in_points_ = false;
      } else if (tag.starts_with("DataArray")) {
        // Points have 3 components (VTK leaks its arrays when they do not).
        if (in_points_ && attribute(tag, "NumberOfComponents").value_or("1") != "3")
          bad("the points' DataArray must have NumberOfComponents=\"3\"");
        data_array(tag, xml, gt + 1);
      }
    }
  }

 private:
  [[noreturn]] void bad(const std::string& problem) const {
    fail(name_, "malformed VTK XML PolyData: " + problem);
  }

  /// A declared count: a non-negative integer the file's size can back.
  std::uint64_t count(std::string_view text, const std::string& key, double bytes_per_item) const {
    std::uint64_t v = 0;
    const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
    if (r.ec != std::errc() || r.ptr != text.data() + text.size())
      bad(key + "=\"" + std::string(text.substr(0, 40)) + "\" is not a non-negative integer");
    if (bytes_per_item > 0.0 && (static_cast<double>(v) * bytes_per_item >
                                     kInflateBound * static_cast<double>(data_.size()) + 4096.0 ||
                                 v > static_cast<std::uint64_t>(kMaxMeshElements)))
      bad(key + "=" + std::to_string(v) + " is more than a file of " +
          std::to_string(data_.size()) + " bytes can hold");
    return v;
  }

  void data_array(std::string_view tag, std::string_view xml, std::size_t content) {
    std::uint64_t components = 1;
    if (const auto v = attribute(tag, "NumberOfComponents")) {
      components = count(*v, "NumberOfComponents", 1.0);
      if (components < 1 || components > 1024)
        bad("NumberOfComponents=" + std::to_string(components) + " (expected 1 to 1024)");
    }
    if (const auto v = attribute(tag, "NumberOfTuples"))
      count(*v, "NumberOfTuples", static_cast<double>(components));
    const auto format = attribute(tag, "format").value_or("ascii");
    if (format == "binary") {
      const std::size_t end = xml.find('<', content);
      check_header(
          decode_base64_prefix(xml.substr(
              content, end == std::string_view::npos ? xml.size() - content : end - content)),
          end == std::string_view::npos ? 0 : (end - content) * 3 / 4);
    } else if (format == "appended") {
      const auto offset_text = attribute(tag, "offset");
      if (!offset_text) bad("an appended DataArray has no offset");
      const std::uint64_t offset = count(*offset_text, "offset", 0.0);
      if (offset >= appended_.size())
        bad("a DataArray's offset " + std::to_string(offset) +
            " is past the end of the appended data");
      const std::string_view rest = appended_.substr(offset);
      if (appended_base64_)
        check_header(decode_base64_prefix(rest), rest.size() * 3 / 4);
      else
        check_header(std::string(rest.substr(0, 64)), rest.size());
    }
  }

  /// The first bytes (at most 48) of base64 text, whitespace skipped.
  static std::string decode_base64_prefix(std::string_view text) {
    auto value = [](char c) -> int {
      if (c >= 'A' && c <= 'Z') return c - 'A';
      if (c >= 'a' && c <= 'z') return c - 'a' + 26;
      if (c >= '0' && c <= '9') return c - '0' + 52;
      if (c == '+') return 62;
      if (c == '/') return 63;
      return -1;
    };
    std::string out;
    std::uint32_t bits = 0;
    int have = 0;
    for (char c : text) {
      const int v = value(c);
      if (v < 0) continue;
      bits = (bits << 6) | static_cast<std::uint32_t>(v);
      have += 6;
      if (have >= 8) {
        have -= 8;
        out.push_back(static_cast<char>((bits >> have) & 0xFF));
        if (out.size() >= 48) break;
      }
    }
    return out;
  }

  std::uint64_t word(const std::string& bytes, std::size_t index) const {
    if ((index + 1) * header_bytes_ > bytes.size())
      bad("a binary DataArray is shorter than its header");
    std::uint64_t v = 0;
    std::memcpy(&v, bytes.data() + index * header_bytes_, header_bytes_);  // little endian
    return v;
  }

  /// The header of a binary array: its byte count (or block counts when
  /// compressed) must fit the `stored` bytes behind it.
  void check_header(const std::string& header, std::size_t stored) const {
    const double limit = kInflateBound * static_cast<double>(stored) + 4096.0;
    if (!compressed_) {
      const std::uint64_t bytes = word(header, 0);
      if (static_cast<double>(bytes) > static_cast<double>(stored))
        bad("a binary DataArray declares " + std::to_string(bytes) + " bytes but holds " +
            std::to_string(stored));
      return;
    }
    const std::uint64_t blocks = word(header, 0), block_size = word(header, 1);
    if (static_cast<double>(blocks) * static_cast<double>(header_bytes_) >
            static_cast<double>(stored) ||
        static_cast<double>(blocks) * static_cast<double>(block_size) > limit)
      bad("a compressed DataArray declares " + std::to_string(blocks) + " blocks of " +
          std::to_string(block_size) + " bytes, more than its " + std::to_string(stored) +
          " stored bytes can hold");
  }

  std::string_view data_;
  const std::string& name_;
  std::string_view appended_;
  bool appended_base64_ = false;
  bool compressed_ = false;
  bool in_points_ = false;
  std::size_t header_bytes_ = 4;
};

}  // namespace

void check_vtp_declarations(std::string_view data, const std::string& name) {
  VtpChecker(data, name).run();
}

void read_vtp(const std::filesystem::path& path, const std::string& name,
              const ReadOptions& options, LoadedMesh& out) {
  check_vtp_declarations(read_input_file(path, name), name);
  MeshFileInfo& info = out.info;
  info.format = "vtp";
  const QuietVtk quiet;
  VtkMessages messages;
  vtkNew<vtkXMLPolyDataReader> reader;
  messages.observe(reader);
  messages.observe(reader->GetExecutive());
  reader->SetReaderErrorObserver(messages.command());
  reader->SetParserErrorObserver(messages.command());
  if (!reader->CanReadFile(path.c_str())) fail(name, "not a VTK XML PolyData (.vtp) file");
  reader->SetFileName(path.c_str());
  reader->Update();
  if (messages.has_errors() || reader->GetErrorCode() != 0)
    fail(name, "cannot read VTK XML PolyData: " +
                   (messages.has_errors() ? messages.first_error() : std::string("read error")));
  vtkPolyData* poly = reader->GetOutput();
  if (!poly) fail(name, "VTK reader returned no data");
  info.binary = true;  // appended/binary or ascii data arrays; VTK does not say
  convert(poly, name, options, out);
}

}  // namespace fabrica::io::detail
