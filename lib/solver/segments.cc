#include "solver/segments.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace g6d {

std::string SegmentOptions::Check() const {
  std::ostringstream out;
  if (!(sensor_noise_at_1m >= 0.0 && sensor_noise_at_1m < 0.1)) out << "SegmentOptions.sensor_noise_at_1m must be in [0, 0.1) m (got " << sensor_noise_at_1m << ")";
  else if (!(noise_sigmas > 0.0 && noise_sigmas <= 10.0)) out << "SegmentOptions.noise_sigmas must be in (0, 10] (got " << noise_sigmas << ")";
  else if (!(max_incidence_deg >= 0.0 && max_incidence_deg < 89.0)) out << "SegmentOptions.max_incidence_deg must be in [0, 89) (got " << max_incidence_deg << ")";
  else if (min_segment_pixels < 1) out << "SegmentOptions.min_segment_pixels must be >= 1 (got " << min_segment_pixels << ")";
  else if (!(crease_half_span_m >= 0.0 && crease_half_span_m < 1.0)) out << "SegmentOptions.crease_half_span_m must be in [0, 1) m (got " << crease_half_span_m << ")";
  else if (crease_erode_px < 0) out << "SegmentOptions.crease_erode_px must be >= 0 (got " << crease_erode_px << ")";
  else if (!(crease_min_depth_m >= 0.0)) out << "SegmentOptions.crease_min_depth_m must be >= 0 m (got " << crease_min_depth_m << ")";
  return out.str();
}

