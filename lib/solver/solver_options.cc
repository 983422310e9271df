#include "solver/solver_options.h"

#include <cmath>
#include <sstream>

namespace g6d {

std::string SolverOptions::Check() const {
  std::string bad = query_orb.Check();
  if (bad.empty()) bad = match.Check();
  if (bad.empty()) bad = pnp.Check();
  if (bad.empty()) bad = score.Check();
  if (bad.empty()) bad = selection_grid.Check();
  if (bad.empty()) bad = refine_grid.Check();
  if (bad.empty()) bad = icp.Check();
  if (bad.empty()) bad = mhpo.Check();
  if (bad.empty()) bad = appearance.Check();
  if (bad.empty()) bad = region.Check();
  if (bad.empty()) bad = segments.Check();
  if (bad.empty()) bad = ppf.Check();
  if (bad.empty()) bad = silhouette.Check();
  if (!bad.empty()) return bad;
  std::ostringstream out;
  if (num_hypotheses < 1) out << "SolverOptions.num_hypotheses must be >= 1 (got " << num_hypotheses << ")";
  else if (ppf_hypotheses < 0) out << "SolverOptions.ppf_hypotheses must be >= 0 (got " << ppf_hypotheses << ")";
  else if (ppf_skip_agreement < 0) out << "SolverOptions.ppf_skip_agreement must be >= 0 (0 = always vote; got " << ppf_skip_agreement << ")";
  else if (silhouette_skip_agreement < 0) out << "SolverOptions.silhouette_skip_agreement must be >= 0 (0 = always add the outline's poses; got " << silhouette_skip_agreement << ")";
  else if (silhouette_hypotheses < 0) out << "SolverOptions.silhouette_hypotheses must be >= 0 (got " << silhouette_hypotheses << ")";
  else if (region_candidates < 0 || region_candidates > 16) out << "SolverOptions.region_candidates must be in [0, 16] (got " << region_candidates << ")";
  else if (!(unsure_score >= 0.0 && std::isfinite(unsure_score))) out << "SolverOptions.unsure_score must be finite and >= 0 (got " << unsure_score << ")";
  else if (!(unsure_ambiguous_score >= 0.0 && std::isfinite(unsure_ambiguous_score))) out << "SolverOptions.unsure_ambiguous_score must be finite and >= 0 (got " << unsure_ambiguous_score << ")";
  else if (!(neighbour_min_fraction > 0.0 && neighbour_min_fraction <= 1.0)) out << "SolverOptions.neighbour_min_fraction must be in (0, 1] (got " << neighbour_min_fraction << ")";
  else if (max_search_regions < 0 || max_search_regions > 8) out << "SolverOptions.max_search_regions must be in [0, 8] (got " << max_search_regions << ")";
  else if (max_observed_points < 10) out << "SolverOptions.max_observed_points must be >= 10 (got " << max_observed_points << ")";
  else if (max_source_points < 10) out << "SolverOptions.max_source_points must be >= 10 (got " << max_source_points << ")";
  else if (min_valid_depth_pixels < 3) out << "SolverOptions.min_valid_depth_pixels must be >= 3 (got " << min_valid_depth_pixels << ")";
  else if (icp_coarse_points < 0) out << "SolverOptions.icp_coarse_points must be >= 0 (got " << icp_coarse_points << ")";
  else if (!(icp_merge_fraction >= 0.0 && icp_merge_fraction < 1.0)) out << "SolverOptions.icp_merge_fraction must be in [0, 1) (got " << icp_merge_fraction << ")";
  else if (icp_probe_iterations < 0) out << "SolverOptions.icp_probe_iterations must be >= 0 (got " << icp_probe_iterations << ")";
  else if (icp_finish_hypotheses < 1) out << "SolverOptions.icp_finish_hypotheses must be >= 1 (got " << icp_finish_hypotheses << ")";
  else if (!(pnp_min_quality_ratio >= 0.0 && pnp_min_quality_ratio <= 1.0)) out << "SolverOptions.pnp_min_quality_ratio must be in [0, 1] (got " << pnp_min_quality_ratio << ")";
  else if (mask_refine_rounds < 0) out << "SolverOptions.mask_refine_rounds must be >= 0 (got " << mask_refine_rounds << ")";
  else if (!(distinct_pose_fraction >= 0.0 && distinct_pose_fraction < 1.0)) out << "SolverOptions.distinct_pose_fraction must be in [0, 1) (got " << distinct_pose_fraction << ")";
  else if (!(ambiguity_distance_fraction > 0.0 && ambiguity_distance_fraction < 10.0)) out << "SolverOptions.ambiguity_distance_fraction must be in (0, 10) (got " << ambiguity_distance_fraction << ")";
  else if (!(ambiguity_margin >= 0.0 && ambiguity_margin < 2.0)) out << "SolverOptions.ambiguity_margin must be in [0, 2) (got " << ambiguity_margin << ")";
  else if (!(appearance_margin >= 0.0 && appearance_margin < 2.0)) out << "SolverOptions.appearance_margin must be in [0, 2) (got " << appearance_margin << ")";
  else if (!(appearance_min_gain >= 0.0 && appearance_min_gain <= 2.0)) out << "SolverOptions.appearance_min_gain must be in [0, 2] (got " << appearance_min_gain << ")";
  else if (!(support_penetration_fraction >= 0.0 && support_penetration_fraction <= 10.0)) out << "SolverOptions.support_penetration_fraction must be in [0, 10] (got " << support_penetration_fraction << ")";
  else if (!(support_margin >= 0.0 && support_margin <= 2.0)) out << "SolverOptions.support_margin must be in [0, 2] (got " << support_margin << ")";
  else if (!std::isfinite(budget_ms)) out << "SolverOptions.budget_ms must be finite (got " << budget_ms << ")";
  else if (!(confidence_score_weight < 0.0)) out << "SolverOptions.confidence_score_weight must be < 0 (got " << confidence_score_weight << ")";
  else if (!std::isfinite(confidence_bias) || !std::isfinite(confidence_ambiguous_weight)) out << "SolverOptions.confidence_bias and confidence_ambiguous_weight must be finite";
  else if (const std::string bad = confidence.Check("SolverOptions.confidence"); !bad.empty()) out << bad;
  else if (const std::string bad = wide_mask_confidence.Check("SolverOptions.wide_mask_confidence"); !bad.empty()) out << bad;
  else if (!(check_surface_fraction > 0.0 && check_surface_fraction < 1.0)) out << "SolverOptions.check_surface_fraction must be in (0, 1) (got " << check_surface_fraction << ")";
  else if (!(check_step_m > 0.0 && check_step_m < 1.0)) out << "SolverOptions.check_step_m must be in (0, 1) metres (got " << check_step_m << ")";
  return out.str();
}

std::string ConfidenceWeights::Check(const std::string& name) const {
  std::ostringstream out;
  if (!(score < 0.0)) out << name << ".score must be < 0 (got " << score << ")";
  else if (!(std::isfinite(bias) && std::isfinite(ambiguous) && std::isfinite(on_surface) && std::isfinite(contour) &&
             std::isfinite(mask_iou))) {
    out << name << ": every weight must be finite";
  }
  return out.str();
}

}  // namespace g6d
