#pragma once
/// @file region.h
/// The observed region of one instance: what the caller's mask says, checked by the depth.
///
/// A segmenter's mask is evidence, not truth: it leaks onto the table and the background
/// behind the object, and it misses parts near the boundary. The depth knows better:
/// - a mask pixel on the support surface the object stands on (a plane fitted to the depth
///   around the mask) is a leak, and so is one far behind anything the object can occupy;
/// - a pixel outside the mask whose depth lies on a pose's rendered surface is object that
///   the mask missed (decided per pose, in ScoreRendering, with the tolerance set here).
/// The paper takes the mask as given (MaskTrust::kExact keeps that behaviour).

#include <cstdint>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "mesh/mesh.h"

namespace g6d {

/// How the solver reads the caller's mask.
enum class MaskTrust {
  kExact,  ///< the paper's: every mask pixel is object, every other pixel is not
  kDepth,  ///< evidence checked by the depth (this file and ScoreOptions::depth_evidence)
};

/// "exact" / "depth".
const char* MaskTrustName(MaskTrust trust);
/// Parses "exact" or "depth"; throws g6d::Error naming the bad value.
MaskTrust ParseMaskTrust(const std::string& name);

/// Options of ComputeObservedRegion().
struct RegionOptions {
  /// Depth noise of the sensor at 1 m, metres; the standard deviation grows with z² (the
  /// structured-light and stereo model; Kinect / Xtion class sensors: about 1.5 mm at 1 m).
  double sensor_noise_at_1m = 1.5e-3;
  /// Noise standard deviations a depth may differ by and still lie on a surface.
  double noise_sigmas = 3.0;
  /// The part of the surface tolerance that comes from the pose itself: a pose good enough to
  /// be refined (within a few percent of the diameter) renders depths off by about this
  /// fraction of the object's diameter.
  double pose_tolerance_fraction = 0.03;
  /// The support plane is fitted to the valid depth in a ring around the mask box, this
  /// fraction of the box's longer side wide on each side.
  double ring_fraction = 0.5;
  /// Where the ring shows no support, a ring this wide is searched for one, only as the
  /// limit no pose may reach behind (ObservedRegion::has_limit_plane); <= ring_fraction =
  /// no second search.
  double limit_ring_fraction = 1.5;
  /// RANSAC over at most `plane_samples` ring points for `plane_iterations` iterations.
  int plane_iterations = 150;
  int plane_samples = 2000;
  /// A plane is the support only when it covers at least this fraction of the ring's pixels
  /// (at least `min_plane_points` of the sampled points), and a fifth of the mask's points
  /// lie clearly in front of it.
  double min_plane_fraction = 0.25;
  int min_plane_points = 100;
  /// A mask pixel farther from the mask's median depth than this fraction of the diameter
  /// (behind: the background; in front: an occluder) is a leak: two visible points of the
  /// object are never farther apart than the diameter.
  double far_fraction = 1.0;
  /// The search (features, PnP) reads the mask grown by the depth over the surface it
  /// continues (GrowRegionByDepth, within the diameter of the mask's median point), at most
  /// this fraction of the mask box's longer side away: an eroded, cut or boxed mask still
  /// gives the features near the object's edge. 0 = the mask as corrected.
  double grow_fraction = 0.5;
  /// A pixel of the caller's mask on the support plane leaves the mask (a leak: neither the
  /// search nor the observed cloud reads it), but when this is on, a pose whose rendered
  /// surface lies on its depth (within ObservedRegion::surface_tolerance_m) is credited with
  /// it as with any pixel the mask missed (ScoreOptions::depth_evidence). A part thinner than
  /// the plane's tolerance (sheet metal lying flat in a bin) cannot be told from its support
  /// by the depth; there the mask decides. A leak onto a table stays a leak for every pose
  /// that does not lay a surface on the table. Off: the support is nobody's (before).
  bool mask_decides_on_support = true;
  /// Unsure pixels (ObservedRegion::unsure) reach a depthless area outside the mask at
  /// least this many pixels wide (1 = any pixel outside it: the mask's edge). A mask that leaked
  /// onto what the sensor did not see (background beyond its range, a shadow) continues
  /// into that unseen area; bare metal that reflects the pattern away lies inside the
  /// object's outline, beyond which the sensor sees the floor, with only a thin band of
  /// lost depth along the edge. 9, as GridOptions::unseen_area_min_px: the same question
  /// (is a depthless area an edge band or something unseen?) asked of the mask's outside.
  /// Read for a caller's mask that outlines the object: a box (mask_stage.cc) and a region
  /// detection drew from the depth (detect.cc) say nothing of where the object's surface
  /// ends, and keep 1 (the rule before: every depthless pixel reaching their edge).
  int unsure_area_min_px = 9;
  /// Seed of the plane fit's sampling (deterministic for a given frame).
  uint64_t seed = 1;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// The observed region and what the depth changed.
struct ObservedRegion {
  cv::Mat mask;     ///< CV_8U 0/255, frame size: the given mask less its leaks
  cv::Mat support;  ///< CV_8U 0/255, frame size: pixels on the support plane; empty = no plane
  bool has_plane = false;
  /// The support plane: n · p + offset = 0 for points p in the camera frame (metres), n a
  /// unit normal pointing towards the camera side (where the object is).
  Eigen::Vector3d plane_normal = Eigen::Vector3d::UnitZ();
  double plane_offset_m = 0.0;
  /// The plane no pose of the object may reach behind (SolverOptions::
  /// support_penetration_fraction): the support plane, or where the ring showed none, one
  /// found the same way in a wider ring (RegionOptions::limit_ring_fraction). Same
  /// convention as the support plane.
  bool has_limit_plane = false;
  Eigen::Vector3d limit_plane_normal = Eigen::Vector3d::UnitZ();
  double limit_plane_offset_m = 0.0;
  /// A depth within this of a rendered surface lies on it (metres): noise_sigmas · σ(z) at
  /// the mask's median depth plus pose_tolerance_fraction · diameter.
  double surface_tolerance_m = 0.0;
  /// CV_8U 0/255, frame size: mask pixels without valid depth that reach the mask's edge
  /// through pixels without depth. The mask may have leaked there onto what the sensor did
  /// not see (background beyond its range, a shadow), or the object's edge is dark: neither
  /// for nor against a pose that does not cover them (ScoreRendering), and the search leaves
  /// them out. Empty when there are none.
  cv::Mat unsure;
  int unsure_pixels = 0;   ///< of the mask's pixels
  int given_pixels = 0;    ///< pixels of the caller's mask
  int support_leak = 0;    ///< of them on the support plane
  int far_leak = 0;        ///< of them far behind or in front of the object
};

/// Checks the caller's mask (CV_8U, non-zero = object) against `depth` (CV_32F metres,
/// 0 = invalid). `diameter_m` is the object's. Pixels without valid depth stay as given.
/// When removing the leaks would leave fewer than a fifth of the mask's valid-depth pixels,
/// the mask is kept as given (the depth disagrees too much to overrule the caller).
ObservedRegion ComputeObservedRegion(const Camera& camera, const cv::Mat& mask, const cv::Mat& depth,
                                     double diameter_m, const RegionOptions& options);

/// The mask a pose implies: the pixels of `mesh` rendered at `cam_from_object` that the
/// depth does not show to be hidden (observed depth in front of the rendered surface by more
/// than `occlusion_margin_m`; pixels without depth stay). CV_8U 0/255, frame size; rendered
/// at full resolution inside `roi` (clipped to the frame) only. With a correct pose this is
/// the object's visible silhouette: the caller's mask with its leaks and misses corrected.
cv::Mat CorrectedMask(const Camera& camera, const Mesh& mesh, const Eigen::Isometry3d& cam_from_object,
                      const cv::Mat& depth, double occlusion_margin_m, bool cull_backfaces, const cv::Rect& roi);

/// IoU of two masks of one size (non-zero = in); 0 when both are empty.
double MaskIntersectionOverUnion(const cv::Mat& a, const cv::Mat& b);

}  // namespace g6d
