#include "solver/stages.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <utility>

#include "core/timer.h"
#include "render/raster.h"
#include "solver/silhouette_poses.h"
#include "templates/crop.h"

namespace g6d {

namespace {

// Stage 6 hypotheses from T_A: its 180-degree flips about the bounding-box axes through
// the box centre (the usual confusions of near-symmetric shapes), and each of those plus
// T_A itself re-centred: the box centre moved onto the ray through the mask box centre,
// at z_M plus a quarter diameter (the centre lies behind the visible surface).
std::vector<Eigen::Isometry3d> PostRefineHypotheses(const Eigen::Isometry3d& cam_from_object, const TemplateBank& bank,
                                                    const Camera& camera, const cv::Rect& box, double z_m) {
  const Eigen::Vector3d centre = bank.bounding_box.center();
  std::vector<Eigen::Isometry3d> poses = {cam_from_object};
  for (const Eigen::Isometry3d& flip : BoxFlips(cam_from_object, bank)) poses.push_back(flip);
  const Eigen::Vector2d box_centre(box.x + 0.5 * box.width, box.y + 0.5 * box.height);
  const Eigen::Vector3d target_centre = camera.Backproject(box_centre, z_m + 0.25 * bank.diameter_m);
  const size_t n = poses.size();
  for (size_t i = 0; i < n; ++i) {
    Eigen::Isometry3d moved = poses[i];
    moved.translation() += target_centre - poses[i] * centre;
    poses.push_back(moved);
  }
  return poses;
}

// Shares of SolverOptions::budget_ms after which a stage starts no new work, so that a
// tight budget still reaches ICP and MHPO on the best hypotheses instead of being spent
// on PnP for every template. They are where the stages end in a median LM-O solve at
// K = 18 (bench/RESULTS.md, issue 13): matching at 17%, PnP 48%, selection 55%, ICP 85%;
// a budget at or above the usual solve time therefore cuts nothing.
constexpr double kPnpBudgetShare = 0.5;
constexpr double kObservableBudgetShare = 0.6;
constexpr double kIcpBudgetShare = 0.85;

// Stage 2: MSAC-PnP on every correspondence set (in rank order, down to
// options.pnp_min_quality_ratio of the best Q), then the poses equal modulo the symmetries
// to a better-ranked one are merged (options.merge_pnp_poses). Past the PnP share of the
// budget no new set starts once one pose exists.
std::vector<Hypothesis> RunPnpStage(const SolveContext& c, const Observation::SearchRegion& region,
                                    const std::vector<CorrespondenceSet>& sets, const std::vector<Feature>& query) {
  const SolverOptions& options = c.options;
  const Observation& observation = c.observation;
  const double projected_size_px = std::max(region.box.width, region.box.height);
  std::vector<Eigen::Vector2d> query_image_points(query.size());
  for (size_t i = 0; i < query.size(); ++i) {
    query_image_points[i] = query[i].xy.cast<double>() + Eigen::Vector2d::Constant(kOpenCvToImage);
  }
  const std::vector<Eigen::Vector3d> query_points_in_cam =
      BackprojectKeypoints(c.frame.camera, observation.depth, region.mask, query_image_points);
  PnpPrior prior;
  prior.z_m = region.z_m;
  prior.diameter_m = c.bank.diameter_m;
  prior.centre_in_object = c.bank.bounding_box.center();
  prior.query_points_in_cam = &query_points_in_cam;
  int tried = static_cast<int>(sets.size());
  for (int i = 1; i < tried; ++i) {
    if (sets[static_cast<size_t>(i)].quality < options.pnp_min_quality_ratio * sets.front().quality) tried = i;
  }
  std::vector<PnpResult> pnp(static_cast<size_t>(tried));
  std::atomic<bool> any_pose{false};
  c.executor->ParallelFor(tried, [&](int i) {
    if (any_pose && c.clock->OutOfTime(kPnpBudgetShare)) return;
    PnpResult& p = pnp[static_cast<size_t>(i)];
    EstimatePnp(options.pnp, sets[static_cast<size_t>(i)], c.frame.camera, projected_size_px, prior, &p);
    if (p.success) any_pose = true;
  });
  c.stages->sets_tried = tried;
  std::vector<Hypothesis> hypotheses;
  const double distinct_m = options.distinct_pose_fraction * c.bank.diameter_m;
  for (int i = 0; i < tried; ++i) {
    const PnpResult& p = pnp[static_cast<size_t>(i)];
    if (!p.success) continue;
    ++c.stages->pnp_hypotheses;
    c.stages->pnp_poses.push_back(p.cam_from_object);
    bool distinct = true;
    if (options.merge_pnp_poses) {
      for (size_t k = 0; k < hypotheses.size() && distinct; ++k) {
        distinct = !c.comparer.Within(p.cam_from_object, hypotheses[k].cam_from_object, distinct_m);
      }
    }
    if (distinct) hypotheses.push_back(Hypothesis{p.cam_from_object, i});
  }
  c.stages->pnp_merged = c.stages->pnp_hypotheses - static_cast<int>(hypotheses.size());
  return hypotheses;
}

// Stage 3: observable selection (eq. 7). Every hypothesis is rendered on the selection
// grid and ranked by E_obs; the first options.num_hypotheses distinct ones are kept.
std::vector<Hypothesis> SelectObservable(const SolveContext& c, const std::vector<Hypothesis>& hypotheses) {
  const SolverOptions& options = c.options;
  std::vector<PoseScore> observable(hypotheses.size());
  c.executor->ParallelFor(static_cast<int>(hypotheses.size()), [&](int i) {
    if (i > 0 && c.clock->OutOfTime(kObservableBudgetShare)) return;  // unscored: E_obs stays at its worst
    RasterImage scratch;
    observable[static_cast<size_t>(i)] = ScorePose(c.observation.selection_grid, *c.selection_mesh,
                                                   hypotheses[static_cast<size_t>(i)].cam_from_object,
                                                   c.observation.z_m, c.selection_score, &scratch);
  });
  std::vector<int> order(hypotheses.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return observable[static_cast<size_t>(a)].e_obs < observable[static_cast<size_t>(b)].e_obs;
  });
  // K slots for distinct poses: a hypothesis equal (modulo the symmetries) to a better
  // one already kept adds nothing (all distinct already when the PnP poses were merged).
  const double distinct_m = options.distinct_pose_fraction * c.bank.diameter_m;
  std::vector<Hypothesis> kept;
  // The PnP poses fill the K slots as in the paper; the point-pair-feature poses have slots
  // of their own beyond K (options.ppf_hypotheses, the best of them by E_obs), so that a
  // depth-voted pose never takes a textured object's PnP pose's place.
  // The outline's poses likewise (options.silhouette_hypotheses).
  int ppf_kept = 0, silhouette_kept = 0;
  for (int i : order) {
    const int source = hypotheses[static_cast<size_t>(i)].set_rank;
    if (source == kPpfSource || source == kSilhouetteSource) {
      int& taken = source == kPpfSource ? ppf_kept : silhouette_kept;
      if (taken >= (source == kPpfSource ? options.ppf_hypotheses : options.silhouette_hypotheses)) continue;
      ++taken;
      kept.push_back(hypotheses[static_cast<size_t>(i)]);
      if (kept.size() == 1) c.stages->best_e_obs = observable[static_cast<size_t>(i)].e_obs;
      continue;
    }
    if (static_cast<int>(kept.size()) - ppf_kept - silhouette_kept >= options.num_hypotheses) continue;
    if (!kept.empty() && c.clock->OutOfTime(kObservableBudgetShare)) break;
    const Hypothesis& h = hypotheses[static_cast<size_t>(i)];
    bool distinct = true;
    for (size_t k = 0; k < kept.size() && distinct && !options.merge_pnp_poses; ++k) {
      distinct = !c.comparer.Within(h.cam_from_object, kept[k].cam_from_object, distinct_m);
    }
    if (!distinct) continue;
    if (kept.empty()) c.stages->best_e_obs = observable[static_cast<size_t>(i)].e_obs;
    kept.push_back(h);
  }
  return kept;
}

// Stage 4: trimmed ICP on depth for every kept hypothesis. Coarse to fine: each runs to
// convergence on options.icp_coarse_points source points first (the long slides from a
// poor start cost a quarter), then on the full source from there. With
// options.icp_probe_iterations > 0, every hypothesis first gets only that many coarse
// iterations and is scored (S); only the options.icp_finish_hypotheses best by S go on.
// Hypotheses that ICP brings onto one pose (within options.icp_merge_fraction) are then
// merged into the one of lowest S: MHPO refines each pose once. (Not after the coarse
// pass: poses one there can part in the fine pass; merged there, the foam brick's AR fell
// from 0.649 to 0.530.) Returns each remaining hypothesis' score after ICP; refines the
// poses in place and drops the merged ones from *kept.
std::vector<PoseScore> RefineHypothesesByIcp(const SolveContext& c, std::vector<Hypothesis>* kept) {
  const SolverOptions& options = c.options;
  const size_t n = kept->size();
  std::vector<PoseScore> scores(n);
  std::vector<int> iterations(n, 0), converged(n, 0), unfinished(n, 0), at_max(n, 0);
  // One ICP run of at most `max_iterations` on a source of at most `max_points`.
  auto run_icp = [&](size_t k, int max_points, int max_iterations, RasterImage* scratch) {
    const IcpReport report = RunIcpFrom(options, c.bank.online_mesh, c.observation.refine_grid, c.online_score,
                                        *c.observation.observed, c.bank.diameter_m, max_points, max_iterations,
                                        scratch, &(*kept)[k].cam_from_object);
    iterations[k] += report.iterations;
    converged[k] = report.success;
    unfinished[k] = report.success && report.iterations >= max_iterations;
    at_max[k] += unfinished[k];
  };
  const bool coarse = options.icp_coarse_points > 0 && options.icp_coarse_points < options.max_source_points;
  // Coarse (unless `probe_only`, to convergence), fine, then S.
  auto refine = [&](size_t k, bool probe_only) {
    RasterImage scratch;
    if (options.run_icp) {
      if (probe_only) {
        run_icp(k, coarse ? options.icp_coarse_points : options.max_source_points, options.icp_probe_iterations, &scratch);
      } else {
        if (coarse) run_icp(k, options.icp_coarse_points, options.icp.max_iterations, &scratch);
        run_icp(k, options.max_source_points, options.icp.max_iterations, &scratch);
      }
    }
    scores[k] = ScorePose(c.observation.refine_grid, c.bank.online_mesh, (*kept)[k].cam_from_object, c.observation.z_m,
                          c.online_score, &scratch);
  };
  const bool two_pass = options.run_icp && options.icp_probe_iterations > 0;
  c.executor->ParallelFor(static_cast<int>(n), [&](int k) {
    if (k > 0 && c.clock->OutOfTime(kIcpBudgetShare)) return;  // not refined, not scored: S stays at its worst
    refine(static_cast<size_t>(k), two_pass);
  });
  if (two_pass) {
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return scores[static_cast<size_t>(a)].s < scores[static_cast<size_t>(b)].s;
    });
    std::vector<size_t> finish;
    for (int k : order) {
      if (finish.size() >= static_cast<size_t>(options.icp_finish_hypotheses)) break;
      if (unfinished[static_cast<size_t>(k)]) finish.push_back(static_cast<size_t>(k));
    }
    c.executor->ParallelFor(static_cast<int>(finish.size()), [&](int i) {
      if (c.clock->OutOfTime(kIcpBudgetShare)) return;
      refine(finish[static_cast<size_t>(i)], false);
    });
    c.stages->icp_finished = static_cast<int>(finish.size());
  }
  for (size_t k = 0; k < n; ++k) {
    c.stages->icp_converged += converged[k];
    c.stages->icp_iterations += iterations[k];
    c.stages->icp_runs_at_max += at_max[k];
  }
  const double same_m = options.icp_merge_fraction * c.bank.diameter_m;
  if (!options.run_icp || !(same_m > 0.0)) return scores;
  // Best S first, each pose kept unless within same_m of one kept before it. Plain
  // distance, no symmetry: a pose and its twin under a symmetry of the shape are both
  // refined (MHPO, then appearance and the runner-up tell them apart).
  const PoseComparer same_pose(MeshSymmetries{}, c.comparer.points());
  std::vector<size_t> by_score(n);
  std::iota(by_score.begin(), by_score.end(), size_t{0});
  std::stable_sort(by_score.begin(), by_score.end(), [&](size_t a, size_t b) { return scores[a].s < scores[b].s; });
  std::vector<size_t> distinct;
  std::vector<char> keep(n, 0);
  for (size_t k : by_score) {
    bool same = false;
    for (size_t j = 0; j < distinct.size() && !same; ++j) {
      same = same_pose.Within((*kept)[k].cam_from_object, (*kept)[distinct[j]].cam_from_object, same_m);
    }
    if (same) continue;
    distinct.push_back(k);
    keep[k] = 1;
  }
  c.stages->icp_merged += static_cast<int>(n - distinct.size());
  if (distinct.size() == n) return scores;
  // The rest in their rank order.
  std::vector<Hypothesis> kept_distinct;
  std::vector<PoseScore> scores_distinct;
  for (size_t k = 0; k < n; ++k) {
    if (!keep[k]) continue;
    kept_distinct.push_back((*kept)[k]);
    scores_distinct.push_back(scores[k]);
  }
  kept->swap(kept_distinct);
  return scores_distinct;
}

