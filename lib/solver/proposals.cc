#include "solver/proposals.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <queue>
#include <random>
#include <set>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "solver/plane.h"

namespace g6d {

namespace {

// (The same one-line test as detect.cc's: each file keeps its own.)
bool ValidDepth(float z) { return z > 0.0f && std::isfinite(z); }

using internal::FitPlane;
using internal::Plane;

// How far a depth point may lie from a plane and still be on it.
class PlaneTolerance {
 public:
  explicit PlaneTolerance(const DetectOptions& options)
      : noise_(options.segments.noise_sigmas * options.segments.sensor_noise_at_1m),
        flatness_(options.plane_flatness_m) {}
  PlaneTolerance(const DetectOptions& options, double flatness_m) : PlaneTolerance(options) { flatness_ = flatness_m; }
  double operator()(double z) const { return noise_ * z * z + flatness_; }
  double flatness() const { return flatness_; }

 private:
  double noise_, flatness_;
};

// The extent of a set of points (largest span over SpanDirections(), no trimming).
double PointsExtent(const std::vector<Eigen::Vector3d>& points) {
  Spans spans;
  spans.low.fill(std::numeric_limits<double>::infinity());
  spans.high.fill(-std::numeric_limits<double>::infinity());
  for (const Eigen::Vector3d& p : points) {
    for (int d = 0; d < kSpanDirections; ++d) {
      const double x = SpanDirections()[static_cast<size_t>(d)].dot(p);
      spans.low[static_cast<size_t>(d)] = std::min(spans.low[static_cast<size_t>(d)], x);
      spans.high[static_cast<size_t>(d)] = std::max(spans.high[static_cast<size_t>(d)], x);
    }
  }
  return points.empty() ? 0.0 : spans.Extent();
}

// The average of `values` over window x window squares, counting only the pixels where
// `weights` is 1 (`values` is 0 elsewhere); 0 where the square holds none.
cv::Mat WeightedAverage(const cv::Mat& values, const cv::Mat& weights, int window) {
  cv::Mat sum, count;
  cv::boxFilter(values, sum, CV_32F, cv::Size(window, window), cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  cv::boxFilter(weights, count, CV_32F, cv::Size(window, window), cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  cv::Mat average = cv::Mat::zeros(values.size(), CV_32F);
  for (int v = 0; v < values.rows; ++v) {
    const float* s = sum.ptr<float>(v);
    const float* c = count.ptr<float>(v);
    float* a = average.ptr<float>(v);
    for (int u = 0; u < values.cols; ++u) a[u] = c[u] > 0.5f ? s[u] / c[u] : 0.0f;
  }
  return average;
}

// The robust sigma of `values` (1.4826 times the median absolute deviation; reorders them).
double RobustSigma(std::vector<float>* values) {
  if (values->empty()) return 0.0;
  const auto middle = values->begin() + static_cast<std::ptrdiff_t>(values->size() / 2);
  std::nth_element(values->begin(), middle, values->end());
  const float median = *middle;
  for (float& x : *values) x = std::abs(x - median);
  std::nth_element(values->begin(), middle, values->end());
  return 1.4826 * *middle;
}

float Median(std::vector<float>* values) {
  const auto middle = values->begin() + static_cast<std::ptrdiff_t>(values->size() / 2);
  std::nth_element(values->begin(), middle, values->end());
  return *middle;
}

// The height above `plane` towards the camera of the pixels of `pixels` (CV_8U), and 1 in
// `weight` there; both CV_32F, 0 elsewhere.
void HeightsAbove(const Frame& frame, const Plane& plane, const cv::Mat& pixels, cv::Mat* height, cv::Mat* weight) {
  const cv::Mat& depth = frame.depth;
  const float toward = plane.Distance(Eigen::Vector3d::Zero()) >= 0.0 ? 1.0f : -1.0f;
  *height = cv::Mat::zeros(depth.size(), CV_32F);
  *weight = cv::Mat::zeros(depth.size(), CV_32F);
  for (int v = 0; v < depth.rows; ++v) {
    const uint8_t* o = pixels.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    float* h = height->ptr<float>(v);
    float* w = weight->ptr<float>(v);
    for (int u = 0; u < depth.cols; ++u) {
      if (!o[u]) continue;
      h[u] = toward * static_cast<float>(plane.Distance(frame.camera.Backproject(PixelCentre(u, v), d[u])));
      w[u] = 1.0f;
    }
  }
}

// |values| (CV_32F) at every other pixel of every other row where `mask` (CV_8U) is set.
std::vector<float> AbsoluteSamples(const cv::Mat& values, const cv::Mat& mask) {
  std::vector<float> samples;
  for (int v = 0; v < values.rows; v += 2) {
    const uint8_t* m = mask.ptr<uint8_t>(v);
    const float* x = values.ptr<float>(v);
    for (int u = 0; u < values.cols; u += 2) {
      if (m[u]) samples.push_back(std::abs(x[u]));
    }
  }
  return samples;
}

// The pixels of a plane's support (`on_support`, CV_8U 0/255) that stand above its local
// level (DetectOptions::raised_*): thin parts lying flat on it. CV_8U 0/255.
cv::Mat RaisedPixels(const Frame& frame, const Plane& plane, const cv::Mat& on_support, const DetectOptions& options) {
  const cv::Mat& depth = frame.depth;
  cv::Mat height, weight;
  HeightsAbove(frame, plane, on_support, &height, &weight);
  const cv::Mat smooth = WeightedAverage(height, weight, options.raised_window_px);
  cv::Mat raised = cv::Mat::zeros(depth.size(), CV_8U);
  // Twice: the second level leaves out what the first found raised (a large part lifts the
  // level under it).
  for (int pass = 0; pass < 2; ++pass) {
    cv::Mat level_weight = weight.clone();
    level_weight.setTo(0.0f, raised);
    cv::Mat level_height = height.clone();
    level_height.setTo(0.0f, raised);
    const cv::Mat level = WeightedAverage(level_height, level_weight, options.raised_level_px);
    const cv::Mat excess = smooth - level;
    std::vector<float> spread = AbsoluteSamples(excess, on_support);
    if (spread.empty()) return raised;
    std::nth_element(spread.begin(), spread.begin() + static_cast<std::ptrdiff_t>(spread.size() / 2), spread.end());
    const double sigma = 1.4826 * spread[spread.size() / 2];
    const float threshold = static_cast<float>(std::max(options.raised_sigmas * sigma, options.raised_min_height_m));
    raised = (excess > threshold) & on_support;
  }
  // Only connected parts the size of a segment (the noise leaves specks) that are flat: a
  // part lying on the support is level, its heights spread like the support's own; a real
  // sensor's depth smeared up towards an object's foot is a ramp.
  cv::Mat parts, stats, centroids;
  const int count = cv::connectedComponentsWithStats(raised, parts, stats, centroids, 8, CV_32S);
  if (count <= 1) return raised;
  std::vector<std::vector<float>> part_heights(static_cast<size_t>(count));
  std::vector<float> support_heights;
  for (int v = 0; v < depth.rows; ++v) {
    const int* l = parts.ptr<int>(v);
    const uint8_t* o = on_support.ptr<uint8_t>(v);
    const float* h = height.ptr<float>(v);
    for (int u = 0; u < depth.cols; ++u) {
      if (l[u] > 0) part_heights[static_cast<size_t>(l[u])].push_back(h[u]);
      else if (o[u] && (u + v) % 4 == 0) support_heights.push_back(h[u]);
    }
  }
  const double support_sigma = RobustSigma(&support_heights);
  std::vector<uint8_t> keep(static_cast<size_t>(count), 0);
  for (int k = 1; k < count; ++k) {
    std::vector<float>& heights = part_heights[static_cast<size_t>(k)];
    keep[static_cast<size_t>(k)] = static_cast<int>(heights.size()) >= options.segments.min_segment_pixels &&
                                   RobustSigma(&heights) <= options.raised_flatness * support_sigma;
  }
  for (int v = 0; v < depth.rows; ++v) {
    const int* l = parts.ptr<int>(v);
    uint8_t* r = raised.ptr<uint8_t>(v);
    for (int u = 0; u < depth.cols; ++u) {
      if (l[u] > 0 && !keep[static_cast<size_t>(l[u])]) r[u] = 0;
    }
  }
  return raised;
}

// Thin parts that the colour image outlines on a support (DetectOptions::raised_outline_*): a
// sheet-metal part on a bin's floor stands 1-3 mm above it, within a square's reach of the
// floor on every side, so RaisedPixels' smoothed height dilutes it; its outline in the colour
// image does not. An area of the support enclosed by colour edges, no larger than the largest
// object, is raised when its heights as a whole (their mean, its noise shrinking with its
// size) stand above the support around it (the median over a ring outside its edges) and are
// level like the support's own. A table's texture is outlined too, but is not above the table.
// CV_8U 0/255.
// `edges`: the colour image's edges (CV_8U 0/255, one pixel thin and 8-connected, so that
// they part the 4-connected areas on either side).
cv::Mat OutlinedRaisedPixels(const Frame& frame, const Plane& plane, const cv::Mat& on_support, const cv::Mat& edges,
                             double largest_diameter_m, const DetectOptions& options) {
  cv::Mat raised = cv::Mat::zeros(on_support.size(), CV_8U);
  if (edges.empty()) return raised;
  const cv::Mat areas = on_support & ~edges;
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(areas, labels, stats, centroids, 4, CV_32S);
  if (count <= 1) return raised;
  const cv::Mat& depth = frame.depth;
  const float toward = plane.Distance(Eigen::Vector3d::Zero()) >= 0.0 ? 1.0f : -1.0f;
  auto height_at = [&](int u, int v) {
    return toward * static_cast<float>(plane.Distance(frame.camera.Backproject(PixelCentre(u, v), depth.at<float>(v, u))));
  };
  std::vector<float> support_heights;
  for (int v = 0; v < depth.rows; v += 2) {
    const uint8_t* o = on_support.ptr<uint8_t>(v);
    for (int u = (v / 2) % 2; u < depth.cols; u += 2) {
      if (o[u]) support_heights.push_back(height_at(u, v));
    }
  }
  const double support_sigma = RobustSigma(&support_heights);
  const double focal = std::min(frame.camera.fx, frame.camera.fy);
  const int ring = options.raised_outline_ring_px;
  const cv::Mat ring_kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * ring + 1, 2 * ring + 1));
  for (int k = 1; k < count; ++k) {
    const int area = stats.at<int>(k, cv::CC_STAT_AREA);
    if (area < options.segments.min_segment_pixels) continue;
    const cv::Rect box(stats.at<int>(k, cv::CC_STAT_LEFT), stats.at<int>(k, cv::CC_STAT_TOP),
                       stats.at<int>(k, cv::CC_STAT_WIDTH), stats.at<int>(k, cv::CC_STAT_HEIGHT));
    const double z = depth.at<float>(cvRound(centroids.at<double>(k, 1)), cvRound(centroids.at<double>(k, 0)));
    const double object_px = focal * largest_diameter_m / (ValidDepth(static_cast<float>(z)) ? z : 1.0);
    if (std::max(box.width, box.height) > object_px || area > 0.25 * M_PI * object_px * object_px) continue;
    // Its heights, and the support's beyond its edges (outside the ring's inner edge band).
    const cv::Rect grown = (box + cv::Point(-ring, -ring) + cv::Size(2 * ring, 2 * ring)) & cv::Rect(0, 0, depth.cols, depth.rows);
    const cv::Mat inside = labels(grown) == k;
    cv::Mat around;
    cv::dilate(inside, around, ring_kernel);
    std::vector<float> heights, outside;
    for (int v = 0; v < grown.height; ++v) {
      const uint8_t* in = inside.ptr<uint8_t>(v);
      const uint8_t* a = around.ptr<uint8_t>(v);
      const uint8_t* o = on_support.ptr<uint8_t>(grown.y + v) + grown.x;
      const uint8_t* e = edges.ptr<uint8_t>(grown.y + v) + grown.x;
      for (int u = 0; u < grown.width; ++u) {
        if (in[u]) heights.push_back(height_at(grown.x + u, grown.y + v));
        else if (a[u] && o[u] && !e[u]) outside.push_back(height_at(grown.x + u, grown.y + v));
      }
    }
    if (static_cast<int>(outside.size()) < options.segments.min_segment_pixels) continue;
    double mean = 0.0;
    for (float h : heights) mean += h;
    mean /= static_cast<double>(heights.size());
    const double level = Median(&outside);
    std::vector<float> spread = heights;
    const double sigma = RobustSigma(&spread);
    if (sigma > options.raised_flatness * support_sigma) continue;  // a ramp, not a part lying flat
    // The sensor's noise is correlated over a few pixels: about one independent sample per 3 x 3.
    const double independent = std::max(1.0, heights.size() / 9.0);
    const double noise_at = options.segments.sensor_noise_at_1m * z * z;
    const double threshold = std::max({options.raised_min_height_m, options.raised_outline_min_noise * noise_at,
                                       options.raised_sigmas * sigma / std::sqrt(independent)});
    if (mean - level <= threshold) continue;
    raised(grown).setTo(255, inside);
  }
  return raised;
}

// How flat a support part is (DetectOptions::measure_plane_flatness): the 95th percentile of
// |its local level| above `plane`, the level being its heights averaged over
// raised_level_px squares (the sensor's noise averages out, a bend does not). `part`: CV_8U.
double MeasuredFlatness(const Frame& frame, const Plane& plane, const cv::Mat& part, const DetectOptions& options) {
  cv::Mat height, weight;
  HeightsAbove(frame, plane, part, &height, &weight);
  const cv::Mat level = WeightedAverage(height, weight, options.raised_level_px);
  std::vector<float> levels = AbsoluteSamples(level, part);
  if (levels.empty()) return options.plane_flatness_m;
  const auto at = levels.begin() + static_cast<std::ptrdiff_t>(0.95 * static_cast<double>(levels.size() - 1));
  std::nth_element(levels.begin(), at, levels.end());
  return std::min(options.plane_flatness_m, static_cast<double>(*at));
}

}  // namespace

int FindSupport(const Frame& frame, const DetectOptions& options, double largest_diameter_m, cv::Mat* support,
                cv::Mat* raised, std::vector<SupportPlane>* planes_out) {
  if (planes_out != nullptr) planes_out->clear();
  const cv::Mat& depth = frame.depth;
  *support = cv::Mat::zeros(depth.size(), CV_8U);
  if (raised != nullptr) *raised = cv::Mat::zeros(depth.size(), CV_8U);
  int valid = 0;
  for (int v = 0; v < depth.rows; ++v) {
    const float* d = depth.ptr<float>(v);
    for (int u = 0; u < depth.cols; ++u) valid += ValidDepth(d[u]);
  }
  if (valid < 3) return 0;
  const int step = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(valid) / options.plane_samples)));
  std::vector<Eigen::Vector3d> samples;
  std::vector<cv::Point> sample_pixels;
  for (int v = step / 2; v < depth.rows; v += step) {
    for (int u = step / 2; u < depth.cols; u += step) {
      const float z = depth.at<float>(v, u);
      if (!ValidDepth(z)) continue;
      samples.push_back(frame.camera.Backproject(PixelCentre(u, v), z));
      sample_pixels.push_back(cv::Point(u, v));
    }
  }
  const PlaneTolerance tolerance(options);
  cv::Mat edges;  // for OutlinedRaisedPixels
  if (options.raised_sigmas > 0.0 && options.raised_outline_edge > 0.0 && !frame.rgb.empty()) {
    cv::Mat gray;
    cv::cvtColor(frame.rgb, gray, cv::COLOR_RGB2GRAY);
    cv::Canny(gray, edges, options.raised_outline_edge, 2.0 * options.raised_outline_edge);
  }
  const size_t total_samples = samples.size();
  std::mt19937_64 random(1);
  int planes = 0;
  for (int round = 0; round < options.max_planes && samples.size() >= 3; ++round) {
    auto count_inliers = [&](const Plane& plane) {
      int count = 0;
      for (const Eigen::Vector3d& p : samples) count += std::abs(plane.Distance(p)) <= tolerance(p.z());
      return count;
    };
    int best_count = -1;
    const Plane best = internal::RansacPlane(
        samples, options.plane_iterations, [&](const Eigen::Vector3d& p) { return tolerance(p.z()); }, &random,
        &best_count);
    if (best_count < std::max(3.0, options.min_plane_fraction * static_cast<double>(total_samples))) break;
    std::vector<Eigen::Vector3d> inlier_points;
    for (const Eigen::Vector3d& p : samples) {
      if (std::abs(best.Distance(p)) <= tolerance(p.z())) inlier_points.push_back(p);
    }
    const Plane refit = FitPlane(inlier_points);
    const Plane plane = count_inliers(refit) >= best_count ? refit : best;
    // Full-resolution inliers within `within`, split into connected parts; the parts larger
    // than any object are support.
    cv::Mat parts;
    std::vector<uint8_t> is_support;
    bool any = false;
    auto split_parts = [&](const PlaneTolerance& within) {
      cv::Mat on_plane = cv::Mat::zeros(depth.size(), CV_8U);
      for (int v = 0; v < depth.rows; ++v) {
        const float* d = depth.ptr<float>(v);
        uint8_t* o = on_plane.ptr<uint8_t>(v);
        const uint8_t* s = support->ptr<uint8_t>(v);
        for (int u = 0; u < depth.cols; ++u) {
          if (s[u] || !ValidDepth(d[u])) continue;
          const Eigen::Vector3d p = frame.camera.Backproject(PixelCentre(u, v), d[u]);
          o[u] = std::abs(plane.Distance(p)) <= within(p.z()) ? 255 : 0;
        }
      }
      const int part_count = cv::connectedComponents(on_plane, parts, 8, CV_32S);
      std::vector<std::vector<Eigen::Vector3d>> part_points(static_cast<size_t>(part_count));
      for (int v = 0; v < depth.rows; v += 2) {
        const int* l = parts.ptr<int>(v);
        for (int u = 0; u < depth.cols; u += 2) {
          if (l[u] > 0) part_points[static_cast<size_t>(l[u])].push_back(frame.camera.Backproject(PixelCentre(u, v), depth.at<float>(v, u)));
        }
      }
      is_support.assign(static_cast<size_t>(part_count), 0);
      any = false;
      int largest = 0;
      size_t largest_points = 0;
      for (int k = 1; k < part_count; ++k) {
        const std::vector<Eigen::Vector3d>& points = part_points[static_cast<size_t>(k)];
        is_support[static_cast<size_t>(k)] = PointsExtent(points) > options.support_extent_factor * largest_diameter_m;
        any = any || is_support[static_cast<size_t>(k)];
        if (is_support[static_cast<size_t>(k)] && points.size() > largest_points) {
          largest = k;
          largest_points = points.size();
        }
      }
      return largest;
    };
    const int largest = split_parts(tolerance);
    if (any && options.measure_plane_flatness) {
      const double flatness = MeasuredFlatness(frame, plane, parts == largest, options);
      if (flatness < tolerance.flatness()) {
        split_parts(PlaneTolerance(options, flatness));
        if (!any) split_parts(tolerance);  // tighter, no part is large enough: as it was
      }
    }
    if (!any) break;  // the best plane is an object's face, or small: no support left
    ++planes;
    cv::Mat on_support = cv::Mat::zeros(depth.size(), CV_8U);
    for (int v = 0; v < depth.rows; ++v) {
      const int* l = parts.ptr<int>(v);
      uint8_t* s = on_support.ptr<uint8_t>(v);
      for (int u = 0; u < depth.cols; ++u) {
        if (l[u] > 0 && is_support[static_cast<size_t>(l[u])]) s[u] = 255;
      }
    }
    if (options.raised_sigmas > 0.0) {
      const cv::Mat above = RaisedPixels(frame, plane, on_support, options) |
                            OutlinedRaisedPixels(frame, plane, on_support, edges, largest_diameter_m, options);
      if (raised != nullptr) *raised |= above;
      else on_support.setTo(0, above);
    }
    *support |= on_support;
    if (planes_out != nullptr) {
      SupportPlane found;
      found.plane = plane;
      if (found.plane.offset < 0.0) {  // the camera (the origin) on the normal's side
        found.plane.normal = -found.plane.normal;
        found.plane.offset = -found.plane.offset;
      }
      found.pixels = on_support;
      found.noise_at_1m_m = options.segments.noise_sigmas * options.segments.sensor_noise_at_1m;
      found.flatness_m = options.plane_flatness_m;
      planes_out->push_back(std::move(found));
    }
    std::vector<Eigen::Vector3d> left;
    std::vector<cv::Point> left_pixels;
    for (size_t i = 0; i < samples.size(); ++i) {
      if (support->at<uint8_t>(sample_pixels[i])) continue;
      left.push_back(samples[i]);
      left_pixels.push_back(sample_pixels[i]);
    }
    samples.swap(left);
    sample_pixels.swap(left_pixels);
  }
  return planes;
}

