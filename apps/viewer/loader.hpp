// Loader: opens files on a worker thread (meshes, label volumes, scene
// JSON), builds each structure's Surface, render mesh and line
// precomputation there, and reports progress; the window keeps drawing and
// the user may cancel. Finished structures and errors are collected by the
// frame loop (Viewer::adopt_loaded).
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "fabrica/render/render_mesh.hpp"
#include "fabrica/render/scene.hpp"
#include "lines_worker.hpp"

namespace fabrica::viewer {

struct LoadedStructure {
  std::string name;
  std::filesystem::path mesh_file;  ///< the mesh file; empty for a label of a volume
  std::optional<Space> space;
  render::Role role = render::Role::context;
  render::StructureStyle style;
  bool role_from_file = false;  ///< role and style given by a scene file
  std::shared_ptr<const Surface> surface;
  std::shared_ptr<const render::RenderMesh> mesh;
  std::shared_ptr<LineSource> lines;
  /// Level of detail for drawing the structure ghosted while the camera
  /// moves (null when the mesh is small enough): a coarse copy of the mesh
  /// (render::cluster_simplify) with its own line source.
  std::shared_ptr<const render::RenderMesh> mesh_lod;
  std::shared_ptr<LineSource> lines_lod;
  /// Coarser copies for drawing the structure opaque while the camera
  /// moves, each about 1 / kMovingLevelFactor of the faces of the one
  /// before, finest first (empty for small meshes); see moving_level.
  std::vector<MovingLevel> moving_levels;
};

/// Coarse levels stop at this many faces (moving_levels).
constexpr std::size_t kMovingLevelMinFaces = 8000;
/// Each level has about 1 / kMovingLevelFactor of the faces of the one
/// before (its edges about sqrt(2) times as long): the level a moving camera
/// picks has edges of kMovingEdgePx / sqrt(2) to kMovingEdgePx pixels.
constexpr std::size_t kMovingLevelFactor = 2;

/// A mesh made ready for lines as a loaded one is (io::prepare_for_lines:
/// repair and topology), as a Surface (not yet precomputed).
std::shared_ptr<Surface> prepared_surface(TriangleMesh mesh);

/// Faces of a ghosted structure's level of detail; meshes of more than
/// kLodMinFaces faces (one and a half times as many) get one.
constexpr std::size_t kLodFaces = 12000;
constexpr std::size_t kLodMinFaces = kLodFaces + kLodFaces / 2;

/// Everything one `open` produced.
struct LoadedFile {
  std::filesystem::path path;
  std::vector<LoadedStructure> structures;
  std::optional<render::SceneSpec> scene;  ///< for a scene JSON (camera, view, background)
  std::string error;                       ///< one-line message when the file failed
};

/// Volume files by name (.nii, .nii.gz, .nrrd, .nhdr, .seg.nrrd, .mha, .mhd).
bool is_volume_file(const std::filesystem::path& path);
/// The file name without any extension: "veins.stl" -> "veins", "seg.nii.gz" -> "seg".
std::string structure_name_from_file(const std::filesystem::path& path);
/// A distinct colour for the i-th label without a colour in its file.
render::Color distinct_color(std::size_t i);

class Loader {
 public:
  Loader();
  ~Loader();
  Loader(const Loader&) = delete;
  Loader& operator=(const Loader&) = delete;

  void open(const std::filesystem::path& path);
  /// Finished files since the last call, in order.
  std::vector<LoadedFile> take_finished();
  bool busy() const;
  /// Progress of the file being read: its name and a fraction in [0, 1].
  std::pair<std::string, double> progress() const;
  /// Stops the file being read (its structures are dropped) and the queue.
  void cancel();

 private:
  void run();
  LoadedFile load(const std::filesystem::path& path);
  LoadedStructure build(TriangleMesh mesh, const std::string& name);
  std::shared_ptr<LineSource> line_source(TriangleMesh mesh);
  void set_progress(double fraction);
  bool cancelled() const { return cancel_.load(); }

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::filesystem::path> queue_;
  std::vector<LoadedFile> finished_;
  std::string current_;
  double fraction_ = 0.0;
  bool running_ = false, stop_ = false;
  std::atomic<bool> cancel_{false};
  std::thread thread_;
};

}  // namespace fabrica::viewer