// Stages 1 and 2 on one search region: ORB on its normalized crop, template matching
// (correspondence sets ranked by Q_j), MSAC-PnP per set with equal poses merged. The sets
// are appended to search->sets and the hypotheses (their ranks into it) to `hypotheses`.
// Returns an empty string, or why this region gave no set.
std::string SearchOneRegion(const SolveContext& c, const Observation::SearchRegion& region, Search* search,
                         std::vector<Hypothesis>* hypotheses) {
  StageReport& stages = *c.stages;
  Stopwatch watch;
  const NormalizedCrop crop = NormalizeCrop(c.frame.rgb, region.mask, c.bank.options.crop);
  const std::vector<Feature> query = DetectOrb(crop, c.options.query_orb);
  stages.query_features += static_cast<int>(query.size());
  stages.features_ms += watch.ElapsedMs();
  watch.Restart();
  std::vector<CorrespondenceSet> sets;
  MatchReport match_report;
  MatchTemplates(c.options.match, query, c.bank, c.executor, &sets, &match_report);
  stages.match_ms += watch.ElapsedMs();
  stages.correspondence_sets += static_cast<int>(sets.size());
  stages.best_quality = std::max(stages.best_quality, match_report.best_quality);
  if (!match_report.success) return "matching: " + match_report.message;
  if (search->sets.empty()) {
    // Template seed: the best template's rotation, translated onto the region centre at z_M.
    const Template& best = c.bank.templates[static_cast<size_t>(sets.front().template_index)];
    const Eigen::Vector2d centre(region.box.x + 0.5 * region.box.width, region.box.y + 0.5 * region.box.height);
    stages.seed_pose.linear() = best.cam_from_object.linear();
    stages.seed_pose.translation() =
        c.frame.camera.Backproject(centre, region.z_m) - best.cam_from_object.linear() * c.bank.bounding_box.center();
  }
  watch.Restart();
  const int tried_before = stages.sets_tried;
  *hypotheses = RunPnpStage(c, region, sets, query);
  stages.sets_tried += tried_before;
  const int offset = static_cast<int>(search->sets.size());
  for (Hypothesis& h : *hypotheses) h.set_rank += offset;
  search->sets.insert(search->sets.end(), sets.begin(), sets.end());
  stages.pnp_ms += watch.ElapsedMs();
  return "";
}

}  // namespace