const SupportPlane* SupportAround(const std::vector<SupportPlane>& planes, const cv::Mat& depth, const cv::Mat& region,
                                  double ring_fraction) {
  if (planes.empty() || region.empty()) return nullptr;
  const cv::Rect box = cv::boundingRect(region);
  if (box.area() == 0) return nullptr;
  const int ring = static_cast<int>(std::ceil(ring_fraction * std::max(box.width, box.height)));
  const cv::Rect roi = cv::Rect(box.x - ring, box.y - ring, box.width + 2 * ring, box.height + 2 * ring) &
                       cv::Rect(0, 0, region.cols, region.rows);
  // The ring: the box less the region; its pixels with depth, and each plane's share of them.
  const cv::Mat outside = region(roi) == 0;
  const int valid = cv::countNonZero(outside & (depth(roi) > 0.0f));
  const SupportPlane* under = nullptr;
  int most = 0;
  for (const SupportPlane& support : planes) {
    const int pixels = cv::countNonZero(support.pixels(roi) & outside);
    if (pixels > most) {
      most = pixels;
      under = &support;
    }
  }
  return under != nullptr && 2 * most > valid ? under : nullptr;
}

double DepthBehindFrameSupport(const std::vector<SupportPlane>& planes, const cv::Mat& depth, const cv::Mat& region,
                               double ring_fraction, const Mesh& mesh, const Eigen::Isometry3d& cam_from_object,
                               double* tolerance_m) {
  *tolerance_m = 0.0;
  const SupportPlane* under = SupportAround(planes, depth, region, ring_fraction);
  return under == nullptr ? 0.0 : DepthBehindPlane(*under, mesh, cam_from_object, tolerance_m);
}

