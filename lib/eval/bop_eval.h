#pragma once
/// @file bop_eval.h
/// The BOP 2019 evaluation of 6D localization results (bop_toolkit `eval_bop19_pose.py`,
/// which runs `eval_calc_errors.py` and `eval_calc_scores.py`; Hodan et al., "BOP Challenge
/// 2020 on 6D Object Localization", ECCVW 2020, Sec. 2), plus the classic ADD(-S)@0.1d
/// recall (Hinterstoisser et al., ACCV 2012) computed the way g6d-bench-dataset does.
///
/// Protocol, per image and target object (one entry of test_targets_bop19.json, asking for
/// `inst_count` instances):
///  1. Targets (BOP'19 `visib_gt_min = -1`): the `inst_count` GT instances of the object
///     with the largest `visib_fract` (scene_gt_info.json; ties and a missing file keep the
///     scene_gt.json order) are the valid GT poses; each is one target. The 10% visibility
///     limit is not applied here: it was applied when the targets file was made
///     (inst_count counts the instances with visib_fract >= 0.1).
///  2. Estimates: those of the object in that image, sorted by decreasing score (stable),
///     at most `inst_count` of them (BOP `n_top = -1`). Estimates of images or objects that
///     are not targets are ignored.
///  3. Errors of every kept estimate against every valid GT instance: VSD (one per tau),
///     MSSD, MSPD (symmetry-aware, model vertices) and ADD or ADD-S.
///  4. For each error kind and correctness threshold, estimates are matched greedily in
///     score order, each to the not yet matched valid GT with the smallest error, only
///     when that error is below the threshold (BOP `pose_matching.match_poses`).
///  5. Recall = matched targets / targets. AR_VSD is the mean recall over the 10 x 10
///     (tau, threshold) pairs, AR_MSSD over thresholds 0.05..0.5 x diameter, AR_MSPD over
///     5..50 px scaled by 640 / image width, AR = (AR_VSD + AR_MSSD + AR_MSPD) / 3. Missing
///     estimates are failures. The overall recall pools all targets (BOP's "recall", not
///     the mean over objects); per-object numbers pool that object's targets.
///
/// ADD(-S)@0.1d uses the same targets and matching with one threshold, 0.1 x diameter, and
/// the error g6d-bench-dataset uses: ADD-S for objects with any symmetry in
/// models_info.json (or listed in `BopEvalOptions::adds_obj_ids`), else ADD, over every
/// k-th vertex of the model (k = max(1, vertices / 3000)).
///
/// Deviation from bop_toolkit: BOP computes errors on the resampled models of
/// models_eval/; we use the mesh that models_info.json names (models/ by default) for
/// rendering and for the MSSD/MSPD points, the model the rest of g6d works with.

#include <string>
#include <vector>

#include "core/executor.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "eval/metrics.h"
#include "eval/vsd.h"