std::string RunSearchStages(const SolveContext& c, Search* search) {
  StageReport& stages = *c.stages;
  std::string why_not;
  const double distinct_m = c.options.distinct_pose_fraction * c.bank.diameter_m;
  for (const Observation::SearchRegion& region : c.observation.search_regions) {
    if (!search->hypotheses.empty() && c.clock->OutOfTime(kPnpBudgetShare)) break;
    std::vector<Hypothesis> found;
    const std::string why = SearchOneRegion(c, region, search, &found);
    if (why_not.empty()) why_not = why;
    for (const Hypothesis& h : found) {
      bool distinct = true;
      for (size_t k = 0; k < search->hypotheses.size() && distinct && c.options.merge_pnp_poses; ++k) {
        distinct = !c.comparer.Within(h.cam_from_object, search->hypotheses[k].cam_from_object, distinct_m);
      }
      if (distinct) search->hypotheses.push_back(h);
    }
    ++stages.search_regions;
  }
  if (search->sets.empty()) return why_not;
  if (search->hypotheses.empty()) {
    return "MSAC-PnP found no valid pose in " + std::to_string(stages.sets_tried) + " correspondence sets";
  }
  stages.pnp_pose = search->hypotheses.front().cam_from_object;  // from the best-ranked template with a valid pose
  return "";
}

