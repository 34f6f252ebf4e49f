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

#include <limits>
#include <mutex>
#include <string>
#include <vector>

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

}  // namespace

void read_vtp(const std::filesystem::path& path, const std::string& name,
              const ReadOptions& options, LoadedMesh& out) {
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
