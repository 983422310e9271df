#include "core/se3.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

namespace g6d {

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  if (theta < 1e-12) return Eigen::Matrix3d::Identity() + Hat(phi);
  return Eigen::AngleAxisd(theta, phi / theta).toRotationMatrix();
}

Eigen::Vector3d LogSO3(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd aa(rotation);
  double angle = aa.angle();
  Eigen::Vector3d axis = aa.axis();
  if (angle > M_PI) {  // Eigen may return angles in (pi, 2pi); fold them back.
    angle = 2.0 * M_PI - angle;
    axis = -axis;
  }
  return angle * axis;
}

namespace {
// Left Jacobian V of SO(3): t = V * rho (Barfoot, eq. 7.86),
// V = I + (1 - cos t) / t^2 [phi]x + (t - sin t) / t^3 [phi]x^2.
// Both coefficients are written without cancellation: 1 - cos t = 2 sin^2(t / 2), and a
// Taylor series for (t - sin t) / t^3 at small t (its closed form loses digits there).
Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d hat = Hat(phi);
  const double t2 = theta * theta;
  double first = 0.5;  // (1 - cos t) / t^2
  if (theta > 0.0) {
    const double sinc_half = std::sin(0.5 * theta) / (0.5 * theta);
    first = 0.5 * sinc_half * sinc_half;
  }
  // Series truncation error below t^8 / 4e7, under 3e-16 for t < 0.1.
  const double second = theta < 0.1
                            ? 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0
                            : (theta - std::sin(theta)) / (t2 * theta);
  return Eigen::Matrix3d::Identity() + first * hat + second * hat * hat;
}
}  // namespace

Eigen::Isometry3d ExpSE3(const Vector6d& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = ExpSO3(phi);
  pose.translation() = LeftJacobianSO3(phi) * rho;
  return pose;
}

Vector6d LogSE3(const Eigen::Isometry3d& pose) {
  Vector6d xi;
  const Eigen::Vector3d phi = LogSO3(pose.linear());
  xi.tail<3>() = phi;
  xi.head<3>() = LeftJacobianSO3(phi).inverse() * pose.translation();
  return xi;
}

double RotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  // atan2(2 sin t, 2 cos t) from the skew and trace parts of a^T b: accurate at every angle,
  // where acos((trace - 1) / 2) loses half the digits near 0 (and near 180 degrees).
  const Eigen::Matrix3d relative = a.transpose() * b;
  const Eigen::Vector3d twice_sin_axis(relative(2, 1) - relative(1, 2),
                                       relative(0, 2) - relative(2, 0),
                                       relative(1, 0) - relative(0, 1));
  return std::atan2(twice_sin_axis.norm(), relative.trace() - 1.0) * 180.0 / M_PI;
}

double TranslationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

Eigen::Matrix3d Orthonormalize(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

Eigen::Isometry3d MakePose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  return pose;
}

Eigen::Isometry3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                         const Eigen::Vector3d& up) {
  // Right-handed camera frame with y = -up (projected): x = y.cross(z) = z.cross(up).
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = z.cross(up.normalized());
  if (x.norm() < 1e-9) x = z.unitOrthogonal();  // looking along up: any x will do
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d object_from_cam_rotation;
  object_from_cam_rotation.col(0) = x;
  object_from_cam_rotation.col(1) = y;
  object_from_cam_rotation.col(2) = z;
  Eigen::Isometry3d object_from_cam = MakePose(object_from_cam_rotation, eye);
  return object_from_cam.inverse();
}

}  // namespace g6d
