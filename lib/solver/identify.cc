#include "solver/identify.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/timer.h"
#include "solver/depth_regions.h"
#include "solver/region.h"
#include "solver/segments.h"

namespace g6d {

namespace {

// Back-projected points at most this many: a stride over the mask box keeps the extent's
// quantiles (the span of a uniform subsample) and its cost under a millisecond.
constexpr int kMaxExtentPoints = 4000;

// True when the pre-screen can read the frame and the mask; otherwise EstimatePose reports
// what is wrong with them and every candidate is solved.
bool CanScreen(const Frame& frame, const cv::Mat& mask, const SolverOptions& options) {
  const Camera& camera = frame.camera;
  return !mask.empty() && mask.type() == CV_8U && frame.depth.type() == CV_32F &&
         mask.size() == frame.depth.size() && camera.width == mask.cols &&
         camera.height == mask.rows && std::isfinite(camera.fx) && std::isfinite(camera.fy) &&
         std::isfinite(camera.cx) && std::isfinite(camera.cy) && camera.fx > 0.0 &&
         camera.fy > 0.0 && options.region.Check().empty();
}

}  // namespace

std::string IdentifyOptions::Check() const {
  std::ostringstream out;
  if (!(extent_trim_fraction >= 0.0 && extent_trim_fraction < 0.25)) {
    out << "IdentifyOptions.extent_trim_fraction must be in [0, 0.25) (got " << extent_trim_fraction << ")";
  } else if (!(extent_margin_px >= 0.0 && std::isfinite(extent_margin_px))) {
    out << "IdentifyOptions.extent_margin_px must be finite and >= 0 (got " << extent_margin_px << ")";
  }
  return out.str();
}

double MaskDepthExtent(const Camera& camera, const cv::Mat& mask, const cv::Mat& depth,
                       double trim_fraction, double* max_depth_m) {
  if (mask.type() != CV_8U || depth.type() != CV_32F || mask.size() != depth.size()) {
    G6D_THROW("MaskDepthExtent: need a CV_8U mask and a CV_32F depth of one size (got types "
              << mask.type() << " and " << depth.type() << ", sizes " << mask.size() << " and " << depth.size() << ")");
  }
  if (max_depth_m != nullptr) *max_depth_m = 0.0;
  const cv::Rect box = cv::boundingRect(mask);
  if (box.area() == 0) return 0.0;
  int valid = 0;
  for (int v = box.y; v < box.y + box.height; ++v) {
    const uint8_t* m = mask.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    for (int u = box.x; u < box.x + box.width; ++u) valid += m[u] != 0 && d[u] > 0.0f;
  }
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(valid) / kMaxExtentPoints))));
  std::vector<Eigen::Vector3d> points;
  double max_depth = 0.0;
  for (int v = box.y + stride / 2; v < box.y + box.height; v += stride) {
    const uint8_t* m = mask.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    for (int u = box.x + stride / 2; u < box.x + box.width; u += stride) {
      if (m[u] == 0 || !(d[u] > 0.0f) || !std::isfinite(d[u])) continue;
      points.push_back(camera.Backproject(PixelCentre(u, v), d[u]));
      max_depth = std::max(max_depth, static_cast<double>(d[u]));
    }
  }
  if (max_depth_m != nullptr) *max_depth_m = max_depth;
  if (points.size() < 2) return 0.0;
  // SpanDirections(): each span is a distance two kept points are at least apart (a lower
  // bound, never more), and the largest is at least 0.89 of the kept points' diameter.
  const size_t n = points.size();
  const size_t low = static_cast<size_t>(std::floor(trim_fraction * static_cast<double>(n - 1)));
  const size_t high = n - 1 - low;
  std::vector<double> projections(n);
  double extent = 0.0;
  for (const Eigen::Vector3d& direction : SpanDirections()) {
    for (size_t i = 0; i < n; ++i) projections[i] = direction.dot(points[i]);
    std::nth_element(projections.begin(), projections.begin() + low, projections.end());
    const double low_value = projections[low];
    // Everything from `low` on is >= low_value; the high quantile lies among them.
    std::nth_element(projections.begin() + low, projections.begin() + high, projections.end());
    extent = std::max(extent, projections[high] - low_value);
  }
  return extent;
}

