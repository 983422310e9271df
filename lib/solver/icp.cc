#include "solver/icp.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include "core/error.h"
#include "solver/point_tree.h"

namespace g6d {

struct PointCloudIndex::Impl {
  explicit Impl(const std::vector<Eigen::Vector3d>& points) : tree(points) {}
  PointTree tree;
};

PointCloudIndex::PointCloudIndex(std::vector<Eigen::Vector3d> points)
    : points_(std::move(points)), impl_(std::make_unique<Impl>(points_)) {}

PointCloudIndex::PointCloudIndex(std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> normals)
    : PointCloudIndex(std::move(points)) {
  if (normals.size() != points_.size()) {
    G6D_THROW("PointCloudIndex: " << normals.size() << " normals for " << points_.size() << " points");
  }
  normals_ = std::move(normals);
}

PointCloudIndex::~PointCloudIndex() = default;

int PointCloudIndex::Nearest(const Eigen::Vector3d& query, double* squared_distance) const {
  std::vector<int> indices;
  std::vector<double> squared;
  NearestAll({query}, &indices, &squared);
  *squared_distance = squared[0];
  return indices[0];
}

void PointCloudIndex::NearestAll(const std::vector<Eigen::Vector3d>& queries, std::vector<int>* indices,
                                 std::vector<double>* squared_distances) const {
  NearestAll(queries, std::numeric_limits<double>::infinity(), false, indices, squared_distances);
  // Empty index: -1 and 0 (the unbounded query's contract).
  for (size_t i = 0; i < queries.size(); ++i) {
    if ((*indices)[i] < 0) (*squared_distances)[i] = 0.0;
  }
}

void PointCloudIndex::NearestAll(const std::vector<Eigen::Vector3d>& queries, double max_squared_distance,
                                 bool use_hints, std::vector<int>* indices,
                                 std::vector<double>* squared_distances) const {
  if (!use_hints || indices->size() != queries.size()) indices->assign(queries.size(), -1);
  squared_distances->resize(queries.size());
  for (size_t i = 0; i < queries.size(); ++i) {
    double squared = 0.0;
    const int found = impl_->tree.Nearest(queries[i], max_squared_distance, (*indices)[i], &squared);
    (*indices)[i] = found;
    (*squared_distances)[i] = found < 0 ? std::numeric_limits<double>::infinity() : squared;
  }
}

std::string IcpOptions::Check() const {
  std::ostringstream out;
  if (!(trim_fraction > 0.0 && trim_fraction <= 1.0)) out << "IcpOptions.trim_fraction must be in (0, 1] (got " << trim_fraction << ")";
  else if (!(kappa_d >= 0.0)) out << "IcpOptions.kappa_d must be >= 0 (got " << kappa_d << ")";
  else if (!(r0_m > 0.0)) out << "IcpOptions.r0_m must be > 0 (got " << r0_m << ")";
  else if (max_iterations < 1) out << "IcpOptions.max_iterations must be >= 1 (got " << max_iterations << ")";
  else if (min_correspondences < 3) out << "IcpOptions.min_correspondences must be >= 3 (got " << min_correspondences << ")";
  else if (!(min_rmse_decrease >= 0.0 && min_rmse_decrease < 1.0)) out << "IcpOptions.min_rmse_decrease must be in [0, 1) (got " << min_rmse_decrease << ")";
  else if (stall_window < 0) out << "IcpOptions.stall_window must be >= 0 (got " << stall_window << ")";
  else if (point_to_point_iterations < 0) out << "IcpOptions.point_to_point_iterations must be >= 0 (got " << point_to_point_iterations << ")";
  return out.str();
}

Eigen::Isometry3d AlignRigid(const std::vector<Eigen::Vector3d>& source,
                             const std::vector<Eigen::Vector3d>& target) {
  G6D_CHECK(source.size() == target.size() && source.size() >= 3);
  Eigen::Vector3d source_mean = Eigen::Vector3d::Zero(), target_mean = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < source.size(); ++i) {
    source_mean += source[i];
    target_mean += target[i];
  }
  source_mean /= static_cast<double>(source.size());
  target_mean /= static_cast<double>(target.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < source.size(); ++i) {
    covariance += (target[i] - target_mean) * (source[i] - source_mean).transpose();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) d(2, 2) = -1.0;
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = svd.matrixU() * d * svd.matrixV().transpose();
  transform.translation() = target_mean - transform.linear() * source_mean;
  return transform;
}

namespace {

// One linearized point-to-plane step: the small rotation w (about the pairs' source
// centroid c, which keeps the 6x6 system well conditioned for an object a metre away) and
// translation t minimizing sum ((c + (1 + [w]x)(p - c) + t - q) . n)^2 over the pairs with a
// normal; false when fewer than `min_pairs` have one or the system is degenerate (then
// the caller uses Kabsch).
bool PointToPlaneUpdate(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
                        const std::vector<Eigen::Vector3d>& normals, int min_pairs, Eigen::Isometry3d* update) {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : source) centre += p;
  centre /= static_cast<double>(std::max<size_t>(1, source.size()));
  Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  int pairs = 0;
  for (size_t i = 0; i < source.size(); ++i) {
    const Eigen::Vector3d& n = normals[i];
    if (n.squaredNorm() < 0.5) continue;  // no normal known
    Eigen::Matrix<double, 6, 1> row;
    row << (source[i] - centre).cross(n), n;
    normal_matrix += row * row.transpose();
    rhs += row * (target[i] - source[i]).dot(n);
    ++pairs;
  }
  if (pairs < min_pairs) return false;
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(normal_matrix);
  if (solver.info() != Eigen::Success) return false;
  const Eigen::Matrix<double, 6, 1> x = solver.solve(rhs);
  if (!x.allFinite()) return false;
  const Eigen::Vector3d w = x.head<3>();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  if (w.norm() > 1e-12) rotation = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  *update = Eigen::Isometry3d::Identity();
  update->linear() = rotation;
  update->translation() = centre - rotation * centre + x.tail<3>();
  return true;
}

}  // namespace