double DepthBehindPlane(const SupportPlane& support, const Mesh& mesh, const Eigen::Isometry3d& cam_from_object,
                        double* tolerance_m) {
  *tolerance_m = 0.0;
  if (mesh.vertices.empty()) return 0.0;
  const Eigen::Vector3d normal = cam_from_object.linear().transpose() * support.plane.normal;
  const double offset = support.plane.offset + support.plane.normal.dot(cam_from_object.translation());
  double deepest = 0.0, at_z = cam_from_object.translation().z();
  for (const Eigen::Vector3f& vertex : mesh.vertices) {
    const double behind = -(normal.dot(vertex.cast<double>()) + offset);
    if (behind > deepest) {
      deepest = behind;
      at_z = (cam_from_object * vertex.cast<double>()).z();
    }
  }
  *tolerance_m = support.ToleranceAt(at_z);
  return deepest;
}

std::set<std::pair<int, int>> NeighbourSegments(const cv::Mat& labels, int gap_px) {
  const int cols = (labels.cols + gap_px - 1) / gap_px, rows = (labels.rows + gap_px - 1) / gap_px;
  std::vector<std::vector<int>> cells(static_cast<size_t>(cols * rows));
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    for (int u = 0; u < labels.cols; ++u) {
      if (l[u] <= 0) continue;
      std::vector<int>& cell = cells[static_cast<size_t>((v / gap_px) * cols + u / gap_px)];
      if (std::find(cell.begin(), cell.end(), l[u]) == cell.end()) cell.push_back(l[u]);
    }
  }
  std::set<std::pair<int, int>> pairs;
  for (int cy = 0; cy < rows; ++cy) {
    for (int cx = 0; cx < cols; ++cx) {
      const std::vector<int>& here = cells[static_cast<size_t>(cy * cols + cx)];
      for (int dy = 0; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          if (dy == 0 && dx < 0) continue;
          const int nx = cx + dx, ny = cy + dy;
          if (nx < 0 || nx >= cols || ny >= rows) continue;
          for (int a : here) {
            for (int b : cells[static_cast<size_t>(ny * cols + nx)]) {
              if (a != b) pairs.insert({std::min(a, b), std::max(a, b)});
            }
          }
        }
      }
    }
  }
  return pairs;
}