IdentifiedPose EstimatePoseOfUnknownObject(const Frame& frame, const cv::Mat& mask,
                                           const std::vector<const TemplateBank*>& candidates,
                                           const SolverOptions& options,
                                           const IdentifyOptions& identify_options,
                                           Executor* executor) {
  if (candidates.empty()) G6D_THROW("EstimatePoseOfUnknownObject: no candidate objects given");
  std::map<std::string, size_t> first_index;
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (candidates[i] == nullptr) G6D_THROW("EstimatePoseOfUnknownObject: candidate " << i << " is a null bank");
    const auto [it, inserted] = first_index.emplace(candidates[i]->object_id, i);
    if (!inserted) {
      G6D_THROW("EstimatePoseOfUnknownObject: object id '" << candidates[i]->object_id << "' is given twice (candidates "
                                                            << it->second << " and " << i << ")");
    }
  }
  if (const std::string bad = identify_options.Check(); !bad.empty()) {
    G6D_THROW("EstimatePoseOfUnknownObject: " << bad);
  }
  if (executor == nullptr) G6D_THROW("EstimatePoseOfUnknownObject: the executor is null");

  const Stopwatch total;
  IdentifiedPose identified;
  identified.candidates.resize(candidates.size());
  std::vector<double> screen_ms(candidates.size(), 0.0);
  for (size_t i = 0; i < candidates.size(); ++i) {
    identified.candidates[i].object_id = candidates[i]->object_id;
    identified.candidates[i].diameter_m = candidates[i]->diameter_m;
  }

  // ---- pre-screen: a candidate too short to span the mask's depth points cannot be it.
  if (identify_options.prescreen && candidates.size() > 1 && CanScreen(frame, mask, options)) {
    cv::Mat depth = frame.depth.clone();
    cv::patchNaNs(depth, 0.0);
    const cv::Mat given = mask > 0;
    const RegionOptions& region = options.region;
    const double f_min = std::min(frame.camera.fx, frame.camera.fy);
    int screened = 0;
    for (size_t i = 0; i < candidates.size(); ++i) {
      const Stopwatch watch;
      IdentityCandidate& candidate = identified.candidates[i];
      // The region this candidate's solve reads: with masks as evidence its leaks onto the
      // support plane and beyond its diameter are not its points.
      const cv::Mat points_mask =
          options.mask_trust == MaskTrust::kDepth
              ? ComputeObservedRegion(frame.camera, given, depth, candidate.diameter_m, region).mask
              : given;
      // The screen's premise is that the region's points are one object's. A region of two
      // large depth segments or more (a box, a merged mask, an object seen past an
      // occluder) may hold several objects: its extent then rules out nothing.
      const DepthSegmentation segmentation = SegmentByDepth(frame.camera, depth, points_mask, options.segments);
      int segmented = 0, large = 0;
      for (const DepthSegment& segment : segmentation.segments) segmented += segment.pixels;
      for (const DepthSegment& segment : segmentation.segments) large += segment.pixels >= 0.1 * segmented;
      if (large > 1) {
        candidate.message = "not run";
        screen_ms[i] = watch.ElapsedMs();
        continue;
      }
      double max_depth_m = 0.0;
      candidate.extent_m = MaskDepthExtent(frame.camera, points_mask, depth,
                                           identify_options.extent_trim_fraction, &max_depth_m);
      // Each end of the span may be off by the depth noise (σ(z) = σ_1m z², region.h) and
      // by the mask boundary's uncertainty, at the farthest depth the mask holds.
      const double noise_m = region.noise_sigmas * region.sensor_noise_at_1m * max_depth_m * max_depth_m;
      candidate.extent_allowance_m = 2.0 * (noise_m + identify_options.extent_margin_px * max_depth_m / f_min);
      if (candidate.extent_m > candidate.diameter_m + candidate.extent_allowance_m) {
        candidate.screened_out = true;
        ++screened;
        std::ostringstream message;
        message.precision(1);
        message << std::fixed << "screened out: the mask's depth points span " << candidate.extent_m * 1000.0
                << " mm, more than the diameter " << candidate.diameter_m * 1000.0 << " mm + "
                << candidate.extent_allowance_m * 1000.0 << " mm of noise";
        candidate.message = message.str();
      }
      screen_ms[i] = watch.ElapsedMs();
    }
    if (screened == static_cast<int>(candidates.size())) {
      // No candidate spans the mask: it holds more than one object (a merged mask) or the
      // depth is off. The screen's premise fails, so it decides nothing.
      for (IdentityCandidate& candidate : identified.candidates) {
        candidate.screened_out = false;
        candidate.message = "not run";
      }
    } else {
      identified.screened_out = screened;
    }
  }

  // ---- solve the rest, each candidate as if it were the object.
  std::vector<PoseResult> results(candidates.size());
  // The candidates are compared on the caller's mask; the depth's regions inside it
  // (depth_regions.h) are searched for the chosen object only: a region is a part of the
  // mask, and a part is easier to fit for the wrong object.
  SolverOptions on_mask = options;
  on_mask.region_candidates = 0;
  int best = -1, second = -1;
  for (size_t i = 0; i < candidates.size(); ++i) {
    IdentityCandidate& candidate = identified.candidates[i];
    if (candidate.screened_out) {
      candidate.ms = screen_ms[i];
      continue;
    }
    const Stopwatch watch;
    results[i] = EstimatePose(frame, Instance{candidates[i]->object_id, mask}, *candidates[i], on_mask, executor);
    candidate.ms = screen_ms[i] + watch.ElapsedMs();
    candidate.success = results[i].success;
    candidate.score = results[i].success ? results[i].score : 2.0;
    candidate.message = results[i].message;
    if (!results[i].success) continue;
    const int index = static_cast<int>(i);
    if (best < 0 || results[i].score < results[best].score) {
      second = best;
      best = index;
    } else if (second < 0 || results[i].score < results[second].score) {
      second = index;
    }
  }

  if (best >= 0) {
    const Stopwatch watch;
    identified.result = SolveOnDepthRegions(frame, Instance{candidates[best]->object_id, mask}, *candidates[best],
                                            options, executor, std::move(results[best]));
    identified.candidates[static_cast<size_t>(best)].ms += watch.ElapsedMs();
    identified.object_id = candidates[best]->object_id;
    if (second >= 0) {
      identified.runner_up_id = candidates[second]->object_id;
      identified.runner_up_score = results[second].score;
      identified.ambiguous = identified.runner_up_score - identified.result.score <= options.ambiguity_margin;
    }
  } else {
    // Nothing fits: the first solved candidate's answer (its termination), with every
    // candidate's reason.
    for (size_t i = 0; i < candidates.size(); ++i) {
      if (!identified.candidates[i].screened_out) {
        identified.result = std::move(results[i]);
        break;
      }
    }
    std::ostringstream message;
    message << "no candidate object was solved:";
    for (size_t i = 0; i < candidates.size(); ++i) {
      message << (i == 0 ? " " : "; ") << identified.candidates[i].object_id << ": " << identified.candidates[i].message;
    }
    identified.result.success = false;
    identified.result.message = message.str();
  }
  identified.total_ms = total.ElapsedMs();
  return identified;
}

IdentifiedPose EstimatePoseOfUnknownObject(const Frame& frame, const cv::Mat& mask,
                                           const std::vector<const TemplateBank*>& candidates,
                                           const SolverOptions& options, Executor* executor) {
  return EstimatePoseOfUnknownObject(frame, mask, candidates, options, IdentifyOptions(), executor);
}

}  // namespace g6d
