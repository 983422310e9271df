#pragma once
/// @file result.h
/// What a solve of one instance returns: PoseResult (T_A, S_A, confidence, runner-up) and its
/// StageReport (counts, scores and times of every stage), why it stopped (Termination), and
/// the confidence calibration. Shared by every stage of lib/solver.

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "solver/frame_check.h"
#include "solver/mhpo.h"
#include "solver/score.h"
#include "solver/solver_options.h"

namespace g6d {

/// Why EstimatePose stopped.
enum class Termination {
  kNotRun,
  kConverged,     ///< all stages ran; the best state is T_A
  kEarlyStopped,  ///< MHPO stopped early: S_A fell below the threshold
  kCutShort,      ///< the budget ran out (or a stop was requested): T_A is the best so far
  kBadInput,      ///< the frame, mask or bank was unusable (see message)
  kNoHypothesis,  ///< matching or PnP produced no valid pose
};

/// Human-readable name of a Termination.
const char* TerminationName(Termination termination);

/// Counts, best scores and times of each stage: the interpretable intermediate results.
struct StageReport {
  int query_features = 0;          ///< over every search region
  int correspondence_sets = 0;     ///< after matching (≤ N_P per search region)
  /// Regions the search ran on: 1, or more for a mask that spans more than the object
  /// (SolverOptions::max_search_regions).
  int search_regions = 0;
  int pnp_hypotheses = 0;          ///< valid MSAC-PnP poses
  /// Point-pair-feature voting (SolverOptions::use_ppf): the scene points it voted with,
  /// the poses it gave (clusters) and how many of them were new (not equal to a PnP pose
  /// modulo the symmetries), and whether T_A came from one of them.
  int ppf_scene_points = 0;
  int ppf_hypotheses = 0;
  int ppf_distinct = 0;
  bool answer_from_ppf = false;
  /// The most MSAC-PnP poses that agree on one pose, and whether the vote was skipped for it
  /// (SolverOptions::ppf_skip_agreement).
  int pnp_agreement = 0;
  bool ppf_skipped = false;
  /// Poses from the mask's outline (SolverOptions::use_silhouettes): how many, how many were
  /// new, and whether T_A came from one of them.
  int silhouette_hypotheses = 0;
  int silhouette_distinct = 0;
  bool answer_from_silhouette = false;
  bool silhouette_skipped = false;  ///< PnP poses agreed (SolverOptions::silhouette_skip_agreement)
  int kept_hypotheses = 0;         ///< after observable selection (≤ N_H)
  int icp_converged = 0;
  int sets_tried = 0;               ///< correspondence sets PnP ran on (pnp_min_quality_ratio)
  int pnp_merged = 0;               ///< PnP poses merged into a better-ranked equal pose
  int icp_iterations = 0;           ///< ICP iterations over all hypotheses and passes
  int icp_runs_at_max = 0;          ///< ICP runs that stopped at their iteration limit
  int icp_finished = 0;             ///< hypotheses that ICP ran to convergence in its second pass
  int icp_merged = 0;               ///< hypotheses ICP brought onto a better-ranked one's pose (icp_merge_fraction)
  /// Index (into the kept hypotheses) of the one that became T_A; -1 = none (stage 6).
  int answer_hypothesis = -1;
  /// Rank by Q_j (0 = best) of T_A's correspondence set and its Q_j / Q_1; -1 / 0 when unknown.
  int answer_set_rank = -1;
  double answer_quality_ratio = 0.0;
  /// The mask as evidence (MaskTrust::kDepth): pixels of the caller's mask, how many of them
  /// the depth put on the support plane or far behind the object (leaks, removed), whether a
  /// support plane was found, and the tolerance of "on the rendered surface", metres.
  int mask_given_pixels = 0;
  int mask_support_leak = 0;
  int mask_far_leak = 0;
  bool support_plane = false;
  double surface_tolerance_m = 0.0;
  /// The region's depth spans more than the object can reach (kDepth): the mask holds more
  /// than the object (merged with a neighbour, a box).
  bool mask_wider_than_object = false;
  /// The caller's mask fills its bounding box (a detector's box): its outline says nothing
  /// of the object's, so the depth's regions inside it are solved too (kDepth).
  bool mask_is_box = false;
  /// The mask was refused for too little evidence (too few pixels with depth, or nothing
  /// left once its leaks were removed; termination kBadInput): it still says where the
  /// object is, and the depth's regions there are solved (SolverOptions::region_candidates).
  bool mask_too_thin = false;
  /// The depth's own regions solved in its place (SolverOptions::region_candidates), and
  /// whether one of them gave T_A (then `region` of the answer is that region).
  int depth_regions_solved = 0;
  bool depth_region_chosen = false;
  double mask_answer_score = 2.0;  ///< S_A of the answer on the mask itself, before the regions
  /// ExplainAwayNeighbours: pixels of the caller's mask the frame's other, more confident
  /// answers explain (0 = not solved again), and whether the solve without them gave T_A.
  int neighbour_pixels = 0;
  bool neighbour_answer_chosen = false;
  /// Another instance's answer of the same object lies at the same place with a lower S_A
  /// (DuplicateAnswers, after the neighbours pass): at most one of the two is right, so the
  /// confidence is at most 1 - that answer's.
  bool duplicate_answer = false;
  double best_quality = 0.0;       ///< best Q_j
  double best_e_obs = 1.0;         ///< best E_obs among PnP poses
  double best_s_after_icp = 2.0;   ///< best S after ICP
  double prepare_ms = 0.0, features_ms = 0.0, match_ms = 0.0, pnp_ms = 0.0,
         ppf_ms = 0.0, silhouette_ms = 0.0, observable_ms = 0.0, icp_ms = 0.0, mhpo_ms = 0.0, post_refine_ms = 0.0, finalists_ms = 0.0,
         mask_refine_ms = 0.0, frame_check_ms = 0.0, depth_regions_ms = 0.0, neighbours_ms = 0.0, total_ms = 0.0;
  int distinct_finalists = 0;         ///< finalists left after merging poses equal modulo symmetry
  int appearance_compared = 0;        ///< finalists whose appearance was scored
  bool appearance_changed = false;    ///< appearance replaced the lowest-S pose as T_A
  int flips_checked = 0;              ///< T_A's flips refined and compared (SolverOptions::check_flips)
  bool flip_answer = false;           ///< a flip of the first T_A fitted better and is the answer
  /// The support check (SolverOptions::support_penetration_fraction): how far the answer's
  /// model reaches behind the support plane under the mask (metres; 0 in front of it or
  /// with no plane), how many distinct finalists reach behind it past the limit, and
  /// whether the check passed over a lower-S finalist for the answer.
  double support_penetration_m = 0.0;
  bool limit_plane = false;  ///< a plane limited the poses (ObservedRegion::has_limit_plane)
  int finalists_behind_support = 0;
  bool support_changed = false;
  /// Every finalist near the best S reached behind it: so does the answer. Detection also
  /// sets it when the answer reaches behind the frame's support plane around its region past
  /// the same limit (DepthBehindFrameSupport: a ring of depth holes shows the solve no plane).
  bool answer_behind_support = false;
  bool post_refine_ran = false;       ///< stage 6 was triggered
  bool post_refine_accepted = false;  ///< and replaced T_A
  /// Best pose after each stage, for per-stage recall (seed, pnp, observable, icp, mhpo);
  /// identity where a stage did not run.
  Eigen::Isometry3d seed_pose = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d pnp_pose = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d observable_pose = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d icp_pose = Eigen::Isometry3d::Identity();
  /// Every valid MSAC-PnP pose (in template rank order) and the N_H kept after observable
  /// selection (best E_obs first), for oracle analyses ("was a good hypothesis there?").
  std::vector<Eigen::Isometry3d> pnp_poses, kept_poses;
  std::vector<Eigen::Isometry3d> ppf_poses;  ///< every point-pair-feature pose, most votes first
  MhpoReport mhpo;
};

/// A stage's name and wall time.
struct StageTime {
  const char* name;
  double ms;
};

/// The stage times of a report in pipeline order, with the names every report uses (the
/// service's status, g6d-solve, the benchmarks): prepare, features, match, pnp, ppf,
/// silhouette, observable, icp, mhpo, post_refine, finalists, total.
std::vector<StageTime> StageTimes(const StageReport& stages);

/// Copies the stage times of one solve on a mask (prepare_ms ... depth_regions_ms; not
/// neighbours_ms or total_ms) and the mask's own findings (mask_given_pixels,
/// mask_wider_than_object, mask_too_thin, mask_is_box) from `from` into *to: an answer taken
/// from a later solve (a depth region's, one without the neighbours' pixels) reports the
/// work its instance cost and the mask it was given.
void CopyMaskSolveReport(const StageReport& from, StageReport* to);

/// The estimate for one instance.
struct PoseResult {
  bool success = false;
  std::string message = "not run";
  Termination termination = Termination::kNotRun;
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();  ///< T_A
  double score = 2.0;        ///< S_A (eq. 12), lower is better
  bool truncated = false;    ///< the instance mask touches the image border (object cut off)
  /// The solve was cut short by SolverOptions::budget_ms or stop_requested: stages were
  /// skipped and T_A is the best pose found until then (termination kCutShort).
  bool cut_short = false;
  /// A pose that is not a symmetry of the mesh scores (nearly) as well as T_A and
  /// appearance does not tell them apart: the runner-up below is a plausible answer too.
  bool ambiguous = false;
  bool has_runner_up = false;  ///< a distinct finalist exists (runner-up fields valid)
  Eigen::Isometry3d runner_up_cam_from_object = Eigen::Isometry3d::Identity();
  double runner_up_score = 2.0;  ///< S of the runner-up
  /// Appearance agreement (ZNCC in [-1, 1]) of T_A; valid only when appearance_valid.
  double appearance_agreement = 0.0;
  bool appearance_valid = false;
  /// The same for the runner-up (valid only when has_runner_up and it was compared).
  double runner_up_appearance_agreement = 0.0;
  bool runner_up_appearance_valid = false;
  /// In [0, 1]: the probability that the pose is right (SolverOptions::confidence).
  double confidence = 0.0;
  /// T_A against the whole frame (CheckAgainstFrame; SolverOptions::check_surface_fraction,
  /// check_step_m); zero when the solve failed.
  FrameCheck frame_check;
  /// The mask T_A implies: its rendered silhouette less the pixels the depth shows hidden
  /// (CorrectedMask), CV_8U 0/255 frame size; empty when the solve failed.
  cv::Mat corrected_mask;
  /// IoU of corrected_mask with the caller's mask: how well the segmenter's mask fits the
  /// answer (1 = exactly; a quality signal for the segmenter).
  double mask_iou = 0.0;
  int mask_refined_rounds = 0;  ///< refinements on the corrected mask that lowered S_A
  PoseScore details;         ///< C, J, depth residual of T_A
  StageReport stages;
};

/// Confidence in [0, 1] for a score S_A and the ambiguity flag (monotone decreasing in S_A,
/// lower when ambiguous): SolverOptions::confidence_bias and the two weights.
double ConfidenceFromScore(const SolverOptions& options, double score, bool ambiguous);

/// The confidence of a successful answer to a mask (SolverOptions::confidence or, for a mask
/// wider than the object or a box, wide_mask_confidence): S_A, ambiguous, frame_check and
/// mask_iou of `result`, which must be set. 0 for a failed one.
double AnswerConfidence(const SolverOptions& options, const PoseResult& result);

/// Whether a successful answer with S_A `score` is unsure (SolverOptions::unsure_score,
/// unsure_ambiguous_score): worth a second reading of its mask, and no evidence for its
/// neighbours. Not finite: unsure.
bool UnsureOfScore(const SolverOptions& options, double score, bool ambiguous);

}  // namespace g6d
