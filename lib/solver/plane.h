#pragma once
/// @file plane.h
/// A plane in the camera frame and its least-squares fit (internal to lib/solver: the
/// support plane under a mask, region.cc, and the support planes of a frame, proposals.cc).

#include <cmath>
#include <cstdint>
#include <random>
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

/// RANSAC: `iterations` planes through three points of `points` (non-empty) drawn with
/// `random`; the one with the most inliers wins (ties: the first), a point p being an inlier
/// when |Distance(p)| <= on_plane(p) (metres). *count receives its inlier count (-1 when
/// every draw was degenerate).
template <typename Tolerance>
Plane RansacPlane(const std::vector<Eigen::Vector3d>& points, int iterations, const Tolerance& on_plane,
                  std::mt19937_64* random, int* count) {
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  Plane best;
  *count = -1;
  for (int iteration = 0; iteration < iterations; ++iteration) {
    const Eigen::Vector3d& a = points[pick(*random)];
    const Eigen::Vector3d& b = points[pick(*random)];
    const Eigen::Vector3d& c = points[pick(*random)];
    const Eigen::Vector3d normal = (b - a).cross(c - a);
    const double length = normal.norm();
    if (!(length > 1e-12)) continue;
    Plane plane;
    plane.normal = normal / length;
    plane.offset = -plane.normal.dot(a);
    int inliers = 0;
    for (const Eigen::Vector3d& p : points) inliers += std::abs(plane.Distance(p)) <= on_plane(p);
    if (inliers > *count) {
      *count = inliers;
      best = plane;
    }
  }
  return best;
}

}  // namespace g6d::internal
