#pragma once
/// @file solver_options.h
/// What every solve of one instance is given: the instance (object id and mask) and the
/// solver's options (SolverOptions, with Check()). Shared by every stage of lib/solver.

#include <atomic>
#include <string>

#include <opencv2/core.hpp>

#include "solver/icp.h"
#include "solver/match.h"
#include "solver/mhpo.h"
#include "solver/observation.h"
#include "solver/pnp.h"
#include "solver/ppf.h"
#include "solver/region.h"
#include "solver/score.h"
#include "solver/segments.h"
#include "solver/silhouette_poses.h"
#include "templates/appearance.h"
#include "templates/features.h"

namespace g6d {

/// Weights of the confidence of an answer to a mask (PoseResult::confidence), a logistic
/// P(the pose is within ADD(-S) 0.1 d) = 1 / (1 + exp(-(bias + score · S_A + ambiguous ·
/// [ambiguous] + on_surface · FrameCheck::on_surface + contour · FrameCheck::contour_support +
/// mask_iou · PoseResult::mask_iou))), fitted by scripts/calibrate_confidence.py.
struct ConfidenceWeights {
  double bias = 0.0;
  double score = 0.0;  ///< < 0: a higher S_A is less likely right
  double ambiguous = 0.0;
  double on_surface = 0.0;
  double contour = 0.0;
  double mask_iou = 0.0;

