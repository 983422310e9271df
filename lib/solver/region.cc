#include "solver/region.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "render/raster.h"
#include "solver/observation.h"
#include "solver/plane.h"

namespace g6d {

const char* MaskTrustName(MaskTrust trust) {
  switch (trust) {
    case MaskTrust::kExact: return "exact";
    case MaskTrust::kDepth: return "depth";
  }
  return "unknown";
}

MaskTrust ParseMaskTrust(const std::string& name) {
  if (name == "exact") return MaskTrust::kExact;
  if (name == "depth") return MaskTrust::kDepth;
  throw Error("mask trust must be exact or depth (got \"" + name + "\")");
}

std::string RegionOptions::Check() const {
  std::ostringstream out;
  if (!(sensor_noise_at_1m >= 0.0 && sensor_noise_at_1m < 0.1)) out << "RegionOptions.sensor_noise_at_1m must be in [0, 0.1) m (got " << sensor_noise_at_1m << ")";
  else if (!(noise_sigmas > 0.0 && noise_sigmas <= 10.0)) out << "RegionOptions.noise_sigmas must be in (0, 10] (got " << noise_sigmas << ")";
  else if (!(pose_tolerance_fraction >= 0.0 && pose_tolerance_fraction <= 0.5)) out << "RegionOptions.pose_tolerance_fraction must be in [0, 0.5] (got " << pose_tolerance_fraction << ")";
  else if (!(ring_fraction > 0.0 && ring_fraction <= 2.0)) out << "RegionOptions.ring_fraction must be in (0, 2] (got " << ring_fraction << ")";
  else if (!(limit_ring_fraction >= 0.0 && limit_ring_fraction <= 5.0)) out << "RegionOptions.limit_ring_fraction must be in [0, 5] (got " << limit_ring_fraction << ")";
  else if (plane_iterations < 1) out << "RegionOptions.plane_iterations must be >= 1 (got " << plane_iterations << ")";
  else if (plane_samples < 3) out << "RegionOptions.plane_samples must be >= 3 (got " << plane_samples << ")";
  else if (!(min_plane_fraction > 0.0 && min_plane_fraction <= 1.0)) out << "RegionOptions.min_plane_fraction must be in (0, 1] (got " << min_plane_fraction << ")";
  else if (min_plane_points < 3) out << "RegionOptions.min_plane_points must be >= 3 (got " << min_plane_points << ")";
  else if (!(far_fraction > 0.0)) out << "RegionOptions.far_fraction must be > 0 (got " << far_fraction << ")";
  else if (unsure_area_min_px < 1) out << "RegionOptions.unsure_area_min_px must be >= 1 (got " << unsure_area_min_px << ")";
  else if (!(grow_fraction >= 0.0 && grow_fraction <= 2.0)) out << "RegionOptions.grow_fraction must be in [0, 2] (got " << grow_fraction << ")";
  return out.str();
}

namespace {

using internal::FitPlane;
using internal::Plane;

// The dominant plane of `points` by RANSAC (inliers within `tolerance_m`), refitted to its
// inliers; *inliers receives their count.
Plane DominantPlane(const std::vector<Eigen::Vector3d>& points, double tolerance_m, const RegionOptions& options,
                    int* inliers) {
  std::mt19937_64 random(options.seed);
  int best_count = -1;
  const Plane best = internal::RansacPlane(
      points, options.plane_iterations, [&](const Eigen::Vector3d&) { return tolerance_m; }, &random, &best_count);
  if (best_count < 3) {
    *inliers = 0;
    return best;
  }
  std::vector<Eigen::Vector3d> inlier_points;
  for (const Eigen::Vector3d& p : points) {
    if (std::abs(best.Distance(p)) <= tolerance_m) inlier_points.push_back(p);
  }
  Plane refit = FitPlane(inlier_points);
  int count = 0;
  for (const Eigen::Vector3d& p : points) count += std::abs(refit.Distance(p)) <= tolerance_m;
  if (count < best_count) {
    refit = best;
    count = best_count;
  }
  if (refit.offset < 0.0) {  // the camera (the origin) on the positive side
    refit.normal = -refit.normal;
    refit.offset = -refit.offset;
  }
  *inliers = count;
  return refit;
}

}  // namespace

namespace {

// ObservedRegion::unsure: the mask's pixels without depth connected (4-neighbours, through
// such pixels) to a depthless area outside the mask at least `min_area_px` wide (or to the
// image's border); with `min_area_px` 1, to any pixel outside the mask. Needs region->mask.
void MarkUnsurePixelsFrom(const cv::Mat& depth, int min_area_px, ObservedRegion* region) {
  const cv::Mat& mask = region->mask;
  cv::Mat unsure = cv::Mat::zeros(mask.size(), CV_8U);
  std::vector<cv::Point> front;
  auto no_depth = [&](int u, int v) {
    const float z = depth.at<float>(v, u);
    return !(z > 0.0f && std::isfinite(z));
  };
  auto no_depth_in_mask = [&](int u, int v) { return mask.at<uint8_t>(v, u) && no_depth(u, v); };
  // The depthless areas outside the mask, around its box, less the bands thinner than
  // min_area_px: where the sensor lost the depth along an edge (only read when min_area_px > 1).
  const cv::Rect box = cv::boundingRect(mask);
  const int margin = min_area_px + 1;
  const cv::Rect roi = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
                       cv::Rect(0, 0, mask.cols, mask.rows);
  const cv::Mat wide_unseen = min_area_px > 1 ? UnseenAreaOutside(mask, depth, roi, min_area_px) : cv::Mat();
  auto unseen_outside = [&](int u, int v) {
    if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows) return true;
    if (min_area_px <= 1) return !mask.at<uint8_t>(v, u);  // any pixel outside the mask
    if (!roi.contains(cv::Point(u, v))) return false;
    return wide_unseen.at<uint8_t>(v - roi.y, u - roi.x) != 0;
  };
  const int du[4] = {-1, 1, 0, 0}, dv[4] = {0, 0, -1, 1};
  for (int v = 0; v < mask.rows; ++v) {
    for (int u = 0; u < mask.cols; ++u) {
      if (!no_depth_in_mask(u, v)) continue;
      bool at_edge = false;
      for (int k = 0; k < 4 && !at_edge; ++k) at_edge = unseen_outside(u + du[k], v + dv[k]);
      if (!at_edge) continue;
      unsure.at<uint8_t>(v, u) = 255;
      front.push_back(cv::Point(u, v));
    }
  }
  while (!front.empty()) {
    const cv::Point p = front.back();
    front.pop_back();
    for (int k = 0; k < 4; ++k) {
      const int u = p.x + du[k], v = p.y + dv[k];
      if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows || unsure.at<uint8_t>(v, u) || !no_depth_in_mask(u, v)) continue;
      unsure.at<uint8_t>(v, u) = 255;
      front.push_back(cv::Point(u, v));
    }
  }
  region->unsure_pixels = cv::countNonZero(unsure);
  if (region->unsure_pixels > 0) region->unsure = unsure;
}

}  // namespace

