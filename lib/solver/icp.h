#pragma once
/// @file icp.h
/// Trimmed point-to-point ICP (paper Sec. III-D): rendered visible model points are
/// aligned to the observed points inside the mask; per iteration only the closest
/// fraction ρ of correspondences with residuals below r_max = max(r_0, κ_d · diameter)
/// enters the rigid (Kabsch) update. The k-d tree over the observed points is
/// solver/point_tree.h (three dimensions, bounded and warm-started queries; why not
/// Open3D's there).

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace g6d {

/// Nearest-neighbour index over a fixed 3D point set (a PointTree inside).
/// Built once per instance; const queries are thread-safe.
class PointCloudIndex {
 public:
  explicit PointCloudIndex(std::vector<Eigen::Vector3d> points);
  /// With a unit normal per point (a zero vector where none is known), for point-to-plane
  /// ICP. Throws g6d::Error when the sizes differ.
  PointCloudIndex(std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> normals);
  ~PointCloudIndex();
  PointCloudIndex(const PointCloudIndex&) = delete;
  PointCloudIndex& operator=(const PointCloudIndex&) = delete;

  const std::vector<Eigen::Vector3d>& points() const { return points_; }
  /// Empty, or one normal per point (zero where unknown).
  const std::vector<Eigen::Vector3d>& normals() const { return normals_; }
  /// Index of the nearest point to `query` and its squared distance; -1 when empty.
  int Nearest(const Eigen::Vector3d& query, double* squared_distance) const;
  /// Nearest() for every query (one result buffer for all; the ICP inner loop).
  void NearestAll(const std::vector<Eigen::Vector3d>& queries, std::vector<int>* indices,
                  std::vector<double>* squared_distances) const;
  /// The same, but only neighbours nearer than sqrt(`max_squared_distance`): a query with
  /// none gets index -1 and squared distance +infinity. With `use_hints`, `*indices` holds
  /// a guess per query on entry (e.g. its match in the previous ICP iteration; -1 = none),
  /// which only speeds the search: the result is the exact nearest point either way.
  void NearestAll(const std::vector<Eigen::Vector3d>& queries, double max_squared_distance, bool use_hints,
                  std::vector<int>* indices, std::vector<double>* squared_distances) const;

 private:
  struct Impl;
  std::vector<Eigen::Vector3d> points_;
  std::vector<Eigen::Vector3d> normals_;
  std::unique_ptr<Impl> impl_;
};

/// Options of RefineByTrimmedIcp(). Defaults are the paper's.
struct IcpOptions {
  double trim_fraction = 0.70;   ///< ρ: fraction of closest correspondences kept
  double kappa_d = 0.35;         ///< κ_d: r_max relative to the object diameter
  double r0_m = 0.01;            ///< r_0: minimum residual cutoff, metres
  int max_iterations = 60;       ///< iterations at most (point-to-point converges slowly along smooth surfaces)
  double min_step_m = 1e-5;      ///< stop when the update moves points less than this, metres (10 µm)
  /// Also stop when the trimmed RMSE has not reached a new lowest value (lower by more
  /// than the fraction `min_rmse_decrease`) for `stall_window` iterations: the fit no
  /// longer improves, e.g. the pose alternates between two correspondence sets (a limit
  /// cycle the step size never ends). 0 = off.
  int stall_window = 0;
  double min_rmse_decrease = 0.0;
  int min_correspondences = 12;  ///< fewer kept correspondences = failure
  /// Minimize the point-to-plane distance (linearized, one 6x6 solve per iteration)
  /// instead of the paper's point-to-point Kabsch: it slides along smooth surfaces in a
  /// few iterations where point-to-point needs tens. The planes are the source's (the
  /// model's normals, when RefineByTrimmedIcp gets them), else the target's (a
  /// PointCloudIndex with normals); pairs with no normal are left out of the update.
  /// False, or no normals at all: point-to-point.
  bool point_to_plane = false;
  /// With point_to_plane, the first this many iterations are point-to-point all the same:
  /// far from the optimum, nearest neighbours are poor matches and Kabsch moves more
  /// robustly; close to it, the plane metric converges in a few steps.
  int point_to_point_iterations = 0;

  std::string Check() const;
};

/// What ICP did.
struct IcpReport {
  bool success = false;
  std::string message = "not run";
  int iterations = 0;
  int correspondences = 0;  ///< kept in the last iteration
  double rmse_m = 0.0;      ///< over the kept correspondences of the last iteration
};

/// Refines *cam_from_object so that `source_in_object` (object frame, metres) matches the
/// observed points indexed by `target` (camera frame, metres). On failure the pose is
/// left unchanged.
/// `source_normals_in_object` (optional): a unit normal per source point (zero where
/// unknown), for point-to-plane along the model's surface. Throws g6d::Error when its size
/// differs from the source's.
void RefineByTrimmedIcp(const IcpOptions& options, const std::vector<Eigen::Vector3d>& source_in_object,
                        const PointCloudIndex& target, double diameter_m,
                        Eigen::Isometry3d* cam_from_object, IcpReport* report,
                        const std::vector<Eigen::Vector3d>* source_normals_in_object = nullptr);

/// Least-squares rigid transform (no scale) mapping `source[i]` onto `target[i]`
/// (Kabsch / Umeyama). Requires at least 3 non-collinear pairs.
Eigen::Isometry3d AlignRigid(const std::vector<Eigen::Vector3d>& source,
                             const std::vector<Eigen::Vector3d>& target);

}  // namespace g6d