const std::array<Eigen::Vector3d, kSpanDirections>& SpanDirections() {
  static const std::array<Eigen::Vector3d, kSpanDirections> directions = [] {
    const Eigen::Vector3d raw[kSpanDirections] = {
        {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {1, 0, -1},
        {0, 1, 1}, {0, 1, -1}, {1, 1, 1}, {1, 1, -1}, {1, -1, 1}, {-1, 1, 1}};
    std::array<Eigen::Vector3d, kSpanDirections> unit;
    for (int k = 0; k < kSpanDirections; ++k) unit[static_cast<size_t>(k)] = raw[k].normalized();
    return unit;
  }();
  return directions;
}

Spans Spans::Union(const Spans& other) const {
  Spans spans;
  for (size_t k = 0; k < low.size(); ++k) {
    spans.low[k] = std::min(low[k], other.low[k]);
    spans.high[k] = std::max(high[k], other.high[k]);
  }
  return spans;
}

double Spans::Extent() const {
  double extent = 0.0;
  for (size_t k = 0; k < low.size(); ++k) extent = std::max(extent, high[k] - low[k]);
  return extent;
}

namespace {

// Union-find over the pixels of a box, with path halving and union by index (the smaller
// root wins, so the result does not depend on the order of the unions).
class DisjointSets {
 public:
  explicit DisjointSets(size_t count) : parent_(count) { std::iota(parent_.begin(), parent_.end(), 0); }
  int Find(int i) {
    while (parent_[static_cast<size_t>(i)] != i) {
      parent_[static_cast<size_t>(i)] = parent_[static_cast<size_t>(parent_[static_cast<size_t>(i)])];
      i = parent_[static_cast<size_t>(i)];
    }
    return i;
  }
  void Union(int a, int b) {
    a = Find(a);
    b = Find(b);
    if (a == b) return;
    if (a < b) std::swap(a, b);
    parent_[static_cast<size_t>(a)] = b;
  }

 private:
  std::vector<int> parent_;
};

// The largest step between neighbouring pixels of one surface at depth z: the noise of
// both (σ(z) = noise_at_1m · z², independent: √2 σ) and the slope of a surface seen at the
// steepest incidence over one pixel (z · tan θ / f, f the shorter focal length).
class SurfaceStep {
 public:
  SurfaceStep(const Camera& camera, const SegmentOptions& options)
      : noise_(options.noise_sigmas * std::sqrt(2.0) * options.sensor_noise_at_1m),
        slope_(std::tan(options.max_incidence_deg * M_PI / 180.0) / std::min(camera.fx, camera.fy)) {}
  double operator()(double z) const { return noise_ * z * z + z * slope_; }

 private:
  double noise_, slope_;
};

}  // namespace

std::vector<DepthSegment> SegmentStatistics(const Camera& camera, const cv::Mat& depth, const cv::Mat& labels,
                                            int count) {
  const size_t n = static_cast<size_t>(count);
  std::vector<DepthSegment> segments(n);
  std::vector<std::vector<float>> depths(n);
  std::vector<std::vector<Eigen::Vector3d>> points(n);
  std::vector<cv::Point> low(n, cv::Point(labels.cols, labels.rows));
  std::vector<cv::Point> high(n, cv::Point(-1, -1));
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const float* d = depth.ptr<float>(v);
    for (int u = 0; u < labels.cols; ++u) {
      if (l[u] <= 0) continue;
      const size_t k = static_cast<size_t>(l[u] - 1);
      depths[k].push_back(d[u]);
      points[k].push_back(camera.Backproject(PixelCentre(u, v), d[u]));
      low[k] = cv::Point(std::min(low[k].x, u), std::min(low[k].y, v));
      high[k] = cv::Point(std::max(high[k].x, u), std::max(high[k].y, v));
    }
  }
  for (size_t k = 0; k < n; ++k) {
    DepthSegment& segment = segments[k];
    segment.pixels = static_cast<int>(depths[k].size());
    if (segment.pixels == 0) continue;
    segment.box = cv::Rect(low[k], high[k] + cv::Point(1, 1));
    const auto middle = depths[k].begin() + static_cast<std::ptrdiff_t>(depths[k].size() / 2);
    std::nth_element(depths[k].begin(), middle, depths[k].end());
    segment.median_depth_m = *middle;
    // Spans between the 2% and 98% quantiles of the projections.
    std::vector<double> projections(points[k].size());
    const size_t trim = points[k].size() / 50;
    for (int d = 0; d < kSpanDirections; ++d) {
      const Eigen::Vector3d& direction = SpanDirections()[static_cast<size_t>(d)];
      for (size_t i = 0; i < points[k].size(); ++i) projections[i] = direction.dot(points[k][i]);
      std::nth_element(projections.begin(), projections.begin() + static_cast<std::ptrdiff_t>(trim), projections.end());
      segment.spans.low[static_cast<size_t>(d)] = projections[trim];
      const size_t top = projections.size() - 1 - trim;
      std::nth_element(projections.begin(), projections.begin() + static_cast<std::ptrdiff_t>(top), projections.end());
      segment.spans.high[static_cast<size_t>(d)] = projections[top];
    }
  }
  return segments;
}

cv::Mat BridgeDepthHoles(const Camera& camera, const cv::Mat& depth, int max_gap_px, const SegmentOptions& options) {
  if (depth.type() != CV_32F) G6D_THROW("BridgeDepthHoles: depth must be CV_32F (got type " << depth.type() << ")");
  if (max_gap_px <= 0) return depth;
  const double noise = 2.0 * options.noise_sigmas * options.sensor_noise_at_1m;  // times z^2
  const double slope = 1.0 / std::min(camera.fx, camera.fy);                      // 45 degrees: z per pixel
  auto measured = [](float z) { return z > 0.0f && std::isfinite(z); };
  cv::Mat out = depth.clone();
  cv::Mat span(depth.size(), CV_32S, cv::Scalar(std::numeric_limits<int>::max()));  // the bridge's length so far
  // One line of pixels (a row or a column): z(k) for k in [0, n).
  auto bridge_line = [&](int n, const auto& z_at, const auto& set) {
    int last = -1;  // the last measured pixel
    for (int k = 0; k < n; ++k) {
      const float z = z_at(k);
      if (!measured(z)) continue;
      const int gap = k - last - 1;
      if (last >= 0 && gap > 0 && gap <= max_gap_px) {
        const float a = z_at(last);
        const double far = std::max(a, z);
        if (std::abs(a - z) <= noise * far * far + (gap + 1) * far * slope) {
          for (int j = last + 1; j < k; ++j) set(j, a + (z - a) * static_cast<float>(j - last) / (gap + 1), gap);
        }
      }
      last = k;
    }
  };
  for (int v = 0; v < depth.rows; ++v) {
    const float* row = depth.ptr<float>(v);
    bridge_line(
        depth.cols, [&](int u) { return row[u]; },
        [&](int u, float z, int gap) {
          out.at<float>(v, u) = z;
          span.at<int>(v, u) = gap;
        });
  }
  for (int u = 0; u < depth.cols; ++u) {
    bridge_line(
        depth.rows, [&](int v) { return depth.at<float>(v, u); },
        [&](int v, float z, int gap) {
          if (gap < span.at<int>(v, u)) {
            out.at<float>(v, u) = z;
            span.at<int>(v, u) = gap;
          }
        });
  }
  return out;
}

