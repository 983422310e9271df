#pragma once
/// @file finalists.h
/// The finalists of a solve (internal to lib/solver): every hypothesis' best state after
/// MHPO and T_A, symmetric duplicates merged, appearance as the tie-break, the runner-up and
/// the ambiguity flag.

#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/frame.h"
#include "solver/match.h"
#include "solver/mhpo.h"
#include "solver/region.h"
#include "solver/result.h"
#include "solver/score.h"
#include "solver/solve_context.h"
#include "solver/solver_options.h"
#include "templates/template_bank.h"

namespace g6d {

/// A candidate answer: one kept hypothesis' best state after MHPO (or T_A), and its S.
struct Finalist {
  Eigen::Isometry3d cam_from_object;
  PoseScore score;
  int hypothesis = -1;  // index of the kept hypothesis it came from; -1 = none (stage 6)
};

/// How far `mesh` at `cam_from_object` reaches behind the limit plane of `region` (its
/// support plane, or one in a wider ring; metres: the deepest vertex's distance on the far
/// side; 0 when none or no plane).
double DepthBehindSupport(const ObservedRegion& region, const Mesh& mesh, const Eigen::Isometry3d& cam_from_object);

/// Among the finalists (T_A last): drops poses equal modulo the symmetries to a better one,
/// passes over those that reach behind the support plane of `region` (SolverOptions::
/// support_penetration_fraction), lets appearance pick among those within
/// options.appearance_margin of the best S, and sets the runner-up and the ambiguity flag
/// of *result (whose T_A and details it may replace).
void ResolveFinalists(const SolverOptions& options, const TemplateBank& bank, const Frame& frame, const cv::Mat& mask,
                      const ObservedRegion& region, const MeshSymmetries& symmetries,
                      const std::vector<Eigen::Vector3d>& distance_points, std::vector<Finalist> finalists,
                      PoseResult* result);

/// The finalists (T_A last, as stage 6 may have moved it): symmetric duplicates merged,
/// appearance tie-break, runner-up and ambiguity; then where the answer came from.
/// With options.check_flips, T_A's flips (SolverOptions::check_flips) refined on `target`
/// join the finalists first.
void RunFinalistStage(const SolveContext& c, const MhpoTarget& target, std::vector<Finalist> finalists,
                      const std::vector<Hypothesis>& kept, const std::vector<CorrespondenceSet>& sets, PoseResult* result);

}  // namespace g6d
