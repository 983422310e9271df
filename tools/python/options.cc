// The options structs of lib/ as Python classes (g6d.SolverOptions, g6d.DetectOptions, ...):
// one line per field, so that a field added to a struct is one line here too
// (tests/python/test_options.py compares these lists with the headers and names any field
// that is missing). Values are the C++ defaults, i.e. the service's; validation is the
// structs' own Check(), whose message names the bad field.
#include "options.h"

#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <vector>

#include "mesh/mesh.h"
#include "mesh/symmetry.h"
#include "solver/detect.h"
#include "solver/identify.h"
#include "solver/pipeline.h"
#include "templates/appearance.h"
#include "templates/crop.h"
#include "templates/features.h"
#include "templates/template_bank.h"
#include "templates/views.h"

namespace g6d::python {
namespace {

namespace py = pybind11;

// A Python class for the options struct T: a default constructor, read-write fields (a
// nested struct is returned by reference, so `options.mhpo.max_rounds = 3` changes
// `options`), the names of the fields in declaration order (`_fields`), copy, and
// `check()` (T::Check(): "" when valid, else the message naming the bad field). Keyword
// construction, repr, equality and as_dict() are added in Python (g6d/__init__.py), the
// same way for every class.
template <typename T>
class OptionsClass {
 public:
  OptionsClass(py::module_& module, const char* name, const char* doc)
      : class_(module, name, doc), names_(std::make_shared<std::vector<std::string>>()) {
    class_.def(py::init<>());
    class_.def("check", &T::Check,
               "'' when every field is valid, else a message naming the bad field (the C++ Check()).");
    class_.def("__copy__", [](const T& options) { return T(options); });
    class_.def("__deepcopy__", [](const T& options, py::dict) { return T(options); }, py::arg("memo"));
  }

  template <typename Field>
  OptionsClass& Add(const char* name, Field T::*member) {
    class_.def_readwrite(name, member);
    names_->push_back(name);
    return *this;
  }

  // Ends the list: the field names in declaration order, for keyword construction, as_dict
  // and repr.
  void Done() { class_.attr("_fields") = py::tuple(py::cast(*names_)); }

