#include "solver/mask_stage.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "render/raster.h"
#include "solver/segments.h"

namespace g6d {

namespace {

bool TouchesBorder(const cv::Rect& box, const cv::Size& size) {
  return box.x == 0 || box.y == 0 || box.x + box.width == size.width || box.y + box.height == size.height;
}

}  // namespace

// Fills *observation; returns an empty string, or what is wrong with the input.
std::string PrepareObservation(const Frame& frame, const Instance& instance, const SolverOptions& options,
                               double diameter_m, Observation* observation) {
  observation->mask = instance.mask > 0;
  observation->box = cv::boundingRect(observation->mask);
  if (observation->box.area() == 0) return "the instance mask is empty";
  observation->truncated = TouchesBorder(observation->box, observation->mask.size());
  // A mask that fills its bounding box is a detector's box (the service's box input, or a
  // user's rectangle): its outline says nothing about the object's.
  observation->is_box = cv::countNonZero(observation->mask) == observation->box.area();
  if (options.reject_border_masks && observation->truncated) {
    return "the instance mask touches the image border (object truncated; solved unless reject_border_masks)";
  }
  observation->depth = frame.depth.clone();
  cv::Mat& depth = observation->depth;
  cv::patchNaNs(depth, 0.0);
  observation->score = options.score;
  if (options.mask_trust == MaskTrust::kDepth) {
    // The mask as evidence: its leaks removed, and the tolerance of "on the rendered
    // surface" for the pixels it missed (region.h).
    // A box's outline is not the object's: a depthless area inside it may be anything.
    RegionOptions region_options = options.region;
    if (observation->is_box) region_options.unsure_area_min_px = 1;
    // The wider ring's plane serves only as the support limit: no search when it is off.
    if (!(options.support_penetration_fraction > 0.0)) region_options.limit_ring_fraction = 0.0;
    observation->region = ComputeObservedRegion(frame.camera, observation->mask, depth, diameter_m, region_options);
    if (!observation->region.has_limit_plane && instance.has_support_limit && options.support_penetration_fraction > 0.0) {
      observation->region.has_limit_plane = true;
      observation->region.limit_plane_normal = instance.support_limit_normal;
      observation->region.limit_plane_offset_m = instance.support_limit_offset_m;
    }
    observation->mask = observation->region.mask;
    observation->box = cv::boundingRect(observation->mask);
    if (observation->box.area() == 0) {
      observation->too_thin = true;
      return "the instance mask is empty once its leaks are removed";
    }
    observation->score.depth_evidence = true;
    observation->score.surface_tolerance_m = observation->region.surface_tolerance_m;
  }
  const cv::Mat& mask = observation->mask;
  const cv::Rect& box = observation->box;
  int& valid_depth = observation->valid_depth;
  observation->z_m = MedianMaskedDepth(mask, depth, &valid_depth);  // eq. (9), robust
  if (valid_depth < options.min_valid_depth_pixels) {
    observation->too_thin = true;
    return "the mask has " + std::to_string(valid_depth) + " pixels with valid depth (need " +
           std::to_string(options.min_valid_depth_pixels) + ")";
  }
  // Observed cloud Y, deterministic image-space subsampling.
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(valid_depth) / options.max_observed_points))));
  std::vector<Eigen::Vector3d> observed;
  for (int v = box.y + stride / 2; v < box.y + box.height; v += stride) {
    for (int u = box.x + stride / 2; u < box.x + box.width; u += stride) {
      const float z = depth.at<float>(v, u);
      if (!mask.at<uint8_t>(v, u) || !(z > 0.0f)) continue;
      observed.push_back(frame.camera.Backproject(PixelCentre(u, v), z));
    }
  }
  observation->observed = std::make_unique<PointCloudIndex>(std::move(observed));
  const cv::Mat& support = observation->region.support;
  const cv::Mat& unsure = observation->region.unsure;
  // What the scores read as support: less the caller's mask where the mask decides.
  cv::Mat scored_support = support;
  if (!support.empty() && options.region.mask_decides_on_support) scored_support = support & ~(instance.mask > 0);
  DepthSegmentation segments;
  const bool by_segment = options.mask_trust == MaskTrust::kDepth && options.score.segment_own_fraction > 0.0;
  if (by_segment) {
    segments = SegmentByDepth(frame.camera, depth, mask, options.segments);
    // No two visible points of the object lie farther apart than its diameter, plus the
    // depth noise and a pixel's footprint at each end.
    const double noise_m = options.segments.noise_sigmas * options.segments.sensor_noise_at_1m * observation->z_m * observation->z_m;
    const double pixel_m = observation->z_m / std::min(frame.camera.fx, frame.camera.fy);
    observation->score.max_object_extent_m = diameter_m + 2.0 * (noise_m + pixel_m);
    // A segment wider than the object holds more than the object: a merged mask or a box
    // over neighbours that touch it at the same depth. Where two convex objects touch they
    // meet in a concave crease, which splits them (a mask of one object alone is left as
    // the depth cuts it: its own concavities would only split it finer).
    bool too_wide = false;
    for (const DepthSegment& segment : segments.segments) {
      too_wide = too_wide || segment.spans.Extent() > observation->score.max_object_extent_m;
    }
    if (too_wide && options.split_merged_at_creases) {
      segments = SegmentByDepthAndCreases(frame.camera, depth, mask, options.segments, nullptr);
    }
  }
  const DepthSegmentation* segmentation = by_segment ? &segments : nullptr;
  const bool grow = options.mask_trust == MaskTrust::kDepth && options.region.grow_fraction > 0.0;
  const int grow_steps = static_cast<int>(std::ceil(options.region.grow_fraction * std::max(box.width, box.height)));
  auto search_region = [&](const cv::Mat& region, double z_m) {
    Observation::SearchRegion search;
    search.mask = grow ? GrowRegionByDepth(frame.camera, depth, region, support, diameter_m, grow_steps,
                                           options.score.segment_own_fraction, options.segments)
                       : region;
    search.box = cv::boundingRect(search.mask);
    search.z_m = z_m;
    return search;
  };
  // The search leaves out what the depth cannot judge at the mask's edge.
  observation->search_regions.push_back(search_region(unsure.empty() ? mask : mask & ~unsure, observation->z_m));
  int total = 0;
  if (by_segment && !segments.segments.empty()) {
    // A region wider than the object can reach holds more than the object.
    Spans all = segments.segments.front().spans;
    for (const DepthSegment& segment : segments.segments) {
      all = all.Union(segment.spans);
      total += segment.pixels;
    }
    observation->wider_than_object = all.Extent() > observation->score.max_object_extent_m;
  }
  if (by_segment && options.max_search_regions > 0 && segments.segments.size() >= 2) {
    // Its large segments that the object could be are searched alone too.
    if (observation->wider_than_object) {
      for (size_t k = 0; k < segments.segments.size(); ++k) {
        const DepthSegment& segment = segments.segments[k];
        if (static_cast<int>(observation->search_regions.size()) > options.max_search_regions) break;
        if (segment.pixels < options.min_valid_depth_pixels || segment.pixels < 0.1 * total) break;  // largest first
        if (segment.spans.Extent() > observation->score.max_object_extent_m) continue;
        cv::Mat region = segments.labels == static_cast<int>(k) + 1;
        observation->search_regions.push_back(search_region(region, segment.median_depth_m));
      }
    }
  }
  // The depthless areas are read only by unseen_is_hidden and the thin holes' fill.
  auto grid_options = [&options](GridOptions grid) {
    if (!options.score.unseen_is_hidden && !grid.fill_thin_holes) grid.unseen_area_min_px = 0;
    return grid;
  };
  observation->selection_grid =
      MakeEvaluationGrid(frame.camera, mask, depth, grid_options(options.selection_grid), scored_support, segmentation, unsure);
  observation->refine_grid =
      MakeEvaluationGrid(frame.camera, mask, depth, grid_options(options.refine_grid), scored_support, segmentation, unsure);
  return "";
}

}  // namespace g6d