namespace {

// False when merging is on and `pose` equals (modulo the symmetries) one of the first
// `count` hypotheses of the search: a later source adds only poses the earlier ones lack.
bool DistinctFromFirst(const SolveContext& c, const Search& search, size_t count, const Eigen::Isometry3d& pose,
                       double distinct_m) {
  if (!c.options.merge_pnp_poses) return true;
  for (size_t k = 0; k < count; ++k) {
    if (c.comparer.Within(pose, search.hypotheses[k].cam_from_object, distinct_m)) return false;
  }
  return true;
}

}  // namespace

void RunPpfStage(const SolveContext& c, Search* search) {
  StageReport& stages = *c.stages;
  const Stopwatch watch;  // the agreement count too: it is this stage's decision (p95 7 ms on synth_dev)
  // How many PnP poses agree on each distinct one: enough of them, and the texture gives the pose.
  const double agree_m = c.options.distinct_pose_fraction * c.bank.diameter_m;
  for (const Hypothesis& hypothesis : search->hypotheses) {
    int agree = 0;
    for (const Eigen::Isometry3d& pose : stages.pnp_poses) agree += c.comparer.Within(pose, hypothesis.cam_from_object, agree_m);
    stages.pnp_agreement = std::max(stages.pnp_agreement, agree);
  }
  stages.ppf_ms = watch.ElapsedMs();
  if (!c.options.use_ppf || c.bank.ppf.empty() || c.observation.search_regions.empty()) return;
  if (!search->hypotheses.empty() && c.clock->OutOfTime(kPnpBudgetShare)) return;
  if (c.options.ppf_skip_agreement > 0 && stages.pnp_agreement >= c.options.ppf_skip_agreement) {
    stages.ppf_skipped = true;
    return;
  }
  const PpfModel& model = c.bank.ppf;
  const PpfScene scene = MakePpfScene(c.frame.camera, c.observation.depth, c.observation.search_regions.front().mask,
                                      model.step_m, model.options.normal_cluster_deg, c.options.ppf);
  PpfReport report;
  const std::vector<PpfPose> poses = VotePpfPoses(model, scene, c.bank.diameter_m, c.options.ppf, c.executor, &report);
  stages.ppf_scene_points = report.scene_points;
  stages.ppf_hypotheses = static_cast<int>(poses.size());
  const double distinct_m = c.options.distinct_pose_fraction * c.bank.diameter_m;
  const size_t pnp_count = search->hypotheses.size();
  for (const PpfPose& pose : poses) {
    stages.ppf_poses.push_back(pose.cam_from_object);
    if (!DistinctFromFirst(c, *search, pnp_count, pose.cam_from_object, distinct_m)) continue;
    search->hypotheses.push_back(Hypothesis{pose.cam_from_object, kPpfSource});
    ++stages.ppf_distinct;
  }
  stages.ppf_ms = watch.ElapsedMs();
}