  /// Empty when valid, else names the bad field (prefixed with `name`).
  std::string Check(const std::string& name) const;
};

/// One instance to estimate: its object and its visible mask in the frame.
struct Instance {
  std::string object_id;  ///< must equal the bank's object id
  cv::Mat mask;           ///< CV_8U, frame size, non-zero = visible object pixels
  /// A support the caller knows under the object (detection: the frame's support plane that
  /// holds most of the depth around the region), the limit no pose may reach behind
  /// (SolverOptions::support_penetration_fraction) where the depth around the mask shows
  /// none: normal · p + offset = 0 (camera frame, metres), the normal towards the camera.
  bool has_support_limit = false;
  Eigen::Vector3d support_limit_normal = Eigen::Vector3d::UnitZ();
  double support_limit_offset_m = 0.0;
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
  /// ... and also when the mask's answer is unsure (unsure_score below): a box or a mask
  /// that missed most of the object can hold the object's region whole without spanning
  /// more than it.
  ///
  /// An answer on a mask is unsure when its S_A is above `unsure_score`, or above
  /// `unsure_ambiguous_score` when it is flagged ambiguous: there the solver's first
  /// calibration of S_A (10.14 - 41.7 S_A - 1.01 ambiguous, before issue 31) put its chance
  /// of being right under one half. An unsure answer is searched again (the depth's regions,
  /// the neighbours' pixels taken out) and does not explain its pixels for its neighbours.
  /// A threshold on S_A, not on the confidence, so that refitting the published confidence
  /// changes no answer. unsure_score >= 2 (S_A's ceiling) searches only for masks wider than
  /// the object or boxes.
  double unsure_score = 0.243165;
  double unsure_ambiguous_score = 0.218945;
  /// A frame's instances read together (ExplainAwayNeighbours, neighbours.h; kDepth): an
  /// instance whose mask holds more than the object, is a box, or whose answer is unsure is
  /// solved again on its mask less the pixels the confident answers of lower S_A of the
  /// frame's other instances explain, when they explain at least `neighbour_min_fraction`
  /// of its mask; the lower S_A wins. Callers that solve one instance at a time ignore it.
  bool explain_neighbours = true;
  double neighbour_min_fraction = 0.05;
  /// In that pass, two answers of one object at one place (DuplicateAnswers, neighbours.h)
  /// are one instance's: the one of higher S_A is solved again without the other's pixels,
  /// and any answer elsewhere replaces it.
  bool resolve_duplicates = true;
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
  /// The point-pair vote is skipped when at least this many MSAC-PnP poses (each from its
  /// own correspondence set) agree on one pose (within distinct_pose_fraction of the
  /// diameter, modulo the symmetries): the texture already gives the pose, and the vote and
  /// the ICP of its poses are time spent for nothing. With GT masks, on the 212 instances of
  /// real YCB-V, LM-O (every 2nd) and synth_dev where 4 or more agreed, ORB-PnP alone came
  /// within 0.01 d of the answer with the vote every time; at 3 (120 instances) it lost none
  /// and moved one; at 2 or fewer it lost 5. Skipping from 3, over every dev set with cut,
  /// merged and box masks, lost 5 answers of 2,643 and gained 2, and lost 1 of 881 without
  /// masks; the real foam brick's vote (3 PnP poses agree on 4 of its 5 instances) is gone
  /// (bench/RESULTS.md, issue 31 item 5). 0 = always vote.
  int ppf_skip_agreement = 3;
  /// Hypotheses from the mask's outline (silhouette_poses.h): template silhouettes matched
  /// to the mask's at in-plane angles, scaled to its area. They need neither texture nor
  /// depth (metal that reflects the sensor's pattern away). Not for a box or a mask wider
  /// than the object, whose outline is not the object's.
  bool use_silhouettes = true;
  SilhouetteOptions silhouette;
  /// Slots beyond K (and the PPF slots) for the outline's poses, the best by E_obs.
  int silhouette_hypotheses = 4;
  /// The outline's poses are skipped, as the point-pair vote is (ppf_skip_agreement), when
  /// at least this many MSAC-PnP poses agree on one pose: the texture gives the pose, and
  /// the outline's poses only add ICP and MHPO work. From 3, over every dev set and input:
  /// GT masks and no masks identical, cut masks +1 -1, merged identical, boxes +1; p50 per
  /// instance with GT masks, side by side: YCB-V clutter -11%, foam brick -10%, synth_dev
  /// -7%, LM-O unchanged (bench/RESULTS.md, issue 31 item 5). 0 = always add them.
  int silhouette_skip_agreement = 3;
  /// The answer's flips checked: T_A turned 180 degrees about each of the three axes of the
  /// object's bounding box through its centre (the usual confusions of a near-symmetric
  /// shape seen from one side: a bracket, a plate with holes), each refined by ICP and MHPO
  /// as the hypotheses were, join the finalists. A flip that fits better becomes the
  /// answer; one within ambiguity_margin of it makes the answer ambiguous (a lower
  /// confidence). Skipped when `silhouette_skip_agreement` PnP poses agree (the texture
  /// tells the sides apart). Its time is part of the finalists' stage. On with masks too
  /// since 2026-12-01: synth_dev GT masks 95.1 -> 95.4%, cut 80.8 -> 81.6%, merged 83.0 ->
  /// 83.3%, boxes 73.1 -> 74.0%; LM-O and YCB-V unchanged but one LM-O GT answer of
  /// confidence 0.03; wrong answers at >= 0.9 left out one object at a time 42 of 1,703 ->
  /// 37 of 1,704 (bench/RESULTS.md, "The flips with masks too").
  bool check_flips = true;
  /// ... only for an answer whose S_A is at most this (an answer refused anyway is not worth
  /// its flips; detection sets its max_score).
  double check_flips_max_score = 1e9;
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
  /// Hypotheses that ICP brings within this fraction of the diameter of each other (ADD,
  /// no symmetry: twins under a symmetry of the shape are both refined) are one pose from
  /// there on: merged into the one of lowest S, so that MHPO refines each pose once.
  /// Different starts often slide into one basin (bench/RESULTS.md, "Speed with masks:
  /// one MHPO per pose"). 0 = off.
  double icp_merge_fraction = 0.02;
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
  /// Physical consistency with the support: an object rests on or stands above the surface
  /// under it (the support plane fitted around the mask, ObservedRegion), never inside it.
  /// A distinct finalist whose model reaches behind that plane by more than this fraction of
  /// the diameter plus the mask's surface tolerance is no pose of the object: when the
  /// lowest-S finalist does, the lowest-S finalist that does not (at most `support_margin`
  /// above it in S) is the answer, and such finalists are no runner-up. A bare bracket seen
  /// from one side fits its flip, whose unseen flange then points into the table, as well
  /// as its true pose. 0 = off.
  double support_penetration_fraction = 0.1;
  double support_margin = 0.1;
  double appearance_min_gain = 0.1;
  AppearanceOptions appearance;  ///< visibility and measure of the agreement
  /// The confidence of an answer to a mask (PoseResult::confidence): a logistic in S_A, the
  /// ambiguity flag, the answer checked against the whole frame (FrameCheck: the share of the
  /// rendered model the depth confirms, the share of its outline at a depth step) and how
  /// much of the caller's mask it explains (PoseResult::mask_iou). `confidence` is for a mask
  /// that fits the object; `wide_mask_confidence` for a mask wider than the object or a box,
  /// where a pose that lies well on one object of the mask may be on the wrong one: the
  /// frame check is left out of it. Fitted on 1707 answers of the sets with sensor depth
  /// (synth_dev's simulated structured light, the real YCB-V Xtion frames) with GT, cut,
  /// merged and box masks (scripts/calibrate_confidence.py on g6d-bench-dataset --records;
  /// bench/RESULTS.md, "A confidence that reads the frame"). LM-O, whose depth is rendered
  /// from the ground truth and makes every frame check clean, is measured held out. Since
  /// 2026-12-02 the features are standardized for the fit and an L2 penalty of 10 holds every
  /// weight but the bias back (calibrate_confidence.py --l2=10): left out one object at a
  /// time, 37 -> 30 of 1,704 answers wrong at >= 0.9, and S_A's weight comes out negative (a
  /// worse fit, a lower confidence) where the unpenalized fit had it positive, collinear with
  /// the frame check; LM-O held out, Brier with cut masks 0.051 -> 0.015 (bench/RESULTS.md,
  /// "The mask path's confidence, held back the same way").
  ConfidenceWeights confidence = {-6.514, -0.919, -2.391, 5.655, 2.976, 4.008};
  ConfidenceWeights wide_mask_confidence = {1.378, -4.059, -1.073, 0.0, 0.0, 2.315};
  /// The frame check's tolerances (CheckAgainstFrame): a rendered pixel is on the surface
  /// within this fraction of the diameter; its outline steps by more than check_step_m.
  double check_surface_fraction = 0.05;
  double check_step_m = 0.005;
  /// The confidence from S_A alone, 1 / (1 + exp(-(confidence_bias + confidence_score_weight
  /// * S_A + confidence_ambiguous_weight * ambiguous))): for answers not checked against
  /// the frame (tracking, track_pose.h). A logistic fit over 3498 answers (K = 18) of the
  /// four dev sets with GT, cut, merged and box masks (bench/RESULTS.md, "A confidence that
  /// knows").
  double confidence_bias = 3.767;
  double confidence_score_weight = -10.041;
  double confidence_ambiguous_weight = -2.299;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

}  // namespace g6d