std::set<std::pair<int, int>> NeighboursAcrossGaps(const Camera& camera, const cv::Mat& depth, const cv::Mat& region,
                                                   const DepthSegmentation& segmentation, double reach_m,
                                                   double occluder_margin_m) {
  std::set<std::pair<int, int>> pairs;
  if (!(reach_m > 0.0)) return pairs;
  const cv::Mat& labels = segmentation.labels;
  if (labels.type() != CV_32S || depth.type() != CV_32F || region.type() != CV_8U || depth.size() != labels.size() ||
      region.size() != labels.size()) {
    G6D_THROW("NeighboursAcrossGaps: labels must be CV_32S, depth CV_32F and region CV_8U of one size (got types "
              << labels.type() << ", " << depth.type() << ", " << region.type() << ")");
  }
  const int width = labels.cols, height = labels.rows;
  const double focal_px = 0.5 * (camera.fx + camera.fy);
  std::vector<int> stamp(static_cast<size_t>(width) * static_cast<size_t>(height), 0);  // the segment that reached it
  std::vector<int> steps(stamp.size(), 0);
  std::vector<int> queue;
  const std::vector<DepthSegment>& segments = segmentation.segments;
  for (size_t k = 0; k < segments.size(); ++k) {
    const DepthSegment& segment = segments[k];
    const int label = static_cast<int>(k) + 1;
    if (segment.pixels == 0 || !(segment.median_depth_m > 0.0)) continue;
    const double z = segment.median_depth_m;
    const int reach_px = std::clamp(static_cast<int>(std::ceil(reach_m * focal_px / z)), 1, 200);
    const cv::Rect box = (segment.box + cv::Point(-reach_px, -reach_px) + cv::Size(2 * reach_px, 2 * reach_px)) &
                         cv::Rect(0, 0, width, height);
    queue.clear();
    for (int v = segment.box.y; v < segment.box.y + segment.box.height; ++v) {
      const int* l = labels.ptr<int>(v);
      for (int u = segment.box.x; u < segment.box.x + segment.box.width; ++u) {
        if (l[u] != label) continue;
        const size_t at = static_cast<size_t>(v) * width + u;
        stamp[at] = label;
        steps[at] = 0;
        queue.push_back(static_cast<int>(at));
      }
    }
    // Breadth first: every pixel is reached by its shortest path first.
    for (size_t head = 0; head < queue.size(); ++head) {
      const int at = queue[head];
      const int u = at % width, v = at / width;
      if (steps[static_cast<size_t>(at)] >= reach_px) continue;
      const int next_u[4] = {u + 1, u - 1, u, u};
      const int next_v[4] = {v, v, v + 1, v - 1};
      for (int n = 0; n < 4; ++n) {
        const int nu = next_u[n], nv = next_v[n];
        if (nu < box.x || nu >= box.x + box.width || nv < box.y || nv >= box.y + box.height) continue;
        const size_t next = static_cast<size_t>(nv) * width + nu;
        if (stamp[next] == label) continue;
        stamp[next] = label;
        const int other = labels.at<int>(nv, nu);
        bool passes = false;
        if (other > 0) {
          if (segments[static_cast<size_t>(other - 1)].median_depth_m < z - occluder_margin_m) {
            passes = true;  // an occluder: what it hides may continue behind it
          } else {
            pairs.insert({std::min(label, other), std::max(label, other)});
          }
        } else if (region.at<uint8_t>(nv, nu) != 0) {
          const float zq = depth.at<float>(nv, nu);
          passes = !ValidDepth(zq) || zq < z + occluder_margin_m;  // a hole, or a fragment not behind it
        }
        if (passes) {
          steps[next] = steps[static_cast<size_t>(at)] + 1;
          queue.push_back(static_cast<int>(next));
        }
      }
    }
  }
  return pairs;
}