namespace {

// The outline's distance comes from its area, which an occluder shrinks: where the mask has
// depth, the pose is moved along its viewing ray so that its rendered surface lies on the
// observed one (the median difference over the mask's pixels with both), keeping the
// object's place in the image. A pose left behind the surface would see every depth pixel
// as an occluder and never be pulled onto it (score.h: occluded pixels count for nothing).
Eigen::Isometry3d OntoObservedDepth(const SolveContext& c, const Eigen::Isometry3d& cam_from_object,
                                    RasterImage* scratch) {
  constexpr int kMinPixels = 10;
  const EvaluationGrid& grid = c.observation.selection_grid;
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  raster_options.cull_backfaces = c.selection_score.cull_backfaces;
  Rasterize(*c.selection_mesh, grid.camera, cam_from_object, raster_options, scratch);
  std::vector<float> differences;
  for (int v = 0; v < grid.mask.rows; ++v) {
    const uint8_t* m = grid.mask.ptr<uint8_t>(v);
    const float* d = grid.depth.ptr<float>(v);
    const float* r = scratch->depth.ptr<float>(v);
    for (int u = 0; u < grid.mask.cols; ++u) {
      if (m[u] != 0 && d[u] > 0.0f && r[u] > 0.0f) differences.push_back(d[u] - r[u]);
    }
  }
  if (static_cast<int>(differences.size()) < kMinPixels) return cam_from_object;
  const auto middle = differences.begin() + static_cast<std::ptrdiff_t>(differences.size() / 2);
  std::nth_element(differences.begin(), middle, differences.end());
  const Eigen::Vector3d centre = cam_from_object * c.bank.bounding_box.center();
  if (centre.z() <= 0.0) return cam_from_object;
  const double ratio = (centre.z() + *middle) / centre.z();
  if (!(ratio > 0.2 && ratio < 5.0)) return cam_from_object;
  Eigen::Isometry3d moved = cam_from_object;
  moved.translation() += (ratio - 1.0) * centre;
  return moved;
}

}  // namespace

