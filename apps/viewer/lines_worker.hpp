// LinesWorker: recomputes the feature lines of the current view on a worker
// thread. The main thread posts a job (a camera, a version number and the
// visible structures with their styles) every time the view or a line
// setting changes; the worker always takes the newest job (older ones are
// dropped) and publishes the lines with the version they belong to, so the
// frame loop can bound how old the lines it draws are (Viewer waits for
// version >= current - 1: never more than one frame old).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/surface.hpp"
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/render/render_mesh.hpp"
#include "fabrica/render/scene.hpp"

namespace fabrica::viewer {

/// A structure's geometry as the worker needs it. The drawer (with the
/// view-independent precomputation, built once per mesh by the loader, or
/// by the worker when it first needs it where the loader left it null) is
/// used by the worker thread only.
struct LineSource {
  std::shared_ptr<const Surface> surface;
  std::unique_ptr<LineDrawer> drawer;
  /// A moving level's mesh as clustered: prepared (repaired, topology) into
  /// `surface` by the worker the first time it draws the level's lines
  /// (only with coarse lines while moving), where `surface` is null.
  std::shared_ptr<const TriangleMesh> unprepared;
};

/// A coarse copy of a mesh with its own line precomputation: while the
/// camera moves, an opaque structure is drawn from it (and its lines
/// extracted from it with Viewer::coarse_lines_while_moving; docs/algorithms.md §16).
struct MovingLevel {
  std::shared_ptr<const render::RenderMesh> mesh;
  std::shared_ptr<LineSource> lines;
};

struct LinesJob {
  std::uint64_t version = 0;
  Camera camera;
  struct Item {
    int id = 0;
    std::shared_ptr<LineSource> source;
    /// When set, the lines come from this coarse copy of the surface
    /// instead of `source`; hatching always uses `source`.
    std::shared_ptr<LineSource> lod;
    /// When set, the structure is drawn with this coarse mesh (the level of
    /// detail of a moving camera; `lod`'s mesh when that is set).
    std::shared_ptr<const render::RenderMesh> lod_mesh;
    render::StructureStyle style;
    LineOptions thresholds;
    bool hatching = false;
    double hatching_width = 1.0;
    /// ApparentOptions::min_ndotv of its lines (moving_apparent_min_ndotv).
    std::optional<double> apparent_min_ndotv;
  };
  std::vector<Item> items;
  /// While the camera moves: the lines' near-collinear vertices merged in
  /// this job's picture (merge_collinear) within `merge_px` pixels and
  /// `merge_strength` of strength; 0 = the lines as extracted.
  double merge_px = 0.0;
  double merge_strength = 0.0;
};

struct LinesResult {
  std::uint64_t version = 0;
  Camera camera;
  std::map<int, LineSet> lines;                   ///< by structure id
  std::map<int, render::PolylineLayer> hatching;  ///< by structure id, where asked for
  /// By structure id, the mesh to draw where the lines come from a level of
  /// detail (Item::lod_mesh); the others are drawn from their full mesh.
  std::map<int, std::shared_ptr<const render::RenderMesh>> lod;
  std::size_t merged = 0;  ///< vertices removed by merge_collinear (LinesJob::merge_px)
  double ms = 0.0;         ///< wall time of the extraction
  std::string error;       ///< empty unless a structure's lines failed
};

class LinesWorker {
 public:
  LinesWorker();
  ~LinesWorker();
  LinesWorker(const LinesWorker&) = delete;
  LinesWorker& operator=(const LinesWorker&) = delete;

  /// Replaces any job not yet started.
  void post(LinesJob job);
  /// The newest finished result (null before the first).
  std::shared_ptr<const LinesResult> latest() const;
  /// Blocks until a result with version >= `version` is published.
  std::shared_ptr<const LinesResult> wait_for(std::uint64_t version);
  /// True while a job is queued or running.
  bool busy() const;

 private:
  void run();

  mutable std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::unique_ptr<LinesJob> pending_;
  std::shared_ptr<const LinesResult> latest_;
  bool running_ = false, stop_ = false;
  std::thread thread_;
};

}  // namespace fabrica::viewer