DepthSegmentation SegmentByDepth(const Camera& camera, const cv::Mat& depth, const cv::Mat& region,
                                 const SegmentOptions& options) {
  const std::string bad = options.Check();
  if (!bad.empty()) G6D_THROW(bad);
  if (depth.type() != CV_32F || region.type() != CV_8U || depth.size() != region.size()) {
    G6D_THROW("SegmentByDepth: depth must be CV_32F and region CV_8U of one size (got types " << depth.type() << ", "
              << region.type() << ", sizes " << depth.cols << "x" << depth.rows << ", " << region.cols << "x"
              << region.rows << ")");
  }
  DepthSegmentation result;
  result.labels = cv::Mat::zeros(region.size(), CV_32S);
  const cv::Rect box = cv::boundingRect(region);
  if (box.area() == 0) return result;

  auto valid_at = [&](int u, int v) {
    const float z = depth.at<float>(v, u);
    return region.at<uint8_t>(v, u) != 0 && z > 0.0f && std::isfinite(z);
  };
  const SurfaceStep max_step_m(camera, options);

  const int width = box.width;
  auto index = [&](int u, int v) { return (v - box.y) * width + (u - box.x); };
  DisjointSets sets(static_cast<size_t>(box.area()));
  for (int v = box.y; v < box.y + box.height; ++v) {
    for (int u = box.x; u < box.x + box.width; ++u) {
      if (!valid_at(u, v)) continue;
      const float z = depth.at<float>(v, u);
      if (u + 1 < box.x + box.width && valid_at(u + 1, v)) {
        const float right = depth.at<float>(v, u + 1);
        if (std::abs(right - z) <= max_step_m(std::max(z, right))) sets.Union(index(u, v), index(u + 1, v));
      }
      if (v + 1 < box.y + box.height && valid_at(u, v + 1)) {
        const float below = depth.at<float>(v + 1, u);
        if (std::abs(below - z) <= max_step_m(std::max(z, below))) sets.Union(index(u, v), index(u, v + 1));
      }
    }
  }
  // Component sizes by root; segments ordered by size (ties: the first pixel in raster order).
  std::vector<int> size(static_cast<size_t>(box.area()), 0);
  for (int v = box.y; v < box.y + box.height; ++v) {
    for (int u = box.x; u < box.x + box.width; ++u) {
      if (valid_at(u, v)) ++size[static_cast<size_t>(sets.Find(index(u, v)))];
    }
  }
  std::vector<int> roots;
  for (int i = 0; i < box.area(); ++i) {
    if (size[static_cast<size_t>(i)] >= options.min_segment_pixels) roots.push_back(i);
  }
  std::stable_sort(roots.begin(), roots.end(),
                   [&](int a, int b) { return size[static_cast<size_t>(a)] > size[static_cast<size_t>(b)]; });
  std::vector<int> label_of_root(static_cast<size_t>(box.area()), 0);
  for (size_t k = 0; k < roots.size(); ++k) label_of_root[static_cast<size_t>(roots[k])] = static_cast<int>(k) + 1;
  for (int v = box.y; v < box.y + box.height; ++v) {
    int* labels = result.labels.ptr<int>(v);
    for (int u = box.x; u < box.x + box.width; ++u) {
      if (valid_at(u, v)) labels[u] = label_of_root[static_cast<size_t>(sets.Find(index(u, v)))];
    }
  }
  result.segments = SegmentStatistics(camera, depth, result.labels, static_cast<int>(roots.size()));
  return result;
}

