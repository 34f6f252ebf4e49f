#include "lines_worker.hpp"

#include <chrono>

#include "fabrica/core/error.hpp"
#include "loader.hpp"
#include "structure_lines.hpp"

namespace fabrica::viewer {

LinesWorker::LinesWorker() : thread_([this] { run(); }) {}

LinesWorker::~LinesWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void LinesWorker::post(LinesJob job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pending_ = std::make_unique<LinesJob>(std::move(job));
  }
  wake_.notify_all();
}

std::shared_ptr<const LinesResult> LinesWorker::latest() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

std::shared_ptr<const LinesResult> LinesWorker::wait_for(std::uint64_t version) {
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [&] { return latest_ && latest_->version >= version; });
  return latest_;
}

bool LinesWorker::busy() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return running_ || pending_ != nullptr;
}

void LinesWorker::run() {
  for (;;) {
    std::unique_ptr<LinesJob> job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || pending_ != nullptr; });
      if (stop_) return;
      job = std::move(pending_);
      running_ = true;
    }
    auto result = std::make_shared<LinesResult>();
    result->version = job->version;
    result->camera = job->camera;
    const auto t0 = std::chrono::steady_clock::now();
    for (auto& item : job->items) {
      try {
        LineSource& source = item.lod ? *item.lod : *item.source;
        if (!source.drawer) {  // a moving level's, the first time
          if (!source.surface) source.surface = prepared_surface(*source.unprepared);
          source.surface->precompute();
          source.drawer = std::make_unique<LineDrawer>(*source.surface);
        }
        if (item.lod_mesh) result->lod[item.id] = item.lod_mesh;
        LineSet& lines = result->lines[item.id] = structure_lines(
            *source.drawer, item.style, item.thresholds, job->camera, item.apparent_min_ndotv);
        if (job->merge_px > 0.0)
          result->merged += merge_collinear(lines, job->camera, job->merge_px, job->merge_strength);
        if (item.hatching)
          result->hatching[item.id] =
              structure_hatching(*item.source->surface, job->camera, item.hatching_width);
      } catch (const std::exception& e) {
        result->error = e.what();
      }
    }
    result->ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      latest_ = std::move(result);
      running_ = false;
    }
    done_.notify_all();
  }
}

}  // namespace fabrica::viewer