void RefineByTrimmedIcp(const IcpOptions& options, const std::vector<Eigen::Vector3d>& source_in_object,
                        const PointCloudIndex& target, double diameter_m,
                        Eigen::Isometry3d* cam_from_object, IcpReport* report,
                        const std::vector<Eigen::Vector3d>* source_normals_in_object) {
  *report = IcpReport();
  if (source_normals_in_object != nullptr && source_normals_in_object->size() != source_in_object.size()) {
    G6D_THROW("RefineByTrimmedIcp: " << source_normals_in_object->size() << " source normals for "
                                     << source_in_object.size() << " source points");
  }
  const std::string bad = options.Check();
  if (!bad.empty()) {
    report->message = bad;
    return;
  }
  if (source_in_object.size() < static_cast<size_t>(options.min_correspondences) ||
      target.points().size() < static_cast<size_t>(options.min_correspondences)) {
    report->message = "too few points (source " + std::to_string(source_in_object.size()) +
                      ", target " + std::to_string(target.points().size()) + ")";
    return;
  }
  const double r_max = std::max(options.r0_m, options.kappa_d * diameter_m);
  const double r_max_squared = r_max * r_max;
  const size_t n = source_in_object.size();
  Eigen::Isometry3d pose = *cam_from_object;
  std::vector<Eigen::Vector3d> moved(n);
  std::vector<int> nearest(n, -1);
  std::vector<double> squared(n);
  std::vector<size_t> order(n);
  std::vector<Eigen::Vector3d> kept_source, kept_target, kept_normal;
  double best_rmse = std::numeric_limits<double>::infinity();
  int best_iteration = 0;
  const bool source_planes = options.point_to_plane && source_normals_in_object != nullptr;
  const bool use_plane = source_planes || (options.point_to_plane && target.normals().size() == target.points().size());
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    for (size_t i = 0; i < n; ++i) moved[i] = pose * source_in_object[i];
    // Only pairs nearer than r_max are ever kept, so the search stops there (the others
    // get +infinity and sort last); each point's previous match is its first guess.
    target.NearestAll(moved, r_max_squared, iteration > 0, &nearest, &squared);
    std::iota(order.begin(), order.end(), size_t{0});
    // Trimming: the closest ρ fraction, then the r_max cutoff. Stable on ties so the
    // result does not depend on anything but the data.
    const size_t keep = static_cast<size_t>(std::ceil(options.trim_fraction * n));
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return squared[a] < squared[b]; });
    kept_source.clear();
    kept_target.clear();
    kept_normal.clear();
    double sum_squared = 0.0;
    for (size_t k = 0; k < keep; ++k) {
      const size_t i = order[k];
      if (nearest[i] < 0 || squared[i] >= r_max_squared) break;
      kept_source.push_back(moved[i]);
      kept_target.push_back(target.points()[static_cast<size_t>(nearest[i])]);
      if (source_planes) kept_normal.push_back(pose.linear() * (*source_normals_in_object)[i]);
      else if (use_plane) kept_normal.push_back(target.normals()[static_cast<size_t>(nearest[i])]);
      sum_squared += squared[i];
    }
    report->iterations = iteration + 1;
    report->correspondences = static_cast<int>(kept_source.size());
    if (kept_source.size() < static_cast<size_t>(options.min_correspondences)) {
      report->message = "too few correspondences within r_max (" + std::to_string(kept_source.size()) + ")";
      return;
    }
    report->rmse_m = std::sqrt(sum_squared / kept_source.size());
    // Stalled (e.g. a limit cycle of two correspondence sets): no new lowest RMSE for
    // stall_window iterations.
    if (report->rmse_m < best_rmse * (1.0 - options.min_rmse_decrease)) {
      best_rmse = report->rmse_m;
      best_iteration = iteration;
    } else if (options.stall_window > 0 && iteration - best_iteration >= options.stall_window) {
      break;
    }
    Eigen::Isometry3d update = Eigen::Isometry3d::Identity();
    const bool plane_step = use_plane && iteration >= options.point_to_point_iterations;
    if (!(plane_step && PointToPlaneUpdate(kept_source, kept_target, kept_normal, options.min_correspondences, &update))) {
      update = AlignRigid(kept_source, kept_target);
    }
    pose = update * pose;
    // Largest displacement of a kept point caused by this update.
    double step = 0.0;
    for (const Eigen::Vector3d& p : kept_source) step = std::max(step, (update * p - p).norm());
    if (step < options.min_step_m) break;
  }
  *cam_from_object = pose;
  report->success = true;
  report->message = "ok";
}

}  // namespace g6d
