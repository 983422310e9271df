#pragma once
/// @file segments.h
/// A region split into depth-connected segments: the surfaces the depth shows, separated
/// where the depth jumps.
///
/// A mask that covers more than the object (a segmenter merged the touching neighbours, or
/// only a box was given) still holds the object as one or a few segments: two objects that
/// touch in the image rarely touch in depth, and the step between them is far larger than
/// the sensor's noise or the step between neighbouring pixels of one surface. The solver
/// lets each pose own the segments it covers (ScoreOptions::segment_ownership): a segment no
/// pose part covers is another object's, neither for nor against it.

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/camera.h"

namespace g6d {

/// Options of SegmentByDepth().
struct SegmentOptions {
  /// Depth noise of the sensor at 1 m, metres; σ grows with z² (as RegionOptions).
  double sensor_noise_at_1m = 1.5e-3;
  /// Noise standard deviations two neighbouring depths may differ by on one surface.
  double noise_sigmas = 3.0;
  /// The steepest surface a segment follows, degrees between the viewing ray and the surface
  /// normal: neighbouring pixels of such a surface differ in depth by z · tan(angle) / f.
  double max_incidence_deg = 75.0;
  /// Segments with fewer valid-depth pixels than this are fragments (flying pixels at depth
  /// edges, speckle): labelled 0, they belong to no segment.
  int min_segment_pixels = 20;
  /// Concave creases (MarkConcaveCreases; SegmentByDepthAndCreases only): the depth at a
  /// pixel is compared with the mean of the depths this far to either side (metres across
  /// the surface, at least 2 pixels); 0 = no crease test.
  double crease_half_span_m = 0.01;
  /// A crease's midpoint lies behind that mean by more than the noise of the three depths
  /// (noise_sigmas) and at least this, metres (real sensors quantize depth in steps of
  /// about a millimetre at 1 m).
  double crease_min_depth_m = 0.003;
  /// SegmentByDepthAndCreases: the region less its creases is eroded by this many pixels
  /// before it is segmented (thin bridges the crease test missed are cut); 0 = none.
  int crease_erode_px = 2;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Directions of the spans that bound a set of points' extent: the camera axes and the
/// face and body diagonals (13, unit length). Two of the points are at least the largest
/// span apart, and every direction lies within 27.6 degrees of one of them, so the largest
/// span is at least cos(27.6°) = 0.89 of the set's diameter.
inline constexpr int kSpanDirections = 13;
const std::array<Eigen::Vector3d, kSpanDirections>& SpanDirections();

/// Where a set of points lies along each of SpanDirections(), metres (camera frame).
struct Spans {
  std::array<double, kSpanDirections> low{}, high{};
  /// The spans of the union with `other`.
  Spans Union(const Spans& other) const;
  /// The largest span: a lower bound on the distance between two of the points.
  double Extent() const;
};

/// One depth-connected segment.
struct DepthSegment {
  int pixels = 0;               ///< its pixels (all with valid depth)
  cv::Rect box;                 ///< their bounding box, image pixels
  double median_depth_m = 0.0;  ///< median depth of its pixels
  /// Spans of its back-projected pixels, each between the 2% and 98% quantiles (flying
  /// pixels at its edges left out).
  Spans spans;
};

/// The segments of a region.
struct DepthSegmentation {
  /// CV_32S, frame size: k > 0 for a pixel of segments[k - 1]; 0 outside the region, without
  /// valid depth, or in a fragment.
  cv::Mat labels;
  /// Largest first.
  std::vector<DepthSegment> segments;
};

/// Pixels, box, median depth and trimmed spans of the segments 1..count of `labels` (CV_32S;
/// every labelled pixel has valid depth in `depth`).
std::vector<DepthSegment> SegmentStatistics(const Camera& camera, const cv::Mat& depth, const cv::Mat& labels,
                                            int count);

/// `depth` (CV_32F metres, 0 or NaN = none) with its small holes bridged, for segmentation:
/// a pixel without depth that lies, along its row or its column, between two measured
/// pixels at most `max_gap_px` apart (nothing measured between them) whose depths could be
/// one surface across the gap (they differ by at most twice the noise of options.noise_sigmas
/// plus a 45-degree slope over the gap) takes the depth interpolated between them (the
/// shorter of the two spans). A real sensor loses depth in blobs on dark, shining or grazing
/// surfaces and in the projector's shadow; without a bridge such a hole cuts one object into
/// segments. A step between two surfaces (an object's edge) is not bridged. `max_gap_px` <=
/// 0: the depth as it is. Throws g6d::Error for a depth that is not CV_32F.
cv::Mat BridgeDepthHoles(const Camera& camera, const cv::Mat& depth, int max_gap_px, const SegmentOptions& options);

/// Splits the pixels of `region` (CV_8U, non-zero = in) with valid depth (`depth`: CV_32F
/// metres, 0 or NaN = invalid) into 4-connected segments whose neighbouring depths differ by
/// at most the noise of the sensor plus the step of a surface at options.max_incidence_deg.
/// Deterministic. Throws g6d::Error on bad options or mismatched sizes.
DepthSegmentation SegmentByDepth(const Camera& camera, const cv::Mat& depth, const cv::Mat& region,
                                 const SegmentOptions& options);

/// The pixels of `region` (CV_8U) with valid depth that lie in a concave crease: along one of
/// four directions (rows, columns, both diagonals) the depth there is farther than the mean
/// of the depths options.crease_half_span_m to either side (both in the region with valid
/// depth), by more than their noise and options.crease_min_depth_m. Two convex objects that
/// touch, or an object standing on another, meet in such a valley; the surface of one convex
/// object never has one (its middle lies in front of the chord). The far side of an
/// occluding edge is marked too (a band about the half span wide). CV_8U 0/255. Throws g6d::Error on bad options or
/// mismatched sizes.
cv::Mat MarkConcaveCreases(const Camera& camera, const cv::Mat& depth, const cv::Mat& region,
                           const SegmentOptions& options);

/// SegmentByDepth on `region` less its concave creases (MarkConcaveCreases), after which the
/// crease pixels (and the fragments' pixels) join the segment they continue in depth,
/// nearest first. Objects that touch at the same depth come out as separate segments; a
/// concave object (a bowl, the inside of a mug) may come out as several, which unions of
/// neighbouring segments put back together. `creases` (may be null) receives the crease
/// pixels.
DepthSegmentation SegmentByDepthAndCreases(const Camera& camera, const cv::Mat& depth, const cv::Mat& region,
                                           const SegmentOptions& options, cv::Mat* creases);

/// The region grown by the depth: `mask` (CV_8U, non-zero = in) and the pixels joined to it
/// through 4-neighbours whose depths differ by no more than SegmentByDepth's step (the same
/// surface), that are not on the support (`support`: CV_8U, non-zero = support; may be
/// empty) and whose points lie within `reach_m` of the mask's median point: the object a
/// cautious (eroded) or partial (cut) mask missed, up to where the object's surface ends in
/// a depth edge. At most `max_steps_px` pixels away from the mask. The mask owns the depth
/// segments of the grown region it covers at least `min_covered_fraction` of (0 = all):
/// only those grow, and a rim of one it does not own (a mask that leaked onto a neighbour's
/// surface) leaves the region, unless that would take away more than half of the mask's
/// pixels with depth. CV_8U 0/255.
cv::Mat GrowRegionByDepth(const Camera& camera, const cv::Mat& depth, const cv::Mat& mask, const cv::Mat& support,
                          double reach_m, int max_steps_px, double min_covered_fraction,
                          const SegmentOptions& options);

}  // namespace g6d