cv::Mat RegionMask(const cv::Mat& labels, const Proposal& proposal) {
  if (!proposal.mask.empty()) return proposal.mask;
  cv::Mat mask = cv::Mat::zeros(labels.size(), CV_8U);
  for (int v = proposal.box.y; v < proposal.box.y + proposal.box.height; ++v) {
    const int* l = labels.ptr<int>(v);
    uint8_t* m = mask.ptr<uint8_t>(v);
    for (int u = proposal.box.x; u < proposal.box.x + proposal.box.width; ++u) {
      if (l[u] > 0 && std::binary_search(proposal.segments.begin(), proposal.segments.end(), l[u])) m[u] = 255;
    }
  }
  return mask;
}

cv::Mat FilledRegionMask(const cv::Mat& labels, const cv::Mat& support, const Proposal& proposal, int gap_px) {
  if (!proposal.mask.empty()) return proposal.mask;  // a voted pose's surface: whole already
  cv::Mat mask = RegionMask(labels, proposal);
  if (gap_px <= 0) return mask;
  cv::Mat grown;
  cv::dilate(mask, grown, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * gap_px + 1, 2 * gap_px + 1)));
  const cv::Rect box = (proposal.box + cv::Point(-gap_px, -gap_px) + cv::Size(2 * gap_px, 2 * gap_px)) &
                       cv::Rect(0, 0, labels.cols, labels.rows);
  for (int v = box.y; v < box.y + box.height; ++v) {
    const int* l = labels.ptr<int>(v);
    const uint8_t* s = support.ptr<uint8_t>(v);
    const uint8_t* g = grown.ptr<uint8_t>(v);
    uint8_t* m = mask.ptr<uint8_t>(v);
    for (int u = box.x; u < box.x + box.width; ++u) {
      if (g[u] && l[u] == 0 && !s[u]) m[u] = 255;
    }
  }
  return mask;
}

