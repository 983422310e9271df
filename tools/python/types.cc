// What crosses the Python boundary as data (types.h): images and poses as numpy arrays,
// results as dictionaries, and the options structs of lib/ as Python classes
// (g6d.SolverOptions, g6d.DetectOptions, ...), one line per field, so that a field added to
// a struct is one line here too (tests/python/test_options_bound.py compares these lists
// with the headers and names any field that is missing). Values are the C++ defaults, i.e. the service's; validation is the
// structs' own Check(), whose message names the bad field.
#include "types.h"

#include <pybind11/stl.h>

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "core/error.h"
#include "mesh/mesh.h"
#include "mesh/symmetry.h"
#include "solver/detect.h"
#include "solver/identify.h"
#include "solver/pipeline.h"
#include "solver/score.h"
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

// A numpy array that owns `mat` (moved to the heap; no copy of the pixels). Rows and
// columns first, then channels when there are several.
py::object MatToArray(cv::Mat mat) {
  if (mat.empty()) return py::none();
  auto* owned = new cv::Mat(std::move(mat));
  py::capsule owner(owned, [](void* pointer) { delete static_cast<cv::Mat*>(pointer); });
  const py::ssize_t element = static_cast<py::ssize_t>(owned->elemSize1());
  std::vector<py::ssize_t> shape = {owned->rows, owned->cols};
  std::vector<py::ssize_t> strides = {static_cast<py::ssize_t>(owned->step[0]),
                                      static_cast<py::ssize_t>(owned->elemSize())};
  if (owned->channels() > 1) {
    shape.push_back(owned->channels());
    strides.push_back(element);
  }
  py::dtype dtype;
  switch (owned->depth()) {
    case CV_8U: dtype = py::dtype::of<uint8_t>(); break;
    case CV_16U: dtype = py::dtype::of<uint16_t>(); break;
    case CV_32F: dtype = py::dtype::of<float>(); break;
    case CV_64F: dtype = py::dtype::of<double>(); break;
    default: throw Error("internal: no numpy dtype for OpenCV depth " + std::to_string(owned->depth()));
  }
  return py::array(dtype, shape, strides, owned->data, owner);
}

// A read-only numpy view of `mat` that keeps `owner` (the Python object holding it) alive.
py::array ReadOnlyView(const cv::Mat& mat, const py::handle& owner) {
  std::vector<py::ssize_t> shape = {mat.rows, mat.cols};
  std::vector<py::ssize_t> strides = {static_cast<py::ssize_t>(mat.step[0]), static_cast<py::ssize_t>(mat.elemSize())};
  if (mat.channels() > 1) {
    shape.push_back(mat.channels());
    strides.push_back(static_cast<py::ssize_t>(mat.elemSize1()));
  }
  const py::dtype dtype = mat.depth() == CV_8U ? py::dtype::of<uint8_t>() : py::dtype::of<float>();
  py::array view(dtype, shape, strides, mat.data, owner);
  view.attr("flags").attr("writeable") = false;
  return view;
}

py::array_t<double> MatrixToArray(const Eigen::Matrix4d& matrix) {
  py::array_t<double> array({4, 4});
  auto out = array.mutable_unchecked<2>();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) out(r, c) = matrix(r, c);
  }
  return array;
}

py::array_t<double> VectorToArray(std::initializer_list<double> values) {
  py::array_t<double> array(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), array.mutable_data());
  return array;
}

// Results as dictionaries (g6d.PoseResult wraps them).

