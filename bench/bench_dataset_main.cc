// g6d-bench-dataset: runs EstimatePose directly (no LCM) on every target instance of a
// BOP dataset with its GT visible mask (or that mask degraded, --degrade-masks); writes the
// BOP results CSV and prints ADD(-S) recall per object and after each stage, and latency
// percentiles per stage. With --identity unknown the mask's object is not given: every
// object of the dataset is a candidate (EstimatePoseOfUnknownObject).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <numeric>
#include <string>
#include <tuple>
#include <vector>

#include <sys/resource.h>

#include <CLI/CLI.hpp>

#include "core/error.h"
#include "core/executor.h"
#include "core/se3.h"
#include "core/timer.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "detect_benchmark.h"
#include "eval/mask_degrade.h"
#include "eval/metrics.h"
#include "mesh/mesh.h"
#include "solver/detect.h"
#include "solver/identify.h"
#include "solver/neighbours.h"
#include "solver/pipeline.h"
#include "templates/cache.h"
#include "bench_objects.h"

namespace {

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t index = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1) + 0.5));
  return values[index];
}

using ObjectData = g6d::bench::BenchObject;

struct Tally {
  int total = 0;
  int correct[5] = {0, 0, 0, 0, 0};  // seed, pnp, observable, icp, final
  int oracle_pnp = 0, oracle_kept = 0, oracle_ppf = 0;  // some PnP / kept / PPF pose is correct
  int oracle_pnp_rot = 0, oracle_kept_rot = 0;  // some PnP / kept pose within 15 deg of GT rotation
  int search_failures = 0, score_failures = 0;  // misses with S(GT) < S_A / S(GT) >= S_A (--score-gt)
  int right_identity = 0;                        // --identity unknown: the true object was chosen
  std::map<std::string, int> chosen_instead;     // --identity unknown: wrong choices by object id
  int ambiguous = 0, wrong_ambiguous = 0;        // --identity unknown: flagged ambiguous, of them wrong
};

double Mean(const std::vector<double>& values) {
  return values.empty() ? 0.0 : std::accumulate(values.begin(), values.end(), 0.0) / values.size();
}

// Every <id>.g6dcache in `dir`, sorted by name (--extra-candidates).
std::vector<g6d::TemplateBank> ReadCacheFolder(const std::string& dir) {
  std::vector<std::string> paths;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(dir, error)) {
    if (entry.path().extension() == ".g6dcache") paths.push_back(entry.path().string());
  }
  if (error) G6D_THROW("--extra-candidates: cannot list '" << dir << "': " << error.message());
  if (paths.empty()) G6D_THROW("--extra-candidates: no .g6dcache file in '" << dir << "'");
  std::sort(paths.begin(), paths.end());
  std::vector<g6d::TemplateBank> banks;
  for (const std::string& path : paths) banks.push_back(g6d::ReadTemplateCache(path));
  return banks;
}