void RunSilhouetteStage(const SolveContext& c, Search* search) {
  const Observation& observation = c.observation;
  if (!c.options.use_silhouettes || c.options.silhouette_hypotheses == 0 || observation.is_box ||
      observation.wider_than_object) {
    return;
  }
  if (!search->hypotheses.empty() && c.clock->OutOfTime(kPnpBudgetShare)) return;
  StageReport& stages = *c.stages;
  // The texture already gives the pose (RunPpfStage counted the agreeing PnP poses).
  if (c.options.silhouette_skip_agreement > 0 && stages.pnp_agreement >= c.options.silhouette_skip_agreement) {
    stages.silhouette_skipped = true;
    return;
  }
  const Stopwatch watch;
  const double distinct_m = c.options.distinct_pose_fraction * c.bank.diameter_m;
  const SamePose same = [&](const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
    return c.comparer.Within(a, b, distinct_m);
  };
  // The outline: the mask with what the depth grew it by over the object it missed (a cut
  // mask's lost part comes back where the depth continues the object).
  cv::Mat outline = observation.mask;
  if (!observation.search_regions.empty()) outline = observation.mask | observation.search_regions.front().mask;
  const std::vector<SilhouettePose> poses =
      SilhouettePoses(c.bank, c.frame.camera, outline, c.options.silhouette, same);
  stages.silhouette_hypotheses = static_cast<int>(poses.size());
  const size_t earlier = search->hypotheses.size();
  RasterImage scratch;
  for (const SilhouettePose& pose : poses) {
    const Eigen::Isometry3d cam_from_object = OntoObservedDepth(c, pose.cam_from_object, &scratch);
    if (!DistinctFromFirst(c, *search, earlier, cam_from_object, distinct_m)) continue;
    search->hypotheses.push_back(Hypothesis{cam_from_object, kSilhouetteSource});
    ++stages.silhouette_distinct;
  }
  stages.silhouette_ms = watch.ElapsedMs();
}

std::vector<Hypothesis> RunObservableStage(const SolveContext& c, const std::vector<Hypothesis>& hypotheses) {
  const Stopwatch watch;
  std::vector<Hypothesis> kept = SelectObservable(c, hypotheses);
  c.stages->kept_hypotheses = static_cast<int>(kept.size());
  c.stages->observable_pose = kept.front().cam_from_object;
  for (const Hypothesis& h : kept) c.stages->kept_poses.push_back(h.cam_from_object);
  c.stages->observable_ms = watch.ElapsedMs();
  return kept;
}

