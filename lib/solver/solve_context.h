#pragma once
/// @file solve_context.h
/// What the stages of one solve share (internal to lib/solver): the input check, the
/// deadline (SolveClock), pose comparison modulo the symmetries (PoseComparer), a hypothesis,
/// the context every stage reads (SolveContext), and one trimmed ICP run from a pose
/// (RunIcpFrom, for the search's ICP stage and for TrackPose).

#include <algorithm>
#include <atomic>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "core/executor.h"
#include "core/frame.h"
#include "core/timer.h"
#include "mesh/mesh.h"
#include "mesh/symmetry.h"
#include "render/raster.h"
#include "solver/icp.h"
#include "solver/mask_stage.h"
#include "solver/result.h"
#include "solver/score.h"
#include "solver/solver_options.h"
#include "templates/template_bank.h"

namespace g6d {

/// Returns an empty string when the inputs can be used, else what is wrong.
std::string ValidateInputs(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                           const SolverOptions& options);

/// One trimmed ICP run of at most `max_iterations` from *cam_from_object, on a source of
/// at most `max_points` visible model points rendered there (with their normals for
/// point-to-plane).
IcpReport RunIcpFrom(const SolverOptions& options, const Mesh& mesh, const EvaluationGrid& grid,
                     const ScoreOptions& score_options, const PointCloudIndex& observed, double diameter_m,
                     int max_points, int max_iterations, RasterImage* scratch, Eigen::Isometry3d* cam_from_object);

/// *result marked failed with `termination` and `message`, its total time taken from
/// `total`; returns a copy for the caller to return.
PoseResult Failed(Termination termination, const std::string& message, const Stopwatch& total, PoseResult* result);

/// The symmetries of the shape: the mesh's geometric ones and those the user gave (BOP
/// models_info.json) as discrete ones.
MeshSymmetries ShapeSymmetries(const TemplateBank& bank);

/// The symmetries under which two poses are the same answer: the shape's, except the
/// geometric ones of a coloured model. A printed box's 180-degree flips have the same shape
/// but not the same print: they must stay apart (as hypotheses and as finalists) so that
/// appearance can choose between them.
MeshSymmetries AnswerSymmetries(const TemplateBank& bank);

/// `cam_from_object` turned 180 degrees about each of the bounding box's three axes through
/// its centre (x, y, z): the usual confusions of a near-symmetric shape seen from one side.
std::vector<Eigen::Isometry3d> BoxFlips(const Eigen::Isometry3d& cam_from_object, const TemplateBank& bank);

/// Up to `count` vertices of the online mesh (even stride): the points of pose distances.
std::vector<Eigen::Vector3d> DistancePoints(const Mesh& mesh, size_t count);

/// The deadline of one solve, and whether work was skipped because of it.
class SolveClock {
 public:
  explicit SolveClock(const SolverOptions& options) : deadline_(options.budget_ms, options.stop_requested) {}
  // True, and records that work was skipped, once `share` of the budget is used up (or a
  // stop was requested).
  bool OutOfTime(double share = 1.0) {
    if (!deadline_.ExpiredAt(share)) return false;
    skipped_ = true;
    return true;
  }
  void MarkSkipped() { skipped_ = true; }
  bool Skipped() const { return skipped_; }
  const Deadline& deadline() const { return deadline_; }

 private:
  Deadline deadline_;
  std::atomic<bool> skipped_{false};
};

/// Pose comparison modulo symmetries (mean distance of model points, as ADD), with a cheap
/// lower bound that settles most pairs of distant poses: for any symmetry g,
/// mean |a x - b g x| >= |a c - b g c| >= |a c - b c| - |c - g c|, c the points' centroid,
/// and |c - g c| <= reach_ for every g.
class PoseComparer {
 public:
  PoseComparer(const MeshSymmetries& symmetries, std::vector<Eigen::Vector3d> points)
      : symmetries_(symmetries), points_(std::move(points)) {
    for (const Eigen::Vector3d& x : points_) centroid_ += x;
    centroid_ /= static_cast<double>(std::max<size_t>(1, points_.size()));
    for (const Eigen::Isometry3d& g : symmetries_.discrete) reach_ = std::max(reach_, (g * centroid_ - centroid_).norm());
    if (symmetries_.revolution) {
      const Eigen::Vector3d axis = symmetries_.axis.normalized();
      const Eigen::Vector3d offset = centroid_ - symmetries_.point;
      reach_ += 2.0 * (offset - offset.dot(axis) * axis).norm();
    }
  }
  const MeshSymmetries& symmetries() const { return symmetries_; }
  const std::vector<Eigen::Vector3d>& points() const { return points_; }
  // True when a and b are within `distance_m` of each other modulo the symmetries.
  bool Within(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double distance_m) const {
    if ((a * centroid_ - b * centroid_).norm() - reach_ > distance_m) return false;
    return SymmetricPoseDistance(symmetries_, points_, a, b) <= distance_m;
  }

 private:
  MeshSymmetries symmetries_;
  std::vector<Eigen::Vector3d> points_;
  Eigen::Vector3d centroid_ = Eigen::Vector3d::Zero();
  double reach_ = 0.0;
};

/// A pose hypothesis and the rank (by Q_j, 0 = best) of the correspondence set it came from
/// (-1: a point-pair-feature pose).
struct Hypothesis {
  Eigen::Isometry3d cam_from_object;
  /// Rank by Q_j of the correspondence set its PnP pose came from, or the source that has
  /// no set: kPpfSource, kSilhouetteSource.
  int set_rank = 0;
};
constexpr int kPpfSource = -1;         ///< Hypothesis::set_rank of a point-pair-feature pose
constexpr int kSilhouetteSource = -2;  ///< Hypothesis::set_rank of a pose from the mask's outline

/// Everything the stages share for one instance.
struct SolveContext {
  const Frame& frame;
  const TemplateBank& bank;
  const SolverOptions& options;
  Executor* executor;
  const Observation& observation;
  const PoseComparer& comparer;      // modulo the answer symmetries
  ScoreOptions online_score;         // options.score, culling set for the online mesh
  ScoreOptions selection_score;      // the same for the selection mesh
  const Mesh* selection_mesh;        // the coarse mesh, or the online mesh
  SolveClock* clock;
  StageReport* stages;
};

/// The context of one solve: the score options per mesh (back faces culled only on closed
/// meshes) and the selection mesh (the coarse one when the bank has it).
SolveContext MakeSolveContext(const Frame& frame, const TemplateBank& bank, const SolverOptions& options,
                              Executor* executor, const Observation& observation, const PoseComparer& comparer,
                              SolveClock* clock, StageReport* stages);

}  // namespace g6d
