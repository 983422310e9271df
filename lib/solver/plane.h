#pragma once
/// @file plane.h
/// A plane in the camera frame and its least-squares fit (internal to lib/solver: the
/// support plane under a mask, region.cc, and the support planes of a frame, detect.cc).

#include <vector>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace g6d::internal {

/// normal · p + offset = 0 for points p on the plane (metres, camera frame), normal unit.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset = 0.0;
  /// Signed distance of `p` from the plane, metres (positive on the normal's side).
  double Distance(const Eigen::Vector3d& p) const { return normal.dot(p) + offset; }
};

/// The least-squares plane through `points` (non-empty): through their centroid, normal
/// along their smallest principal axis.
inline Plane FitPlane(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) scatter += (p - centroid) * (p - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  Plane plane;
  plane.normal = eigen.eigenvectors().col(0).normalized();
  plane.offset = -plane.normal.dot(centroid);
  return plane;
}

}  // namespace g6d::internal
