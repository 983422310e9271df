#pragma once
/// @file vsd.h
/// VSD, the Visible Surface Discrepancy of the BOP Challenge 2019 (Hodan et al., "BOP:
/// Benchmark for 6D Object Pose Estimation", ECCV 2018, eq. (1), with the BOP'19 changes:
/// visibility "bop19" mode, the "step" pixel cost, tau relative to the object diameter),
/// following bop_toolkit's `pose_error.vsd`, `visibility.estimate_visib_mask_*` and
/// `misc.depth_im_to_dist_im_fast`.
///
/// The model is rendered under the estimated and the GT pose with the g6d rasterizer
/// (lib/render, nearest surface, pixel centres, 1 cm near plane as BOP's renderer), depth is
/// turned into distance from the camera centre, and the visible parts are compared with the
/// test depth image:
///
///   e_VSD = ( sum_{p in V_gt ∩ V_est} [ |D_gt(p) - D_est(p)| / diameter >= tau ]
///             + |V_gt ∪ V_est| - |V_gt ∩ V_est| ) / |V_gt ∪ V_est|
///
/// (1 when the union is empty). All depths and distances are metres; the BOP'19 delta of
/// 15 mm is `VsdOptions::delta_m = 0.015`.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/camera.h"
#include "mesh/mesh.h"

namespace g6d {

/// The BOP'19 misalignment tolerances (and VSD correctness thresholds): 0.05, 0.10, ..., 0.50,
/// computed as numpy's `np.arange(0.05, 0.51, 0.05)` does (0.05 + i * 0.05), so the values
/// agree with bop_toolkit bit for bit.
std::vector<double> BopVsdTaus();

/// Options of the VSD error (defaults: BOP'19 for LM-O and YCB-V, `eval_bop19_pose.py`).
struct VsdOptions {
  /// Visibility tolerance delta, metres: a model pixel is visible when its distance is at
  /// most this much behind the test distance (or the test depth is missing). BOP'19
  /// `vsd_deltas`: 15 mm for every dataset but ITODD (5 mm).
  double delta_m = 0.015;
  /// Misalignment tolerances tau, one error per value: fractions of the object diameter
  /// when `normalized_by_diameter`, else metres. BOP'19 `vsd_taus`: 0.05..0.5 step 0.05.
  std::vector<double> taus = BopVsdTaus();
  /// BOP'19 `vsd_normalized_by_diameter`: divide pixel distances by the diameter.
  bool normalized_by_diameter = true;

  /// Empty when valid, else names the bad field (delta_m finite and >= 0, taus non-empty,
  /// finite and > 0).
  std::string Check() const;
};

/// Distance image from a depth image, as bop_toolkit's `misc.depth_im_to_dist_im_fast`:
/// distance(u, v) = depth(u, v) * sqrt(1 + ((u - cx) / fx)^2 + ((v - cy) / fy)^2), 0 where
/// depth is 0. Note that BOP uses the integer pixel index u here, not the pixel centre
/// u + 0.5 (see the .cc). `depth_m` is CV_32F metres (z along the optical axis); returns
/// CV_32F metres of the same size. Throws g6d::Error when `depth_m` is not CV_32FC1 or the
/// focal lengths are not positive.
cv::Mat DepthToDistance(const cv::Mat& depth_m, const Camera& camera);

/// Visibility mask of the model in the GT pose, bop_toolkit `estimate_visib_mask_gt` in
/// "bop19" mode: gt_distance > 0 and (test_distance == 0 or gt_distance - test_distance <=
/// delta_m). Inputs CV_32F distance images of one size, metres; returns CV_8U 0/255.
/// Throws g6d::Error on a size or type mismatch.
cv::Mat EstimateVisibilityMaskGt(const cv::Mat& test_distance_m, const cv::Mat& gt_distance_m,
                                 double delta_m);

/// Visibility mask of the model in the estimated pose, bop_toolkit
/// `estimate_visib_mask_est` ("bop19"): the same test as EstimateVisibilityMaskGt() on
/// `estimate_distance_m`, united with (visib_gt and estimate_distance > 0), so that the
/// estimate is not penalized where it is occluded exactly where the GT is (Hodan et al.,
/// ECCVW 2016, eq. (14)). `visib_gt` is CV_8U (non-zero = visible). Returns CV_8U 0/255.
/// Throws g6d::Error on a size or type mismatch.
cv::Mat EstimateVisibilityMaskEstimate(const cv::Mat& test_distance_m,
                                       const cv::Mat& estimate_distance_m, const cv::Mat& visib_gt,
                                       double delta_m);

/// VSD from already rendered model depth images (CV_32F metres, z, 0 = no surface) and the
/// test depth image (CV_32F metres, 0 = no measurement), all of the camera's size. Returns
/// one error in [0, 1] per `options.taus` ("step" cost, bop_toolkit `pose_error.vsd`);
/// all 1 when neither pose has a visible pixel. `diameter_m` normalizes the pixel
/// distances when `options.normalized_by_diameter`. Throws g6d::Error for invalid options,
/// a non-positive diameter, or images of the wrong type or size.
std::vector<double> ComputeVsdFromDepth(const cv::Mat& estimate_depth_m, const cv::Mat& gt_depth_m,
                                        const cv::Mat& test_depth_m, const Camera& camera,
                                        double diameter_m, const VsdOptions& options);

/// VSD of `estimate_cam_from_object` against `gt_cam_from_object`: renders `mesh` (metres,
/// object frame; BOP uses the full model of models/) under both poses with Rasterize() and
/// calls ComputeVsdFromDepth(). `test_depth_m` must have the camera's size (the camera's
/// width and height are those of the rendering). Throws g6d::Error as ComputeVsdFromDepth()
/// and for an invalid camera.
std::vector<double> ComputeVsd(const Eigen::Isometry3d& estimate_cam_from_object,
                               const Eigen::Isometry3d& gt_cam_from_object,
                               const cv::Mat& test_depth_m, const Camera& camera, const Mesh& mesh,
                               double diameter_m, const VsdOptions& options);

/// bop_toolkit's `misc.overlapping_sphere_projections`: whether the image projections of
/// two spheres of `radius_m` centred at the two points (camera frame) may overlap, tested
/// in normalized image coordinates: |c1/z1 - c2/z2| < radius * (1/z1 + 1/z2). False when a
/// centre has z = 0. BOP's eval_calc_errors.py skips VSD (error 1 for every tau) when this
/// is false for the model origins with radius = diameter / 2.
bool SphereProjectionsOverlap(double radius_m, const Eigen::Vector3d& centre1_in_cam,
                              const Eigen::Vector3d& centre2_in_cam);

}  // namespace g6d
