#pragma once
/// @file track_pose.h
/// TrackPose: one instance solved from known poses (the tracker's last answer and its
/// prediction, or T_A on the mask T_A implies): trimmed ICP and MHPO from the given starts
/// only.

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/executor.h"
#include "core/frame.h"
#include "solver/result.h"
#include "solver/solver_options.h"
#include "templates/template_bank.h"

namespace g6d {

/// Options of a solve from known poses.
struct TrackSolveOptions {
  int icp_iterations = 10;        ///< ICP iterations per start (point-to-plane after the first 3)
  int max_source_points = 300;    ///< rendered ICP source points at most
  int max_observed_points = 1200; ///< observed points (inside the mask) at most
  int mhpo_rounds = 2;            ///< MHPO re-rasterizations per start
  /// A coloured surface of revolution (a printed can): depth and silhouette cannot see its
  /// turn about the axis, so a tracked pose would drift along it. The turn is searched by
  /// appearance agreement within +- this many degrees of the refined pose (0 = off) ...
  double appearance_search_deg = 8.0;
  double appearance_step_deg = 2.0;  ///< ... in steps of this many degrees
  /// Score the appearance agreement of the answer of any other coloured mesh too
  /// (PoseResult::appearance_valid / appearance_agreement), for the tracker's loss test.
  bool score_appearance = true;

  std::string Check() const;
};

/// Solves one instance from `starts` (poses near the answer, e.g. the last answer and a
/// constant-velocity prediction): trimmed ICP on depth, MHPO, the best state by S. The
/// observation is prepared as EstimatePose prepares it, with `options`; the result has the
/// same fields (T_A, S_A, details, confidence, truncated; no runner-up: only the starts'
/// neighbourhood is searched; with a coloured mesh, the appearance agreement of T_A, and a
/// surface of revolution turned about its axis by it, see TrackSolveOptions). Never throws for bad data: bad input gives success = false,
/// termination kBadInput. Starts fan out over `executor`.
/// `pose` with the turn about `shape`'s revolution axis that it has relative to `start`
/// taken out (`pose` itself when `shape` is no surface of revolution): the swing of
/// start^-1 · pose is kept, its twist about the axis (through shape.point) dropped. The
/// surface is the same at either pose.
Eigen::Isometry3d KeepTurnAboutAxis(const MeshSymmetries& shape, const Eigen::Isometry3d& start,
                                    const Eigen::Isometry3d& pose);

PoseResult TrackPose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                     const SolverOptions& options, const TrackSolveOptions& track_options,
                     const std::vector<Eigen::Isometry3d>& starts, Executor* executor);

}  // namespace g6d