// "GT visible" or the degradation, e.g. "erode 6 px" or "cut 0.30, seed 1", for the report.
std::string MaskLabel(const g6d::MaskDegradeOptions& degrade) {
  char label[128];
  switch (degrade.mode) {
    case g6d::MaskDegradation::kNone:
      return "GT visible";
    case g6d::MaskDegradation::kCut:
      std::snprintf(label, sizeof(label), "cut %.2f, seed %llu", degrade.cut_fraction,
                    static_cast<unsigned long long>(degrade.seed));
      return label;
    case g6d::MaskDegradation::kJitter:
      std::snprintf(label, sizeof(label), "jitter %d px, seed %llu", degrade.size_px,
                    static_cast<unsigned long long>(degrade.seed));
      return label;
    default:
      return g6d::MaskDegradationName(degrade.mode) + " " + std::to_string(degrade.size_px) + " px";
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"g6d-bench-dataset: solver accuracy and latency on a BOP dataset (GT visible masks)"};
  std::string dataset_dir, caches_dir, targets_file, out_csv;
  int hypotheses = g6d::SolverOptions().num_hypotheses, threads = 2, limit = 0, every = 1, pnp_iterations = 0;
  bool no_mhpo = false, no_icp = false, prosac = false, no_lo = false, oracle = false;
  std::string records_csv;
  app.add_option("--dataset", dataset_dir, "BOP dataset folder (models/, test/, ...)")->required();
  app.add_option("--caches", caches_dir, "folder with <obj_XXXXXX>.g6dcache files")->required();
  app.add_option("--targets", targets_file, "targets json (default: the dataset's test_targets_bop19.json)");
  app.add_option("--hypotheses", hypotheses, "K = N_H")->capture_default_str();
  app.add_option("--threads", threads, "threads (including the main one)")->capture_default_str();
  app.add_option("--limit", limit, "stop after this many instances (0 = all)")->capture_default_str();
  app.add_flag("--no-mhpo", no_mhpo, "skip MHPO (ablation)");
  app.add_flag("--no-icp", no_icp, "skip ICP (ablation)");
  app.add_option("--out", out_csv, "BOP results CSV to write");
  app.add_option("--every", every, "run every N-th target instance only (quick looks)")->capture_default_str();
  app.add_option("--records", records_csv, "per-instance CSV (S_A, confidence, error, correct) for calibration; with --masks none one row per answer (S_A, the frame check, the region terms)");
  app.add_option("--pnp-iterations", pnp_iterations, "MSAC-PnP iterations at most (0 = default)");
  double budget_ms = 0.0;
  app.add_option("--budget-ms", budget_ms, "time budget per instance (0 = none): answers are cut short when it runs out");
  app.add_flag("--pnp-prosac", prosac, "PROSAC sampling ordered by Hamming distance (opencv solver)");
  std::string pnp_solver = "depth";
  app.add_option("--pnp-solver", pnp_solver, "MSAC-PnP minimal solver: depth | p3p | opencv")->capture_default_str();
  app.add_flag("--pnp-no-lo", no_lo, "no USAC local optimization");
  double icp_min_step = 0.0;
  int icp_iterations = 0, source_points = 0;
  app.add_option("--icp-min-step", icp_min_step, "ICP stops when points move less than this, metres (0 = default)");
  app.add_option("--icp-iterations", icp_iterations, "ICP iterations at most (0 = default)");
  app.add_option("--icp-source-points", source_points, "rendered ICP source points at most (0 = default)");
  bool allow_border = false, reject_border = false, post_refine = false, score_gt = false;
  std::vector<int> adds_ids;
  app.add_flag("--post-refine", post_refine, "enable the optional post-refinement (stage 6)");
  bool check_flips = false, no_check_flips = false;
  app.add_flag("--check-flips", check_flips, "check the answer's 180-degree flips about its box axes (the default; kept for old scripts)");
  app.add_flag("--no-check-flips", no_check_flips, "with masks: do not check the answer's 180-degree flips (SolverOptions::check_flips; ablation)");
  app.add_flag("--allow-border-masks", allow_border, "solve masks that touch the image border (the default; kept for old scripts)");
  app.add_flag("--reject-border-masks", reject_border, "refuse masks that touch the image border (truncated objects)");
  app.add_option("--adds-ids", adds_ids, "object ids scored with ADD-S besides models_info's symmetric ones (e.g. 1 for the YCB-V can)")
      ->delimiter(',');
  bool no_appearance = false, no_occlusion = false, no_dedupe = false, point_to_point = false;
  app.add_flag("--icp-point-to-point", point_to_point, "the paper's point-to-point ICP instead of point-to-plane along the rendered model's normals (ablation)");
  int icp_point_iterations = -1;
  app.add_option("--icp-point-iterations", icp_point_iterations, "point-to-plane ICP: the first N iterations are point-to-point (default: solver's)");
  app.add_flag("--no-appearance", no_appearance, "no appearance tie-break among finalists (ablation)");
  bool no_ppf = false;
  app.add_flag("--no-ppf", no_ppf, "no point-pair-feature hypotheses: ORB-PnP alone (ablation)");
  g6d::PpfSearchOptions ppf_options;
  app.add_option("--ppf-stride", ppf_options.reference_stride, "point-pair features: every N-th scene point is a reference")
      ->capture_default_str();
  app.add_option("--ppf-poses", ppf_options.max_poses, "point-pair features: pose clusters kept")->capture_default_str();
  app.add_option("--ppf-bucket", ppf_options.max_bucket_fraction,
                 "point-pair features: features holding more than this fraction of the model's pairs are not looked up")
      ->capture_default_str();
  app.add_option("--ppf-spread", ppf_options.neighbour_spread, "point-pair features: neighbouring-bin spread")
      ->capture_default_str();
  int ppf_extra_hypotheses = -1;
  app.add_option("--ppf-hypotheses", ppf_extra_hypotheses, "point-pair features: PPF poses refined beside the K PnP poses (-1 = default)");
  app.add_option("--ppf-peaks", ppf_options.peaks_per_reference, "point-pair features: peaks per reference point")
      ->capture_default_str();
  bool no_silhouettes = false;
  app.add_flag("--no-silhouettes", no_silhouettes, "no poses from the mask's outline (ablation)");
  int silhouette_hypotheses = -1;
  app.add_option("--silhouette-hypotheses", silhouette_hypotheses,
                 "outline poses refined beside the K PnP and the PPF poses (-1 = default)");
  std::string mask_trust = "depth";
  app.add_option("--mask-trust", mask_trust, "how the mask is read: depth (evidence checked by the depth) or exact (the paper's; ablation)")
      ->capture_default_str();
  app.add_flag("--no-occlusion", no_occlusion, "no occlusion reasoning in the scores, ICP and MHPO (ablation)");
  bool unseen_hidden = false;
  app.add_flag("--unseen-hidden", unseen_hidden,
               "a rendered pixel outside the mask without observed depth counts for nothing (ScoreOptions::unseen_is_hidden)");
  int unseen_area_px = -1;
  bool fill_thin_holes = false;
  app.add_flag("--fill-thin-holes", fill_thin_holes,
               "a rendered pixel outside the mask in a thin depth hole whose surroundings lie on its surface counts as object (GridOptions::fill_thin_holes)");
  app.add_option("--unseen-area-px", unseen_area_px,
                 "--unseen-hidden: a depthless pixel is hidden only in a depthless area this wide, image pixels (GridOptions::unseen_area_min_px; 0 = every one; default: solver's)");
  app.add_flag("--no-dedupe", no_dedupe, "keep hypotheses equal modulo symmetry as separate K slots (ablation)");
  // Speed schedule (issue 13), each switchable for the ablation table.
  bool no_simd_match = false;
  app.add_flag("--no-simd-match", no_simd_match, "portable template matching loop instead of AVX-512 or AVX2 (same result; ablation)");
  bool no_avx512_match = false;
  app.add_flag("--no-avx512-match", no_avx512_match,
               "template matching's AVX2 loop even where the CPU has AVX-512 (same result: what a machine without it takes)");
  bool no_merge = false, no_cull = false, full_selection_mesh = false, icp_source_in_mask = false;
  int icp_probe = -1, icp_finish = 0;
  double pnp_min_quality = -1.0;
  app.add_flag("--no-merge-pnp", no_merge, "score every PnP pose in observable selection, duplicates dropped after ranking (ablation)");
  app.add_flag("--no-cull", no_cull, "rasterize back faces of closed meshes too (ablation)");
  app.add_flag("--full-selection-mesh", full_selection_mesh, "observable selection renders the online mesh, not the coarse one (ablation)");
  app.add_flag("--icp-source-in-mask", icp_source_in_mask, "ICP source: only rendered points inside the observed mask");
  app.add_option("--icp-probe", icp_probe, "ICP probing: N coarse iterations for every hypothesis, then only the best by S go on (0 = off; default: solver's)");
  int icp_coarse = -1;
  int icp_stall = -1, mhpo_min_rounds = -1;
  app.add_option("--mhpo-min-rounds", mhpo_min_rounds, "MHPO rounds before early stopping may end it (default: solver's)");
  double grow_fraction = -1.0;
  int max_search_regions = -1;
  int unsure_area_px = 0;
  app.add_option("--unsure-area-px", unsure_area_px,
                 "a mask's depthless pixels are unsure when they reach a depthless area outside the mask this wide (RegionOptions::unsure_area_min_px; 1 = any; default: solver's)");
  double support_penetration = -1.0, limit_ring = -1.0;
  app.add_option("--support-penetration", support_penetration,
                 "a finalist reaching behind the support plane by more than this fraction of the diameter (plus the surface tolerance) is passed over (SolverOptions::support_penetration_fraction; 0 = off, ablation; default: solver's)");
  app.add_option("--limit-ring", limit_ring,
                 "where the mask's ring shows no support, a ring this wide (fraction of the mask box) is searched for the plane no pose may reach behind (RegionOptions::limit_ring_fraction; 0 = none; default: solver's)");
  bool support_nobodys = false;
  app.add_flag("--no-mask-on-support", support_nobodys,
               "a pixel of the mask on the support plane is nobody's: no pose is credited with it (RegionOptions::mask_decides_on_support off; ablation)");
  app.add_option("--grow-fraction", grow_fraction, "search region grown by the depth up to this fraction of the mask box (0 = off; default: solver's)");
  int region_candidates = -1;
  double unsure_score = -1.0;
  app.add_option("--region-candidates", region_candidates,
                 "depth regions solved in place of a mask wider than the object or an unsure answer (0 = off; default: solver's)");
  app.add_option("--unsure-score", unsure_score,
                 "the depth regions are solved too when the mask's answer has S_A above this (ambiguous answers: the solver's unsure_ambiguous_score; 2 = only for wide masks and boxes; default: solver's)");
  bool no_neighbours = false;
  bool no_duplicates = false;
  app.add_flag("--no-resolve-duplicates", no_duplicates,
               "keep two answers of one object at one place (SolverOptions::resolve_duplicates; ablation)");
  app.add_flag("--no-neighbours", no_neighbours,
               "solve each instance alone: no second pass of an image's doubtful instances without the pixels their "
               "confident neighbours explain (SolverOptions::explain_neighbours; ablation)");
  app.add_option("--max-search-regions", max_search_regions, "depth segments searched alone when the region spans more than the object (0 = off; default: solver's)");
  app.add_option("--icp-stall", icp_stall, "ICP stops when the trimmed RMSE reached no new minimum for N iterations (0 = off; default: solver's)");
  app.add_option("--icp-coarse-points", icp_coarse, "ICP coarse-to-fine: converge on this many source points first (0 = off; default: solver's)");
  app.add_option("--icp-finish", icp_finish, "hypotheses ICP finishes after the probe (default: solver's)");
  double icp_merge = -1.0;
  app.add_option("--icp-merge", icp_merge,
                 "hypotheses ICP brings within this fraction of the diameter of a better-ranked one are merged (0 = off; default: solver's)");
  int ppf_skip = -1, silhouette_skip = -1;
  app.add_option("--ppf-skip-agreement", ppf_skip,
                 "skip the point-pair vote when this many PnP poses agree on one pose (0 = always vote; default: solver's)");
  app.add_option("--silhouette-skip-agreement", silhouette_skip,
                 "skip the outline's poses when this many PnP poses agree on one pose (0 = always add them; default: "
                 "solver's)");
  app.add_option("--pnp-min-quality", pnp_min_quality, "PnP only on sets with Q_j >= this fraction of Q_1 (default: solver's)");
  app.add_flag("--score-gt", score_gt,
               "also score the GT pose (S, 1 - J, depth term) beside S_A per instance: a miss with S(GT) < S_A is a "
               "search failure, with S(GT) >= S_A a score failure (records CSV and a summary)");
  app.add_flag("--oracle", oracle, "also report whether any PnP / kept hypothesis was correct (slow)");
  // Masks as a segmenter might give them (issue 22): the GT visible mask degraded.
  std::string degrade_mode = "none";
  g6d::MaskDegradeOptions degrade;
  app.add_option("--degrade-masks", degrade_mode,
                 "give the solver the GT visible mask degraded: " + g6d::MaskDegradationNames())
      ->capture_default_str();
  app.add_option("--degrade-px", degrade.size_px,
                 "degradation strength, pixels (erode/dilate radius, jitter amplitude, merge "
                 "distance, box margin)")
      ->capture_default_str();
  app.add_option("--degrade-seed", degrade.seed, "seed of the random degradations (jitter, cut)")
      ->capture_default_str();
  app.add_option("--degrade-cut-fraction", degrade.cut_fraction,
                 "cut: fraction of the mask's pixels removed, in [0, 1)")
      ->capture_default_str();
  // Depth as a real sensor gives it, where a dataset has only rendered depth (issue 31).
  std::string depth_folder = "depth", depth_sensor = "none";
  g6d::DepthSensorModel sensor;
  app.add_option("--depth-folder", depth_folder,
                 "the scenes' depth folder the solver reads (depth_gt: synth_dev's exact depth, e.g. under "
                 "--depth-sensor to compare the simulation with the set's own sensor)")
      ->capture_default_str();
  app.add_option("--depth-sensor", depth_sensor,
                 "none: the depth as it is; structured-light: through a simulated Kinect v1 / Xtion "
                 "(eval/depth_sensor.h: projector shadows, grazing angles, flying pixels at steps, noise "
                 "and disparity steps)")
      ->check(CLI::IsMember({"none", "structured-light"}))
      ->capture_default_str();
  app.add_option("--depth-sensor-seed", sensor.seed, "seed of the simulated sensor's noise")->capture_default_str();
  std::string sensor_off;
  app.add_option("--depth-sensor-off", sensor_off,
                 "the simulated sensor's effects switched off, comma separated: shadows, grazing, edges, noise, dark, "
                 "bright, speckle (ablations; noise off for a set whose depth is noisy already)");
  app.add_option("--depth-sensor-noise", sensor.noise_at_1m_m, "the simulated sensor's depth noise at 1 m, metres (grows with z^2)")
      ->capture_default_str();
  // The unknown-identity solve (issue 22, item 5).
  std::string identity = "given", extra_candidates_dir;
  bool no_prescreen = false;
  app.add_option("--identity", identity,
                 "given: the solver is told each mask's object; unknown: every object of the dataset is a "
                 "candidate, the lowest S_A wins, and a wrong identity counts as a miss")
      ->check(CLI::IsMember({"given", "unknown"}))
      ->capture_default_str();
  app.add_option("--extra-candidates", extra_candidates_dir,
                 "--identity unknown: every .g6dcache in this folder is a candidate too (objects not in the "
                 "dataset; choosing one is a wrong identity)");
  app.add_flag("--no-prescreen", no_prescreen,
               "--identity unknown: solve every candidate (no ruling out of objects shorter than the mask's depth "
               "extent)");
  // Detection without masks (issue 23).
  std::string masks = "gt";
  g6d::DetectOptions detect_options;
  app.add_option("--masks", masks,
                 "gt: each instance's GT visible mask (or --degrade-masks); none: no mask at all, the BOP "
                 "localization task (ids and instance counts from the targets, DetectObjects finds them)")
      ->check(CLI::IsMember({"gt", "none"}))
      ->capture_default_str();
  app.add_option("--detect-ppf-extra", detect_options.ppf_extra,
                 "--masks none: regions of the point-pair-feature vote solved per object beyond its count (0 = none)")
      ->capture_default_str();
  app.add_option("--detect-ppf-stride", detect_options.ppf_reference_stride,
                 "--masks none: every N-th scene point is a reference of the vote over the frame")
      ->capture_default_str();
  bool no_shape = false;
  app.add_flag("--detect-no-shape", no_shape,
               "--masks none: rank the regions of objects without colour by size alone, not by their shape (PPF "
               "support; ablation)");
  app.add_option("--detect-shape-references", detect_options.shape_references,
                 "--masks none: PPF reference points per depth segment for the shape term")
      ->capture_default_str();
  app.add_option("--detect-raised-sigmas", detect_options.raised_sigmas,
                 "--masks none: support pixels standing this many sigmas of the smoothed height above the support's "
                 "level are depth to segment (thin parts lying flat; 0 = off)")
      ->capture_default_str();
  app.add_option("--detect-raised-flatness", detect_options.raised_flatness,
                 "--masks none: a raised part's heights may spread this many times the support's")
      ->capture_default_str();
  app.add_option("--detect-island-bonus", detect_options.uncoloured_island_bonus,
                 "--masks none: added to the rank of an island for an object without colour (0 = none)")
      ->capture_default_str();
  app.add_option("--detect-island-split", detect_options.island_split_core,
                 "--masks none: split islands at their necks: a core is at least this fraction as thick as the thickest "
                 "pixel near it (0 = no split)");
  app.add_option("--detect-pieces-uncoloured-only", detect_options.island_pieces_uncoloured_only,
                 "--masks none: pieces of split islands are candidates for objects without colour only");
  app.add_option("--detect-island-window", detect_options.island_split_window,
                 "--masks none: the neighbourhood of --detect-island-split, as a fraction of the largest object's size in pixels");
  app.add_option("--detect-raised-outline", detect_options.raised_outline_edge,
                 "--masks none: areas of a support that the colour image's edges enclose (Canny thresholds this and "
                 "twice this) are raised when their mean height stands above the support around them (0 = off)")
      ->capture_default_str();
  app.add_option("--detect-raised-outline-noise", detect_options.raised_outline_min_noise,
                 "--masks none: an outlined area is raised only above this many sigmas of the sensor's noise at its depth")
      ->capture_default_str();
  app.add_option("--detect-raised-window", detect_options.raised_window_px,
                 "--masks none: the raised test averages the height above a support over squares of this side (odd)");
  app.add_option("--detect-measure-flatness", detect_options.measure_plane_flatness,
                 "--masks none: each support plane reads its flatness off its largest part, at most "
                 "--detect-plane-flatness (DetectOptions::measure_plane_flatness)")
      ->capture_default_str();
  app.add_option("--detect-plane-flatness", detect_options.plane_flatness_m,
                 "--masks none: a support plane's tolerance beyond the sensor's noise, metres (DetectOptions::plane_flatness_m)")
      ->capture_default_str();
  app.add_option("--detect-max-planes", detect_options.max_planes,
                 "--masks none: support planes at most (RANSAC, one after the other)");
  app.add_option("--detect-island-open", detect_options.island_open_px,
                 "--masks none: islands (connected parts of the frame less its support, opened by this many pixels) "
                 "are candidate regions too (-1 = none)")
      ->capture_default_str();
  std::vector<double> detect_confidence;
  app.add_option("--detect-confidence", detect_confidence,
                 "--masks none: the confidence's weights (scripts/calibrate_detection.py): bias, S_A, ambiguous, "
                 "on_surface, free_space, contour, region_iou, colour, in_image, edge, runner_up[, free_band] (default: DetectOptions'; "
                 "an old list of 11 leaves free_band's weight at 0)")
      ->expected(11, 12)
      ->delimiter(',');
  app.add_option("--detect-min-confidence", detect_options.min_confidence,
                 "--masks none: an answer less confident than this is no answer")
      ->capture_default_str();
  app.add_option("--detect-max-free-space", detect_options.max_free_space,
                 "--masks none: an answer seeing past its surface at more than this fraction of its pixels is none")
      ->capture_default_str();
  app.add_option("--detect-min-contour", detect_options.min_contour_support,
                 "--masks none: an answer whose outline shows a depth step at less than this fraction is none")
      ->capture_default_str();
  app.add_option("--detect-extra", detect_options.extra_candidates,
                 "--masks none: candidate regions solved per object beyond its count")
      ->capture_default_str();
  app.add_option("--detect-solve-hypotheses", detect_options.max_solve_hypotheses,
                 "--masks none: hypotheses kept in a candidate region's solve (min with --hypotheses; 0 = --hypotheses)")
      ->capture_default_str();
  app.add_option("--detect-solve-pnp-quality", detect_options.solve_pnp_min_quality,
                 "--masks none: a candidate region's solve runs PnP on sets with Q_j >= this fraction of Q_1")
      ->capture_default_str();
  app.add_option("--detect-island-silhouettes", detect_options.island_silhouettes,
                 "--masks none: poses from the outline in the solves of islands (their outline is the support's edge)");
  app.add_option("--detect-check-flips", detect_options.solve_check_flips,
                 "--masks none: a candidate region's solve checks its answer's 180-degree flips (SolverOptions::check_flips)")
      ->capture_default_str();
  app.add_option("--detect-solve-silhouettes", detect_options.solve_silhouettes,
                 "--masks none: a candidate region's solve adds poses from the region's outline")
      ->capture_default_str();
  app.add_option("--detect-passes", detect_options.explain_away_passes,
                 "--masks none: explaining-away passes after the first (answers' pixels taken out, the rest solved again)")
      ->capture_default_str();
  app.add_option("--detect-refuse-behind-support", detect_options.refuse_behind_support,
                 "--masks none: an answer whose model reaches behind the support under its region is no answer")
      ->capture_default_str();
  app.add_option("--detect-support-limit-from-frame", detect_options.support_limit_from_frame,
                 "--masks none: a region's solve takes the frame's support plane around it as its support limit where its own ring shows none")
      ->capture_default_str();
  app.add_option("--detect-sure-first", detect_options.sure_first_confidence,
                 "--masks none: answers at least this confident claim counts and pixels first, then the others; each group by S_A (> 1 = by S_A alone)")
      ->capture_default_str();
  app.add_option("--detect-found-passes", detect_options.found_object_passes,
                 "--masks none: further passes for the objects already found that want more")
      ->capture_default_str();
  app.add_option("--detect-colour-weight", detect_options.colour_weight,
                 "--masks none: weight of the colour agreement in the ranking of candidate regions")
      ->capture_default_str();
  app.add_option("--detect-bridge-holes", detect_options.bridge_holes_px,
                 "--masks none: depth holes at most this many pixels across are bridged for the segmentation (0 = off)")
      ->capture_default_str();
  app.add_option("--detect-gap-reach", detect_options.gap_neighbour_reach_m,
                 "--masks none: depth segments on both sides of a gap this many metres wide that holds no depth or a "
                 "nearer segment are neighbours (0 = off)")
      ->capture_default_str();
  app.add_option("--detect-max-union", detect_options.max_union_segments,
                 "--masks none: neighbouring depth segments joined into one candidate region, at most")
      ->capture_default_str();
  app.add_option("--detect-identity-check", detect_options.identity_check_below,
                 "--masks none: an answer less confident than this is solved as each other object asked for on its "
                 "region, and gives way to one that explains it with a higher confidence; 0 = off")
      ->capture_default_str();
  app.add_option("--detect-area-weight", detect_options.area_weight,
                 "--masks none: weight of the region's area against the object's silhouettes in the size agreement "
                 "of the ranking (0 = the 3D extent only)")
      ->capture_default_str();
  app.add_option("--detect-accept-confidence", detect_options.accept_confidence,
                 "--masks none: stop solving an object's candidates once it has its count of answers this confident "
                 "that explain their regions (1 = solve them all)")
      ->capture_default_str();
  bool crease_split = false;
  app.add_flag("--crease-split", crease_split,
               "split a mask's depth segments wider than the object at concave creases (SolverOptions::"
               "split_merged_at_creases; off by default)");
  std::string detect_pictures;
  app.add_option("--detect-pictures", detect_pictures,
                 "--masks none: write a picture of the support, segments, solved regions and answers per image "
                 "into this folder");
  int absent_requests = 0;
  app.add_option("--absent-requests", absent_requests,
                 "--masks none: per image, this many requests for objects of the dataset that are not in it (their "
                 "answers are counted apart: NO_SOLUTION is right)")
      ->capture_default_str();
  bool detect_diagnose = false;
  app.add_flag("--detect-diagnose", detect_diagnose,
               "--masks none: per GT instance (visib_fract >= 0.1), the best IoU of any region formed and of the "
               "regions solved for its object with its visible mask: where detection lost it (segments, ranking "
               "or solve)");
  CLI11_PARSE(app, argc, argv);
  if (!detect_confidence.empty()) {
    double* weights[] = {&detect_options.confidence_bias, &detect_options.confidence_score_weight,
                         &detect_options.confidence_ambiguous_weight, &detect_options.confidence_on_surface_weight,
                         &detect_options.confidence_free_space_weight, &detect_options.confidence_contour_weight,
                         &detect_options.confidence_region_iou_weight, &detect_options.confidence_colour_weight,
                         &detect_options.confidence_in_image_weight, &detect_options.confidence_edge_weight,
                         &detect_options.confidence_runner_up_weight, &detect_options.confidence_free_band_weight};
    if (detect_confidence.size() == 11) detect_options.confidence_free_band_weight = 0.0;
    for (size_t k = 0; k < detect_confidence.size(); ++k) *weights[k] = detect_confidence[k];
  }

  try {
    g6d::BopDataset dataset = g6d::LoadBopDataset(dataset_dir);
    if (!targets_file.empty()) {
      dataset.targets = g6d::LoadBopTargets(targets_file);
    } else if (!dataset.has_targets) {
      G6D_THROW("'" << dataset_dir << "' has no test_targets_bop19.json (pass --targets FILE)");
    }
    if (allow_border && reject_border) G6D_THROW("--allow-border-masks and --reject-border-masks contradict each other");
    g6d::SolverOptions options;
    options.num_hypotheses = hypotheses;
    options.run_mhpo = !no_mhpo;
    options.run_icp = !no_icp;
    if (pnp_iterations > 0) options.pnp.max_iterations = pnp_iterations;
    options.pnp.progressive_sampling = prosac;
    options.reject_border_masks = reject_border;
    options.budget_ms = budget_ms;
    if (no_appearance) options.appearance_tiebreak = false;
    if (no_ppf) options.use_ppf = false;
    options.ppf = ppf_options;
    if (ppf_extra_hypotheses >= 0) options.ppf_hypotheses = ppf_extra_hypotheses;
    if (no_silhouettes) options.use_silhouettes = false;
    if (silhouette_hypotheses >= 0) options.silhouette_hypotheses = silhouette_hypotheses;
    if (no_occlusion) options.score.occlusion_margin_m = 0.0;
    if (unseen_hidden) options.score.unseen_is_hidden = true;
    if (unseen_area_px >= 0) options.selection_grid.unseen_area_min_px = options.refine_grid.unseen_area_min_px = unseen_area_px;
    if (fill_thin_holes) options.selection_grid.fill_thin_holes = options.refine_grid.fill_thin_holes = true;
    options.mask_trust = g6d::ParseMaskTrust(mask_trust);
    options.split_merged_at_creases = crease_split;
    if (no_dedupe) options.distinct_pose_fraction = 0.0;
    if (point_to_point) options.icp.point_to_plane = false;
    if (icp_point_iterations >= 0) options.icp.point_to_point_iterations = icp_point_iterations;
    if (no_merge) options.merge_pnp_poses = false;
    if (no_simd_match) options.match.simd = false;
    if (no_avx512_match) options.match.simd_avx512 = false;
    if (no_cull) options.cull_backfaces = false;
    if (full_selection_mesh) options.coarse_selection_mesh = false;
    if (icp_source_in_mask) options.icp_source_in_mask = true;
    if (icp_probe >= 0) options.icp_probe_iterations = icp_probe;
    if (icp_finish > 0) options.icp_finish_hypotheses = icp_finish;
    if (icp_merge >= 0.0) options.icp_merge_fraction = icp_merge;
    if (ppf_skip >= 0) options.ppf_skip_agreement = ppf_skip;
    if (silhouette_skip >= 0) options.silhouette_skip_agreement = silhouette_skip;
    if (icp_coarse >= 0) options.icp_coarse_points = icp_coarse;
    if (icp_stall >= 0) options.icp.stall_window = icp_stall;
    if (mhpo_min_rounds >= 0) options.mhpo.min_rounds = mhpo_min_rounds;
    if (grow_fraction >= 0.0) options.region.grow_fraction = grow_fraction;
    if (support_nobodys) options.region.mask_decides_on_support = false;
    if (unsure_area_px > 0) options.region.unsure_area_min_px = unsure_area_px;
    if (support_penetration >= 0.0) options.support_penetration_fraction = support_penetration;
    if (limit_ring >= 0.0) options.region.limit_ring_fraction = limit_ring;
    if (max_search_regions >= 0) options.max_search_regions = max_search_regions;
    if (region_candidates >= 0) options.region_candidates = region_candidates;
    if (no_neighbours) options.explain_neighbours = false;
    if (no_duplicates) options.resolve_duplicates = false;
    if (unsure_score >= 0.0) options.unsure_score = unsure_score;
    if (pnp_min_quality >= 0.0) options.pnp_min_quality_ratio = pnp_min_quality;
    options.post_refine = post_refine;
    options.check_flips = (options.check_flips || check_flips) && !no_check_flips;
    if (icp_min_step > 0) options.icp.min_step_m = icp_min_step;
    if (icp_iterations > 0) options.icp.max_iterations = icp_iterations;
    if (source_points > 0) options.max_source_points = source_points;
    if (pnp_solver == "depth") options.pnp.minimal_solver = g6d::PnpMinimalSolver::kDepthRigid;
    else if (pnp_solver == "p3p") options.pnp.minimal_solver = g6d::PnpMinimalSolver::kP3p;
    else if (pnp_solver == "opencv") options.pnp.minimal_solver = g6d::PnpMinimalSolver::kOpenCvUsac;
    else G6D_THROW("--pnp-solver must be depth, p3p or opencv (got '" << pnp_solver << "')");
    options.pnp.local_optimization = !no_lo;
    if (every < 1) G6D_THROW("--every must be >= 1 (got " << every << ")");
    const bool simulate_sensor = g6d::ParseDepthSensorName(depth_sensor);
    sensor = g6d::WithoutSensorEffects(sensor, sensor_off);
    if (const std::string bad = sensor.Check(); !bad.empty()) G6D_THROW("bad --depth-sensor-* options: " << bad);
    if (masks == "none") {
      if (degrade_mode != "none" || identity != "given" || score_gt || oracle) {
        G6D_THROW("--masks none takes none of --degrade-masks, --identity, --score-gt or --oracle");
      }
      g6d::bench::DetectBenchmarkArgs detect_args;
      detect_args.dataset_dir = dataset_dir;
      detect_args.caches_dir = caches_dir;
      detect_args.targets_file = targets_file;
      detect_args.adds_ids = adds_ids;
      detect_args.out_csv = out_csv;
      detect_args.pictures_dir = detect_pictures;
      detect_args.diagnose = detect_diagnose;
      detect_args.absent_requests = absent_requests;
      detect_args.records_csv = records_csv;
      detect_args.depth_folder = depth_folder;
      detect_args.simulate_sensor = simulate_sensor;
      detect_args.sensor = sensor;
      detect_args.threads = threads;
      detect_args.every = every;
      detect_args.limit = limit;
      detect_args.solver = options;
      detect_args.detect = detect_options;
      if (no_shape) detect_args.detect.rank_uncoloured_by_shape = false;
      return g6d::bench::RunDetectBenchmark(detect_args);
    }
    degrade.mode = g6d::ParseMaskDegradation(degrade_mode);
    if (degrade.size_px < 0) G6D_THROW("--degrade-px must be >= 0 (got " << degrade.size_px << ")");
    if (!(degrade.cut_fraction >= 0.0 && degrade.cut_fraction < 1.0)) {
      G6D_THROW("--degrade-cut-fraction must be in [0, 1) (got " << degrade.cut_fraction << ")");
    }
    if (const std::string problem = degrade.Check(); !problem.empty())
      G6D_THROW("bad --degrade-* options: " << problem);
    const bool degrading = degrade.mode != g6d::MaskDegradation::kNone;
    const bool unknown_identity = identity == "unknown";
    if (!unknown_identity && (!extra_candidates_dir.empty() || no_prescreen)) {
      G6D_THROW("--extra-candidates and --no-prescreen need --identity unknown");
    }
    g6d::IdentifyOptions identify_options;
    identify_options.prescreen = !no_prescreen;
    std::FILE* records = nullptr;
    if (!records_csv.empty()) {
      records = std::fopen(records_csv.c_str(), "w");
      if (!records) G6D_THROW("cannot write '" << records_csv << "'");
      std::fprintf(records,
                   "scene_id,im_id,obj_id,gt_idx,success,score,confidence,iou,depth_residual,error_d,correct,total_ms,"
                   "truncated,ambiguous,runner_up_gap,appearance_valid,appearance_agreement,appearance_changed,"
                   "gt_score,gt_iou,gt_depth_residual,gt_occluded_px,sets_tried,pnp_hypotheses,pnp_merged,kept,"
                   "icp_iterations,answer_set_rank,answer_quality_ratio,ppf_hypotheses,ppf_distinct,answer_from_ppf,"
                   "silhouette_hypotheses,silhouette_distinct,answer_from_silhouette,"
                   "on_surface,free_space,contour_support,mask_iou,mask_wider,mask_is_box,depth_region_chosen,"
                   "neighbour_answer_chosen,duplicate_answer,pnp_agreement,support_penetration_mm,finalists_behind_support,"
                   "support_changed%s\n",
                   unknown_identity ? ",chosen_id,right_identity,true_object_score,best_other_id,best_other_score,"
                                      "candidates_solved,screened_out,identify_ms"
                                    : "");
    }
    int seen = 0;
    g6d::ThreadPool pool(std::max(1, threads));

    std::map<int, ObjectData> objects;
    std::map<int, g6d::BopScene> scenes;
    std::map<int, Tally> tallies;
    std::map<std::string, std::vector<double>> times;
    std::map<std::string, std::vector<double>> counts;
    std::vector<g6d::BopEstimate> estimates;
    std::map<std::pair<int, int>, double> image_time_s;
    int done = 0, cut_short = 0;
    // --identity unknown: every object the targets name is loaded up front and is a
    // candidate for every instance, with the --extra-candidates after them.
    std::vector<g6d::TemplateBank> extra_banks;
    std::vector<const g6d::TemplateBank*> candidates;
    std::map<std::string, int> obj_id_of;  // bank object id -> BOP obj_id (dataset objects)
    std::vector<double> candidate_ms, solved_candidate_ms, identify_ms;
    int candidate_count = 0, screened_count = 0, true_screened = 0;
    if (unknown_identity) {
      for (const g6d::BopTarget& target : dataset.targets) {
        if (!objects.count(target.obj_id)) {
          objects.emplace(target.obj_id, g6d::bench::LoadBenchObject(dataset, target.obj_id, caches_dir, adds_ids));
        }
      }
      for (const auto& [obj_id, object] : objects) {
        candidates.push_back(&object.bank);
        obj_id_of[object.bank.object_id] = obj_id;
      }
      if (!extra_candidates_dir.empty()) extra_banks = ReadCacheFolder(extra_candidates_dir);
      for (const g6d::TemplateBank& bank : extra_banks) candidates.push_back(&bank);
    }
    // Degraded masks: IoU with the GT visible mask, how many were merged / came out empty.
    double mask_iou_sum = 0.0;
    int masks_merged = 0, masks_empty = 0;
    // The mask the solver is given for one GT instance (the GT visible mask, or degraded).
    auto solver_mask_of = [&](const g6d::BopScene& scene, const g6d::BopFrame& bop_frame, const g6d::BopTarget& target,
                              size_t gt_idx, bool* merged) {
      const cv::Mat gt_mask = g6d::LoadBopMaskVisib(scene, target.im_id, static_cast<int>(gt_idx));
      if (!degrading) return gt_mask;
      // Merge needs the image's other instances (their GT visible masks); nothing else does.
      std::vector<cv::Mat> other_masks;
      if (degrade.mode == g6d::MaskDegradation::kMerge) {
        for (size_t other = 0; other < bop_frame.gt.size(); ++other) {
          if (other == gt_idx) continue;
          other_masks.push_back(g6d::LoadBopMaskVisib(scene, target.im_id, static_cast<int>(other)));
        }
      }
      return g6d::DegradeMask(gt_mask, other_masks, degrade,
                              g6d::MaskInstanceKey(target.scene_id, target.im_id, static_cast<int>(gt_idx)), merged);
    };
    // With a known identity an image's target instances are solved together, as the service
    // solves a frame's instances (ExplainAwayNeighbours, SolverOptions::explain_neighbours):
    // each is solved (EstimatePose), then the doubtful ones again without the pixels their
    // confident neighbours explain. The answers, by GT index, of the image being evaluated.
    const bool frame_pass = !unknown_identity && options.explain_neighbours;
    std::pair<int, int> frame_pass_image{-1, -1};
    std::map<size_t, g6d::PoseResult> frame_answers;
    std::map<size_t, std::pair<cv::Mat, bool>> frame_masks;  // the solver's mask, merged or not
    for (const g6d::BopTarget& target : dataset.targets) {
      if (!scenes.count(target.scene_id)) scenes.emplace(target.scene_id, g6d::LoadBopScene(dataset_dir, target.scene_id));
      const g6d::BopScene& scene = scenes.at(target.scene_id);
      if (!objects.count(target.obj_id)) {
        objects.emplace(target.obj_id, g6d::bench::LoadBenchObject(dataset, target.obj_id, caches_dir, adds_ids));
      }
      const ObjectData& object = objects.at(target.obj_id);
      const g6d::BopFrame& bop_frame = scene.Frame(target.im_id);
      g6d::Frame frame;
      frame.camera = bop_frame.camera;
      frame.rgb = g6d::LoadBopRgb(scene, target.im_id);
      frame.camera.width = frame.rgb.cols;
      frame.camera.height = frame.rgb.rows;
      frame.depth = g6d::bench::BenchDepth(scene, target.scene_id, target.im_id, frame.camera, frame.rgb, depth_folder,
                                           simulate_sensor, sensor);
      if (frame_pass && frame_pass_image != std::make_pair(target.scene_id, target.im_id)) {
        frame_pass_image = {target.scene_id, target.im_id};
        frame_answers.clear();
        frame_masks.clear();
        std::vector<size_t> gt_indices;
        std::vector<g6d::Instance> frame_instances;
        std::vector<const g6d::TemplateBank*> frame_banks;
        for (const g6d::BopTarget& other : dataset.targets) {
          if (other.scene_id != target.scene_id || other.im_id != target.im_id) continue;
          if (!objects.count(other.obj_id)) {
            objects.emplace(other.obj_id, g6d::bench::LoadBenchObject(dataset, other.obj_id, caches_dir, adds_ids));
          }
          for (const int gt_index : g6d::TargetGtIndices(bop_frame, other.obj_id, other.inst_count)) {
            const size_t gt_idx = static_cast<size_t>(gt_index);
            bool merged = false;
            const cv::Mat mask = solver_mask_of(scene, bop_frame, other, gt_idx, &merged);
            frame_masks[gt_idx] = {mask, merged};
            gt_indices.push_back(gt_idx);
            frame_banks.push_back(&objects.at(other.obj_id).bank);
            frame_instances.push_back({frame_banks.back()->object_id, mask});
          }
        }
        std::vector<g6d::PoseResult> frame_results;
        for (size_t k = 0; k < frame_instances.size(); ++k) {
          frame_results.push_back(g6d::EstimatePose(frame, frame_instances[k], *frame_banks[k], options, &pool));
        }
        g6d::ExplainAwayNeighbours(frame, frame_instances, frame_banks, {}, options, &pool, &frame_results);
        for (size_t k = 0; k < gt_indices.size(); ++k) frame_answers[gt_indices[k]] = std::move(frame_results[k]);
      }
      // The instances the target asks for: its inst_count most visible (BOP's rule; a hidden
      // copy of an object seen twice is not asked for).
      for (const int gt_index : g6d::TargetGtIndices(bop_frame, target.obj_id, target.inst_count)) {
        const size_t gt_idx = static_cast<size_t>(gt_index);
        const g6d::BopGtInstance& gt = bop_frame.gt[gt_idx];
        if (seen++ % every != 0) continue;
        const cv::Mat gt_mask =
            g6d::LoadBopMaskVisib(scene, target.im_id, static_cast<int>(gt_idx));
        bool merged = false;
        cv::Mat solver_mask;
        if (frame_pass) {
          std::tie(solver_mask, merged) = frame_masks.at(gt_idx);  // made for the frame's solve
        } else {
          solver_mask = solver_mask_of(scene, bop_frame, target, gt_idx, &merged);
        }
        double mask_iou = 1.0;
        if (degrading) {
          mask_iou = g6d::MaskIou(solver_mask, gt_mask);
          masks_merged += merged ? 1 : 0;
          masks_empty += cv::countNonZero(solver_mask) == 0 ? 1 : 0;
        }
        mask_iou_sum += mask_iou;
        const g6d::Instance instance{object.bank.object_id, solver_mask};
        g6d::IdentifiedPose identified;
        if (unknown_identity) {
          identified = g6d::EstimatePoseOfUnknownObject(frame, solver_mask, candidates, options, identify_options, &pool);
          for (const g6d::IdentityCandidate& candidate : identified.candidates) {
            candidate_ms.push_back(candidate.ms);
            if (!candidate.screened_out) solved_candidate_ms.push_back(candidate.ms);
            ++candidate_count;
            screened_count += candidate.screened_out ? 1 : 0;
            // The pre-screen must never rule out the object the mask shows.
            if (candidate.screened_out && candidate.object_id == object.bank.object_id) ++true_screened;
          }
          identify_ms.push_back(identified.total_ms);
        } else {
          identified.result = frame_pass ? frame_answers.at(gt_idx)
                                         : g6d::EstimatePose(frame, instance, object.bank, options, &pool);
          identified.object_id = object.bank.object_id;
        }
        const g6d::PoseResult& result = identified.result;
        // A wrong identity is a miss at every stage: its poses are another object's.
        const bool right_identity = identified.object_id == object.bank.object_id;
        const bool solved = result.success && right_identity;
        const g6d::StageReport& s = result.stages;
        g6d::PoseScore gt_score;
        bool has_gt_score = false;
        if (score_gt && result.success) {
          gt_score = g6d::ScoreInstancePose(frame, instance, object.bank, options, gt.cam_from_object);
          has_gt_score = true;
        }
        auto error = [&](const Eigen::Isometry3d& pose) {
          return object.symmetric ? g6d::ComputeAdds(pose, gt.cam_from_object, object.points)
                                  : g6d::ComputeAdd(pose, gt.cam_from_object, object.points);
        };
        Tally& tally = tallies[target.obj_id];
        ++tally.total;
        tally.ambiguous += identified.ambiguous ? 1 : 0;
        tally.wrong_ambiguous += identified.ambiguous && !right_identity ? 1 : 0;
        if (right_identity) {
          ++tally.right_identity;
        } else {
          ++tally.chosen_instead[identified.object_id.empty() ? "(none)" : identified.object_id];
        }
        double final_error = -1.0;
        if (solved) {
          const Eigen::Isometry3d stage_poses[5] = {s.seed_pose, s.pnp_pose, s.observable_pose, s.icp_pose, result.cam_from_object};
          for (int k = 0; k < 5; ++k) {
            const double e = error(stage_poses[k]);
            tally.correct[k] += g6d::IsAddCorrect(e, object.diameter_m);
            if (k == 4) final_error = e;
          }
          auto any_correct = [&](const std::vector<Eigen::Isometry3d>& poses) {
            for (const Eigen::Isometry3d& pose : poses) {
              if (g6d::IsAddCorrect(error(pose), object.diameter_m)) return 1;
            }
            return 0;
          };
          auto any_rotation = [&](const std::vector<Eigen::Isometry3d>& poses) {
            for (const Eigen::Isometry3d& pose : poses) {
              if (g6d::RotationErrorDeg(pose.linear(), gt.cam_from_object.linear()) < 15.0) return 1;
            }
            return 0;
          };
          if (oracle) {
            tally.oracle_pnp += any_correct(s.pnp_poses);
            tally.oracle_kept += any_correct(s.kept_poses);
            tally.oracle_ppf += any_correct(s.ppf_poses);
            tally.oracle_pnp_rot += any_rotation(s.pnp_poses);
            tally.oracle_kept_rot += any_rotation(s.kept_poses);
          }
        }
        const bool has_bop_id = !unknown_identity || obj_id_of.count(identified.object_id) > 0;
        if (result.success && has_bop_id) {
          // The answer as the BOP results CSV holds it: under the object it was given as
          // (a wrong identity's answer too; one of --extra-candidates has no BOP id here).
          g6d::BopEstimate estimate;
          estimate.scene_id = target.scene_id;
          estimate.im_id = target.im_id;
          estimate.obj_id = unknown_identity ? obj_id_of.at(identified.object_id) : target.obj_id;
          estimate.score = result.confidence;
          estimate.cam_from_object = result.cam_from_object;
          estimates.push_back(estimate);
        }
        const bool correct = solved && g6d::IsAddCorrect(final_error, object.diameter_m);
        if (has_gt_score && !correct) {
          // A miss: was a pose at least as good as the GT by S found (score failure) or not
          // (search failure)?
          (gt_score.s < result.score ? tally.search_failures : tally.score_failures) += 1;
        }
        if (records) {
          std::fprintf(records, "%d,%d,%d,%zu,%d,%.6f,%.6f,%.6f,%.6f,%.6f,%d,%.3f,%d,", target.scene_id, target.im_id,
                       target.obj_id, gt_idx, result.success ? 1 : 0, result.score, result.confidence,
                       result.details.iou, result.details.depth_residual,
                       solved ? final_error / object.diameter_m : -1.0, correct ? 1 : 0, s.total_ms,
                       result.truncated ? 1 : 0);
          std::fprintf(records, "%d,%.6f,%d,%.6f,%d,", result.ambiguous ? 1 : 0,
                       result.has_runner_up ? result.runner_up_score - result.score : -1.0,
                       result.appearance_valid ? 1 : 0, result.appearance_agreement, s.appearance_changed ? 1 : 0);
          if (has_gt_score) {
            std::fprintf(records, "%.6f,%.6f,%.6f,%d,", gt_score.s, gt_score.iou, gt_score.depth_residual,
                         gt_score.occluded_pixels);
          } else {
            std::fprintf(records, ",,,,");
          }
          std::fprintf(records, "%d,%d,%d,%d,%d,%d,%.4f", s.sets_tried, s.pnp_hypotheses, s.pnp_merged, s.kept_hypotheses,
                       s.icp_iterations, s.answer_set_rank, s.answer_quality_ratio);
          std::fprintf(records, ",%d,%d,%d", s.ppf_hypotheses, s.ppf_distinct, s.answer_from_ppf ? 1 : 0);
          std::fprintf(records, ",%d,%d,%d", s.silhouette_hypotheses, s.silhouette_distinct,
                       s.answer_from_silhouette ? 1 : 0);
          if (result.success && !unknown_identity) {
            // The answer against the whole frame (the solve's check, as detection's answers').
            const g6d::FrameCheck& check = result.frame_check;
            std::fprintf(records, ",%.4f,%.4f,%.4f", check.on_surface, check.free_space, check.contour_support);
          } else {
            std::fprintf(records, ",,,");
          }
          std::fprintf(records, ",%.4f,%d,%d,%d,%d,%d", result.mask_iou, s.mask_wider_than_object ? 1 : 0,
                       s.mask_is_box ? 1 : 0, s.depth_region_chosen ? 1 : 0, s.neighbour_answer_chosen ? 1 : 0,
                       s.duplicate_answer ? 1 : 0);
          std::fprintf(records, ",%d,%.1f,%d,%d", s.pnp_agreement, s.limit_plane ? s.support_penetration_m * 1000.0 : -1.0,
                       s.finalists_behind_support, s.support_changed ? 1 : 0);
          if (unknown_identity) {
            // The true object's S and the best other object's: the margin identity was decided by.
            double true_score = 2.0, other_score = 2.0;
            std::string other_id;
            int solved_count = 0;
            for (const g6d::IdentityCandidate& candidate : identified.candidates) {
              solved_count += candidate.screened_out ? 0 : 1;
              if (candidate.object_id == object.bank.object_id) {
                true_score = candidate.score;
              } else if (candidate.success && candidate.score < other_score) {
                other_score = candidate.score;
                other_id = candidate.object_id;
              }
            }
            std::fprintf(records, ",%s,%d,%.6f,%s,%.6f,%d,%d,%.3f", identified.object_id.c_str(), right_identity ? 1 : 0,
                         true_score, other_id.c_str(), other_score, solved_count, identified.screened_out,
                         identified.total_ms);
          }
          std::fprintf(records, "\n");
        }
        image_time_s[{target.scene_id, target.im_id}] += (unknown_identity ? identified.total_ms : s.total_ms) / 1000.0;
        for (const g6d::StageTime& stage : g6d::StageTimes(s)) times[stage.name].push_back(stage.ms);
        counts["sets tried"].push_back(s.sets_tried);
        counts["PnP poses"].push_back(s.pnp_hypotheses);
        counts["distinct PnP poses"].push_back(s.pnp_hypotheses - s.pnp_merged);
        counts["PPF poses"].push_back(s.ppf_hypotheses);
        counts["PPF poses new to PnP"].push_back(s.ppf_distinct);
        counts["answers from a PPF pose"].push_back(s.answer_from_ppf ? 1 : 0);
        counts["outline poses new to PnP and PPF"].push_back(s.silhouette_distinct);
        counts["answers from an outline pose"].push_back(s.answer_from_silhouette ? 1 : 0);
        counts["kept (K)"].push_back(s.kept_hypotheses);
        counts["merged by ICP"].push_back(s.icp_merged);
        counts["PnP poses agreeing"].push_back(s.pnp_agreement);
        counts["finalists behind the support"].push_back(s.finalists_behind_support);
        counts["answers moved off a pose behind the support"].push_back(s.support_changed ? 1 : 0);
        counts["point-pair vote skipped"].push_back(s.ppf_skipped ? 1 : 0);
        counts["outline poses skipped"].push_back(s.silhouette_skipped ? 1 : 0);
        counts["ICP iterations"].push_back(s.icp_iterations);
        counts["ICP runs at the iteration limit"].push_back(s.icp_runs_at_max);
        ++done;
        cut_short += result.cut_short ? 1 : 0;
        std::fprintf(stderr, "[%d] scene %d im %d obj %d: %s%s%s S %.3f ADD%s %.1f mm (%.2f d) %.0f ms", done,
                     target.scene_id, target.im_id, target.obj_id, result.success ? "ok" : result.message.c_str(),
                     result.truncated ? " (truncated)" : "", result.ambiguous ? " (ambiguous)" : "", result.score,
                     object.symmetric ? "-S" : "",
                     final_error * 1000, final_error / object.diameter_m, s.total_ms);
        if (degrading) std::fprintf(stderr, " | mask IoU %.2f", mask_iou);
        if (s.depth_regions_solved > 0) {
          std::fprintf(stderr, " | %s: mask's answer S %.3f, %d depth regions solved%s",
                       s.mask_wider_than_object ? "wider than the object" : s.mask_is_box ? "a box" : "unsure", s.mask_answer_score, s.depth_regions_solved, s.depth_region_chosen ? ", one chosen" : "");
        }
        if (s.neighbour_pixels > 0) {
          std::fprintf(stderr, " | %d px the neighbours explain: %s", s.neighbour_pixels,
                       s.neighbour_answer_chosen ? "solved without them" : "first answer stands");
        }
        if (unknown_identity) {
          std::fprintf(stderr, " | identity %s%s", identified.object_id.empty() ? "(none)" : identified.object_id.c_str(),
                       right_identity ? "" : " WRONG");
          if (!identified.runner_up_id.empty()) {
            std::fprintf(stderr, ", runner-up %s S %.3f%s", identified.runner_up_id.c_str(), identified.runner_up_score,
                         identified.ambiguous ? " (ambiguous)" : "");
          }
          std::fprintf(stderr, ", %zu candidates (%d screened out) %.0f ms", identified.candidates.size(),
                       identified.screened_out, identified.total_ms);
        }
        if (has_gt_score) {
          std::fprintf(stderr, " | S(GT) %.3f (1-J %.3f, depth %.3f, occluded %d px)", gt_score.s, 1.0 - gt_score.iou,
                       options.score.lambda_s * gt_score.depth_residual, gt_score.occluded_pixels);
        }
        std::fprintf(stderr, "\n");
        if (limit > 0 && done >= limit) break;
      }
      if (limit > 0 && done >= limit) break;
    }
    if (records) std::fclose(records);
    for (g6d::BopEstimate& e : estimates) e.time_s = image_time_s[{e.scene_id, e.im_id}];
    if (!out_csv.empty()) g6d::WriteBopCsv(out_csv, estimates);

    std::printf("\nADD(-S)@0.1d recall (%%), K = %d, %d threads, masks: %s", hypotheses, threads,
                MaskLabel(degrade).c_str());
    if (unknown_identity) {
      std::printf(", identity unknown (%zu candidates; a wrong identity is a miss)", candidates.size());
    }
    std::printf("\n");
    std::printf("| object | n | seed | +PnP | +observable | +ICP | +MHPO (final) |\n|---|---|---|---|---|---|---|\n");
    Tally all;
    for (const auto& [obj_id, tally] : tallies) {
      std::printf("| %s%s | %d", g6d::BopObjectName(obj_id).c_str(), objects.at(obj_id).symmetric ? " (ADD-S)" : "", tally.total);
      for (int k = 0; k < 5; ++k) {
        std::printf(" | %.1f", 100.0 * tally.correct[k] / std::max(1, tally.total));
        all.correct[k] += tally.correct[k];
      }
      all.total += tally.total;
      std::printf(" |\n");
    }
    std::printf("| **all** | %d", all.total);
    for (int k = 0; k < 5; ++k) std::printf(" | %.1f", 100.0 * all.correct[k] / std::max(1, all.total));
    if (oracle) {
      int pnp = 0, kept = 0, ppf = 0;
      for (const auto& [obj_id, tally] : tallies) {
        ppf += tally.oracle_ppf;
        pnp += tally.oracle_pnp;
        kept += tally.oracle_kept;
        std::printf(" |\noracle %s: some PnP pose correct %d/%d, some PPF pose %d, some kept pose correct %d/%d; rotation < 15 deg: PnP %d, kept %d",
                    g6d::BopObjectName(obj_id).c_str(), tally.oracle_pnp, tally.total, tally.oracle_ppf, tally.oracle_kept, tally.total,
                    tally.oracle_pnp_rot, tally.oracle_kept_rot);
      }
      std::printf(" |\noracle all: some PnP pose correct %.1f%%, some PPF pose %.1f%%, some kept pose correct %.1f%%",
                  100.0 * pnp / std::max(1, all.total), 100.0 * ppf / std::max(1, all.total),
                  100.0 * kept / std::max(1, all.total));
    }
    if (score_gt) {
      std::printf(" |\n\nmisses by cause (--score-gt): search failure = S(GT) < S_A (a better pose by S exists, not found);"
                  " score failure = S(GT) >= S_A (S prefers the wrong pose)\n| object | misses | search | score |\n|---|---|---|---|\n");
      int search = 0, score = 0;
      for (const auto& [obj_id, tally] : tallies) {
        std::printf("| %s | %d | %d | %d |\n", g6d::BopObjectName(obj_id).c_str(), tally.search_failures + tally.score_failures,
                    tally.search_failures, tally.score_failures);
        search += tally.search_failures;
        score += tally.score_failures;
      }
      std::printf("| **all** | %d | %d | %d", search + score, search, score);
    }
    struct rusage usage;
    getrusage(RUSAGE_SELF, &usage);
    std::printf(" |\n\npeak resident memory: %.0f MB\n", usage.ru_maxrss / 1024.0);
    std::printf(
        "masks (%s): mean IoU with the GT visible mask %.3f over %d instances, %d empty (counted "
        "as misses)",
        MaskLabel(degrade).c_str(), mask_iou_sum / std::max(1, done), done, masks_empty);
    if (degrade.mode == g6d::MaskDegradation::kMerge)
      std::printf(", %d merged with a touching neighbour", masks_merged);
    std::printf("\n");
    if (budget_ms > 0.0) std::printf("budget %.0f ms per instance: %d of %d answers cut short\n", budget_ms, cut_short, done);
    if (unknown_identity) {
      std::printf("\nidentity unknown: %zu candidates per instance (%zu of the dataset, %zu extra), pre-screen %s\n",
                  candidates.size(), candidates.size() - extra_banks.size(), extra_banks.size(),
                  identify_options.prescreen ? "on" : "off");
      std::printf("| object | n | right identity (%%) | chosen instead | ambiguous (of them wrong) |\n"
                  "|---|---|---|---|---|\n");
      int right = 0, ambiguous = 0, wrong_ambiguous = 0;
      for (const auto& [obj_id, tally] : tallies) {
        std::string instead;
        for (const auto& [id, count] : tally.chosen_instead) {
          instead += (instead.empty() ? "" : ", ") + id + " x" + std::to_string(count);
        }
        std::printf("| %s | %d | %.1f | %s | %d (%d) |\n", g6d::BopObjectName(obj_id).c_str(), tally.total,
                    100.0 * tally.right_identity / std::max(1, tally.total), instead.c_str(), tally.ambiguous,
                    tally.wrong_ambiguous);
        right += tally.right_identity;
        ambiguous += tally.ambiguous;
        wrong_ambiguous += tally.wrong_ambiguous;
      }
      std::printf("| **identity** | %d | %.1f | | %d (%d) |\n", all.total, 100.0 * right / std::max(1, all.total),
                  ambiguous, wrong_ambiguous);
      std::printf("pre-screen: %d of %d candidate solves skipped; the true object screened out %d times\n",
                  screened_count, candidate_count, true_screened);
      std::printf("time per candidate (ms): mean %.1f, p50 %.1f; per solved candidate mean %.1f, p50 %.1f; per "
                  "instance (all candidates) mean %.1f, p50 %.1f, p95 %.1f\n",
                  Mean(candidate_ms), Percentile(candidate_ms, 0.5), Mean(solved_candidate_ms),
                  Percentile(solved_candidate_ms, 0.5), Mean(identify_ms), Percentile(identify_ms, 0.5),
                  Percentile(identify_ms, 0.95));
    }
    std::printf("\nlatency per instance (ms)%s\n| stage | p50 | p95 |\n|---|---|---|\n",
                unknown_identity ? ", the chosen object's solve" : "");
    for (const g6d::StageTime& stage : g6d::StageTimes(g6d::StageReport())) {
      std::printf("| %s | %.1f | %.1f |\n", stage.name, Percentile(times[stage.name], 0.5), Percentile(times[stage.name], 0.95));
    }
    std::printf("\nwork per instance\n| count | p50 | p95 |\n|---|---|---|\n");
    for (const char* count : {"sets tried", "PnP poses", "distinct PnP poses", "kept (K)", "merged by ICP", "PnP poses agreeing", "ICP iterations", "ICP runs at the iteration limit"}) {
      std::printf("| %s | %.0f | %.0f |\n", count, Percentile(counts[count], 0.5), Percentile(counts[count], 0.95));
    }
    for (const auto& [count, option] : {std::pair<const char*, const char*>{"point-pair vote skipped", "ppf_skip_agreement"},
                                         {"outline poses skipped", "silhouette_skip_agreement"}}) {
      const std::vector<double>& skipped = counts[count];
      std::printf("%s (PnP poses agree, SolverOptions::%s): %.0f of %zu instances\n", count, option,
                  std::accumulate(skipped.begin(), skipped.end(), 0.0), skipped.size());
    }
    // Where the answers came from (every instance counted, failures as from none).
    auto share = [&](const char* count) {
      const std::vector<double>& values = counts[count];
      double sum = 0.0;
      for (double v : values) sum += v;
      return values.empty() ? 0.0 : 100.0 * sum / values.size();
    };
    std::printf("\nanswers from a point-pair-feature pose: %.1f%%; from an outline pose: %.1f%%\n",
                share("answers from a PPF pose"), share("answers from an outline pose"));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-bench-dataset: error: %s\n", e.what());
    return 2;
  }
}