cv::Mat GrowRegionByDepth(const Camera& camera, const cv::Mat& depth, const cv::Mat& mask, const cv::Mat& support,
                          double reach_m, int max_steps_px, double min_covered_fraction,
                          const SegmentOptions& options) {
  const std::string bad = options.Check();
  if (!bad.empty()) G6D_THROW(bad);
  if (depth.type() != CV_32F || mask.type() != CV_8U || depth.size() != mask.size() ||
      (!support.empty() && (support.type() != CV_8U || support.size() != mask.size()))) {
    G6D_THROW("GrowRegionByDepth: depth must be CV_32F, mask and support CV_8U, all of one size");
  }
  cv::Mat grown = mask > 0;
  // The mask's median point: the centre of the reach.
  std::vector<float> xs, ys, zs;
  for (int v = 0; v < mask.rows; ++v) {
    const uint8_t* m = grown.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    for (int u = 0; u < mask.cols; ++u) {
      if (!m[u] || !(d[u] > 0.0f) || !std::isfinite(d[u])) continue;
      const Eigen::Vector3d p = camera.Backproject(PixelCentre(u, v), d[u]);
      xs.push_back(static_cast<float>(p.x()));
      ys.push_back(static_cast<float>(p.y()));
      zs.push_back(static_cast<float>(p.z()));
    }
  }
  if (xs.empty() || max_steps_px <= 0) return grown;
  auto median = [](std::vector<float>* values) {
    auto middle = values->begin() + static_cast<std::ptrdiff_t>(values->size() / 2);
    std::nth_element(values->begin(), middle, values->end());
    return static_cast<double>(*middle);
  };
  const Eigen::Vector3d centre(median(&xs), median(&ys), median(&zs));
  const SurfaceStep max_step_m(camera, options);
  auto usable = [&](int u, int v) {
    const float z = depth.at<float>(v, u);
    return z > 0.0f && std::isfinite(z) && (support.empty() || !support.at<uint8_t>(v, u));
  };
  // Breadth first, one ring of pixels per step.
  std::vector<cv::Point> front;
  for (int v = 0; v < mask.rows; ++v) {
    for (int u = 0; u < mask.cols; ++u) {
      if (grown.at<uint8_t>(v, u) && usable(u, v)) front.push_back(cv::Point(u, v));
    }
  }
  const int du[4] = {-1, 1, 0, 0}, dv[4] = {0, 0, -1, 1};
  for (int step = 0; step < max_steps_px && !front.empty(); ++step) {
    std::vector<cv::Point> next;
    for (const cv::Point& p : front) {
      const float z = depth.at<float>(p.y, p.x);
      for (int k = 0; k < 4; ++k) {
        const int u = p.x + du[k], v = p.y + dv[k];
        if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows || grown.at<uint8_t>(v, u) || !usable(u, v)) continue;
        const float zq = depth.at<float>(v, u);
        if (std::abs(zq - z) > max_step_m(std::max(z, zq))) continue;
        if ((camera.Backproject(PixelCentre(u, v), zq) - centre).norm() > reach_m) continue;
        grown.at<uint8_t>(v, u) = 255;
        next.push_back(cv::Point(u, v));
      }
    }
    front.swap(next);
  }
  if (min_covered_fraction <= 0.0) return grown;
  // Growth from a leak: a mask that reached a neighbour's surface covers a thin rim of it,
  // and the growth would go on over the whole neighbour. The mask owns the segments of the
  // grown region it covers at least `min_covered_fraction` of (as a pose owns segments,
  // ScoreOptions::segment_own_fraction); the others keep only the mask's own pixels.
  const DepthSegmentation segmentation = SegmentByDepth(camera, depth, grown, options);
  std::vector<int> covered(segmentation.segments.size() + 1, 0);
  for (int v = 0; v < mask.rows; ++v) {
    const uint8_t* m = mask.ptr<uint8_t>(v);
    const int* label = segmentation.labels.ptr<int>(v);
    for (int u = 0; u < mask.cols; ++u) {
      if (m[u] && label[u] > 0) ++covered[static_cast<size_t>(label[u])];
    }
  }
  // The rims of segments the mask does not own leave the region too, unless that would take
  // most of the mask's depth away (then the mask is mostly on such a segment: the object
  // touches a neighbour at the same depth, and the mask is the better guess).
  auto owned = [&](int label) {
    return label > 0 && covered[static_cast<size_t>(label)] >=
                            min_covered_fraction * segmentation.segments[static_cast<size_t>(label) - 1].pixels;
  };
  cv::Mat result = cv::Mat::zeros(mask.size(), CV_8U);
  int kept = 0, with_depth = 0;
  for (int v = 0; v < mask.rows; ++v) {
    const uint8_t* m = mask.ptr<uint8_t>(v);
    const uint8_t* g = grown.ptr<uint8_t>(v);
    const int* label = segmentation.labels.ptr<int>(v);
    uint8_t* r = result.ptr<uint8_t>(v);
    for (int u = 0; u < mask.cols; ++u) {
      if (m[u] && label[u] > 0) ++with_depth;
      if (owned(label[u]) && g[u]) {
        r[u] = 255;
        kept += m[u] != 0;
      } else if (m[u] && label[u] == 0) {
        r[u] = 255;  // no depth, or a fragment: the mask's word
      }
    }
  }
  if (2 * kept < with_depth) {
    cv::Mat fallback = mask > 0;
    for (int v = 0; v < mask.rows; ++v) {
      const uint8_t* g = grown.ptr<uint8_t>(v);
      const int* label = segmentation.labels.ptr<int>(v);
      uint8_t* f = fallback.ptr<uint8_t>(v);
      for (int u = 0; u < mask.cols; ++u) {
        if (g[u] && owned(label[u])) f[u] = 255;
      }
    }
    return fallback;
  }
  return result;
}