int PixelsInside(const cv::Mat& labels, const Proposal& proposal, const cv::Mat& within) {
  if (!proposal.mask.empty()) return cv::countNonZero(proposal.mask & within);
  int inside = 0;
  for (int v = proposal.box.y; v < proposal.box.y + proposal.box.height; ++v) {
    const int* l = labels.ptr<int>(v);
    const uint8_t* w = within.ptr<uint8_t>(v);
    for (int u = proposal.box.x; u < proposal.box.x + proposal.box.width; ++u) {
      inside += w[u] && l[u] > 0 && std::binary_search(proposal.segments.begin(), proposal.segments.end(), l[u]);
    }
  }
  return inside;
}

int SharedPixels(const Proposal& a, const Proposal& b, const DepthSegmentation& segmentation, const cv::Mat& depth) {
  if (!a.mask.empty() || !b.mask.empty()) {
    const cv::Mat a_pixels = RegionMask(segmentation.labels, a), b_pixels = RegionMask(segmentation.labels, b);
    const cv::Rect box = a.box & b.box;
    int shared = 0;
    for (int v = box.y; v < box.y + box.height; ++v) {
      const uint8_t* pa = a_pixels.ptr<uint8_t>(v);
      const uint8_t* pb = b_pixels.ptr<uint8_t>(v);
      const float* d = depth.ptr<float>(v);
      for (int u = box.x; u < box.x + box.width; ++u) shared += pa[u] && pb[u] && ValidDepth(d[u]);
    }
    return shared;
  }
  const std::vector<DepthSegment>& segments = segmentation.segments;
  int shared = 0;
  for (int s : a.segments) {
    if (std::binary_search(b.segments.begin(), b.segments.end(), s)) shared += segments[static_cast<size_t>(s - 1)].pixels;
  }
  return shared;
}