IcpOutcome RunIcpStage(const SolveContext& c, std::vector<Hypothesis>* kept) {
  const Stopwatch watch;
  IcpOutcome outcome;
  outcome.scores = RefineHypothesesByIcp(c, kept);
  for (const Hypothesis& h : *kept) outcome.refined.push_back(h.cam_from_object);
  for (size_t k = 0; k < kept->size(); ++k) {
    if (outcome.scores[k].s < outcome.scores[static_cast<size_t>(outcome.best)].s) outcome.best = static_cast<int>(k);
  }
  c.stages->best_s_after_icp = outcome.scores[static_cast<size_t>(outcome.best)].s;
  c.stages->icp_pose = outcome.refined[static_cast<size_t>(outcome.best)];
  c.stages->icp_ms = watch.ElapsedMs();
  return outcome;
}

std::vector<Finalist> RunMhpoStage(const SolveContext& c, const MhpoTarget& target, const std::vector<Hypothesis>& kept,
                                   const IcpOutcome& icp, PoseResult* result) {
  const SolverOptions& options = c.options;
  StageReport& stages = *c.stages;
  const Stopwatch watch;
  result->cam_from_object = stages.icp_pose;
  result->details = icp.scores[static_cast<size_t>(icp.best)];
  stages.answer_hypothesis = icp.best;
  result->termination = Termination::kConverged;
  if (options.run_mhpo && !c.clock->OutOfTime()) {
    Eigen::Isometry3d best;
    RefineByMhpo(options.mhpo, c.online_score, target, c.bank.online_mesh, icp.refined, c.executor, &best, &stages.mhpo,
                 &c.clock->deadline(), &icp.scores);
    if (stages.mhpo.cut_short) c.clock->MarkSkipped();
    if (stages.mhpo.success && stages.mhpo.best_score.s <= result->details.s) {
      result->cam_from_object = best;
      result->details = stages.mhpo.best_score;
      stages.answer_hypothesis = stages.mhpo.best_hypothesis;
    }
    if (stages.mhpo.early_stopped) result->termination = Termination::kEarlyStopped;
  }
  stages.mhpo_ms = watch.ElapsedMs();
  std::vector<Finalist> finalists;
  for (size_t k = 0; k < kept.size(); ++k) {
    const bool mhpo_ran = options.run_mhpo && stages.mhpo.success && k < stages.mhpo.hypotheses.size();
    finalists.push_back(mhpo_ran ? Finalist{stages.mhpo.hypotheses[k].best_cam_from_object, stages.mhpo.hypotheses[k].best_score, static_cast<int>(k)}
                                 : Finalist{icp.refined[k], icp.scores[k], static_cast<int>(k)});
  }
  return finalists;
}

void RunPostRefineStage(const SolveContext& c, const MhpoTarget& target, PoseResult* result) {
  const SolverOptions& options = c.options;
  const Observation& observation = c.observation;
  if (!options.post_refine || !(result->details.s > options.post_refine_trigger_s) || c.clock->OutOfTime()) return;
  StageReport& stages = *c.stages;
  const Stopwatch watch;
  stages.post_refine_ran = true;
  std::vector<Eigen::Isometry3d> extra =
      PostRefineHypotheses(result->cam_from_object, c.bank, c.frame.camera, observation.box, observation.z_m);
  c.executor->ParallelFor(static_cast<int>(extra.size()), [&](int k) {
    RasterImage scratch;
    RunIcpFrom(options, c.bank.online_mesh, observation.refine_grid, c.online_score, *observation.observed,
               c.bank.diameter_m, options.max_source_points, options.icp.max_iterations, &scratch,
               &extra[static_cast<size_t>(k)]);
  });
  Eigen::Isometry3d best;
  MhpoReport report;
  RefineByMhpo(options.mhpo, c.online_score, target, c.bank.online_mesh, extra, c.executor, &best, &report);
  if (report.success && report.best_score.s < result->details.s - options.post_refine_margin) {
    result->cam_from_object = best;
    result->details = report.best_score;
    stages.post_refine_accepted = true;
    stages.answer_hypothesis = -1;
  }
  stages.post_refine_ms = watch.ElapsedMs();
}

}  // namespace g6d