ObservedRegion ComputeObservedRegion(const Camera& camera, const cv::Mat& mask, const cv::Mat& depth,
                                     double diameter_m, const RegionOptions& options) {
  G6D_CHECK(mask.type() == CV_8U && depth.type() == CV_32F && mask.size() == depth.size());
  G6D_CHECK(mask.cols == camera.width && mask.rows == camera.height);
  ObservedRegion region;
  region.mask = mask > 0;
  region.given_pixels = cv::countNonZero(region.mask);
  const cv::Rect box = cv::boundingRect(region.mask);
  if (box.area() == 0) return region;

  // The mask's points and their median depth (the object's distance, robust to leaks).
  std::vector<float> mask_depths;
  for (int v = box.y; v < box.y + box.height; ++v) {
    const uint8_t* m = region.mask.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    for (int u = box.x; u < box.x + box.width; ++u) {
      if (m[u] && d[u] > 0.0f && std::isfinite(d[u])) mask_depths.push_back(d[u]);
    }
  }
  if (mask_depths.empty()) return region;
  auto median_of = [](std::vector<float> values) {
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    return static_cast<double>(*middle);
  };
  const double z_median = median_of(mask_depths);
  const double noise_m = options.noise_sigmas * options.sensor_noise_at_1m * z_median * z_median;
  region.surface_tolerance_m = noise_m + options.pose_tolerance_fraction * diameter_m;
  // The plane's inlier band: the sensor's noise, never below a millimetre (depth images
  // are quantized to about that).
  const double plane_tolerance_m = std::max(noise_m, 1e-3);

  // ---- the support plane, fitted to the valid depth around the mask: in a ring of
  // `ring_fraction` of the box's longer side on each side; the plane and the ring's box when
  // one is the support.
  auto find_support = [&](double ring_fraction, Plane* plane, cv::Rect* roi) {
    const int ring = static_cast<int>(std::ceil(ring_fraction * std::max(box.width, box.height)));
    *roi = cv::Rect(box.x - ring, box.y - ring, box.width + 2 * ring, box.height + 2 * ring) &
           cv::Rect(0, 0, mask.cols, mask.rows);
    int ring_valid = 0;
    for (int v = roi->y; v < roi->y + roi->height; ++v) {
      const uint8_t* m = region.mask.ptr<uint8_t>(v);
      const float* d = depth.ptr<float>(v);
      for (int u = roi->x; u < roi->x + roi->width; ++u) ring_valid += !m[u] && d[u] > 0.0f && std::isfinite(d[u]);
    }
    if (ring_valid < options.min_plane_points) return false;
    const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(ring_valid) / options.plane_samples))));
    std::vector<Eigen::Vector3d> ring_points;
    for (int v = roi->y + stride / 2; v < roi->y + roi->height; v += stride) {
      const uint8_t* m = region.mask.ptr<uint8_t>(v);
      const float* d = depth.ptr<float>(v);
      for (int u = roi->x + stride / 2; u < roi->x + roi->width; u += stride) {
        if (!m[u] && d[u] > 0.0f && std::isfinite(d[u])) ring_points.push_back(camera.Backproject(PixelCentre(u, v), d[u]));
      }
    }
    int inliers = 0;
    if (ring_points.size() >= 3) *plane = DominantPlane(ring_points, plane_tolerance_m, options, &inliers);
    // A support fills much of the ring, not just much of its valid depth (a neighbour's
    // face beside an object whose surroundings have no depth is no support).
    const double ring_pixels = static_cast<double>(roi->area() - cv::countNonZero(region.mask(*roi)));
    const double sampled_fraction = static_cast<double>(inliers) / std::max<size_t>(1, ring_points.size());
    const bool large = inliers >= options.min_plane_points &&
                       sampled_fraction * ring_valid >= options.min_plane_fraction * ring_pixels;
    if (!large) return false;
    // The object stands in front of its support: a fifth of the mask's points at least
    // lie clearly on the camera side of the plane (a plane through the object's own
    // face, or one in front of it, is no support).
    int in_front = 0, counted = 0;
    for (int v = box.y; v < box.y + box.height; v += stride) {
      const uint8_t* m = region.mask.ptr<uint8_t>(v);
      const float* d = depth.ptr<float>(v);
      for (int u = box.x; u < box.x + box.width; u += stride) {
        if (!m[u] || !(d[u] > 0.0f) || !std::isfinite(d[u])) continue;
        ++counted;
        in_front += plane->Distance(camera.Backproject(PixelCentre(u, v), d[u])) > 2.0 * plane_tolerance_m;
      }
    }
    return counted > 0 && in_front >= 0.2 * counted;
  };
  Plane plane;
  cv::Rect roi;
  region.has_plane = find_support(options.ring_fraction, &plane, &roi);
  if (region.has_plane) {
    region.has_limit_plane = true;
    region.limit_plane_normal = plane.normal;
    region.limit_plane_offset_m = plane.offset;
  } else if (options.limit_ring_fraction > options.ring_fraction) {
    // Crowded surroundings (a bin's pile) hide the support in the ring; a wider ring may
    // show it. Only a limit on the poses: the mask's leaks are judged in the ring alone.
    Plane wide;
    cv::Rect wide_roi;
    if (find_support(options.limit_ring_fraction, &wide, &wide_roi)) {
      region.has_limit_plane = true;
      region.limit_plane_normal = wide.normal;
      region.limit_plane_offset_m = wide.offset;
    }
  }

  // ---- leaks: mask pixels on the support, or far behind the object
  cv::Mat kept = region.mask.clone();
  if (region.has_plane) {
    region.plane_normal = plane.normal;
    region.plane_offset_m = plane.offset;
    region.support = cv::Mat::zeros(mask.size(), CV_8U);
    for (int v = roi.y; v < roi.y + roi.height; ++v) {
      const float* d = depth.ptr<float>(v);
      uint8_t* s = region.support.ptr<uint8_t>(v);
      uint8_t* k = kept.ptr<uint8_t>(v);
      for (int u = roi.x; u < roi.x + roi.width; ++u) {
        if (!(d[u] > 0.0f) || !std::isfinite(d[u])) continue;
        // On the plane or behind it (seen through a gap, the floor under a table).
        if (plane.Distance(camera.Backproject(PixelCentre(u, v), d[u])) > plane_tolerance_m) continue;
        s[u] = 255;
        if (k[u]) {
          k[u] = 0;
          ++region.support_leak;
        }
      }
    }
  }
  std::vector<float> object_depths;
  for (int v = box.y; v < box.y + box.height; ++v) {
    const uint8_t* k = kept.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    for (int u = box.x; u < box.x + box.width; ++u) {
      if (k[u] && d[u] > 0.0f && std::isfinite(d[u])) object_depths.push_back(d[u]);
    }
  }
  if (!object_depths.empty()) {
    // No visible point of the object lies farther than this from the median one: beyond
    // it lies the background behind, or an occluder in front that the mask leaked onto.
    const double median_m = median_of(object_depths);
    const double reach_m = options.far_fraction * diameter_m;
    for (int v = box.y; v < box.y + box.height; ++v) {
      uint8_t* k = kept.ptr<uint8_t>(v);
      const float* d = depth.ptr<float>(v);
      for (int u = box.x; u < box.x + box.width; ++u) {
        if (k[u] && d[u] > 0.0f && std::abs(d[u] - median_m) > reach_m) {
          k[u] = 0;
          ++region.far_leak;
        }
      }
    }
  }
  const int leaks = region.support_leak + region.far_leak;
  if (static_cast<double>(mask_depths.size() - static_cast<size_t>(std::min<int>(leaks, static_cast<int>(mask_depths.size())))) <
      0.2 * static_cast<double>(mask_depths.size())) {
    // The depth disagrees with most of the mask: keep the caller's word.
    region.support_leak = region.far_leak = 0;
    region.has_plane = false;
    region.support.release();
    MarkUnsurePixelsFrom(depth, options.unsure_area_min_px, &region);
    return region;
  }
  region.mask = kept;
  MarkUnsurePixelsFrom(depth, options.unsure_area_min_px, &region);
  return region;
}