int SplitAtNecks(const cv::Mat& island, double core_fraction, int window_px, int min_core_px, cv::Mat* pieces,
                 std::set<std::pair<int, int>>* touching) {
  if (island.empty() || island.type() != CV_8U) G6D_THROW("SplitAtNecks: the island must be CV_8U");
  if (!(core_fraction > 0.0 && core_fraction <= 1.0)) G6D_THROW("SplitAtNecks: core_fraction must be in (0, 1] (got " << core_fraction << ")");
  if (window_px < 1) G6D_THROW("SplitAtNecks: window_px must be >= 1 (got " << window_px << ")");
  *pieces = cv::Mat::zeros(island.size(), CV_32S);
  if (touching != nullptr) touching->clear();
  // The distance to the island's edge, with the frame's border as edge too.
  cv::Mat padded;
  cv::copyMakeBorder(island > 0, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat distance;
  cv::distanceTransform(padded, distance, cv::DIST_L2, cv::DIST_MASK_3);
  distance = distance(cv::Rect(1, 1, island.cols, island.rows)).clone();
  // Cores: the pixels at least core_fraction as far from the edge as the farthest pixel
  // around them. Where two objects touch, the island's neck is thinner than both objects,
  // so no core crosses it.
  cv::Mat local_max;
  const int side = 2 * window_px + 1;
  cv::dilate(distance, local_max, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(side, side)));  // separable: fast
  cv::Mat cores = (distance >= core_fraction * local_max) & (distance >= 1.5f) & (island > 0);
  cv::Mat core_labels, stats, centroids;
  const int found = cv::connectedComponentsWithStats(cores, core_labels, stats, centroids, 8, CV_32S);
  // Cores of fewer than min_core_px pixels are noise on the edge: their pixels go to a
  // neighbouring piece.
  std::vector<int> renumber(static_cast<size_t>(found), 0);
  int count = 0;
  for (int k = 1; k < found; ++k) {
    if (stats.at<int>(k, cv::CC_STAT_AREA) >= min_core_px) renumber[static_cast<size_t>(k)] = ++count;
  }
  if (count == 0) return 0;
  // Grow the cores back over the island, farthest from the edge first (a flood by
  // decreasing distance): each pixel joins the core that reaches it first from above.
  struct Item {
    float distance;
    int index;
    bool operator<(const Item& other) const { return distance < other.distance || (distance == other.distance && index > other.index); }
  };
  std::priority_queue<Item> queue;
  const int cols = island.cols;
  for (int v = 0; v < island.rows; ++v) {
    const int* c = core_labels.ptr<int>(v);
    int* p = pieces->ptr<int>(v);
    const float* d = distance.ptr<float>(v);
    for (int u = 0; u < cols; ++u) {
      const int label = renumber[static_cast<size_t>(c[u])];
      if (label == 0) continue;
      p[u] = label;
      queue.push({d[u], v * cols + u});
    }
  }
  int* labels = pieces->ptr<int>(0);
  const uint8_t* inside = island.ptr<uint8_t>(0);
  const float* far = distance.ptr<float>(0);
  const bool continuous = island.isContinuous() && pieces->isContinuous() && distance.isContinuous();
  if (!continuous) G6D_THROW("SplitAtNecks: the island must be a continuous matrix");
  while (!queue.empty()) {
    const Item item = queue.top();
    queue.pop();
    const int u = item.index % cols, v = item.index / cols;
    const int label = labels[item.index];
    const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
    for (int n = 0; n < 4; ++n) {
      const int x = u + du[n], y = v + dv[n];
      if (x < 0 || y < 0 || x >= cols || y >= island.rows) continue;
      const int index = y * cols + x;
      if (!inside[index]) continue;
      if (labels[index] == 0) {
        labels[index] = label;
        queue.push({far[index], index});
      } else if (labels[index] != label && touching != nullptr) {
        touching->insert({std::min(label, labels[index]), std::max(label, labels[index])});
      }
    }
  }
  return count;
}

std::vector<Proposal> FormIslands(const Frame& frame, const cv::Mat& region, double largest_extent_m,
                                  const DetectOptions& options) {
  std::vector<Proposal> islands;
  if (options.island_open_px < 0) return islands;
  cv::Mat opened;
  const int side = 2 * options.island_open_px + 1;
  cv::morphologyEx(region > 0, opened, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(side, side)));
  cv::Mat parts, stats, centroids;
  const int count = cv::connectedComponentsWithStats(opened, parts, stats, centroids, 8, CV_32S);
  if (count <= 1) return islands;
  // Their pixels with depth, labelled as segments.
  cv::Mat labels = cv::Mat::zeros(parts.size(), CV_32S);
  for (int v = 0; v < parts.rows; ++v) {
    const int* p = parts.ptr<int>(v);
    const float* d = frame.depth.ptr<float>(v);
    int* l = labels.ptr<int>(v);
    for (int u = 0; u < parts.cols; ++u) {
      if (p[u] > 0 && ValidDepth(d[u])) l[u] = p[u];
    }
  }
  const std::vector<DepthSegment> statistics = SegmentStatistics(frame.camera, frame.depth, labels, count - 1);
  const double focal = std::min(frame.camera.fx, frame.camera.fy);
  // A region with its own mask, from its pixels' statistics.
  auto make = [&](const DepthSegment& segment, const cv::Rect& box, cv::Mat mask, int mask_pixels) {
    Proposal proposal;
    proposal.box = box;
    proposal.pixels = segment.pixels;
    proposal.mask_pixels = mask_pixels;
    proposal.depth_m = segment.median_depth_m;
    proposal.extent_m = std::max(segment.spans.Extent(), std::max(box.width, box.height) * segment.median_depth_m / focal);
    for (int axis = 0; axis < 3; ++axis) {
      proposal.centre_m[axis] = 0.5 * (segment.spans.low[static_cast<size_t>(axis)] + segment.spans.high[static_cast<size_t>(axis)]);
    }
    proposal.mask = std::move(mask);
    return proposal;
  };
  for (int k = 1; k < count; ++k) {
    const DepthSegment& island = statistics[static_cast<size_t>(k - 1)];
    if (island.pixels < options.segments.min_segment_pixels) continue;
    const cv::Rect box(stats.at<int>(k, cv::CC_STAT_LEFT), stats.at<int>(k, cv::CC_STAT_TOP),
                       stats.at<int>(k, cv::CC_STAT_WIDTH), stats.at<int>(k, cv::CC_STAT_HEIGHT));
    Proposal whole = make(island, box, parts == k, stats.at<int>(k, cv::CC_STAT_AREA));
    const bool fits = whole.extent_m <= largest_extent_m;
    if (fits) islands.push_back(std::move(whole));
    if (options.island_split_core <= 0.0) continue;
    // Objects that touch make one island: its pieces split at its necks, and pairs of
    // touching pieces, are regions too (a part thin in its middle splits in two).
    const double object_px = focal * largest_extent_m / island.median_depth_m;
    if (std::max(box.width, box.height) < 0.5 * object_px && fits) continue;  // too small to hold two
    const int window_px = std::max(2, static_cast<int>(std::lround(options.island_split_window * object_px)));
    cv::Mat pieces;
    std::set<std::pair<int, int>> touching;
    const cv::Mat in_box = parts(box) == k;
    const int n = SplitAtNecks(in_box, options.island_split_core, window_px, options.island_split_min_core_px, &pieces, &touching);
    if (n < 2) continue;
    if (n > options.island_split_max_pieces) continue;  // not a pile of objects: a wall, a floor
    // The pieces' statistics, in the island's box (its camera cropped to it).
    cv::Mat piece_depth_labels = cv::Mat::zeros(box.size(), CV_32S);
    for (int v = 0; v < box.height; ++v) {
      const int* p = pieces.ptr<int>(v);
      const int* l = labels.ptr<int>(box.y + v) + box.x;
      int* out = piece_depth_labels.ptr<int>(v);
      for (int u = 0; u < box.width; ++u) out[u] = l[u] > 0 ? p[u] : 0;
    }
    const std::vector<DepthSegment> piece_statistics = SegmentStatistics(
        frame.camera.Cropped(box.x, box.y, box.width, box.height), frame.depth(box), piece_depth_labels, n);
    std::vector<cv::Rect> piece_boxes(static_cast<size_t>(n));  // in the island's box
    for (int i = 1; i <= n; ++i) piece_boxes[static_cast<size_t>(i - 1)] = cv::boundingRect(pieces == i);
    // A piece, or two touching ones, as a region when it fits the largest object.
    auto add = [&](const DepthSegment& segment, const cv::Rect& piece_box, int a, int b) {
      if (segment.pixels < options.segments.min_segment_pixels) return;
      cv::Mat local = pieces(piece_box) == a;
      if (b > 0) local |= pieces(piece_box) == b;
      cv::Mat mask = cv::Mat::zeros(parts.size(), CV_8U);
      local.copyTo(mask(piece_box + box.tl()));
      Proposal proposal = make(segment, piece_box + box.tl(), std::move(mask), cv::countNonZero(local));
      if (proposal.extent_m > largest_extent_m) return;
      proposal.island_piece = true;
      islands.push_back(std::move(proposal));
    };
    for (int i = 0; i < n; ++i) {
      add(piece_statistics[static_cast<size_t>(i)], piece_boxes[static_cast<size_t>(i)], i + 1, 0);
    }
    if (n == 2 && fits) continue;  // the pair is the whole island
    for (const auto& [a, b] : touching) {
      const DepthSegment& first = piece_statistics[static_cast<size_t>(a - 1)];
      const DepthSegment& second = piece_statistics[static_cast<size_t>(b - 1)];
      if (first.pixels == 0 || second.pixels == 0) continue;
      DepthSegment both;
      both.pixels = first.pixels + second.pixels;
      both.median_depth_m = (first.pixels * first.median_depth_m + second.pixels * second.median_depth_m) / both.pixels;
      both.spans = first.spans.Union(second.spans);
      add(both, piece_boxes[static_cast<size_t>(a - 1)] | piece_boxes[static_cast<size_t>(b - 1)], a, b);
    }
  }
  return islands;
}

