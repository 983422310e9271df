#pragma once
/// @file mhpo.h
/// Mask-depth multi-hypothesis pose optimization (paper Sec. III-E) on the CPU.
///
/// The paper differentiates through a GPU soft rasterizer with Adam. Here, per hypothesis
/// and round: rasterize once; take the rendered silhouette contour and the visible surface
/// points (object frame, from the exact rasterized depth); run a few Levenberg-Marquardt
/// steps (a dense 6x6 loop with Ceres' trust-region rules; the bicubic interpolation is
/// Ceres') on an SE(3) increment over (a) silhouette residuals, the signed distance
/// of each projected contour point to the observed mask boundary, and (b) Huber depth
/// residuals (rendered − observed depth) / z_M, both read through bicubic interpolation;
/// then re-rasterize and score S (eq. 12) exactly. The best state over all hypotheses and
/// rounds is kept (T_A, S_A). The optimized objective and the selection score are separate.

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/executor.h"
#include "core/timer.h"
#include "mesh/mesh.h"
#include "solver/observation.h"
#include "solver/score.h"

namespace g6d {

/// Options of RefineByMhpo().
struct MhpoOptions {
  double lambda_d = 0.1;        ///< λ_D: weight of the mean depth term against the mean mask term
  double huber_beta = 0.02;     ///< β of the Huber penalty on (D̂ − D) / z_M (unitless)
  double silhouette_robust_px = 3.0;  ///< Huber scale of the silhouette residual, grid pixels
  int max_rounds = 5;           ///< re-rasterizations per hypothesis
  int lm_iterations = 4;        ///< Levenberg-Marquardt iterations per round
  int max_contour_points = 160; ///< silhouette residuals per round at most
  int max_depth_points = 240;   ///< depth residuals per round at most
  /// Stop all hypotheses once the best S falls below this (progressive stopping);
  /// <= 0 disables it.
  double early_stop_score = 0.06;
  /// Early stopping applies only after this many rounds: every hypothesis is refined at
  /// least this often, so that a competitor of T_A (a flip that appearance must judge) is
  /// compared in its refined state, not as ICP left it.
  int min_rounds = 1;
  int patience = 2;             ///< stop a hypothesis after this many rounds without a lower S

  std::string Check() const;
};

/// The observation prepared for MHPO: the grid plus the observed mask's signed distance.
struct MhpoTarget {
  const EvaluationGrid* grid = nullptr;  ///< observed mask and depth on the ROI grid
  double z_m = 0.0;                      ///< z_M (eq. 9), metres
  cv::Mat signed_distance;               ///< CV_32F on the grid, px: > 0 outside the mask
  /// Observed depth with small holes filled from their valid neighbours (CV_32F, metres):
  /// what the depth residuals interpolate, so a step that moves a point next to a hole
  /// reads a plausible depth instead of the hole's 0.
  cv::Mat filled_depth;
};

/// Builds the signed distance of grid->mask (grid pixels; positive outside the mask) and
/// the hole-filled depth (holes up to `fill_radius_px` grid pixels from valid depth).
MhpoTarget MakeMhpoTarget(const EvaluationGrid& grid, double z_m, int fill_radius_px = 3);

/// Per-hypothesis outcome.
struct MhpoHypothesisReport {
  double initial_s = 0.0;
  double best_s = 0.0;
  int rounds = 0;
  int best_round = 0;  ///< 0 = the initial pose was the best
  Eigen::Isometry3d best_cam_from_object = Eigen::Isometry3d::Identity();  ///< its best state
  PoseScore best_score;  ///< S and its parts at that state
};

/// What MHPO did.
struct MhpoReport {
  bool success = false;
  std::string message = "not run";
  int best_hypothesis = -1;
  PoseScore best_score;  ///< score of T_A
  bool early_stopped = false;
  bool cut_short = false;  ///< the deadline expired: rounds were skipped
  std::vector<MhpoHypothesisReport> hypotheses;
};

/// Refines every pose of `hypotheses` and returns T_A = argmin over hypotheses and rounds
/// of S (eq. 17) in *best_cam_from_object. Hypotheses fan out over `executor`, in
/// lock-step rounds, so early stopping and the result do not depend on the thread count.
/// With a `deadline`, no round starts after it expired (report->cut_short; the result is
/// the best state reached). `initial_scores` (optional, one per hypothesis) are the
/// hypotheses' scores on target.grid with `score_options` when the caller has them
/// already (they are not recomputed).
void RefineByMhpo(const MhpoOptions& options, const ScoreOptions& score_options,
                  const MhpoTarget& target, const Mesh& mesh,
                  const std::vector<Eigen::Isometry3d>& hypotheses, Executor* executor,
                  Eigen::Isometry3d* best_cam_from_object, MhpoReport* report,
                  const Deadline* deadline = nullptr,
                  const std::vector<PoseScore>* initial_scores = nullptr);

/// The residuals exposed for tests (Jacobian checks): a silhouette residual of one contour
/// point and a depth residual of one surface point (camera frame), unweighted, and when
/// `jacobian` is not null their derivatives with respect to the left increment
/// (rho, phi) at zero, p' = R(phi) p + rho: what each Levenberg-Marquardt step linearizes.
double EvaluateSilhouetteResidual(const MhpoTarget& target, const Eigen::Vector3d& point_in_cam, double jacobian[6]);
double EvaluateDepthResidual(const MhpoTarget& target, const Eigen::Vector3d& point_in_cam, double jacobian[6]);

}  // namespace g6d
