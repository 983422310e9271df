#pragma once
/// @file metrics.h
/// Pose error functions for evaluation: ADD, ADD-S (Hinterstoisser et al., ACCV 2012) and
/// the BOP 2019 errors MSSD and MSPD (Hodan et al., "BOP Challenge 2020 on 6D Object
/// Localization", ECCV workshops 2020, Sec. 2.2), following bop_toolkit's `pose_error.py`.
///
/// All poses are `cam_from_object`; model points are in the object frame, metres. Errors in
/// metres (ADD, ADD-S, MSSD) or pixels (MSPD). Symmetries are `object_from_object`
/// transforms S with the property that the model under `cam_from_object * S` looks the
/// same as under `cam_from_object`; the identity must be part of the list (the
/// `SymmetryTransforms()` output always starts with it).
///
/// VSD (Visible Surface Discrepancy), which needs depth rendering, is in eval/vsd.h; the
/// whole BOP'19 evaluation (matching, recalls, AR) in eval/bop_eval.h.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "core/camera.h"

namespace g6d {

/// A continuous rotational symmetry: rotation by any angle about `axis` through the point
/// `offset_m` (object frame). BOP's `symmetries_continuous` entry, offset converted to m.
struct ContinuousSymmetry {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();     ///< rotation axis (need not be unit)
  Eigen::Vector3d offset_m = Eigen::Vector3d::Zero();  ///< a point on the axis, metres
};

/// bop_toolkit's default `max_sym_disc_step`: the largest fraction of the object diameter
/// that the point furthest from a continuous-symmetry axis travels between two
/// consecutive discretized rotations. With 0.01 the step is 2*pi / ceil(pi / 0.01) =
/// 2*pi / 315 (about 1.14 degrees), i.e. 315 rotations per continuous symmetry.
inline constexpr double kBopMaxSymmetryDiscretizationStep = 0.01;

/// The full list of symmetry transforms (object_from_object), built as bop_toolkit's
/// `misc.get_symmetry_transformations`: the identity followed by `discrete` (each used as
/// given, not orthonormalized); if `continuous` is not empty every one of those is
/// combined with each discretized continuous rotation (angle i * 2*pi / n, i = 0..n-1,
/// n = ceil(pi / max_discretization_step)), so the result has
/// (1 + discrete.size()) * continuous.size() * n entries. Throws g6d::Error when
/// `max_discretization_step` is not in (0, 1] or a continuous axis is zero or not finite.
std::vector<Eigen::Isometry3d> SymmetryTransforms(
    const std::vector<Eigen::Isometry3d>& discrete,
    const std::vector<ContinuousSymmetry>& continuous,
    double max_discretization_step = kBopMaxSymmetryDiscretizationStep);

/// ADD: mean over model points x of |estimate * x - ground_truth * x|, metres.
/// Throws g6d::Error when `model_points_m` is empty.
double ComputeAdd(const Eigen::Isometry3d& estimate_cam_from_object,
                  const Eigen::Isometry3d& gt_cam_from_object,
                  const std::vector<Eigen::Vector3f>& model_points_m);

/// ADD-S (bop_toolkit `adi`): mean over model points x of the distance from
/// ground_truth * x to the nearest point of {estimate * y}, metres. Uses an Open3D
/// KD-tree built over the estimated points on each call (O(n log n)). Throws g6d::Error
/// when `model_points_m` is empty.
double ComputeAdds(const Eigen::Isometry3d& estimate_cam_from_object,
                   const Eigen::Isometry3d& gt_cam_from_object,
                   const std::vector<Eigen::Vector3f>& model_points_m);

/// The usual ADD(-S) acceptance test: `error_m < fraction * diameter_m` (0.1 d, as in
/// Hinterstoisser et al.).
inline bool IsAddCorrect(double error_m, double diameter_m, double fraction = 0.1) {
  return error_m < fraction * diameter_m;
}

/// MSSD (Maximum Symmetry-aware Surface Distance): min over symmetries S of
/// max over model points x of |estimate * x - ground_truth * S * x|, metres.
/// `symmetries` must hold at least the identity (see `SymmetryTransforms()`). Throws
/// g6d::Error when `model_points_m` or `symmetries` is empty.
double ComputeMssd(const Eigen::Isometry3d& estimate_cam_from_object,
                   const Eigen::Isometry3d& gt_cam_from_object,
                   const std::vector<Eigen::Vector3f>& model_points_m,
                   const std::vector<Eigen::Isometry3d>& symmetries);

/// MSPD (Maximum Symmetry-aware Projection Distance): min over symmetries S of
/// max over model points x of |proj(estimate * x) - proj(ground_truth * S * x)|, pixels,
/// with the pinhole intrinsics of `camera` (the image size is not used). Points at or
/// behind the camera plane give infinite or meaningless projections, as in bop_toolkit.
/// Throws g6d::Error when `model_points_m` or `symmetries` is empty.
double ComputeMspd(const Eigen::Isometry3d& estimate_cam_from_object,
                   const Eigen::Isometry3d& gt_cam_from_object, const Camera& camera,
                   const std::vector<Eigen::Vector3f>& model_points_m,
                   const std::vector<Eigen::Isometry3d>& symmetries);

}  // namespace g6d
