#include "solver/depth_regions.h"

#include <exception>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "core/timer.h"
#include "solver/detect.h"
#include "solver/region.h"

namespace g6d {

bool AnswerInDoubt(const PoseResult& answer, const SolverOptions& options) {
  if (!answer.success) return answer.termination == Termination::kNoHypothesis;
  const StageReport& s = answer.stages;
  return s.mask_wider_than_object || s.mask_is_box || UnsureOfScore(options, answer.score, answer.ambiguous);
}

PoseResult SolveOnDepthRegions(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                               const SolverOptions& options, Executor* executor, PoseResult on_mask) {
  // In doubt, or a mask too thin to solve on: it still says where the object is (a refusal
  // for any other reason, e.g. reject_border_masks, stands).
  const bool search = AnswerInDoubt(on_mask, options) ||
                      (on_mask.termination == Termination::kBadInput && on_mask.stages.mask_too_thin);
  // A mask with too few pixels with depth (an eroded sliver) still says where the object
  // is; a mask of the wrong size or type says nothing, and a bad frame none of the regions
  // can use either (its message stays the answer's).
  const bool usable = instance.mask.size() == frame.depth.size() && instance.mask.type() == CV_8U &&
                      frame.rgb.size() == frame.depth.size() && cv::countNonZero(instance.mask) > 0;
  if (options.mask_trust != MaskTrust::kDepth || options.region_candidates <= 0 || on_mask.cut_short || !usable ||
      !search) {
    return on_mask;
  }
  const Stopwatch watch;
  DetectRequest request;
  request.bank = &bank;
  request.count = 1;
  request.within = instance.mask > 0;
  DetectOptions detect;
  detect.extra_candidates = options.region_candidates - 1;
  detect.explain_away_passes = 0;
  detect.found_object_passes = 0;
  // The best region's answer is compared with the mask's by S_A, whatever its S_A; but a
  // region answer very unlikely right as a detection (under 0.1) is no candidate, by the
  // detection calibration this search was measured with (issue 31's first fit: S_A, the
  // frame check and the region IoU, no colour). Detection's refit (colour, floor 0.5) is
  // for answers without a mask: in this search it cost synth_dev's boxes 2 points
  // (66.3% -> 64.1%), and without any floor 64.3%.
  detect.max_score = 1e9;
  detect.min_confidence = 0.1;
  detect.confidence_bias = -7.296;
  detect.confidence_score_weight = -11.569;
  detect.confidence_ambiguous_weight = -2.950;
  detect.confidence_on_surface_weight = 6.322;
  detect.confidence_free_space_weight = -4.489;
  detect.confidence_contour_weight = 3.204;
  detect.confidence_region_iou_weight = 5.358;
  detect.confidence_colour_weight = 0.0;
  detect.confidence_in_image_weight = 0.0;
  detect.confidence_edge_weight = 0.0;
  detect.confidence_runner_up_weight = 0.0;
  detect.confidence_free_band_weight = 0.0;
  // Inside one mask there are few segments: unions of up to 4 (a drill's handle, body and
  // battery split at their own creases, and a fragment) cost little. On LM-O merged masks
  // 93.5% against 93.3% with 3, boxes 92.4% against 91.8% (bench/RESULTS.md, issue 22).
  detect.max_union_segments = 4;
  // The support and the ranking as this search was measured with (detection's defaults are
  // 5 planes and the area's agreement since).
  detect.max_planes = 3;
  detect.area_weight = 0.0;
  // The regions inside a mask are solved as the mask is: its flip check
  // (SolverOptions::check_flips), its K, PnP on every set.
  detect.solve_check_flips = options.check_flips;
  detect.max_solve_hypotheses = 0;
  detect.solve_pnp_min_quality = 0.0;
  SolverOptions region_options = options;
  region_options.region_candidates = 0;  // a region of the depth holds one object
  if (options.budget_ms > 0.0) {
    // The regions get what the mask's solve left of the budget (solved side by side).
    const double left_ms = options.budget_ms - on_mask.stages.total_ms;
    if (left_ms <= 0.0) return on_mask;
    region_options.budget_ms = left_ms;
  }
  DetectionReport report;
  std::vector<Detection> found;
  try {
    found = DetectObjects(frame, {request}, region_options, detect, executor, &report);
  } catch (const std::exception&) {
    return on_mask;  // a lower layer refused what the mask's solve took: its answer stands
  }
  StageReport stages = on_mask.stages;
  stages.mask_answer_score = on_mask.success ? on_mask.score : 2.0;
  stages.depth_regions_solved = report.solves;
  stages.depth_regions_ms = watch.ElapsedMs();
  stages.total_ms += stages.depth_regions_ms;
  if (!found.empty() && found.front().result.success &&
      (!on_mask.success || found.front().result.score < on_mask.score)) {
    PoseResult chosen = std::move(found.front().result);
    // The answer's stage counts and poses are its own solve's; the times are of the work
    // this instance cost: the solve on the mask, then the regions.
    CopyMaskSolveReport(stages, &chosen.stages);
    StageReport& merged = chosen.stages;
    merged.total_ms = stages.total_ms;
    merged.depth_regions_solved = stages.depth_regions_solved;
    merged.depth_region_chosen = true;
    merged.mask_answer_score = stages.mask_answer_score;
    chosen.truncated = chosen.truncated || on_mask.truncated;
    chosen.mask_iou = MaskIntersectionOverUnion(chosen.corrected_mask, instance.mask > 0);
    // An answer to a mask: the mask path's confidence, like every other one (the mask's flags
    // are the mask's: CopyMaskSolveReport).
    chosen.confidence = AnswerConfidence(options, chosen);
    return chosen;
  }
  on_mask.stages = std::move(stages);
  return on_mask;
}

}  // namespace g6d
