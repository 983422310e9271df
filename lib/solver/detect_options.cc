#include "solver/detect_options.h"

#include <cmath>
#include <sstream>

namespace g6d {

std::string DetectOptions::Check() const {
  std::ostringstream out;
  const std::string segment_problem = segments.Check();
  if (!segment_problem.empty()) out << "DetectOptions." << segment_problem;
  else if (max_planes < 0) out << "DetectOptions.max_planes must be >= 0 (got " << max_planes << ")";
  else if (plane_iterations < 1) out << "DetectOptions.plane_iterations must be >= 1 (got " << plane_iterations << ")";
  else if (plane_samples < 3) out << "DetectOptions.plane_samples must be >= 3 (got " << plane_samples << ")";
  else if (!(plane_flatness_m >= 0.0 && plane_flatness_m < 0.1)) out << "DetectOptions.plane_flatness_m must be in [0, 0.1) m (got " << plane_flatness_m << ")";
  else if (!(min_plane_fraction > 0.0 && min_plane_fraction <= 1.0)) out << "DetectOptions.min_plane_fraction must be in (0, 1] (got " << min_plane_fraction << ")";
  else if (!(support_extent_factor >= 1.0)) out << "DetectOptions.support_extent_factor must be >= 1 (got " << support_extent_factor << ")";
  else if (!(raised_sigmas >= 0.0)) out << "DetectOptions.raised_sigmas must be >= 0 (0 = off; got " << raised_sigmas << ")";
  else if (raised_window_px < 1 || raised_window_px % 2 == 0) out << "DetectOptions.raised_window_px must be odd and >= 1 (got " << raised_window_px << ")";
  else if (raised_level_px < raised_window_px || raised_level_px % 2 == 0) out << "DetectOptions.raised_level_px must be odd and >= raised_window_px (got " << raised_level_px << ")";
  else if (!(raised_flatness > 0.0)) out << "DetectOptions.raised_flatness must be > 0 (got " << raised_flatness << ")";
  else if (!(raised_outline_edge >= 0.0 && raised_outline_edge <= 1000.0)) out << "DetectOptions.raised_outline_edge must be in [0, 1000] (0 = off; got " << raised_outline_edge << ")";
  else if (raised_outline_ring_px < 1) out << "DetectOptions.raised_outline_ring_px must be >= 1 (got " << raised_outline_ring_px << ")";
  else if (!(raised_outline_min_noise >= 0.0)) out << "DetectOptions.raised_outline_min_noise must be >= 0 (got " << raised_outline_min_noise << ")";
  else if (!(raised_min_height_m >= 0.0 && raised_min_height_m < 0.1)) out << "DetectOptions.raised_min_height_m must be in [0, 0.1) m (got " << raised_min_height_m << ")";
  else if (bridge_holes_px < 0 || bridge_holes_px > 50) out << "DetectOptions.bridge_holes_px must be in [0, 50] (0 = off; got " << bridge_holes_px << ")";
  else if (island_open_px < -1 || island_open_px > 10) out << "DetectOptions.island_open_px must be in [-1, 10] (-1 = no islands; got " << island_open_px << ")";
  else if (!(island_split_core >= 0.0 && island_split_core <= 1.0)) out << "DetectOptions.island_split_core must be in [0, 1] (0 = no split; got " << island_split_core << ")";
  else if (!(island_split_window > 0.0 && island_split_window <= 1.0)) out << "DetectOptions.island_split_window must be in (0, 1] (got " << island_split_window << ")";
  else if (island_split_max_pieces < 2) out << "DetectOptions.island_split_max_pieces must be >= 2 (got " << island_split_max_pieces << ")";
  else if (island_split_min_core_px < 1) out << "DetectOptions.island_split_min_core_px must be >= 1 (got " << island_split_min_core_px << ")";
  else if (!(uncoloured_island_bonus >= 0.0 && uncoloured_island_bonus <= 1.0)) out << "DetectOptions.uncoloured_island_bonus must be in [0, 1] (got " << uncoloured_island_bonus << ")";
  else if (!(gap_neighbour_reach_m >= 0.0 && gap_neighbour_reach_m <= 0.5)) out << "DetectOptions.gap_neighbour_reach_m must be in [0, 0.5] m (0 = off; got " << gap_neighbour_reach_m << ")";
  else if (!(gap_occluder_margin_m > 0.0 && gap_occluder_margin_m <= 1.0)) out << "DetectOptions.gap_occluder_margin_m must be in (0, 1] m (got " << gap_occluder_margin_m << ")";
  else if (neighbour_gap_px < 1) out << "DetectOptions.neighbour_gap_px must be >= 1 (got " << neighbour_gap_px << ")";
  else if (max_union_segments < 1) out << "DetectOptions.max_union_segments must be >= 1 (got " << max_union_segments << ")";
  else if (max_regions < 1) out << "DetectOptions.max_regions must be >= 1 (got " << max_regions << ")";
  else if (!(extent_margin_px >= 0.0)) out << "DetectOptions.extent_margin_px must be >= 0 (got " << extent_margin_px << ")";
  else if (!(min_extent_fraction >= 0.0 && min_extent_fraction < 1.0)) out << "DetectOptions.min_extent_fraction must be in [0, 1) (got " << min_extent_fraction << ")";
  else if (!(min_area_fraction >= 0.0 && min_area_fraction < 1.0)) out << "DetectOptions.min_area_fraction must be in [0, 1) (got " << min_area_fraction << ")";
  else if (extra_candidates < 0) out << "DetectOptions.extra_candidates must be >= 0 (got " << extra_candidates << ")";
  else if (found_object_passes < 0) out << "DetectOptions.found_object_passes must be >= 0 (got " << found_object_passes << ")";
  else if (max_solve_hypotheses < 0) out << "DetectOptions.max_solve_hypotheses must be >= 0 (got " << max_solve_hypotheses << ")";
  else if (!(solve_pnp_min_quality >= 0.0 && solve_pnp_min_quality <= 1.0)) out << "DetectOptions.solve_pnp_min_quality must be in [0, 1] (got " << solve_pnp_min_quality << ")";
  else if (!(colour_weight >= 0.0 && colour_weight <= 1.0)) out << "DetectOptions.colour_weight must be in [0, 1] (got " << colour_weight << ")";
  else if (!(area_weight >= 0.0 && area_weight <= 1.0)) out << "DetectOptions.area_weight must be in [0, 1] (got " << area_weight << ")";
  else if (!(accept_confidence >= 0.0 && accept_confidence <= 1.0)) out << "DetectOptions.accept_confidence must be in [0, 1] (got " << accept_confidence << ")";
  else if (!(accept_region_iou >= 0.0 && accept_region_iou <= 1.0)) out << "DetectOptions.accept_region_iou must be in [0, 1] (got " << accept_region_iou << ")";
  else if (fill_gap_px < 0) out << "DetectOptions.fill_gap_px must be >= 0 (got " << fill_gap_px << ")";
  else if (explain_away_passes < 0) out << "DetectOptions.explain_away_passes must be >= 0 (got " << explain_away_passes << ")";
  else if (!(max_score > 0.0)) out << "DetectOptions.max_score must be > 0 (got " << max_score << ")";
  else if (!(max_overlap >= 0.0 && max_overlap <= 1.0)) out << "DetectOptions.max_overlap must be in [0, 1] (got " << max_overlap << ")";
  else if (ppf_extra < 0) out << "DetectOptions.ppf_extra must be >= 0 (got " << ppf_extra << ")";
  else if (ppf_reference_stride < 1) out << "DetectOptions.ppf_reference_stride must be >= 1 (got " << ppf_reference_stride << ")";
  else if (ppf_max_scene_points < 10) out << "DetectOptions.ppf_max_scene_points must be >= 10 (got " << ppf_max_scene_points << ")";
  else if (!(ppf_surface_fraction > 0.0 && ppf_surface_fraction < 1.0)) out << "DetectOptions.ppf_surface_fraction must be in (0, 1) (got " << ppf_surface_fraction << ")";
  else if (!(ppf_min_contour_support >= 0.0 && ppf_min_contour_support <= 1.0)) out << "DetectOptions.ppf_min_contour_support must be in [0, 1] (got " << ppf_min_contour_support << ")";
  else if (!(max_free_space >= 0.0 && max_free_space <= 1.0)) out << "DetectOptions.max_free_space must be in [0, 1] (got " << max_free_space << ")";
  else if (!(identity_check_below >= 0.0 && identity_check_below <= 1.0)) out << "DetectOptions.identity_check_below must be in [0, 1] (got " << identity_check_below << ")";
  else if (!(free_space_fraction > 0.0)) out << "DetectOptions.free_space_fraction must be > 0 (got " << free_space_fraction << ")";
  else if (!(min_contour_support >= 0.0 && min_contour_support <= 1.0)) out << "DetectOptions.min_contour_support must be in [0, 1] (got " << min_contour_support << ")";
  else if (shape_references < 1) out << "DetectOptions.shape_references must be >= 1 (got " << shape_references << ")";
  else if (!(min_confidence >= 0.0 && min_confidence <= 1.0)) out << "DetectOptions.min_confidence must be in [0, 1] (got " << min_confidence << ")";
  else if (!(sure_first_confidence >= 0.0)) out << "DetectOptions.sure_first_confidence must be >= 0 (got " << sure_first_confidence << ")";
  else if (!(std::isfinite(confidence_bias) && std::isfinite(confidence_score_weight) && std::isfinite(confidence_ambiguous_weight) &&
             std::isfinite(confidence_on_surface_weight) && std::isfinite(confidence_free_space_weight) &&
             std::isfinite(confidence_contour_weight) && std::isfinite(confidence_region_iou_weight) &&
             std::isfinite(confidence_colour_weight) && std::isfinite(confidence_in_image_weight) &&
             std::isfinite(confidence_edge_weight) && std::isfinite(confidence_runner_up_weight) &&
             std::isfinite(confidence_free_band_weight))) {
    out << "DetectOptions.confidence_* must be finite";
  }
  else if (!(ppf_contour_step_m >= 0.0)) out << "DetectOptions.ppf_contour_step_m must be >= 0 (got " << ppf_contour_step_m << ")";
  else if (!(ppf_max_free_space >= 0.0 && ppf_max_free_space <= 1.0)) out << "DetectOptions.ppf_max_free_space must be in [0, 1] (got " << ppf_max_free_space << ")";
  return out.str();
}

}  // namespace g6d