cv::Mat MarkConcaveCreases(const Camera& camera, const cv::Mat& depth, const cv::Mat& region,
                           const SegmentOptions& options) {
  const std::string bad = options.Check();
  if (!bad.empty()) G6D_THROW(bad);
  if (depth.type() != CV_32F || region.type() != CV_8U || depth.size() != region.size()) {
    G6D_THROW("MarkConcaveCreases: depth must be CV_32F and region CV_8U of one size");
  }
  cv::Mat creases = cv::Mat::zeros(depth.size(), CV_8U);
  if (options.crease_half_span_m <= 0.0) return creases;
  const double focal = std::min(camera.fx, camera.fy);
  // The midpoint of a crease's span lies behind the chord between its ends by at least
  // this: the noise of three depths (√1.5 σ for the difference of one and the mean of two)
  // with the options' sigmas, and never less than the floor (a real sensor quantizes depth
  // in steps of about a millimetre at 1 m).
  const double noise = options.noise_sigmas * std::sqrt(1.5) * options.sensor_noise_at_1m;
  auto usable = [&](int u, int v) {
    if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows || !region.at<uint8_t>(v, u)) return false;
    const float z = depth.at<float>(v, u);
    return z > 0.0f && std::isfinite(z);
  };
  const int du[4] = {1, 0, 1, 1}, dv[4] = {0, 1, 1, -1};
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      if (!usable(u, v)) continue;
      const double z = depth.at<float>(v, u);
      const int k = std::max(2, static_cast<int>(std::lround(focal * options.crease_half_span_m / z)));
      const double threshold = std::max(options.crease_min_depth_m, noise * z * z);
      for (int d = 0; d < 4; ++d) {
        // Both ends inside the region with depth. A depth jump on the way is no reason to
        // stop: the far side of an occluding edge passes the test too, and its band of
        // pixels goes back to the surface it continues (SegmentByDepthAndCreases' growth);
        // where a convex object rests against another the junction is often such a jump
        // on one side and a crease on the other.
        double ends[2];
        bool continuous = true;
        for (int side = 0; side < 2 && continuous; ++side) {
          const int su = side == 0 ? du[d] : -du[d], sv = side == 0 ? dv[d] : -dv[d];
          double previous = z;
          for (int step = 1; step <= k && continuous; ++step) {
            const int uu = u + step * su, vv = v + step * sv;
            if (!usable(uu, vv)) {
              continuous = false;
              break;
            }
            previous = depth.at<float>(vv, uu);
          }
          ends[side] = previous;
        }
        if (continuous && z - 0.5 * (ends[0] + ends[1]) > threshold) {
          creases.at<uint8_t>(v, u) = 255;
          break;
        }
      }
    }
  }
  return creases;
}

