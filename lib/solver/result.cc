#include "solver/result.h"

#include <cmath>

namespace g6d {

const char* TerminationName(Termination termination) {
  switch (termination) {
    case Termination::kNotRun: return "not_run";
    case Termination::kConverged: return "converged";
    case Termination::kEarlyStopped: return "early_stopped";
    case Termination::kCutShort: return "cut_short";
    case Termination::kBadInput: return "bad_input";
    case Termination::kNoHypothesis: return "no_hypothesis";
  }
  return "unknown";
}

std::vector<StageTime> StageTimes(const StageReport& s) {
  return {{"prepare", s.prepare_ms},     {"features", s.features_ms},       {"match", s.match_ms},
          {"pnp", s.pnp_ms},             {"ppf", s.ppf_ms},                 {"silhouette", s.silhouette_ms},   {"observable", s.observable_ms},   {"icp", s.icp_ms},
          {"mhpo", s.mhpo_ms},           {"post_refine", s.post_refine_ms}, {"finalists", s.finalists_ms},
          {"mask_refine", s.mask_refine_ms}, {"frame_check", s.frame_check_ms}, {"depth_regions", s.depth_regions_ms},
          {"neighbours", s.neighbours_ms},       {"total", s.total_ms}};
}

void CopyMaskSolveReport(const StageReport& from, StageReport* to) {
  to->prepare_ms = from.prepare_ms;
  to->features_ms = from.features_ms;
  to->match_ms = from.match_ms;
  to->pnp_ms = from.pnp_ms;
  to->ppf_ms = from.ppf_ms;
  to->silhouette_ms = from.silhouette_ms;
  to->observable_ms = from.observable_ms;
  to->icp_ms = from.icp_ms;
  to->mhpo_ms = from.mhpo_ms;
  to->post_refine_ms = from.post_refine_ms;
  to->finalists_ms = from.finalists_ms;
  to->mask_refine_ms = from.mask_refine_ms;
  to->frame_check_ms = from.frame_check_ms;
  to->depth_regions_ms = from.depth_regions_ms;
  to->mask_given_pixels = from.mask_given_pixels;
  to->mask_wider_than_object = from.mask_wider_than_object;
  to->mask_too_thin = from.mask_too_thin;
  to->mask_is_box = from.mask_is_box;
}

double ConfidenceFromScore(const SolverOptions& options, double score, bool ambiguous) {
  if (!std::isfinite(score)) return 0.0;
  const double logit = options.confidence_bias + options.confidence_score_weight * score +
                       (ambiguous ? options.confidence_ambiguous_weight : 0.0);
  return 1.0 / (1.0 + std::exp(-logit));
}

double AnswerConfidence(const SolverOptions& options, const PoseResult& result) {
  if (!result.success || !std::isfinite(result.score)) return 0.0;
  const bool wide = result.stages.mask_wider_than_object || result.stages.mask_is_box;
  const ConfidenceWeights& w = wide ? options.wide_mask_confidence : options.confidence;
  const double logit = w.bias + w.score * result.score + (result.ambiguous ? w.ambiguous : 0.0) +
                       w.on_surface * result.frame_check.on_surface + w.contour * result.frame_check.contour_support +
                       w.mask_iou * result.mask_iou;
  return 1.0 / (1.0 + std::exp(-logit));
}

bool UnsureOfScore(const SolverOptions& options, double score, bool ambiguous) {
  if (!std::isfinite(score)) return true;
  return score > (ambiguous ? options.unsure_ambiguous_score : options.unsure_score);
}

}  // namespace g6d