cv::Mat CorrectedMask(const Camera& camera, const Mesh& mesh, const Eigen::Isometry3d& cam_from_object,
                      const cv::Mat& depth, double occlusion_margin_m, bool cull_backfaces, const cv::Rect& roi) {
  G6D_CHECK(depth.type() == CV_32F && depth.cols == camera.width && depth.rows == camera.height);
  cv::Mat corrected = cv::Mat::zeros(depth.size(), CV_8U);
  const cv::Rect area = roi & cv::Rect(0, 0, camera.width, camera.height);
  if (area.area() == 0) return corrected;
  RasterOptions options;
  options.want_face_id = false;
  options.cull_backfaces = cull_backfaces;
  RasterImage rendered;
  Rasterize(mesh, camera.Cropped(area.x, area.y, area.width, area.height), cam_from_object, options, &rendered);
  for (int v = 0; v < area.height; ++v) {
    const float* r = rendered.depth.ptr<float>(v);
    const float* d = depth.ptr<float>(area.y + v) + area.x;
    uint8_t* out = corrected.ptr<uint8_t>(area.y + v) + area.x;
    for (int u = 0; u < area.width; ++u) {
      if (!(r[u] > 0.0f)) continue;
      const bool hidden = occlusion_margin_m > 0.0 && d[u] > 0.0f && d[u] < r[u] - occlusion_margin_m;
      out[u] = hidden ? 0 : 255;
    }
  }
  return corrected;
}

double MaskIntersectionOverUnion(const cv::Mat& a, const cv::Mat& b) {
  G6D_CHECK(a.type() == CV_8U && b.type() == CV_8U && a.size() == b.size());
  int intersection = 0, union_count = 0;
  for (int v = 0; v < a.rows; ++v) {
    const uint8_t* pa = a.ptr<uint8_t>(v);
    const uint8_t* pb = b.ptr<uint8_t>(v);
    for (int u = 0; u < a.cols; ++u) {
      intersection += pa[u] && pb[u];
      union_count += pa[u] || pb[u];
    }
  }
  return union_count > 0 ? static_cast<double>(intersection) / union_count : 0.0;
}

}  // namespace g6d