py::dict StagesDict(const StageReport& s) {
  py::dict d;
  d["query_features"] = s.query_features;
  d["correspondence_sets"] = s.correspondence_sets;
  d["search_regions"] = s.search_regions;
  d["pnp_hypotheses"] = s.pnp_hypotheses;
  d["kept_hypotheses"] = s.kept_hypotheses;
  d["icp_converged"] = s.icp_converged;
  d["sets_tried"] = s.sets_tried;
  d["pnp_merged"] = s.pnp_merged;
  d["pnp_agreement"] = s.pnp_agreement;
  d["ppf_skipped"] = s.ppf_skipped;
  d["silhouette_skipped"] = s.silhouette_skipped;
  d["flips_checked"] = s.flips_checked;
  d["flip_answer"] = s.flip_answer;
  d["support_penetration_m"] = s.support_penetration_m;
  d["limit_plane"] = s.limit_plane;
  d["finalists_behind_support"] = s.finalists_behind_support;
  d["support_changed"] = s.support_changed;
  d["answer_behind_support"] = s.answer_behind_support;
  d["icp_merged"] = s.icp_merged;
  d["icp_iterations"] = s.icp_iterations;
  d["icp_runs_at_max"] = s.icp_runs_at_max;
  d["icp_finished"] = s.icp_finished;
  d["answer_hypothesis"] = s.answer_hypothesis;
  d["answer_set_rank"] = s.answer_set_rank;
  d["answer_quality_ratio"] = s.answer_quality_ratio;
  d["mask_given_pixels"] = s.mask_given_pixels;
  d["mask_support_leak"] = s.mask_support_leak;
  d["mask_far_leak"] = s.mask_far_leak;
  d["support_plane"] = s.support_plane;
  d["surface_tolerance_m"] = s.surface_tolerance_m;
  d["mask_wider_than_object"] = s.mask_wider_than_object;
  d["mask_is_box"] = s.mask_is_box;
  d["mask_too_thin"] = s.mask_too_thin;
  d["depth_regions_solved"] = s.depth_regions_solved;
  d["depth_region_chosen"] = s.depth_region_chosen;
  d["mask_answer_score"] = s.mask_answer_score;
  d["neighbour_pixels"] = s.neighbour_pixels;
  d["neighbour_answer_chosen"] = s.neighbour_answer_chosen;
  d["duplicate_answer"] = s.duplicate_answer;
  d["best_quality"] = s.best_quality;
  d["best_e_obs"] = s.best_e_obs;
  d["best_s_after_icp"] = s.best_s_after_icp;
  d["distinct_finalists"] = s.distinct_finalists;
  d["appearance_compared"] = s.appearance_compared;
  d["appearance_changed"] = s.appearance_changed;
  d["post_refine_ran"] = s.post_refine_ran;
  d["post_refine_accepted"] = s.post_refine_accepted;
  d["mhpo_early_stopped"] = s.mhpo.early_stopped;
  d["mhpo_best_hypothesis"] = s.mhpo.best_hypothesis;
  // Every stage's wall time, ms, by the names the service and g6d-solve use, then the rest.
  py::dict times;
  for (const StageTime& stage : StageTimes(s)) times[stage.name] = stage.ms;
  times["mask_refine"] = s.mask_refine_ms;
  times["frame_check"] = s.frame_check_ms;
  times["depth_regions"] = s.depth_regions_ms;
  times["neighbours"] = s.neighbours_ms;
  d["time_ms"] = times;
  return d;
}