std::vector<Proposal> FormRegions(const DepthSegmentation& segmentation, const std::set<std::pair<int, int>>& neighbours,
                                  double largest_extent_m, const DetectOptions& options) {
  const std::vector<DepthSegment>& segments = segmentation.segments;
  std::map<int, std::vector<int>> adjacent;
  for (const auto& [a, b] : neighbours) {
    adjacent[a].push_back(b);
    adjacent[b].push_back(a);
  }
  struct Partial {
    std::vector<int> members;  // sorted labels
    Spans spans;
  };
  std::set<std::vector<int>> seen;
  std::vector<Partial> level;
  for (size_t k = 0; k < segments.size(); ++k) {
    if (segments[k].spans.Extent() > largest_extent_m) continue;
    Partial single{{static_cast<int>(k) + 1}, segments[k].spans};
    seen.insert(single.members);
    level.push_back(single);
  }
  std::vector<Partial> all = level;
  for (int size = 2; size <= options.max_union_segments && !level.empty(); ++size) {
    std::vector<Partial> next;
    for (const Partial& partial : level) {
      for (int member : partial.members) {
        for (int other : adjacent[member]) {
          if (std::binary_search(partial.members.begin(), partial.members.end(), other)) continue;
          const DepthSegment& segment = segments[static_cast<size_t>(other - 1)];
          const Spans spans = partial.spans.Union(segment.spans);
          if (spans.Extent() > largest_extent_m) continue;
          std::vector<int> members = partial.members;
          members.insert(std::upper_bound(members.begin(), members.end(), other), other);
          if (!seen.insert(members).second) continue;
          next.push_back({members, spans});
          if (static_cast<int>(all.size() + next.size()) >= options.max_regions) break;
        }
      }
    }
    all.insert(all.end(), next.begin(), next.end());
    level.swap(next);
    if (static_cast<int>(all.size()) >= options.max_regions) break;
  }
  std::vector<Proposal> proposals;
  for (const Partial& partial : all) {
    Proposal proposal;
    proposal.segments = partial.members;
    double weighted_depth = 0.0;
    for (int label : partial.members) {
      const DepthSegment& segment = segments[static_cast<size_t>(label - 1)];
      proposal.box = proposal.pixels == 0 ? segment.box : (proposal.box | segment.box);
      proposal.pixels += segment.pixels;
      weighted_depth += segment.median_depth_m * segment.pixels;
    }
    proposal.depth_m = weighted_depth / std::max(1, proposal.pixels);
    proposal.extent_m = partial.spans.Extent();
    // The centre of the spans along the camera axes (directions 0..2).
    for (int axis = 0; axis < 3; ++axis) {
      proposal.centre_m[axis] = 0.5 * (partial.spans.low[static_cast<size_t>(axis)] + partial.spans.high[static_cast<size_t>(axis)]);
    }
    proposals.push_back(proposal);
  }
  return proposals;
}

}  // namespace g6d
