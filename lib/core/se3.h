#pragma once
/// @file se3.h
/// SE(3) helpers on Eigen::Isometry3d. Poses are named `target_from_source`
/// (`cam_from_object` maps object-frame points into the camera frame).
/// Tangent vectors are ordered (rho, phi): translation part first, rotation part second,
/// and act by left multiplication: T' = Exp(xi) * T.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace g6d {

using Vector6d = Eigen::Matrix<double, 6, 1>;

/// Skew-symmetric matrix [v]x with [v]x * w = v.cross(w).
Eigen::Matrix3d Hat(const Eigen::Vector3d& v);

/// SO(3) exponential (Rodrigues), exact near zero.
Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& phi);
/// SO(3) logarithm, returns phi with |phi| in [0, pi].
Eigen::Vector3d LogSO3(const Eigen::Matrix3d& rotation);

/// SE(3) exponential of xi = (rho, phi).
Eigen::Isometry3d ExpSE3(const Vector6d& xi);
/// SE(3) logarithm; inverse of ExpSE3 for |phi| < pi.
Vector6d LogSE3(const Eigen::Isometry3d& pose);

/// Geodesic angle between two rotations, degrees.
double RotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);
/// Distance between two translations, metres.
double TranslationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);

/// Projects a nearly orthonormal matrix onto SO(3) (SVD, det +1).
Eigen::Matrix3d Orthonormalize(const Eigen::Matrix3d& m);

/// Pose built from a row-major 3x3 rotation and a translation (any units; caller's).
Eigen::Isometry3d MakePose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);

/// cam_from_object for a camera at `eye` (object frame) looking at `target`, with image
/// y axis pointing along -`up` as far as possible (OpenCV camera: x right, y down, z forward).
Eigen::Isometry3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                         const Eigen::Vector3d& up);

}  // namespace g6d