 private:
  py::class_<T> class_;
  std::shared_ptr<std::vector<std::string>> names_;
};

// Adds field `name` of the struct in scope as `T`.
#define G6D_FIELD(name) .Add(#name, &T::name)

}  // namespace

void BindOptions(py::module_& module) {
  py::enum_<MaskTrust>(module, "MaskTrust",
                       "How the instance mask is read: DEPTH (as evidence checked by the depth, the default) or "
                       "EXACT (the paper's: every mask pixel is object). Options also take 'depth' / 'exact'.")
      .value("EXACT", MaskTrust::kExact)
      .value("DEPTH", MaskTrust::kDepth);
  py::enum_<PnpMinimalSolver>(module, "PnpMinimalSolver",
                              "PnP hypothesis generator (solver/pnp.h). Options also take the names as strings.")
      .value("OPENCV_USAC", PnpMinimalSolver::kOpenCvUsac)
      .value("P3P", PnpMinimalSolver::kP3p)
      .value("DEPTH_RIGID", PnpMinimalSolver::kDepthRigid);

  {
    using T = OrbOptions;
    OptionsClass<T>(module, "OrbOptions", "ORB detection (templates/features.h).")
        G6D_FIELD(max_features) G6D_FIELD(scale_factor) G6D_FIELD(num_levels) G6D_FIELD(edge_threshold)
        G6D_FIELD(fast_threshold) G6D_FIELD(mask_erosion_px).Done();
  }
  {
    using T = RegionOptions;
    OptionsClass<T>(module, "RegionOptions", "The depth's check of the mask, mask_trust DEPTH (solver/region.h).")
        G6D_FIELD(sensor_noise_at_1m) G6D_FIELD(noise_sigmas) G6D_FIELD(pose_tolerance_fraction)
        G6D_FIELD(ring_fraction) G6D_FIELD(plane_iterations) G6D_FIELD(plane_samples) G6D_FIELD(min_plane_fraction)
        G6D_FIELD(min_plane_points) G6D_FIELD(far_fraction) G6D_FIELD(grow_fraction) G6D_FIELD(seed).Done();
  }
  {
    using T = SegmentOptions;
    OptionsClass<T>(module, "SegmentOptions", "Depth segmentation (solver/segments.h).")
        G6D_FIELD(sensor_noise_at_1m) G6D_FIELD(noise_sigmas) G6D_FIELD(max_incidence_deg)
        G6D_FIELD(min_segment_pixels) G6D_FIELD(crease_half_span_m) G6D_FIELD(crease_min_depth_m)
        G6D_FIELD(crease_erode_px).Done();
  }
  {
    using T = MatchOptions;
    OptionsClass<T>(module, "MatchOptions", "Template matching: tau_H, N_P (solver/match.h).")
        G6D_FIELD(hamming_threshold) G6D_FIELD(max_sets) G6D_FIELD(min_correspondences) G6D_FIELD(simd).Done();
  }
  {
    using T = PnpOptions;
    OptionsClass<T>(module, "PnpOptions", "MSAC-PnP (solver/pnp.h).")
        G6D_FIELD(tau_fraction) G6D_FIELD(tau_min_px) G6D_FIELD(tau_max_px) G6D_FIELD(max_iterations)
        G6D_FIELD(confidence) G6D_FIELD(min_inliers) G6D_FIELD(seed) G6D_FIELD(minimal_solver)
        G6D_FIELD(max_centre_depth_error) G6D_FIELD(progressive_sampling) G6D_FIELD(local_optimization).Done();
  }
  {
    using T = ScoreOptions;
    OptionsClass<T>(module, "ScoreOptions", "E_obs and S: omega_C, lambda_S (solver/score.h).")
        G6D_FIELD(omega_c) G6D_FIELD(lambda_s) G6D_FIELD(occlusion_margin_m) G6D_FIELD(cull_backfaces)
        G6D_FIELD(depth_evidence) G6D_FIELD(surface_tolerance_m) G6D_FIELD(segment_own_fraction)
        G6D_FIELD(max_object_extent_m).Done();
  }
  {
    using T = GridOptions;
    OptionsClass<T>(module, "GridOptions", "Evaluation grid around the mask (solver/observation.h).")
        G6D_FIELD(margin) G6D_FIELD(max_side_px).Done();
  }
  {
    using T = IcpOptions;
    OptionsClass<T>(module, "IcpOptions", "Trimmed ICP: rho, kappa_d (solver/icp.h).")
        G6D_FIELD(trim_fraction) G6D_FIELD(kappa_d) G6D_FIELD(r0_m) G6D_FIELD(max_iterations) G6D_FIELD(min_step_m)
        G6D_FIELD(stall_window) G6D_FIELD(min_rmse_decrease) G6D_FIELD(min_correspondences)
        G6D_FIELD(point_to_plane) G6D_FIELD(point_to_point_iterations).Done();
  }
  {
    using T = MhpoOptions;
    OptionsClass<T>(module, "MhpoOptions", "Mask-depth multi-hypothesis optimization: lambda_D (solver/mhpo.h).")
        G6D_FIELD(lambda_d) G6D_FIELD(huber_beta) G6D_FIELD(silhouette_robust_px) G6D_FIELD(max_rounds)
        G6D_FIELD(lm_iterations) G6D_FIELD(max_contour_points) G6D_FIELD(max_depth_points)
        G6D_FIELD(early_stop_score) G6D_FIELD(min_rounds) G6D_FIELD(patience).Done();
  }
  {
    using T = AppearanceOptions;
    OptionsClass<T>(module, "AppearanceOptions", "Appearance samples and agreement (templates/appearance.h).")
        G6D_FIELD(sample_points) G6D_FIELD(seed) G6D_FIELD(min_color_std) G6D_FIELD(texture_max_side_px)
        G6D_FIELD(grid_max_side_px) G6D_FIELD(visibility_tolerance_m) G6D_FIELD(min_facing_cos)
        G6D_FIELD(edge_margin_px) G6D_FIELD(min_chroma_std) G6D_FIELD(min_visible_points).Done();
  }
  {
    using T = SolverOptions;
    // stop_requested (a pointer to the caller's atomic flag) is not bound: a Python caller
    // bounds a solve with budget_ms.
    OptionsClass<T>(module, "SolverOptions",
                    "All options of estimate_pose (solver/pipeline.h; the meaning and units of each field are "
                    "documented there). The defaults are the service's and g6d-solve's; K = num_hypotheses.")
        G6D_FIELD(query_orb) G6D_FIELD(mask_trust) G6D_FIELD(region) G6D_FIELD(segments)
        G6D_FIELD(split_merged_at_creases) G6D_FIELD(max_search_regions) G6D_FIELD(region_candidates)
        G6D_FIELD(region_search_confidence) G6D_FIELD(explain_neighbours) G6D_FIELD(neighbour_min_fraction)
        G6D_FIELD(mask_refine_rounds) G6D_FIELD(match) G6D_FIELD(pnp) G6D_FIELD(num_hypotheses) G6D_FIELD(score)
        G6D_FIELD(selection_grid) G6D_FIELD(refine_grid) G6D_FIELD(icp) G6D_FIELD(run_icp)
        G6D_FIELD(max_observed_points) G6D_FIELD(max_source_points) G6D_FIELD(icp_coarse_points)
        G6D_FIELD(icp_probe_iterations) G6D_FIELD(icp_finish_hypotheses) G6D_FIELD(icp_source_in_mask)
        G6D_FIELD(mhpo) G6D_FIELD(run_mhpo) G6D_FIELD(post_refine) G6D_FIELD(post_refine_trigger_s)
        G6D_FIELD(post_refine_margin) G6D_FIELD(min_valid_depth_pixels) G6D_FIELD(reject_border_masks)
        G6D_FIELD(budget_ms) G6D_FIELD(distinct_pose_fraction) G6D_FIELD(merge_pnp_poses)
        G6D_FIELD(pnp_min_quality_ratio) G6D_FIELD(cull_backfaces) G6D_FIELD(coarse_selection_mesh)
        G6D_FIELD(ambiguity_distance_fraction) G6D_FIELD(ambiguity_margin) G6D_FIELD(appearance_tiebreak)
        G6D_FIELD(appearance_margin) G6D_FIELD(appearance_min_gain) G6D_FIELD(appearance)
        G6D_FIELD(confidence_bias) G6D_FIELD(confidence_score_weight) G6D_FIELD(confidence_ambiguous_weight).Done();
  }
  {
    using T = TrackSolveOptions;
    OptionsClass<T>(module, "TrackSolveOptions", "A solve from known poses, track_pose (solver/pipeline.h).")
        G6D_FIELD(icp_iterations) G6D_FIELD(max_source_points) G6D_FIELD(max_observed_points)
        G6D_FIELD(mhpo_rounds) G6D_FIELD(appearance_search_deg) G6D_FIELD(appearance_step_deg)
        G6D_FIELD(score_appearance).Done();
  }
  {
    using T = IdentifyOptions;
    OptionsClass<T>(module, "IdentifyOptions",
                    "The identity search of estimate_pose_of_unknown_object (solver/identify.h).")
        G6D_FIELD(prescreen) G6D_FIELD(extent_trim_fraction) G6D_FIELD(extent_margin_px).Done();
  }
  {
    using T = DetectOptions;
    OptionsClass<T>(module, "DetectOptions", "Finding objects without a mask, find_objects (solver/detect.h).")
        G6D_FIELD(segments) G6D_FIELD(max_planes) G6D_FIELD(plane_iterations) G6D_FIELD(plane_samples)
        G6D_FIELD(plane_flatness_m) G6D_FIELD(min_plane_fraction) G6D_FIELD(support_extent_factor)
        G6D_FIELD(neighbour_gap_px) G6D_FIELD(max_union_segments) G6D_FIELD(max_regions)
        G6D_FIELD(extent_margin_px) G6D_FIELD(min_extent_fraction) G6D_FIELD(min_area_fraction)
        G6D_FIELD(extra_candidates) G6D_FIELD(colour_weight) G6D_FIELD(accept_confidence)
        G6D_FIELD(accept_region_iou) G6D_FIELD(fill_gap_px) G6D_FIELD(explain_away_passes) G6D_FIELD(max_score)
        G6D_FIELD(max_overlap).Done();
  }
  {
    using T = ViewSamplingOptions;
    OptionsClass<T>(module, "ViewSamplingOptions", "Template views: N_T = num_directions * num_inplane (templates/views.h).")
        G6D_FIELD(num_directions) G6D_FIELD(num_inplane) G6D_FIELD(fill_fraction).Done();
  }
  {
    using T = CropOptions;
    OptionsClass<T>(module, "CropOptions", "The normalized crop: padding p, side S (templates/crop.h).")
        G6D_FIELD(padding) G6D_FIELD(size_px) G6D_FIELD(background_gray) G6D_FIELD(normalized_mean)
        G6D_FIELD(normalized_std) G6D_FIELD(min_std).Done();
  }
  {
    using T = SymmetryOptions;
    OptionsClass<T>(module, "SymmetryOptions", "The search for the mesh's geometric symmetries (mesh/symmetry.h).")
        G6D_FIELD(sample_points) G6D_FIELD(mean_tolerance) G6D_FIELD(max_tolerance) G6D_FIELD(max_order)
        G6D_FIELD(seed).Done();
  }
  {
    using T = TemplateBuildOptions;
    OptionsClass<T>(module, "TemplateBuildOptions",
                    "Everything that determines a template bank, build_templates (templates/template_bank.h). "
                    "The defaults are g6d-build-templates' (324 templates).")
        G6D_FIELD(views) G6D_FIELD(crop) G6D_FIELD(orb) G6D_FIELD(render_size_px) G6D_FIELD(render_focal_px)
        G6D_FIELD(online_mesh_faces) G6D_FIELD(max_view_angle_deg) G6D_FIELD(thumbnail_size_px)
        G6D_FIELD(find_symmetries) G6D_FIELD(symmetry) G6D_FIELD(sample_appearance) G6D_FIELD(appearance).Done();
  }
}

}  // namespace g6d::python
