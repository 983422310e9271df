#pragma once
/// @file stages.h
/// The search stages of a solve on a mask, in the paper's order (internal to lib/solver;
/// EstimatePoseOnMask, mask_solve.h, runs them): features, template matching and MSAC-PnP on
/// every search region (RunSearchStages), point-pair-feature voting (RunPpfStage),
/// observable selection (RunObservableStage), trimmed ICP (RunIcpStage), MHPO (RunMhpoStage)
/// and the optional post-refinement (RunPostRefineStage).

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "solver/finalists.h"
#include "solver/match.h"
#include "solver/mhpo.h"
#include "solver/result.h"
#include "solver/score.h"
#include "solver/solve_context.h"

namespace g6d {

/// What the search found: the correspondence sets (best Q first) and the PnP hypotheses.
struct Search {
  std::vector<CorrespondenceSet> sets;
  std::vector<Hypothesis> hypotheses;
};

/// Stages 1 and 2 on every search region (the whole region first), the hypotheses pooled:
/// one equal (modulo the symmetries) to an earlier region's is dropped. Returns an empty
/// string, or why no hypothesis came out (the solve's kNoHypothesis).
std::string RunSearchStages(const SolveContext& c, Search* search);

/// Point-pair-feature voting on the first search region's depth (the mask the depth
/// corrected and grew): its poses join the PnP hypotheses, those equal to one already there
/// (modulo the symmetries) merged into it.
void RunPpfStage(const SolveContext& c, Search* search);

/// Poses from the mask's outline (silhouette_poses.h; not for a box or a mask wider than the
/// object): they join the hypotheses, those equal to one already there (modulo the
/// symmetries) merged into it.
void RunSilhouetteStage(const SolveContext& c, Search* search);

/// Stage 3 with its report: the K hypotheses kept by E_obs.
std::vector<Hypothesis> RunObservableStage(const SolveContext& c, const std::vector<Hypothesis>& hypotheses);

/// The kept hypotheses after ICP, their scores and the best of them.
struct IcpOutcome {
  std::vector<Eigen::Isometry3d> refined;
  std::vector<PoseScore> scores;
  int best = 0;
};

/// Stage 4 with its report: trimmed ICP on every kept hypothesis (in place), then S.
IcpOutcome RunIcpStage(const SolveContext& c, std::vector<Hypothesis>* kept);

/// Stage 5: MHPO from the ICP poses, T_A and S_A the best state over all hypotheses and
/// rounds (the best ICP pose when MHPO does not improve on it). Returns every hypothesis'
/// best state, the finalists for the runner-up and appearance.
std::vector<Finalist> RunMhpoStage(const SolveContext& c, const MhpoTarget& target, const std::vector<Hypothesis>& kept,
                                   const IcpOutcome& icp, PoseResult* result);

/// Stage 6 (options.post_refine): a poor T_A (S above the trigger) is tried again from its
/// flips and re-centred copies (PostRefineHypotheses), ICP + MHPO, accepted by a margin.
void RunPostRefineStage(const SolveContext& c, const MhpoTarget& target, PoseResult* result);

}  // namespace g6d
