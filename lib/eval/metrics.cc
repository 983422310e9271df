#include "eval/metrics.h"

#include <open3d/geometry/KDTreeFlann.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace g6d {
namespace {

void CheckNotEmpty(const std::vector<Eigen::Vector3f>& model_points_m, const char* function) {
  if (model_points_m.empty()) G6D_THROW(function << ": model_points_m is empty");
}

void CheckNotEmpty(const std::vector<Eigen::Isometry3d>& symmetries, const char* function) {
  if (symmetries.empty()) {
    G6D_THROW(function << ": symmetries is empty (it must hold at least the identity; "
                          "use SymmetryTransforms())");
  }
}

}  // namespace

std::vector<Eigen::Isometry3d> SymmetryTransforms(const std::vector<Eigen::Isometry3d>& discrete,
                                                  const std::vector<ContinuousSymmetry>& continuous,
                                                  double max_discretization_step) {
  if (!(max_discretization_step > 0.0 && max_discretization_step <= 1.0)) {
    G6D_THROW("SymmetryTransforms: max_discretization_step must be in (0, 1] (got "
              << max_discretization_step << ")");
  }
  std::vector<Eigen::Isometry3d> discrete_all;
  discrete_all.reserve(discrete.size() + 1);
  discrete_all.push_back(Eigen::Isometry3d::Identity());
  discrete_all.insert(discrete_all.end(), discrete.begin(), discrete.end());

  // bop_toolkit misc.get_symmetry_transformations: the furthest point (at most one
  // diameter from the axis) moves by at most step * diameter between rotations when the
  // angular step is 2*pi / ceil(pi / step) (arc = angle * radius <= angle * diameter / 2).
  std::vector<Eigen::Isometry3d> continuous_all;
  for (size_t k = 0; k < continuous.size(); ++k) {
    const ContinuousSymmetry& symmetry = continuous[k];
    const double norm = symmetry.axis.norm();
    if (!std::isfinite(norm) || norm == 0.0 || !symmetry.offset_m.allFinite()) {
      G6D_THROW("SymmetryTransforms: continuous symmetry "
                << k << " has a zero or non-finite axis or offset (axis "
                << symmetry.axis.transpose() << ", offset_m " << symmetry.offset_m.transpose()
                << ")");
    }
    const Eigen::Vector3d axis = symmetry.axis / norm;
    const int steps = static_cast<int>(std::ceil(M_PI / max_discretization_step));
    const double step_rad = 2.0 * M_PI / steps;
    for (int i = 0; i < steps; ++i) {
      Eigen::Isometry3d rotation = Eigen::Isometry3d::Identity();
      rotation.linear() = Eigen::AngleAxisd(i * step_rad, axis).toRotationMatrix();
      // Rotation about the axis through `offset`: x -> R (x - offset) + offset.
      rotation.translation() = symmetry.offset_m - rotation.linear() * symmetry.offset_m;
      continuous_all.push_back(rotation);
    }
  }

  if (continuous_all.empty()) return discrete_all;
  std::vector<Eigen::Isometry3d> all;
  all.reserve(discrete_all.size() * continuous_all.size());
  for (const Eigen::Isometry3d& d : discrete_all) {
    for (const Eigen::Isometry3d& c : continuous_all) all.push_back(c * d);
  }
  return all;
}

double ComputeAdd(const Eigen::Isometry3d& estimate_cam_from_object,
                  const Eigen::Isometry3d& gt_cam_from_object,
                  const std::vector<Eigen::Vector3f>& model_points_m) {
  CheckNotEmpty(model_points_m, "ComputeAdd");
  double sum = 0.0;
  for (const Eigen::Vector3f& point : model_points_m) {
    const Eigen::Vector3d x = point.cast<double>();
    sum += (estimate_cam_from_object * x - gt_cam_from_object * x).norm();
  }
  return sum / static_cast<double>(model_points_m.size());
}