namespace g6d {

/// The BOP'19 MSPD correctness thresholds, pixels at 640 px image width: 5, 10, ..., 50.
std::vector<double> BopMspdThresholdsPx();

/// Options of EvaluateBop(). The defaults are the BOP'19 protocol for LM-O and YCB-V.
struct BopEvalOptions {
  /// VSD: delta 15 mm, taus 0.05..0.5 (fractions of the diameter), "step" cost.
  VsdOptions vsd;
  /// Correctness thresholds on e_VSD (unitless), BOP'19: 0.05..0.5 step 0.05.
  std::vector<double> vsd_thresholds = BopVsdTaus();
  /// Correctness thresholds on MSSD as fractions of the object diameter, BOP'19: 0.05..0.5.
  std::vector<double> mssd_thresholds = BopVsdTaus();
  /// Correctness thresholds on MSPD, pixels at `mspd_reference_width_px`, BOP'19: 5..50.
  std::vector<double> mspd_thresholds_px = BopMspdThresholdsPx();
  /// MSPD errors are multiplied by reference width / image width before thresholding
  /// (BOP `normalized_by_im_width`), pixels.
  double mspd_reference_width_px = 640.0;
  /// ADD(-S) correctness threshold, fraction of the object diameter.
  double add_threshold = 0.1;
  /// Upper bound on the ADD(-S) model points: every k-th vertex, k = max(1, n / this), as
  /// g6d-bench-dataset does, so both report the same recall.
  int add_max_points = 3000;
  /// Objects evaluated with ADD-S although models_info.json lists no symmetry for them
  /// (e.g. the YCB-V foam brick, 21, which BOP's YCB-V treats as symmetric). MSSD/MSPD
  /// still use only the symmetries of models_info.json.
  std::vector<int> adds_obj_ids;
  /// Continuous symmetries are discretized as bop_toolkit's `get_symmetry_transformations`
  /// with this `max_sym_disc_step` (fraction of the diameter).
  double max_symmetry_discretization_step = kBopMaxSymmetryDiscretizationStep;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// True positives and recalls over a set of targets.
struct BopRecall {
  int targets = 0;        ///< valid GT instances (BOP "targets_count")
  int with_estimate = 0;  ///< targets whose (image, object) has at least one estimate
  int add_correct = 0;    ///< targets matched with ADD(-S) < add_threshold x diameter
  /// True positives per VSD tau (outer) and VSD threshold (inner).
  std::vector<std::vector<int>> vsd_correct;
  std::vector<int> mssd_correct;  ///< per MSSD threshold
  std::vector<int> mspd_correct;  ///< per MSPD threshold
  double add_recall = 0.0;        ///< add_correct / targets (0 without targets, as BOP)
  double ar_vsd = 0.0;            ///< mean recall over (tau, threshold)
  double ar_mssd = 0.0;           ///< mean recall over MSSD thresholds
  double ar_mspd = 0.0;           ///< mean recall over MSPD thresholds
  double ar = 0.0;                ///< (ar_vsd + ar_mssd + ar_mspd) / 3, the BOP'19 score
};

/// The numbers of one object.
struct BopObjectReport {
  int obj_id = 0;
  std::string name;        ///< "obj_000005"
  bool uses_adds = false;  ///< ADD-S (symmetric or forced) rather than ADD
  BopRecall recall;
};

/// One target (valid GT instance) and the best errors any of its image's kept estimates
/// of the same object reach against it (infinity when there is none). For inspection; the
/// recalls come from the greedy matching, not from these minima.
struct BopTargetReport {
  int scene_id = 0;
  int im_id = 0;
  int obj_id = 0;
  int gt_idx = 0;            ///< index in the image's scene_gt.json list
  double visib_fract = 1.0;  ///< from scene_gt_info.json (1 when absent)
  int estimates = 0;         ///< kept estimates of this (image, object)
  double add_m = 0.0;        ///< smallest ADD or ADD-S, metres
  double mssd_m = 0.0;       ///< smallest MSSD, metres
  double mspd_px = 0.0;      ///< smallest MSPD, pixels (not rescaled to 640 px)
  double vsd_mean = 0.0;     ///< smallest mean of the VSD errors over the taus
  bool add_correct = false;  ///< matched under the ADD(-S) criterion
};

/// What EvaluateBop() found.
struct BopEvalReport {
  bool success = false;
  std::string message = "not run";
  BopRecall overall;                     ///< all targets pooled
  std::vector<BopObjectReport> objects;  ///< per object, by obj_id
  std::vector<BopTargetReport> targets;  ///< every target, by scene, image, object, gt_idx
  std::vector<double> vsd_taus;          ///< copies of the option lists, for printing
  std::vector<double> vsd_thresholds;
  std::vector<double> mssd_thresholds;
  std::vector<double> mspd_thresholds_px;
  int num_target_entries = 0;          ///< entries of the targets list
  int num_images = 0;                  ///< images with targets
  int num_estimates = 0;               ///< estimates given
  int num_estimates_evaluated = 0;     ///< kept (top inst_count per target object)
  int num_estimates_ignored = 0;       ///< of images / objects that are not targets
  int num_estimates_beyond_count = 0;  ///< of target objects, beyond the inst_count best
  double load_ms = 0.0;                ///< scenes and meshes
  double errors_ms = 0.0;              ///< depth images, rendering, errors and matching
  double total_ms = 0.0;
};

/// Evaluates `estimates` (cam_from_object in metres, e.g. from ReadBopCsv()) on `targets`
/// of `dataset` (LoadBopDataset(); scenes, depth images of `dataset.split` and meshes are
/// read here, each mesh once) with the BOP'19 protocol described at the top of this file.
/// Work is fanned out per image over `executor` (nullptr: the calling thread); the result
/// does not depend on the number of threads.
/// Throws g6d::Error for invalid options, a target or estimate naming an object that is not
/// in models_info.json, a target image that is not in its scene, or a missing or unreadable
/// scene file, depth image or mesh. Returns success = false (not an exception) when there
/// are no targets.
BopEvalReport EvaluateBop(const BopDataset& dataset, const std::vector<BopTarget>& targets,
                          const std::vector<BopEstimate>& estimates, const BopEvalOptions& options,
                          Executor* executor);

}  // namespace g6d
