#pragma once
/// @file proposals.h
/// The depth's candidate regions (internal to lib/solver): support planes removed, neighbouring
/// depth segments, and the segments and unions of them that fit an object, as DetectObjects
/// forms them (detect.h: over a frame, or inside a mask that holds more than the object for
/// SolveOnDepthRegions, depth_regions.h); each region as a mask.

#include <set>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/frame.h"
#include "mesh/mesh.h"
#include "solver/detect_options.h"
#include "solver/plane.h"
#include "solver/segments.h"

namespace g6d {

/// One candidate region.
struct Proposal {
  std::vector<int> segments;  ///< labels (1-based) of DetectionReport::segmentation
  cv::Rect box;               ///< pixel box
  int pixels = 0;             ///< pixels with depth
  double extent_m = 0.0;      ///< Spans::Extent of its points
  double depth_m = 0.0;       ///< median depth (pixel-weighted over its segments)
  Eigen::Vector3d centre_m = Eigen::Vector3d::Zero();  ///< centre of its spans' box, camera frame
  int pass = 0;               ///< the pass whose segmentation its labels refer to (DetectionReport::passes)
  /// A region of the point-pair-feature vote (DetectOptions::ppf_extra): CV_8U 0/255, frame
  /// size, the pixels on the surface of a voted pose of object `ppf_request`; `segments` is
  /// then empty. Empty for a region of the depth segments.
  cv::Mat mask;
  int mask_pixels = 0;  ///< pixels of `mask`, with depth or not (an island's area)
  int ppf_request = -1;
  double ppf_votes = 0.0;
  /// A piece of an island split at its necks, or two touching pieces (FormIslands).
  bool island_piece = false;
};

/// Support planes (DetectOptions): RANSAC on a grid sample of the depth, one plane after the
/// other; a plane's large connected inlier parts are the support. Returns the number of
/// planes removed and fills *support (CV_8U 0/255). The support's pixels that stand above its
/// level (DetectOptions::raised_*: thin parts lying flat on it) go to *raised (CV_8U 0/255)
/// when it is given, and stay support; without it they are taken out of the support.
/// One support plane FindSupport removed: the plane (its normal towards the camera), its
/// pixels (CV_8U 0/255), and the inlier tolerance at 1 m and its flatness (the tolerance at
/// depth z is noise_at_1m_m * z^2 + flatness_m).
struct SupportPlane {
  internal::Plane plane;
  cv::Mat pixels;
  double noise_at_1m_m = 0.0;
  double flatness_m = 0.0;
  double ToleranceAt(double z) const { return noise_at_1m_m * z * z + flatness_m; }
};

int FindSupport(const Frame& frame, const DetectOptions& options, double largest_diameter_m, cv::Mat* support,
                cv::Mat* raised = nullptr, std::vector<SupportPlane>* planes_out = nullptr);

/// The support plane around `region` (CV_8U, frame size): in the ring of the region's box
/// widened by `ring_fraction` of its longer side on each side (less the region), the plane
/// holding most of the pixels with `depth`, if one holds more than half of them (a wall beside
/// the region is no support under it); null when none does.
const SupportPlane* SupportAround(const std::vector<SupportPlane>& planes, const cv::Mat& depth, const cv::Mat& region,
                                  double ring_fraction);

/// How far the model of `mesh` at `cam_from_object` reaches behind the support plane around
/// `region` (SupportAround): its deepest vertex behind that plane (metres; 0 in front of it,
/// or with no such plane), and the plane's tolerance at that vertex's depth in *tolerance_m.
double DepthBehindFrameSupport(const std::vector<SupportPlane>& planes, const cv::Mat& depth, const cv::Mat& region,
                               double ring_fraction, const Mesh& mesh, const Eigen::Isometry3d& cam_from_object,
                               double* tolerance_m);

/// How far the model of `mesh` at `cam_from_object` reaches behind `support`'s plane: its
/// deepest vertex (metres; 0 in front of it), and the plane's tolerance at that vertex's
/// depth in *tolerance_m (0 for an empty mesh).
double DepthBehindPlane(const SupportPlane& support, const Mesh& mesh, const Eigen::Isometry3d& cam_from_object,
                        double* tolerance_m);

/// Pairs of segments (1-based labels, a < b) with pixels within `gap_px` of each other.
std::set<std::pair<int, int>> NeighbourSegments(const cv::Mat& labels, int gap_px);

/// Pairs of segments (1-based labels, a < b) that may be one surface seen on both sides of
/// a gap: from a segment's pixels a path of at most `reach_m` (metres across the image at the
/// segment's median depth, in pixels) through pixels of `region` that hold no segment and
/// have no depth or a fragment's depth not behind the segment by more than `occluder_margin_m`,
/// or through a segment nearer the camera than it by more than `occluder_margin_m`, reaches
/// the other segment. An object behind a thin occluder shows on both sides of it, and a real
/// sensor widens the gap by the projector's shadow and loses depth in blobs on dark or
/// shining surfaces; within NeighbourSegments' few pixels such pieces are no neighbours.
/// Support and what lies behind it stop a path: a gap is crossed only through what hides or
/// what gives no depth. Unions formed of such pairs (FormRegions) hold the pieces without
/// the occluder. Empty for reach_m <= 0. Throws g6d::Error for mismatched sizes or types.
std::set<std::pair<int, int>> NeighboursAcrossGaps(const Camera& camera, const cv::Mat& depth, const cv::Mat& region,
                                                   const DepthSegmentation& segmentation, double reach_m,
                                                   double occluder_margin_m);

/// The full-frame 0/255 mask of a region's segments (its own mask, for a region that has one).
cv::Mat RegionMask(const cv::Mat& labels, const Proposal& proposal);

/// The region as a segmenter would draw it: its segments plus the unclaimed pixels (no
/// depth, or a depth fragment; not support, no other segment) within `gap_px` of them: the
/// dark rims at the object's edges and the holes in its depth.
cv::Mat FilledRegionMask(const cv::Mat& labels, const cv::Mat& support, const Proposal& proposal, int gap_px);

/// The region's pixels with depth where `within` is set (for a region with its own mask:
/// its pixels there).
int PixelsInside(const cv::Mat& labels, const Proposal& proposal, const cv::Mat& within);

/// Pixels with depth the two regions share (regions of segments share whole segments; with
/// a region that has its own mask, the pixels of `a` with depth inside the other's).
int SharedPixels(const Proposal& a, const Proposal& b, const DepthSegmentation& segmentation, const cv::Mat& depth);

/// Splits an island (CV_8U, non-zero = in, continuous) where it is thin: its cores, the
/// pixels whose distance to the island's edge is at least `core_fraction` of the largest such
/// distance within `window_px` (and 1.5 px), are grown back over the island in order of
/// decreasing distance. Objects that touch meet at a neck thinner than either, so each gets
/// a core of its own. Cores of fewer than `min_core_px` pixels are dropped. Fills *pieces
/// (CV_32S, the island's size: 0 outside, 1..n) and the pairs of pieces that touch (a < b);
/// returns n (0 when the island has no core).
int SplitAtNecks(const cv::Mat& island, double core_fraction, int window_px, int min_core_px, cv::Mat* pieces,
                 std::set<std::pair<int, int>>* touching);

/// Islands: the connected parts of `region` (CV_8U: the frame less its support; pixels
/// without depth count) after an opening by a (2 · island_open_px + 1) square, each a
/// region with its own mask (Proposal::mask) when it holds at least
/// segments.min_segment_pixels with depth and fits the largest object (`largest_extent_m`: its
/// points' spans, and its pixel box at its median depth). Its extent is the larger of the
/// two: bare metal leaves few points with depth, spread thin over the part. An object lying apart on a floor
/// or a bin's bottom is one, whole, with its pixels without depth (bare metal reflects the
/// sensor's pattern away, dark faces absorb it); the depth segments break such an object
/// into specks or lose it.
/// With DetectOptions::island_split_core > 0, an island at least half the largest object's
/// size in pixels is also split at its necks (SplitAtNecks): its pieces and each two touching
/// pieces that fit the largest object are regions too (Proposal::island_piece), so objects
/// that touch each other, as parts in a bin do, get a region each.
std::vector<Proposal> FormIslands(const Frame& frame, const cv::Mat& region, double largest_extent_m,
                                  const DetectOptions& options);

/// Regions: every segment that fits the largest object and the unions of up to
/// max_union_segments neighbouring ones that still fit it.
std::vector<Proposal> FormRegions(const DepthSegmentation& segmentation, const std::set<std::pair<int, int>>& neighbours,
                                  double largest_extent_m, const DetectOptions& options);

}  // namespace g6d