double ComputeAdds(const Eigen::Isometry3d& estimate_cam_from_object,
                   const Eigen::Isometry3d& gt_cam_from_object,
                   const std::vector<Eigen::Vector3f>& model_points_m) {
  CheckNotEmpty(model_points_m, "ComputeAdds");
  const int count = static_cast<int>(model_points_m.size());
  // As bop_toolkit's adi(): the tree holds the estimated points, the GT points query it.
  Eigen::MatrixXd estimated(3, count);
  for (int i = 0; i < count; ++i) {
    estimated.col(i) = estimate_cam_from_object * model_points_m[i].cast<double>();
  }
  const open3d::geometry::KDTreeFlann tree(estimated);
  std::vector<int> indices(1);
  std::vector<double> squared_distances(1);
  double sum = 0.0;
  for (const Eigen::Vector3f& point : model_points_m) {
    const Eigen::Vector3d query = gt_cam_from_object * point.cast<double>();
    const int found = tree.SearchKNN(query, 1, indices, squared_distances);
    G6D_CHECK(found == 1);
    sum += std::sqrt(squared_distances[0]);
  }
  return sum / count;
}

double ComputeMssd(const Eigen::Isometry3d& estimate_cam_from_object,
                   const Eigen::Isometry3d& gt_cam_from_object,
                   const std::vector<Eigen::Vector3f>& model_points_m,
                   const std::vector<Eigen::Isometry3d>& symmetries) {
  CheckNotEmpty(model_points_m, "ComputeMssd");
  CheckNotEmpty(symmetries, "ComputeMssd");
  std::vector<Eigen::Vector3d> estimated;
  estimated.reserve(model_points_m.size());
  for (const Eigen::Vector3f& point : model_points_m) {
    estimated.push_back(estimate_cam_from_object * point.cast<double>());
  }
  double best_squared = std::numeric_limits<double>::infinity();
  for (const Eigen::Isometry3d& symmetry : symmetries) {
    const Eigen::Isometry3d gt_symmetric = gt_cam_from_object * symmetry;
    double worst_squared = 0.0;
    for (size_t i = 0; i < model_points_m.size(); ++i) {
      worst_squared =
          std::max(worst_squared,
                   (estimated[i] - gt_symmetric * model_points_m[i].cast<double>()).squaredNorm());
      // This symmetry cannot beat the best one any more.
      if (worst_squared >= best_squared) break;
    }
    best_squared = std::min(best_squared, worst_squared);
  }
  return std::sqrt(best_squared);
}

double ComputeMspd(const Eigen::Isometry3d& estimate_cam_from_object,
                   const Eigen::Isometry3d& gt_cam_from_object, const Camera& camera,
                   const std::vector<Eigen::Vector3f>& model_points_m,
                   const std::vector<Eigen::Isometry3d>& symmetries) {
  CheckNotEmpty(model_points_m, "ComputeMspd");
  CheckNotEmpty(symmetries, "ComputeMspd");
  std::vector<Eigen::Vector2d> estimated;
  estimated.reserve(model_points_m.size());
  for (const Eigen::Vector3f& point : model_points_m) {
    estimated.push_back(camera.Project(estimate_cam_from_object * point.cast<double>()));
  }
  double best_squared = std::numeric_limits<double>::infinity();
  for (const Eigen::Isometry3d& symmetry : symmetries) {
    const Eigen::Isometry3d gt_symmetric = gt_cam_from_object * symmetry;
    double worst_squared = 0.0;
    for (size_t i = 0; i < model_points_m.size(); ++i) {
      const Eigen::Vector2d gt = camera.Project(gt_symmetric * model_points_m[i].cast<double>());
      worst_squared = std::max(worst_squared, (estimated[i] - gt).squaredNorm());
      if (worst_squared >= best_squared) break;
    }
    best_squared = std::min(best_squared, worst_squared);
  }
  return std::sqrt(best_squared);
}

}  // namespace g6d
