#pragma once
/// @file pnp.h
/// MSAC-PnP (paper eq. 5): a robust metric pose per correspondence set, with the inlier
/// threshold τ_P scaled by the projected object size and clipped, then refined on the
/// MSAC inliers.
///
/// Why not only OpenCV's USAC: on LM-O the objects span 40-100 px at ~1 m, so a P3P
/// sample from three correspondences a few pixels apart is badly conditioned, and the
/// many-to-one ORB matches let a pose far from the truth (often 0.3-1 m off in depth)
/// collect as many reprojection inliers as the true one (measured with g6d-bench-match:
/// the set with the most GT-consistent correspondences gives a pose > 15 degrees off in
/// most cases). Two additions fix that while the objective stays eq. (5):
///  - a plausibility test on every minimal-sample model: the object centre must lie
///    within `max_centre_depth_error` diameters of the observed mean depth z_M (a
///    metric RGB-D sensor tells us where the object is along the ray);
///  - optionally a depth-assisted minimal solver: three correspondences whose query
///    keypoints have valid depth give a rigid 3D-3D fit (Kabsch), which is well
///    conditioned at any distance. Samples are still scored by the reprojection MSAC
///    cost over all correspondences, and the final pose is refined on the 2D inliers.

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "solver/match.h"

namespace g6d {

/// Minimal solver used inside MSAC.
enum class PnpMinimalSolver {
  kOpenCvUsac,  ///< OpenCV USAC (P3P, MSAC score, inner LO); no plausibility test (ablation)
  kP3p,         ///< own MSAC loop, OpenCV AP3P minimal solver, plausibility test
  kDepthRigid,  ///< own MSAC loop, 3-point 3D-3D Kabsch on keypoint depth, plausibility test
};

/// Options of EstimatePnp().
struct PnpOptions {
  double tau_fraction = 0.03;   ///< τ_P as a fraction of the projected object size (px / px)
  double tau_min_px = 3.0;      ///< lower clip of τ_P, pixels
  double tau_max_px = 12.0;     ///< upper clip of τ_P, pixels
  int max_iterations = 300;     ///< RANSAC iterations at most
  double confidence = 0.99;     ///< RANSAC stopping confidence
  int min_inliers = 6;          ///< fewer MSAC inliers = invalid hypothesis
  uint64_t seed = 7;            ///< base RNG seed; set j uses seed + template index
  PnpMinimalSolver minimal_solver = PnpMinimalSolver::kDepthRigid;
  /// Plausibility: |depth of the object centre − z_M| must be below this many object
  /// diameters (z_M is the mean observed depth of the visible surface, so the centre is
  /// at most about half a diameter behind it). <= 0 disables the test.
  double max_centre_depth_error = 0.75;
  /// PROSAC-style ordering for kOpenCvUsac: correspondences sorted by Hamming distance δ.
  bool progressive_sampling = false;
  bool local_optimization = true;  ///< re-fit improved models on their inliers

  std::string Check() const;
};

/// What the observation tells PnP beyond the 2D points.
struct PnpPrior {
  double z_m = 0.0;          ///< mean observed depth inside the mask (eq. 9), metres; 0 = unknown
  double diameter_m = 0.0;   ///< object diameter, metres
  Eigen::Vector3d centre_in_object = Eigen::Vector3d::Zero();  ///< bounding-box centre, metres
  /// Camera-frame 3D point of each query feature from the depth image (NaN when the
  /// keypoint has no valid depth), indexed by CorrespondenceSet::query_indices. May be
  /// null; kDepthRigid then falls back to kP3p.
  const std::vector<Eigen::Vector3d>* query_points_in_cam = nullptr;
};

/// One PnP hypothesis.
struct PnpResult {
  bool success = false;
  std::string message = "not run";
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();
  int inliers = 0;
  int iterations = 0;       ///< minimal samples drawn
  double tau_px = 0.0;      ///< the threshold used
  double msac_cost = 0.0;   ///< Σ min(r², τ_P²) over the set at the final pose (eq. 5), px²
};

/// τ_P for an object whose projection spans `projected_size_px` pixels.
double PnpThreshold(const PnpOptions& options, double projected_size_px);

/// Robust PnP on one correspondence set (image points under `camera`'s K).
void EstimatePnp(const PnpOptions& options, const CorrespondenceSet& set, const Camera& camera,
                 double projected_size_px, const PnpPrior& prior, PnpResult* result);

/// Levenberg-Marquardt on the reprojection error of the correspondences `indices` (pixels
/// squared, summed), from *cam_from_object: what OpenCV's solvePnPRefineLM minimizes, at
/// most 20 iterations as there, in a 6x6 loop of its own (EstimatePnp refines every set's
/// MSAC pose with it, and P3P's local optimization each new best model; OpenCV's generic
/// solver took a tenth of a detection's CPU time). The step is a rotation about the camera
/// centre and a translation. It ends at OpenCV's pose to rounding (under a micrometre on
/// ill-conditioned sets), yet not bit for bit, and the stages after PnP turn that rounding
/// into a few different answers per dev set (bench/RESULTS.md, "ICP's and PnP's inner
/// loops"). False (pose untouched) with fewer than 4 indices, a point behind the camera at
/// the start, or a non-finite step.
bool RefinePoseByReprojection(const Camera& camera, const std::vector<Eigen::Vector3d>& object_points,
                              const std::vector<Eigen::Vector2d>& image_points, const std::vector<int>& indices,
                              Eigen::Isometry3d* cam_from_object);

/// Camera-frame 3D points of image points from a depth image: the median of the valid
/// depths (CV_32F metres, > 0) in the 3x3 pixels around each point that are also inside
/// `mask` (CV_8U, may be empty), back-projected; NaN where fewer than 3 are valid.
std::vector<Eigen::Vector3d> BackprojectKeypoints(const Camera& camera, const cv::Mat& depth, const cv::Mat& mask,
                                                  const std::vector<Eigen::Vector2d>& image_points);

}  // namespace g6d
