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

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "fabrica/core/input_file.hpp"
#include "inflate.hpp"
#include "mesh_io_internal.hpp"
#include "vtk_module.hpp"

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
        big_endian_ = attribute(tag, "byte_order").value_or("LittleEndian") == "BigEndian";
      } else if (tag.starts_with("Piece")) {
        for (const char* key : {"NumberOfPoints", "NumberOfVerts", "NumberOfLines",
                                "NumberOfStrips", "NumberOfPolys"})
          if (const auto v = attribute(tag, key)) count(*v, key, 1.0);
        for (std::size_t b = 0; b < kCellBlocks.size(); ++b) {
          const auto v = attribute(tag, "NumberOf" + std::string(kCellBlocks[b]));
          cells_[b] = v ? count(*v, "NumberOf" + std::string(kCellBlocks[b]), 1.0) : 0;
        }
      } else if (const auto b = cell_block(tag); b && !tag.starts_with('/')) {
        block_ = b;
        connectivity_values_.reset();
        offsets_.reset();
      } else if (b) {
        if (block_) check_offsets();  // (an end tag without its start: VTK's parser says so)
        block_.reset();
      } else if (tag.starts_with("Points")) {
        in_points_ = true;
      } else if (tag.starts_with("/Points")) {
        in_points_ = false;
      } else if (tag.starts_with("DataArray")) {
        // Points have 3 components (VTK leaks its arrays when they do not).
        if (in_points_ && attribute(tag, "NumberOfComponents").value_or("1") != "3")
          bad("the points' DataArray must have NumberOfComponents=\"3\"");
        data_array(tag, xml, gt + 1);
        if (block_) cell_array(tag, xml, gt + 1);
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
    return unsigned_value(bytes.data() + index * header_bytes_, header_bytes_);
  }

  /// An unsigned integer of `size` bytes in the file's byte order.
  std::uint64_t unsigned_value(const char* p, std::size_t size) const {
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < size; ++i) {
      const auto byte = static_cast<std::uint64_t>(static_cast<unsigned char>(p[i]));
      v |= byte << (8 * (big_endian_ ? size - 1 - i : i));
    }
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

  // ---- The cell blocks' offsets (decoded here: VTK sizes the connectivity
  // by the last offset, so a huge one made it allocate gigabytes).
  static constexpr std::array<std::string_view, 4> kCellBlocks{"Verts", "Lines", "Strips", "Polys"};

  /// The index in kCellBlocks of a start or end tag of a cell block.
  static std::optional<std::size_t> cell_block(std::string_view tag) {
    if (tag.starts_with('/')) tag.remove_prefix(1);
    const std::string_view element = tag.substr(0, tag.find_first_of(" \t\r\n/"));
    for (std::size_t b = 0; b < kCellBlocks.size(); ++b)
      if (element == kCellBlocks[b]) return b;
    return std::nullopt;
  }

  /// A DataArray of a cell block: the connectivity's number of values, the
  /// first NumberOf<block> offsets.
  void cell_array(std::string_view tag, std::string_view xml, std::size_t content) {
    const auto array_name = attribute(tag, "Name");
    if (array_name != "connectivity" && array_name != "offsets") return;
    const std::string type(attribute(tag, "type").value_or(""));
    const std::size_t size = type_size(type);
    if (size == 0)
      bad("the " + std::string(kCellBlocks[*block_]) + " " + std::string(*array_name) +
          " have type \"" + type.substr(0, 40) + "\" (expected an integer or float type)");
    const auto format = attribute(tag, "format").value_or("ascii");
    std::string_view text;
    bool base64 = true;
    if (format == "binary") {
      const std::size_t end = xml.find('<', content);
      text =
          xml.substr(content, end == std::string_view::npos ? xml.size() - content : end - content);
    } else if (format == "appended") {
      // data_array() checked that the offset is a number inside the data.
      std::uint64_t offset = 0;
      const std::string_view o = attribute(tag, "offset").value_or("0");
      std::from_chars(o.data(), o.data() + o.size(), offset);
      text = appended_.substr(static_cast<std::size_t>(offset));
      base64 = appended_base64_;
    } else {
      const std::size_t end = xml.find('<', content);
      text =
          xml.substr(content, end == std::string_view::npos ? xml.size() - content : end - content);
      if (array_name == "connectivity")
        connectivity_values_ = ascii_count(text);
      else
        offsets_ = ascii_values(text, static_cast<std::size_t>(cells_[*block_]));
      return;
    }
    if (array_name == "connectivity") {
      std::uint64_t total = 0;
      array_bytes(text, base64, 0, total);
      connectivity_values_ = total / size;
      return;
    }
    std::uint64_t total = 0;
    const std::string bytes =
        array_bytes(text, base64, static_cast<std::size_t>(cells_[*block_]) * size, total);
    std::vector<double> values(bytes.size() / size);
    for (std::size_t i = 0; i < values.size(); ++i)
      values[i] = binary_value(bytes.data() + i * size, type);
    offsets_ = std::move(values);
  }

  /// Bytes of one value of a DataArray `type`; 0 for a type that is no number.
  static std::size_t type_size(std::string_view type) {
    if (type == "Int8" || type == "UInt8") return 1;
    if (type == "Int16" || type == "UInt16") return 2;
    if (type == "Int32" || type == "UInt32" || type == "Float32") return 4;
    if (type == "Int64" || type == "UInt64" || type == "Float64") return 8;
    return 0;
  }

  double binary_value(const char* p, std::string_view type) const {
    const std::size_t size = type_size(type);
    const std::uint64_t u = unsigned_value(p, size);
    if (type == "Float32") {
      float f = 0;
      const auto u32 = static_cast<std::uint32_t>(u);
      std::memcpy(&f, &u32, 4);
      return f;
    }
    if (type == "Float64") {
      double d = 0;
      std::memcpy(&d, &u, 8);
      return d;
    }
    if (type.starts_with("UInt")) return static_cast<double>(u);
    const std::uint64_t sign = std::uint64_t{1} << (8 * size - 1);
    if (size < 8 && (u & sign)) return static_cast<double>(u) - 2.0 * static_cast<double>(sign);
    return static_cast<double>(static_cast<std::int64_t>(u));
  }

  /// The number of whitespace-separated values of an ascii DataArray.
  static std::uint64_t ascii_count(std::string_view text) {
    std::uint64_t n = 0;
    bool in_value = false;
    for (const char c : text) {
      const bool space = c == ' ' || c == '\t' || c == '\r' || c == '\n';
      if (!space && !in_value) ++n;
      in_value = !space;
    }
    return n;
  }

  /// Up to `limit` numbers of an ascii DataArray.
  std::vector<double> ascii_values(std::string_view text, std::size_t limit) const {
    std::vector<double> out;
    std::size_t i = 0;
    while (out.size() < limit) {
      i = text.find_first_not_of(" \t\r\n", i);
      if (i == std::string_view::npos) break;
      std::size_t end = text.find_first_of(" \t\r\n", i);
      if (end == std::string_view::npos) end = text.size();
      double v = 0;
      const auto r = std::from_chars(text.data() + i, text.data() + end, v);
      if (r.ec == std::errc::invalid_argument || r.ptr != text.data() + end)
        bad("the " + std::string(kCellBlocks[*block_]) + " cell arrays hold \"" +
            std::string(text.substr(i, std::min<std::size_t>(end - i, 20))) +
            "\", which is not a number");
      out.push_back(v);
      i = end;
    }
    return out;
  }

  /// Decodes base64 `text` from `pos` (whitespace skipped) until `want` more
  /// bytes are out, a padded group ends the stream or the text ends; `pos`
  /// moves past the last group read, whose bytes are all appended (up to 2
  /// more than `want`), so that the next call continues the stream.
  static void base64(std::string_view text, std::size_t& pos, std::size_t want, std::string& out) {
    const std::size_t target = out.size() + want;
    std::uint32_t group = 0;
    int chars = 0, padding = 0;
    while (out.size() < target && pos < text.size()) {
      const char c = text[pos];
      int v = -1;
      if (c >= 'A' && c <= 'Z')
        v = c - 'A';
      else if (c >= 'a' && c <= 'z')
        v = c - 'a' + 26;
      else if (c >= '0' && c <= '9')
        v = c - '0' + 52;
      else if (c == '+')
        v = 62;
      else if (c == '/')
        v = 63;
      else if (c == '=')
        v = 0, ++padding;
      else if (c == ' ' || c == '\t' || c == '\r' || c == '\n') {
        ++pos;
        continue;
      } else {
        break;
      }
      ++pos;
      group = (group << 6) | static_cast<std::uint32_t>(v);
      if (++chars < 4) continue;
      for (int k = 0; k < 3 - std::min(padding, 2); ++k)
        out.push_back(static_cast<char>((group >> (16 - 8 * k)) & 0xFF));
      if (padding > 0) break;
      group = 0;
      chars = 0;
    }
  }

  /// `want` more bytes of an array's stored (encoded or raw) data.
  static void take(std::string_view text, bool is_base64, std::size_t& pos, std::size_t want,
                   std::string& out) {
    if (is_base64) return base64(text, pos, want, out);
    const std::string_view raw = text.substr(std::min(pos, text.size()), want);
    out.append(raw);
    pos += raw.size();
  }

  /// The first `want` bytes of a binary array's values (fewer when it holds
  /// fewer), inflated when the file is compressed; `total` is the number of
  /// value bytes its header declares. Allocates at most `want` bytes plus
  /// the stored bytes read.
  std::string array_bytes(std::string_view text, bool is_base64, std::size_t want,
                          std::uint64_t& total) const {
    std::size_t pos = 0;
    std::string header;
    if (!compressed_) {
      take(text, is_base64, pos, header_bytes_ + want, header);
      total = word(header, 0);
      return header.substr(header_bytes_,
                           static_cast<std::size_t>(std::min<std::uint64_t>(total, want)));
    }
    take(text, is_base64, pos, 3 * header_bytes_, header);
    const std::uint64_t blocks = word(header, 0), block_size = word(header, 1),
                        last_size = word(header, 2);
    // check_header() bounded blocks by the stored bytes.
    take(text, is_base64, pos, static_cast<std::size_t>(blocks) * header_bytes_, header);
    if (blocks > 0) word(header, 3 + static_cast<std::size_t>(blocks) - 1);
    total = blocks == 0 ? 0 : (blocks - 1) * block_size + (last_size ? last_size : block_size);
    std::string out, stored;
    std::size_t used = 0;  // stored bytes of the blocks before this one
    for (std::uint64_t b = 0; b < blocks && out.size() < want; ++b) {
      const std::uint64_t compressed = word(header, 3 + static_cast<std::size_t>(b));
      if (used + compressed > stored.size())
        take(text, is_base64, pos, static_cast<std::size_t>(used + compressed - stored.size()),
             stored);
      if (used + compressed > stored.size())
        bad("a compressed DataArray holds fewer bytes than its header declares");
      const std::uint64_t block = b + 1 == blocks && last_size ? last_size : block_size;
      const std::size_t need =
          static_cast<std::size_t>(std::min<std::uint64_t>(block, want - out.size()));
      out += inflate_zlib_or_gzip(
          std::string_view(stored).substr(used, static_cast<std::size_t>(compressed)), need,
          InflateSize::at_least, [&](const std::string& problem) {
            bad("a compressed DataArray of a cell block: " + problem);
          });
      used += static_cast<std::size_t>(compressed);
    }
    return out;
  }

  static std::string number(double v) {
    char buffer[64];
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::fixed, 0);
    return std::string(buffer, r.ptr);
  }

  /// At the end of a cell block: its offsets must be NumberOf<block>
  /// non-negative, non-decreasing values, the last no more than the
  /// connectivity's number of values.
  void check_offsets() const {
    const std::size_t b = *block_;
    const std::uint64_t n = cells_[b];
    if (n == 0 || !offsets_) return;
    const std::string what = "the " + std::string(kCellBlocks[b]) + " offsets";
    if (offsets_->size() < n)
      bad(what + " hold " + std::to_string(offsets_->size()) + " values but NumberOf" +
          std::string(kCellBlocks[b]) + "=" + std::to_string(n));
    double previous = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double v = (*offsets_)[i];
      if (!(v >= 0)) bad(what + " hold " + number(v) + " at index " + std::to_string(i));
      if (v < previous)
        bad(what + " decrease from " + number(previous) + " to " + number(v) + " at index " +
            std::to_string(i));
      previous = v;
    }
    const std::uint64_t connectivity = connectivity_values_.value_or(0);
    if (previous > static_cast<double>(connectivity))
      bad(what + " end at " + number(previous) + " but the connectivity holds " +
          std::to_string(connectivity) + " values");
  }

  std::string_view data_;
  const std::string& name_;
  std::array<std::uint64_t, 4> cells_{};  ///< NumberOfVerts, ...Lines, ...Strips, ...Polys
  std::optional<std::size_t> block_;      ///< inside this cell block
  std::optional<std::uint64_t> connectivity_values_;
  std::optional<std::vector<double>> offsets_;
  bool big_endian_ = false;
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

void read_vtp_with_vtk(const std::filesystem::path& path, const std::string& name,
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
