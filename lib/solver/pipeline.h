#pragma once
/// @file pipeline.h
/// EstimatePose: the whole G6D online pipeline for one instance (paper Sec. III-C..E):
/// match -> MSAC-PnP -> observable selection -> trimmed ICP -> MHPO, selected by S.

#include <atomic>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/executor.h"
#include "mesh/symmetry.h"
#include "templates/appearance.h"
#include "solver/icp.h"
#include "solver/match.h"
#include "solver/mhpo.h"
#include "solver/observation.h"
#include "solver/pnp.h"
#include "solver/ppf.h"
#include "solver/region.h"
#include "solver/score.h"
#include "solver/segments.h"
#include "templates/features.h"
#include "templates/template_bank.h"

namespace g6d {

/// One instance to estimate: its object and its visible mask in the frame.
struct Instance {
  std::string object_id;  ///< must equal the bank's object id
  cv::Mat mask;           ///< CV_8U, frame size, non-zero = visible object pixels
};

/// All options of EstimatePose. Defaults are the paper's where it gives them.
struct SolverOptions {
  OrbOptions query_orb = [] {
    OrbOptions orb;
    orb.max_features = 500;
    return orb;
  }();                          ///< ORB on the query crop (the crop options come from the bank)
  /// How the instance mask is read. kDepth (default): as evidence checked by the depth, its
  /// leaks onto the support plane and the background removed and the object it missed
  /// counted per pose (region.h); kExact: the paper's, every mask pixel is object and no
  /// other pixel is (bit for bit the solver before masks were evidence).
  MaskTrust mask_trust = MaskTrust::kDepth;
  RegionOptions region;         ///< the depth's check of the mask (kDepth)
  /// The mask's depth segments (kDepth): each pose owns the segments it covers and the rest
  /// are another object's (ScoreOptions::segment_own_fraction; a merged or boxed mask).
  SegmentOptions segments;
  /// kDepth: when a depth segment of the mask is wider than the object (a merged mask, a
  /// box), the mask's segments are split at concave creases too (SegmentByDepthAndCreases),
  /// so that objects touching at the same depth each own their part. Off: on LM-O's merged
  /// masks it measured 75.1% against 76.6% without, boxes 82.4% either way (bench/RESULTS.md,
  /// issue 23): there the touching objects' own concavities split them as well, and the
  /// ownership of the pieces misleads S more than the merge did.
  bool split_merged_at_creases = false;
  /// When the mask's depth segments span more than the object can (kDepth: merged with a
  /// neighbour, or a box), the search (features, matching, PnP) also runs on each of its
  /// largest segments within the object's reach, at most this many; the hypotheses are
  /// pooled. 0 = the whole region only.
  int max_search_regions = 2;
  /// The depth's own regions when the mask holds more than the object (kDepth): when the
  /// mask's depth spans more than the object can reach (merged with a touching neighbour, a
  /// box over neighbours), the regions the depth forms inside it (DetectObjects' proposals:
  /// depth steps and concave creases, and unions of them that fit the object, ranked by
  /// size and colour, detect.h) are solved too, the best `region_candidates` of them, each
  /// as a mask of its own, and the answer with the lowest S_A wins. Objects that touch at
  /// the same depth form one segment that ownership cannot split; the creases can. 0 = off.
  int region_candidates = 2;
  /// ... and also when the mask's answer is unsure: its confidence (the calibration below)
  /// is under this (0.5: the answer is more likely wrong than right). A box or a mask that
  /// missed most of the object can hold the object's region whole without spanning more
  /// than it. 0 = only for masks wider than the object.
  double region_search_confidence = 0.5;
  /// A frame's instances read together (ExplainAwayNeighbours, neighbours.h; kDepth): an
  /// instance whose mask holds more than the object, is a box, or whose answer is unsure is
  /// solved again on its mask less the pixels the confident answers of lower S_A of the
  /// frame's other instances explain, when they explain at least `neighbour_min_fraction`
  /// of its mask; the lower S_A wins. Callers that solve one instance at a time ignore it.
  bool explain_neighbours = true;
  double neighbour_min_fraction = 0.05;
  /// The mask refined with the pose (kDepth): after the solve, ICP + MHPO from T_A on the
  /// mask T_A implies (CorrectedMask), accepted when S with the caller's mask as evidence
  /// is lower; repeated while it improves, at most this many times (0 = off).
  int mask_refine_rounds = 1;
  MatchOptions match;           ///< τ_H = 64, N_P = 256
  PnpOptions pnp;
  /// Point-pair-feature hypotheses (ppf.h) from the depth of the search region, beside the
  /// ORB-PnP ones: they need no texture (bare metal, plain plastic). Used when the bank has
  /// a PPF model (TemplateBank::ppf); the two sources' poses meet in observable selection.
  bool use_ppf = true;
  PpfSearchOptions ppf;
  /// Slots beyond K for the point-pair-feature poses: after observable selection kept the K
  /// best PnP poses by E_obs, the best this many PPF poses by E_obs join them, so that ICP
  /// and MHPO refine K + ppf_hypotheses poses. (Competing for the K slots instead, they
  /// displaced a textured object's right PnP pose at small K.)
  int ppf_hypotheses = 6;
  int num_hypotheses = 18;      ///< N_H = K: hypotheses kept after observable selection
  ScoreOptions score;           ///< ω_C = 0.70, λ_S = 10
  GridOptions selection_grid = [] {
    GridOptions grid;
    grid.max_side_px = 96;
    return grid;
  }();                          ///< ROI grid for observable selection (eq. 7)
  GridOptions refine_grid = [] {
    GridOptions grid;
    grid.max_side_px = 160;
    return grid;
  }();                          ///< ROI grid for ICP sources, MHPO and the final S
  /// ρ = 0.70, κ_d = 0.35 (the paper's trimming); point-to-plane along the rendered
  /// model's normals after 3 point-to-point iterations, stopped when the trimmed RMSE has
  /// not improved for 5 iterations: on LM-O it converges in about a third of the paper's
  /// point-to-point iterations and fits tighter (bench/RESULTS.md, issue 13).
  IcpOptions icp = [] {
    IcpOptions icp;
    icp.point_to_plane = true;
    icp.point_to_point_iterations = 3;
    icp.stall_window = 5;
    return icp;
  }();
  bool run_icp = true;          ///< stage 4 on/off (ablations)
  int max_observed_points = 2500;  ///< observed cloud Y is subsampled to about this many points
  int max_source_points = 600;     ///< rendered ICP source cloud size at most (fine)
  /// ICP coarse to fine: each hypothesis converges on this many source points first, then
  /// on max_source_points from there (0 = the full source only).
  int icp_coarse_points = 150;
  /// ICP probing: every kept hypothesis first gets only this many (coarse) iterations and
  /// is scored (S); only the `icp_finish_hypotheses` best by S then run to convergence.
  /// 0 = off: every hypothesis runs to convergence (the paper's schedule).
  int icp_probe_iterations = 0;
  int icp_finish_hypotheses = 6;
  /// ICP source: only rendered points inside the observed mask (else also those outside
  /// it that no unmasked occluder hides).
  bool icp_source_in_mask = false;
  MhpoOptions mhpo;             ///< λ_D = 0.1
  bool run_mhpo = true;         ///< stage 5 on/off (ablations)
  /// Stage 6, optional post-refinement (off by default, as in the paper): when S_A is
  /// above `post_refine_trigger_s`, T_A's 180-degree flips about the three bounding-box
  /// axes and depth re-centred copies become new hypotheses for ICP and MHPO; the best is
  /// accepted only when its S is lower than S_A by more than `post_refine_margin`.
  bool post_refine = false;
  double post_refine_trigger_s = 0.15;
  double post_refine_margin = 0.02;
  int min_valid_depth_pixels = 30;  ///< fewer valid depth pixels in the mask = bad input
  /// Refuse a mask that touches the image border (a truncated object). Off: truncated
  /// objects are solved, the rendered silhouette outside the image never counts against a
  /// pose, and the result says `truncated`.
  bool reject_border_masks = false;
  /// Time budget of one EstimatePose call, milliseconds; <= 0 = none. When it is used up the
  /// solver skips the remaining work (always keeping the best-ranked template's PnP pose, so
  /// that a pose can be returned) and returns T_A / S_A so far with `cut_short` set.
  double budget_ms = 0.0;
  /// When not null and it becomes true, the solve ends the same way as at the budget
  /// (the service sets it at shutdown). Read only; the caller owns it.
  const std::atomic<bool>* stop_requested = nullptr;
  /// Hypotheses closer than this fraction of the diameter (ADD modulo the mesh's
  /// symmetries) are one pose: observable selection fills its K slots with distinct poses.
  double distinct_pose_fraction = 0.05;
  /// Merge PnP poses closer than distinct_pose_fraction to a pose from a better-ranked
  /// template before observable selection, so that each distinct pose is rendered once
  /// (false: every PnP pose is scored and duplicates are dropped after ranking).
  bool merge_pnp_poses = true;
  /// PnP runs on the correspondence sets in rank order while Q_j is at least this fraction
  /// of the best Q_1 (0 = all N_P sets).
  double pnp_min_quality_ratio = 0.0;
  /// Rasterize closed, outward-oriented meshes with back faces culled (no change to any
  /// rendering; TemplateBank::online_mesh_closed / selection_mesh_closed).
  bool cull_backfaces = true;
  /// Observable selection renders TemplateBank::selection_mesh (about a quarter of the
  /// online mesh's faces) on its 96 px grid instead of the online mesh.
  bool coarse_selection_mesh = true;
  /// Finalists (every hypothesis' best state after MHPO) farther than this fraction of
  /// the diameter from T_A, modulo the symmetries, are different answers; the best of them
  /// by S is the runner-up.
  double ambiguity_distance_fraction = 0.1;
  /// The answer is ambiguous when the runner-up's S is within this of S_A and appearance
  /// does not separate the two.
  double ambiguity_margin = 0.03;
  /// Appearance breaks geometric ties (where the cache has a coloured appearance model):
  /// among distinct finalists whose S is within `appearance_margin` of S_A, the one whose
  /// colours agree best with the image wins, when its agreement (ZNCC, in [-1, 1]) beats
  /// T_A's by more than `appearance_min_gain`.
  bool appearance_tiebreak = true;
  double appearance_margin = 0.05;
  double appearance_min_gain = 0.1;
  AppearanceOptions appearance;  ///< visibility and measure of the agreement
  /// Confidence = 1 / (1 + exp(-(confidence_bias + confidence_score_weight * S_A +
  /// confidence_ambiguous_weight * ambiguous))): the probability that the pose is within
  /// ADD(-S) 0.1 d, a logistic fit over 589 answers (K = 18) of four datasets with rendered
  /// and real depth (LM-O, YCB-V clutter and foam brick, the 40-frame sample), fit and
  /// measured by scripts/accuracy.sh (scripts/calibrate_confidence.py on g6d-bench-dataset
  /// --records); the leave-one-object-out reliability tables and their limits are in
  /// bench/RESULTS.md.
  double confidence_bias = 10.14;
  double confidence_score_weight = -41.7;
  double confidence_ambiguous_weight = -1.01;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

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
  int kept_hypotheses = 0;         ///< after observable selection (≤ N_H)
  int icp_converged = 0;
  int sets_tried = 0;               ///< correspondence sets PnP ran on (pnp_min_quality_ratio)
  int pnp_merged = 0;               ///< PnP poses merged into a better-ranked equal pose
  int icp_iterations = 0;           ///< ICP iterations over all hypotheses and passes
  int icp_runs_at_max = 0;          ///< ICP runs that stopped at their iteration limit
  int icp_finished = 0;             ///< hypotheses that ICP ran to convergence in its second pass
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
  double best_quality = 0.0;       ///< best Q_j
  double best_e_obs = 1.0;         ///< best E_obs among PnP poses
  double best_s_after_icp = 2.0;   ///< best S after ICP
  double prepare_ms = 0.0, features_ms = 0.0, match_ms = 0.0, pnp_ms = 0.0,
         ppf_ms = 0.0, observable_ms = 0.0, icp_ms = 0.0, mhpo_ms = 0.0, post_refine_ms = 0.0, finalists_ms = 0.0,
         mask_refine_ms = 0.0, depth_regions_ms = 0.0, neighbours_ms = 0.0, total_ms = 0.0;
  int distinct_finalists = 0;         ///< finalists left after merging poses equal modulo symmetry
  int appearance_compared = 0;        ///< finalists whose appearance was scored
  bool appearance_changed = false;    ///< appearance replaced the lowest-S pose as T_A
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
/// observable, icp, mhpo, post_refine, finalists, total.
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
  double confidence = 0.0;   ///< in [0, 1], monotone decreasing in S_A
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
/// lower when ambiguous).
double ConfidenceFromScore(const SolverOptions& options, double score, bool ambiguous);

/// S (and its parts) of a given pose for one instance, with the observation prepared
/// exactly as EstimatePose prepares it (refinement grid, z_M, occlusion reasoning): for
/// diagnostics such as scoring the ground-truth pose beside the answer. Throws g6d::Error
/// for input EstimatePose would refuse.
PoseScore ScoreInstancePose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                            const SolverOptions& options, const Eigen::Isometry3d& cam_from_object);

/// Estimates cam_from_object for one instance. Never throws for bad data: bad input
/// gives success = false with termination kBadInput and a message naming the problem.
/// Per-hypothesis work fans out over `executor`; any thread count gives the same result.
PoseResult EstimatePose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                        const SolverOptions& options, Executor* executor);

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
PoseResult TrackPose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                     const SolverOptions& options, const TrackSolveOptions& track_options,
                     const std::vector<Eigen::Isometry3d>& starts, Executor* executor);

}  // namespace g6d