DepthSegmentation SegmentByDepthAndCreases(const Camera& camera, const cv::Mat& depth, const cv::Mat& region,
                                           const SegmentOptions& options, cv::Mat* creases_out) {
  const cv::Mat creases = MarkConcaveCreases(camera, depth, region, options);
  if (creases_out) *creases_out = creases;
  cv::Mat inner = region.clone();
  inner.setTo(0, creases);
  // A crease found along most of a contact still leaves bridges where the test missed a
  // few pixels: cutting the region back by crease_erode_px more closes gaps twice as wide
  // (the pixels come back by the growth below).
  if (options.crease_erode_px > 0) {
    const int size = 2 * options.crease_erode_px + 1;
    cv::erode(inner, inner, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(size, size)));
  }
  DepthSegmentation result = SegmentByDepth(camera, depth, inner, options);
  // Crease pixels (and fragments) join the segment they continue, nearest first: a
  // breadth-first growth from every labelled pixel over the region's valid depth.
  const SurfaceStep max_step_m(camera, options);
  std::vector<cv::Point> front;
  for (int v = 0; v < depth.rows; ++v) {
    const int* l = result.labels.ptr<int>(v);
    for (int u = 0; u < depth.cols; ++u) {
      if (l[u] > 0) front.push_back(cv::Point(u, v));
    }
  }
  const int du[4] = {-1, 1, 0, 0}, dv[4] = {0, 0, -1, 1};
  while (!front.empty()) {
    std::vector<cv::Point> next;
    for (const cv::Point& p : front) {
      const int label = result.labels.at<int>(p);
      const float z = depth.at<float>(p);
      for (int k = 0; k < 4; ++k) {
        const int u = p.x + du[k], v = p.y + dv[k];
        if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows || result.labels.at<int>(v, u) != 0 ||
            !region.at<uint8_t>(v, u)) {
          continue;
        }
        const float zq = depth.at<float>(v, u);
        if (!(zq > 0.0f) || !std::isfinite(zq) || std::abs(zq - z) > max_step_m(std::max(z, zq))) continue;
        result.labels.at<int>(v, u) = label;
        next.push_back(cv::Point(u, v));
      }
    }
    front.swap(next);
  }
  result.segments = SegmentStatistics(camera, depth, result.labels, static_cast<int>(result.segments.size()));
  // Largest first again (the growth changed the sizes).
  std::vector<int> order(result.segments.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return result.segments[static_cast<size_t>(a)].pixels > result.segments[static_cast<size_t>(b)].pixels;
  });
  std::vector<int> new_label(order.size() + 1, 0);
  std::vector<DepthSegment> sorted;
  for (size_t k = 0; k < order.size(); ++k) {
    new_label[static_cast<size_t>(order[k]) + 1] = static_cast<int>(k) + 1;
    sorted.push_back(result.segments[static_cast<size_t>(order[k])]);
  }
  for (int v = 0; v < depth.rows; ++v) {
    int* l = result.labels.ptr<int>(v);
    for (int u = 0; u < depth.cols; ++u) l[u] = new_label[static_cast<size_t>(l[u])];
  }
  result.segments.swap(sorted);
  return result;
}

}  // namespace g6d
