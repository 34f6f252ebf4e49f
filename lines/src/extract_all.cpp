#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <optional>

#include "fabrica/core/error.hpp"
#include "fabrica/lines/extract.hpp"
#include "parallel.hpp"
#include "view_fields_light.hpp"
#include "zero_crossing_internal.hpp"

namespace fabrica {

std::vector<LineFamily> reference_families() {
  return {LineFamily::contour, LineFamily::suggestive, LineFamily::apparent, LineFamily::ridge,
          LineFamily::valley};
}

std::vector<LineFamily> all_families() {
  std::vector<LineFamily> out;
  for (int i = 0; i < kLineFamilyCount; ++i) out.push_back(static_cast<LineFamily>(i));
  return out;
}

LineExtractor::LineExtractor(const Surface& surface, LineOptions options)
    : surface_(&surface),
      precompute_(std::make_unique<LinePrecompute>(surface)),
      apparent_faces_(std::make_unique<detail::FaceLists>()) {
  set_options(std::move(options));
}

LineExtractor::~LineExtractor() = default;

void LineExtractor::set_options(LineOptions options) {
  options_ = std::move(options);
  feature_size_ = options_.feature_size > 0.0 ? options_.feature_size : surface_->feature_size();
  if (!(feature_size_ > 0.0) || !std::isfinite(feature_size_))
    throw InputError("feature size must be a positive number (got " +
                     std::to_string(feature_size_) + "); pass --feature-size");
  // Every family's thresholds and fades up front (each extractor checks its
  // own again), so a bad one is reported before any view is computed.
  const LineOptions& o = options_;
  detail::require_non_negative(o.suggestive.threshold, LineFamily::suggestive, "threshold");
  detail::require_non_negative(o.suggestive.fade, LineFamily::suggestive, "fade");
  detail::require_non_negative(o.highlight.threshold, LineFamily::highlight, "threshold");
  detail::require_non_negative(o.highlight.fade, LineFamily::highlight, "fade");
  detail::require_non_negative(o.ridge.threshold, LineFamily::ridge, "threshold");
  detail::require_non_negative(o.valley.threshold, LineFamily::valley, "threshold");
  detail::require_non_negative(o.apparent.threshold, LineFamily::apparent, "threshold");
  detail::require_non_negative(o.pel.threshold, LineFamily::pel, "threshold");
  detail::require_non_negative(o.laplacian.threshold, LineFamily::laplacian, "threshold");
  detail::require_non_negative(o.demarcating.threshold, LineFamily::demarcating, "threshold");
}

void LineExtractor::extract(const Camera& camera, std::vector<SegmentSoup>& soups) {
  // The previous soups' storage goes back to the output pool, where this
  // view's extractors find it (no fresh pages per view).
  for (auto& soup : soups)
    detail::ChunkBufferPool<LineSegment>::instance().give(detail::kOutputKey,
                                                          std::move(soup.segments));
  soups = extract(camera);
}

std::vector<SegmentSoup> LineExtractor::extract(const Camera& camera) {
  const auto has = [&](LineFamily f) {
    return std::find(options_.families.begin(), options_.families.end(), f) !=
           options_.families.end();
  };
  ViewFieldsRequest req;
  // n·v and K_r for contours; n·v for culling ridges, valleys, demarcating
  // curves (suggestive contours, highlights and apparent ridges imply it;
  // PELs and Laplacian lines get n·v with the illumination).
  req.radial = has(LineFamily::contour) || has(LineFamily::ridge) || has(LineFamily::valley) ||
               has(LineFamily::demarcating);
  req.sc_test = has(LineFamily::suggestive) || has(LineFamily::highlight);
  req.apparent = has(LineFamily::apparent);
  // t1 and D_t1 q1 only where an apparent ridge can be drawn (the same
  // threshold expression as extract_apparent_ridges).
  if (req.apparent) {
    req.apparent_cull_threshold = options_.apparent.threshold / (feature_size_ * feature_size_);
    req.apparent_min_ndotv = options_.apparent.min_ndotv;
  }
  // The suggestive-contour test's rejection in the sign bytes (the same
  // shift as suggestive_setup).
  if (has(LineFamily::suggestive))
    req.suggestive_test_shift = options_.suggestive.threshold / (feature_size_ * feature_size_);
  req.light = has(LineFamily::laplacian) || has(LineFamily::pel);
  req.pel = has(LineFamily::pel);
  if (has(LineFamily::pel) && has(LineFamily::laplacian) &&
      options_.pel.light_direction != options_.laplacian.light_direction)
    throw InputError("PELs and Laplacian lines must use the same light in one extraction");
  req.light_direction =
      has(LineFamily::pel) ? options_.pel.light_direction : options_.laplacian.light_direction;
  detail::set_light_support(req, has(LineFamily::pel) ? &options_.pel : nullptr,
                            has(LineFamily::laplacian) ? &options_.laplacian : nullptr,
                            feature_size_);
  // The view-independent line precompute that this view's families need
  // and that the view fields do not (the raw ridges, valleys and
  // demarcating curves above their thresholds, the tangent ring of the
  // D_t1 q1 pass) starts at once, beside the view fields; on a later view
  // it is cached and the tasks return at once. Each part is deterministic
  // and computed once (LinePrecompute's once flags and locks), so the
  // result does not depend on which thread gets there first.
  tbb::task_group view_independent;
  const double fs = feature_size_;
  if ((has(LineFamily::ridge) || has(LineFamily::valley)) && !one_shot_)
    view_independent.run([&] {
      if (has(LineFamily::ridge))
        (void)precompute_->raw_above(LineFamily::ridge, options_.ridge.threshold / fs);
      if (has(LineFamily::valley))
        (void)precompute_->raw_above(LineFamily::valley, options_.valley.threshold / fs);
    });
  if (has(LineFamily::demarcating) && !one_shot_)
    view_independent.run([&] {
      (void)precompute_->raw_above(LineFamily::demarcating,
                                   options_.demarcating.threshold / (fs * fs));
    });
  // Not in one-shot mode (draw_lines, `fabrica lines`: least memory): there
  // each part is built by the pass that reads it, after the vertex blocks
  // are freed, so they are never alive together (on igea the overlap adds
  // ~18 MB to the peak: 139 against 121 MB resident).
  if (has(LineFamily::apparent) && !one_shot_)
    view_independent.run([&] { (void)precompute_->tangent_ring(); });
  try {
    // D_t1 q1 (the apparent ridges' second field pass) is computed in the
    // apparent-ridge task below, concurrently with the other families.
    detail::update_view_fields(fields_, *surface_, camera, req, precompute_.get(), true, true,
                               one_shot_);
  } catch (...) {
    view_independent.wait();
    throw;
  }
  view_independent.wait();
  // The vertex and light passes are done with the vertex blocks (in one-shot
  // mode only the light pass builds them: the vertex pass packs its own a
  // few at a time); the
  // D_t1 q1 pass (the apparent-ridge task) is the only reader of the
  // tangent ring, freed when it is through (one-shot only).
  if (one_shot_) precompute_->release_vertex_blocks();

  // The families are independent given the fields: run them concurrently
  // (each is itself a deterministic parallel loop), one output slot each,
  // so small families and the tails of large ones share the threads.
  std::vector<SegmentSoup> out(options_.families.size());
  // Contours and suggestive contours together: one scan over the faces'
  // sign bytes (in the contour's task) gives both soups.
  const auto& fam = options_.families;
  const auto contour_at = std::find(fam.begin(), fam.end(), LineFamily::contour);
  const auto suggestive_at = std::find(fam.begin(), fam.end(), LineFamily::suggestive);
  const bool fused = contour_at != fam.end() && suggestive_at != fam.end();
  const auto fused_contour = static_cast<std::size_t>(contour_at - fam.begin());
  const auto fused_suggestive = static_cast<std::size_t>(suggestive_at - fam.begin());
  // With apparent ridges too, that scan also lists the apparent-ridge
  // kernel's candidate faces. On several threads D_t1 q1 runs beside the
  // scan (and the other families), and the kernel in whichever of the two
  // tasks finishes second. On one thread the kernel runs right after the
  // scan and D_t1 q1 is computed in blocks of vertices, in increasing
  // order, as the kernel's face chunks need them (igea's faces follow its
  // vertex order: chunk c's corners lie below ~2000 (c + 1)), so each chunk
  // reads records just written: 1T ~3-4 % faster. (On two threads the same
  // order ran the kernel beside D_t1 q1 on the other core and was ~3 %
  // slower: both passes are memory-heavy.)
  const auto apparent_at = std::find(fam.begin(), fam.end(), LineFamily::apparent);
  // (Not in one-shot mode: there the apparent ridges run first, before the
  // scan's soups exist, and their kernel finds its faces itself.)
  const bool three = fused && apparent_at != fam.end() && !one_shot_;
  const auto apparent_k = static_cast<std::size_t>(apparent_at - fam.begin());
  const bool one_thread =
      tbb::this_task_arena::max_concurrency() == 1 ||
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism) == 1;
  const bool pipelined = three && one_thread;
  // One-shot (the families one after another, below): the apparent
  // ridges' own fields, read by no other family, are freed as soon as
  // possible, so that the families after them reuse their memory. Their
  // inputs (q1, D_t1 q1, t1, t1 in world space: ~48 bytes per vertex) once
  // D_t1 q1 is complete, when the kernel then reads only the packed records
  // and the sign bytes (detail::apparent_reads_records_only); the records
  // (64 bytes per vertex) and whatever is left once the kernel is through.
  auto free_apparent_inputs = [&] {
    std::vector<Vec3>().swap(fields_.t1_world);
    std::vector<Vec2>().swap(fields_.t1);
    std::vector<double>().swap(fields_.q1);
    std::vector<double>().swap(fields_.dt1q1);
  };
  auto apparent_inputs_done = [&] {
    if (one_shot_ && detail::apparent_reads_records_only(*surface_, fields_, fs, options_.apparent))
      free_apparent_inputs();
  };
  auto apparent_done = [&] {
    if (!one_shot_) return;
    std::vector<ApparentVertex>().swap(fields_.apparent_vertex);
    free_apparent_inputs();
  };
  // One-shot: the contour and suggestive-contour fields kr and sc_num once
  // the fused scan is through, when no later family reads them (highlights
  // do; the families run one after another in one-shot mode).
  auto scan_done = [&] {
    if (!one_shot_ || has(LineFamily::highlight)) return;
    std::vector<double>().swap(fields_.kr);
    std::vector<double>().swap(fields_.sc_num);
  };
  // One-shot: the tangent ring is freed once D_t1 q1 is complete (never
  // pipelined: `three` is off in one-shot mode).
  auto ring_done = [&] {
    if (one_shot_) precompute_->release_tangent_ring();
  };
  // One-shot: the raw lines (LinePrecompute::release_raw_lines) once the
  // families that read them are through.
  const int raw_families = static_cast<int>(std::count_if(fam.begin(), fam.end(), [](LineFamily f) {
    return f == LineFamily::ridge || f == LineFamily::valley || f == LineFamily::demarcating;
  }));
  std::atomic<int> raw_through{0};
  auto raw_done = [&] {
    if (one_shot_ && raw_through.fetch_add(1) + 1 == raw_families) precompute_->release_raw_lines();
  };
  std::optional<detail::Dt1q1Blocks> dt1q1;
  detail::ChunkReady ready;
  if (pipelined) {
    dt1q1.emplace(fields_, *surface_, fields_.apparent_cull_threshold.has_value(), *precompute_,
                  false, false);
    std::vector<std::int32_t>& top = apparent_faces_->top_vertex;
    if (top.empty()) {
      // Per chunk, the largest index among its faces' corners: a flat
      // maximum over the chunk's 3 * kFaceChunk indices (vectorised).
      const auto& faces = surface_->faces();
      const std::size_t chunk = detail::kFaceChunk;
      top.resize((faces.size() + chunk - 1) / chunk);
      const std::int32_t* idx = faces.empty() ? nullptr : faces[0].data();
      for (std::size_t c = 0; c < top.size(); ++c) {
        std::int32_t m = 0;
        for (std::size_t i = 3 * c * chunk, e = 3 * std::min(faces.size(), (c + 1) * chunk); i < e;
             ++i)
          m = std::max(m, idx[i]);
        top[c] = m;
      }
    }
    ready = [&](std::size_t c) { dt1q1->ready_through(static_cast<std::size_t>(top[c])); };
  }
  std::atomic<int> arrived{0};
  bool listed = false;
  auto apparent_kernel = [&] {
    out[apparent_k] = detail::extract_apparent_ridges(*surface_, fields_, fs, options_.apparent,
                                                      listed ? apparent_faces_.get() : nullptr,
                                                      pipelined ? &ready : nullptr);
  };
  auto run = [&](std::size_t k) {
    const LineFamily f = options_.families[k];
    if (fused && (k == fused_contour || k == fused_suggestive)) {
      if (k == fused_contour) {
        const bool l = detail::extract_contours_and_suggestive(
            *surface_, fields_, options_.contour, fs, options_.suggestive, out[fused_contour],
            out[fused_suggestive], three ? apparent_faces_.get() : nullptr);
        scan_done();
        if (three) {
          listed = l;
          if (pipelined || arrived.fetch_add(1) == 1) apparent_kernel();
        }
      }
      return;
    }
    switch (f) {
      case LineFamily::contour:
        out[k] = extract_contours(*surface_, fields_, options_.contour);
        break;
      case LineFamily::boundary:
        out[k] = extract_boundaries(*surface_);
        break;
      case LineFamily::crease:
        out[k] = extract_creases(*surface_, options_.crease);
        break;
      case LineFamily::suggestive:
        out[k] = extract_suggestive_contours(*surface_, fields_, fs, options_.suggestive);
        break;
      case LineFamily::highlight:
        out[k] = extract_suggestive_highlights(*surface_, fields_, fs, options_.highlight);
        break;
      case LineFamily::ridge:
        out[k] = extract_ridges(*precompute_, fields_, fs, options_.ridge);
        raw_done();
        break;
      case LineFamily::valley:
        out[k] = extract_valleys(*precompute_, fields_, fs, options_.valley);
        raw_done();
        break;
      case LineFamily::apparent:
        if (pipelined) {
          dt1q1->run_all();  // what the kernel (in the scan's task) left
          break;
        }
        detail::update_dt1q1(fields_, *surface_, fields_.apparent_cull_threshold.has_value(),
                             precompute_.get(), false, one_shot_);
        ring_done();
        apparent_inputs_done();
        if (three) {
          if (arrived.fetch_add(1) == 1) apparent_kernel();
        } else {
          out[k] = extract_apparent_ridges(*surface_, fields_, fs, options_.apparent);
          apparent_done();
        }
        break;
      case LineFamily::pel:
        out[k] = extract_pels(*surface_, fields_, fs, options_.pel);
        break;
      case LineFamily::laplacian:
        out[k] = extract_laplacian_lines(*surface_, fields_, fs, options_.laplacian);
        break;
      case LineFamily::demarcating:
        out[k] = extract_demarcating_curves(*precompute_, fields_, fs, options_.demarcating);
        raw_done();
        break;
    }
  };
  if (one_shot_) {
    // One view, least memory: the families one after another (each a
    // parallel loop on all threads), so that no two families' working sets
    // and outputs are alive beside the full view fields: first the apparent
    // ridges (D_t1 q1, then its inputs are freed, then the kernel, then the
    // records), then the fused scan (kr and sc_num are freed after it),
    // then the rest in the given order (the raw ridges and valleys are
    // computed in the memory the apparent fields left). The outputs are the
    // concurrent schedule's, bit for bit (each family writes its own slot
    // from the same fields; the kernel's faces found by itself are the ones
    // the scan would list).
    std::vector<std::size_t> order;
    if (apparent_at != fam.end()) order.push_back(apparent_k);
    if (fused) order.push_back(fused_contour);
    for (std::size_t k = 0; k < out.size(); ++k)
      if (std::find(order.begin(), order.end(), k) == order.end()) order.push_back(k);
    for (const std::size_t k : order) run(k);
  } else {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, out.size(), 1),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t k = r.begin(); k != r.end(); ++k) run(k);
                      });
  }
  for (auto& soup : out) soup.surface = surface_;  // the ends refer to this mesh
  return out;
}

}  // namespace fabrica