py::dict ResultDict(PoseResult result, const BankPtr& bank) {
  const Eigen::Quaterniond q(result.cam_from_object.linear());
  const Eigen::Vector3d t = result.cam_from_object.translation();
  py::dict d;
  d["object_id"] = bank ? bank->object_id : std::string();
  d["bank"] = bank ? py::cast(bank) : py::object(py::none());
  d["success"] = result.success;
  d["message"] = result.message;
  d["termination"] = TerminationName(result.termination);
  d["cam_from_object"] = MatrixToArray(result.cam_from_object.matrix());
  // As g6d-solve writes them (Eigen's quaternion of the same matrix).
  d["position_m"] = VectorToArray({t.x(), t.y(), t.z()});
  d["orientation_wxyz"] = VectorToArray({q.w(), q.x(), q.y(), q.z()});
  d["score"] = result.score;
  d["confidence"] = result.confidence;
  d["iou"] = result.details.iou;
  d["coverage"] = result.details.coverage;
  d["depth_residual"] = result.details.depth_residual;
  d["truncated"] = result.truncated;
  d["ambiguous"] = result.ambiguous;
  d["cut_short"] = result.cut_short;
  d["has_runner_up"] = result.has_runner_up;
  d["runner_up_cam_from_object"] =
      result.has_runner_up ? py::object(MatrixToArray(result.runner_up_cam_from_object.matrix())) : py::none();
  d["runner_up_score"] = result.has_runner_up ? py::object(py::float_(result.runner_up_score)) : py::none();
  d["appearance_agreement"] =
      result.appearance_valid ? py::object(py::float_(result.appearance_agreement)) : py::none();
  d["runner_up_appearance_agreement"] = result.runner_up_appearance_valid
                                            ? py::object(py::float_(result.runner_up_appearance_agreement))
                                            : py::none();
  d["corrected_mask"] = MatToArray(std::move(result.corrected_mask));
  d["mask_iou"] = result.mask_iou;
  d["on_surface"] = result.frame_check.on_surface;
  d["free_space"] = result.frame_check.free_space;
  d["free_space_band_px"] = result.frame_check.free_space_band_px;
  d["contour_support"] = result.frame_check.contour_support;
  d["in_image"] = result.frame_check.in_image;
  d["edge_support"] = result.frame_check.edge_support;
  d["oriented_edge"] = result.frame_check.oriented_edge;
  d["mask_refined_rounds"] = result.mask_refined_rounds;
  d["stages"] = StagesDict(result.stages);
  return d;
}

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
        G6D_FIELD(ring_fraction) G6D_FIELD(limit_ring_fraction) G6D_FIELD(plane_iterations) G6D_FIELD(plane_samples) G6D_FIELD(min_plane_fraction)
        G6D_FIELD(min_plane_points) G6D_FIELD(far_fraction) G6D_FIELD(grow_fraction) G6D_FIELD(mask_decides_on_support)
        G6D_FIELD(unsure_area_min_px) G6D_FIELD(seed).Done();
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
        G6D_FIELD(hamming_threshold) G6D_FIELD(max_sets) G6D_FIELD(min_correspondences) G6D_FIELD(simd) G6D_FIELD(simd_avx512).Done();
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
        G6D_FIELD(max_object_extent_m) G6D_FIELD(unseen_is_hidden) G6D_FIELD(max_unseen_background).Done();
  }
  {
    using T = GridOptions;
    OptionsClass<T>(module, "GridOptions", "Evaluation grid around the mask (solver/observation.h).")
        G6D_FIELD(margin) G6D_FIELD(max_side_px) G6D_FIELD(unseen_area_min_px) G6D_FIELD(fill_thin_holes).Done();
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
    using T = PpfSearchOptions;
    OptionsClass<T>(module, "PpfSearchOptions",
                    "Point-pair-feature voting on the depth, the texture-free hypothesis source (solver/ppf.h).")
        G6D_FIELD(reference_stride) G6D_FIELD(max_reference_points) G6D_FIELD(neighbour_spread) G6D_FIELD(max_bucket_fraction)
        G6D_FIELD(peaks_per_reference) G6D_FIELD(peak_ratio) G6D_FIELD(cluster_distance_fraction)
        G6D_FIELD(cluster_angle_deg) G6D_FIELD(max_poses) G6D_FIELD(min_cluster_ratio)
        G6D_FIELD(normal_radius_steps) G6D_FIELD(max_scene_points).Done();
  }
  {
    using T = SilhouetteOptions;
    OptionsClass<T>(module, "SilhouetteOptions",
                    "Poses from the mask's outline: template silhouettes matched at in-plane angles "
                    "(solver/silhouette_poses.h).")
        G6D_FIELD(rotations) G6D_FIELD(candidates) G6D_FIELD(min_iou) G6D_FIELD(min_mask_pixels).Done();
  }
  {
    using T = PpfModelOptions;
    OptionsClass<T>(module, "PpfModelOptions",
                    "The point-pair-feature model built into a cache (templates/ppf_model.h).")
        G6D_FIELD(step_fraction) G6D_FIELD(angle_step_deg) G6D_FIELD(normal_cluster_deg)
        G6D_FIELD(surface_samples) G6D_FIELD(max_points) G6D_FIELD(seed).Done();
  }
  {
    using T = ConfidenceWeights;
    OptionsClass<T>(module, "ConfidenceWeights",
                    "Weights of the logistic confidence of an answer to a mask (solver/solver_options.h).")
        G6D_FIELD(bias) G6D_FIELD(score) G6D_FIELD(ambiguous) G6D_FIELD(on_surface) G6D_FIELD(contour)
        G6D_FIELD(mask_iou).Done();
  }
  {
    using T = SolverOptions;
    // stop_requested (a pointer to the caller's atomic flag) is not bound: a Python caller
    // bounds a solve with budget_ms.
    OptionsClass<T>(module, "SolverOptions",
                    "All options of estimate_pose (solver/solver_options.h; the meaning and units of each field are "
                    "documented there). The defaults are the service's and g6d-solve's; K = num_hypotheses.")
        G6D_FIELD(query_orb) G6D_FIELD(mask_trust) G6D_FIELD(region) G6D_FIELD(segments)
        G6D_FIELD(split_merged_at_creases) G6D_FIELD(max_search_regions) G6D_FIELD(region_candidates)
        G6D_FIELD(unsure_score) G6D_FIELD(unsure_ambiguous_score) G6D_FIELD(explain_neighbours) G6D_FIELD(neighbour_min_fraction) G6D_FIELD(resolve_duplicates)
        G6D_FIELD(mask_refine_rounds) G6D_FIELD(match) G6D_FIELD(pnp) G6D_FIELD(use_ppf) G6D_FIELD(ppf)
        G6D_FIELD(ppf_hypotheses) G6D_FIELD(ppf_skip_agreement) G6D_FIELD(use_silhouettes) G6D_FIELD(silhouette) G6D_FIELD(silhouette_hypotheses)
        G6D_FIELD(silhouette_skip_agreement) G6D_FIELD(check_flips) G6D_FIELD(check_flips_max_score)
        G6D_FIELD(num_hypotheses) G6D_FIELD(score)
        G6D_FIELD(selection_grid) G6D_FIELD(refine_grid) G6D_FIELD(icp) G6D_FIELD(run_icp)
        G6D_FIELD(max_observed_points) G6D_FIELD(max_source_points) G6D_FIELD(icp_coarse_points) G6D_FIELD(icp_merge_fraction)
        G6D_FIELD(icp_probe_iterations) G6D_FIELD(icp_finish_hypotheses) G6D_FIELD(icp_source_in_mask)
        G6D_FIELD(mhpo) G6D_FIELD(run_mhpo) G6D_FIELD(post_refine) G6D_FIELD(post_refine_trigger_s)
        G6D_FIELD(post_refine_margin) G6D_FIELD(min_valid_depth_pixels) G6D_FIELD(reject_border_masks)
        G6D_FIELD(budget_ms) G6D_FIELD(distinct_pose_fraction) G6D_FIELD(merge_pnp_poses)
        G6D_FIELD(pnp_min_quality_ratio) G6D_FIELD(cull_backfaces) G6D_FIELD(coarse_selection_mesh)
        G6D_FIELD(ambiguity_distance_fraction) G6D_FIELD(ambiguity_margin) G6D_FIELD(appearance_tiebreak)
        G6D_FIELD(appearance_margin) G6D_FIELD(appearance_min_gain) G6D_FIELD(appearance)
        G6D_FIELD(support_penetration_fraction) G6D_FIELD(support_margin)
        G6D_FIELD(confidence) G6D_FIELD(wide_mask_confidence) G6D_FIELD(check_surface_fraction) G6D_FIELD(check_step_m)
        G6D_FIELD(confidence_bias) G6D_FIELD(confidence_score_weight) G6D_FIELD(confidence_ambiguous_weight).Done();
  }
  {
    using T = TrackSolveOptions;
    OptionsClass<T>(module, "TrackSolveOptions", "A solve from known poses, track_pose (solver/track_pose.h).")
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
    OptionsClass<T>(module, "DetectOptions", "Finding objects without a mask, find_objects (solver/detect_options.h).")
        G6D_FIELD(segments) G6D_FIELD(max_planes) G6D_FIELD(plane_iterations) G6D_FIELD(plane_samples)
        G6D_FIELD(plane_flatness_m) G6D_FIELD(measure_plane_flatness) G6D_FIELD(min_plane_fraction) G6D_FIELD(support_extent_factor)
        G6D_FIELD(raised_sigmas) G6D_FIELD(raised_window_px) G6D_FIELD(raised_level_px) G6D_FIELD(raised_min_height_m)
        G6D_FIELD(raised_flatness)
        G6D_FIELD(raised_outline_edge) G6D_FIELD(raised_outline_ring_px) G6D_FIELD(raised_outline_min_noise) G6D_FIELD(island_open_px) G6D_FIELD(island_split_core) G6D_FIELD(island_split_window)
        G6D_FIELD(island_split_min_core_px) G6D_FIELD(island_split_max_pieces) G6D_FIELD(island_pieces_uncoloured_only)
        G6D_FIELD(island_silhouettes) G6D_FIELD(uncoloured_island_bonus)
        G6D_FIELD(bridge_holes_px) G6D_FIELD(neighbour_gap_px) G6D_FIELD(gap_neighbour_reach_m) G6D_FIELD(gap_occluder_margin_m) G6D_FIELD(max_union_segments) G6D_FIELD(max_regions)
        G6D_FIELD(extent_margin_px) G6D_FIELD(min_extent_fraction) G6D_FIELD(min_area_fraction)
        G6D_FIELD(extra_candidates) G6D_FIELD(colour_weight) G6D_FIELD(rank_uncoloured_by_shape) G6D_FIELD(shape_references) G6D_FIELD(accept_confidence)
        G6D_FIELD(accept_region_iou) G6D_FIELD(fill_gap_px) G6D_FIELD(explain_away_passes) G6D_FIELD(found_object_passes) G6D_FIELD(refuse_behind_support) G6D_FIELD(sure_first_confidence) G6D_FIELD(support_limit_from_frame)
        G6D_FIELD(max_solve_hypotheses) G6D_FIELD(solve_pnp_min_quality) G6D_FIELD(solve_silhouettes) G6D_FIELD(solve_check_flips) G6D_FIELD(area_weight) G6D_FIELD(identity_check_below) G6D_FIELD(max_score)
        G6D_FIELD(max_overlap) G6D_FIELD(ppf_extra) G6D_FIELD(ppf_reference_stride) G6D_FIELD(ppf_max_scene_points)
        G6D_FIELD(ppf_surface_fraction) G6D_FIELD(ppf_max_free_space) G6D_FIELD(ppf_min_contour_support)
        G6D_FIELD(ppf_contour_step_m) G6D_FIELD(max_free_space) G6D_FIELD(free_space_fraction)
        G6D_FIELD(min_contour_support) G6D_FIELD(confidence_bias) G6D_FIELD(confidence_score_weight)
        G6D_FIELD(confidence_ambiguous_weight) G6D_FIELD(confidence_on_surface_weight) G6D_FIELD(confidence_free_space_weight)
        G6D_FIELD(confidence_contour_weight) G6D_FIELD(confidence_region_iou_weight) G6D_FIELD(confidence_colour_weight) G6D_FIELD(confidence_in_image_weight)
        G6D_FIELD(confidence_edge_weight) G6D_FIELD(confidence_runner_up_weight) G6D_FIELD(confidence_free_band_weight)
        G6D_FIELD(min_confidence).Done();
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
        G6D_FIELD(find_symmetries) G6D_FIELD(symmetry) G6D_FIELD(sample_appearance) G6D_FIELD(appearance)
        G6D_FIELD(build_ppf) G6D_FIELD(ppf).Done();
  }
}

}  // namespace g6d::python
