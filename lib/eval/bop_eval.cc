#include "eval/bop_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <tuple>
#include <utility>

#include "core/error.h"
#include "core/timer.h"
#include "mesh/mesh.h"
#include "render/raster.h"

namespace g6d {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Everything the errors need about one object, loaded once.
struct ObjectModel {
  const BopObjectInfo* info = nullptr;
  Mesh mesh;                                  // full model, metres: VSD rendering
  std::vector<Eigen::Vector3f> points;        // all vertices: MSSD, MSPD
  std::vector<Eigen::Vector3f> add_points;    // every k-th vertex: ADD(-S)
  std::vector<Eigen::Isometry3d> symmetries;  // identity first
  bool uses_adds = false;
};

// One image with its target objects (obj_id -> inst_count, ascending obj_id).
struct ImageTargets {
  int scene_id = 0;
  int im_id = 0;
  std::map<int, int> inst_counts;
};

// Sizes a tally for the option lists.
BopRecall EmptyRecall(const BopEvalOptions& options) {
  BopRecall recall;
  recall.vsd_correct.assign(options.vsd.taus.size(),
                            std::vector<int>(options.vsd_thresholds.size(), 0));
  recall.mssd_correct.assign(options.mssd_thresholds.size(), 0);
  recall.mspd_correct.assign(options.mspd_thresholds_px.size(), 0);
  return recall;
}

void AddCounts(const BopRecall& from, BopRecall* to) {
  to->targets += from.targets;
  to->with_estimate += from.with_estimate;
  to->add_correct += from.add_correct;
  for (size_t t = 0; t < from.vsd_correct.size(); ++t) {
    for (size_t k = 0; k < from.vsd_correct[t].size(); ++k) {
      to->vsd_correct[t][k] += from.vsd_correct[t][k];
    }
  }
  for (size_t k = 0; k < from.mssd_correct.size(); ++k) to->mssd_correct[k] += from.mssd_correct[k];
  for (size_t k = 0; k < from.mspd_correct.size(); ++k) to->mspd_correct[k] += from.mspd_correct[k];
}

// score.calc_recall: 0 when there are no targets.
double Recall(int correct, int targets) {
  return targets > 0 ? static_cast<double>(correct) / targets : 0.0;
}

// eval_bop19_pose.py: the average recall of an error kind is the mean of the recalls over
// all its (tau,) threshold settings; AR is the mean of the three.
void FinishRecall(BopRecall* recall) {
  recall->add_recall = Recall(recall->add_correct, recall->targets);
  double sum = 0.0;
  int count = 0;
  for (const std::vector<int>& per_threshold : recall->vsd_correct) {
    for (int correct : per_threshold) {
      sum += Recall(correct, recall->targets);
      ++count;
    }
  }
  recall->ar_vsd = count > 0 ? sum / count : 0.0;
  auto mean = [&](const std::vector<int>& correct) {
    double total = 0.0;
    for (int c : correct) total += Recall(c, recall->targets);
    return correct.empty() ? 0.0 : total / static_cast<double>(correct.size());
  };
  recall->ar_mssd = mean(recall->mssd_correct);
  recall->ar_mspd = mean(recall->mspd_correct);
  recall->ar = (recall->ar_vsd + recall->ar_mssd + recall->ar_mspd) / 3.0;
}

// bop_toolkit pose_matching.match_poses: estimates (rows, already in decreasing score
// order) are matched greedily, each to the not yet matched GT (columns, in scene_gt order)
// with the smallest error below `threshold`; on equal errors the first GT wins, as in
// BOP's strict `<`. Returns, per GT, whether it was matched.
std::vector<bool> GreedyMatch(const std::vector<std::vector<double>>& errors, double threshold,
                              size_t gt_count) {
  std::vector<bool> matched(gt_count, false);
  for (const std::vector<double>& row : errors) {
    int best = -1;
    double best_error = threshold;
    for (size_t g = 0; g < gt_count; ++g) {
      if (!matched[g] && row[g] < best_error) {
        best = static_cast<int>(g);
        best_error = row[g];
      }
    }
    if (best >= 0) matched[best] = true;
  }
  return matched;
}

int CountMatches(const std::vector<std::vector<double>>& errors, double threshold,
                 size_t gt_count) {
  const std::vector<bool> matched = GreedyMatch(errors, threshold, gt_count);
  return static_cast<int>(std::count(matched.begin(), matched.end(), true));
}

// `factor` times every entry (BOP's MSPD normalization by the image width).
std::vector<std::vector<double>> Scaled(std::vector<std::vector<double>> errors, double factor) {
  for (auto& row : errors) {
    for (double& e : row) e *= factor;
  }
  return errors;
}

// Every entry divided by `divisor` (BOP's MSSD normalization by the diameter).
std::vector<std::vector<double>> Divided(std::vector<std::vector<double>> errors, double divisor) {
  for (auto& row : errors) {
    for (double& e : row) e /= divisor;
  }
  return errors;
}

ObjectModel LoadObjectModel(const BopObjectInfo& info, const BopEvalOptions& options) {
  ObjectModel model;
  model.info = &info;
  model.mesh = LoadMesh(info.mesh_path, info.mesh_units);
  if (model.mesh.vertices.empty()) G6D_THROW("mesh " << info.mesh_path << " has no vertices");
  model.points = model.mesh.vertices;
  // The subsampling of bench/bench_dataset_main.cc, so both tools agree on ADD(-S).
  const size_t step =
      std::max<size_t>(1, model.mesh.vertices.size() / static_cast<size_t>(options.add_max_points));
  for (size_t i = 0; i < model.mesh.vertices.size(); i += step) {
    model.add_points.push_back(model.mesh.vertices[i]);
  }
  model.symmetries = info.Symmetries(options.max_symmetry_discretization_step);
  model.uses_adds =
      info.IsSymmetric() || std::find(options.adds_obj_ids.begin(), options.adds_obj_ids.end(),
                                      info.obj_id) != options.adds_obj_ids.end();
  return model;
}

// Result of one image: a tally per target object and the per-target details.
struct ImageResult {
  std::map<int, BopRecall> per_object;
  std::vector<BopTargetReport> targets;
  int evaluated = 0;
  int beyond_count = 0;
};

// Estimates of one (scene, image, object): indices into the estimate list, file order.
using EstimateIndex = std::map<std::tuple<int, int, int>, std::vector<int>>;

ImageResult EvaluateImage(const ImageTargets& image, const BopScene& scene,
                          const std::map<int, ObjectModel>& models,
                          const std::vector<BopEstimate>& estimates,
                          const EstimateIndex& estimate_index, const BopEvalOptions& options) {
  ImageResult result;
  const BopFrame& frame = scene.Frame(image.im_id);
  const cv::Mat test_depth_m = LoadBopDepth(scene, image.im_id);
  // The depth image defines the rendering size (camera.json may be absent).
  Camera camera = frame.camera;
  camera.width = test_depth_m.cols;
  camera.height = test_depth_m.rows;
  const std::string camera_problem = camera.Check();
  if (!camera_problem.empty()) {
    G6D_THROW("scene " << scene.scene_id << " image " << image.im_id << ": " << camera_problem);
  }
  const double mspd_scale = options.mspd_reference_width_px / camera.width;
  RasterOptions raster_options;
  raster_options.want_face_id = false;

  for (const auto& [obj_id, inst_count] : image.inst_counts) {
    const ObjectModel& model = models.at(obj_id);
    const double diameter_m = model.info->diameter_m;
    BopRecall tally = EmptyRecall(options);

    // Valid GT (eval_calc_scores.py with visib_gt_min = -1): the inst_count instances of
    // the object with the largest visib_fract; matching walks them in scene_gt order (BOP
    // iterates its error dict by gt_id).
    const std::vector<int> valid_gt = TargetGtIndices(frame, obj_id, inst_count);
    auto visib = [&](int g) { return frame.gt[g].info ? frame.gt[g].info->visib_fract : 1.0; };

    // Kept estimates (eval_calc_errors.py, n_top = -1): stable sort by decreasing score,
    // the first inst_count.
    std::vector<int> kept;
    const auto found = estimate_index.find({scene.scene_id, image.im_id, obj_id});
    if (found != estimate_index.end()) kept = found->second;
    std::stable_sort(kept.begin(), kept.end(),
                     [&](int a, int b) { return estimates[a].score > estimates[b].score; });
    const size_t keep = std::min<size_t>(kept.size(), std::max(0, inst_count));
    result.beyond_count += static_cast<int>(kept.size() - keep);
    kept.resize(keep);
    result.evaluated += static_cast<int>(kept.size());

    const size_t gt_count = valid_gt.size();
    const size_t taus = options.vsd.taus.size();
    std::vector<std::vector<double>> add(kept.size(), std::vector<double>(gt_count));
    std::vector<std::vector<double>> mssd = add, mspd = add;
    // vsd[tau][estimate][gt]
    std::vector<std::vector<std::vector<double>>> vsd(taus, add);

    std::vector<std::optional<RasterImage>> gt_renders(gt_count);
    for (size_t e = 0; e < kept.size(); ++e) {
      const Eigen::Isometry3d& estimate = estimates[kept[e]].cam_from_object;
      std::optional<RasterImage> estimate_render;
      for (size_t g = 0; g < gt_count; ++g) {
        const Eigen::Isometry3d& gt = frame.gt[valid_gt[g]].cam_from_object;
        add[e][g] = model.uses_adds ? ComputeAdds(estimate, gt, model.add_points)
                                    : ComputeAdd(estimate, gt, model.add_points);
        // eval_calc_errors.py: MSSD is infinite when the bounding spheres do not overlap.
        const bool spheres_overlap =
            (estimate.translation() - gt.translation()).norm() < diameter_m;
        mssd[e][g] =
            spheres_overlap ? ComputeMssd(estimate, gt, model.points, model.symmetries) : kInfinity;
        mspd[e][g] = ComputeMspd(estimate, gt, camera, model.points, model.symmetries);
        // ... and VSD is 1 when the projections of the bounding spheres cannot overlap.
        if (!SphereProjectionsOverlap(0.5 * diameter_m, estimate.translation(), gt.translation())) {
          for (size_t t = 0; t < taus; ++t) vsd[t][e][g] = 1.0;
          continue;
        }
        if (!estimate_render) {
          estimate_render.emplace();
          Rasterize(model.mesh, camera, estimate, raster_options, &*estimate_render);
        }
        if (!gt_renders[g]) {
          gt_renders[g].emplace();
          Rasterize(model.mesh, camera, gt, raster_options, &*gt_renders[g]);
        }
        const std::vector<double> errors =
            ComputeVsdFromDepth(estimate_render->depth, gt_renders[g]->depth, test_depth_m, camera,
                                diameter_m, options.vsd);
        for (size_t t = 0; t < taus; ++t) vsd[t][e][g] = errors[t];
      }
    }

    tally.targets = static_cast<int>(gt_count);
    tally.with_estimate = kept.empty() ? 0 : static_cast<int>(gt_count);
    // ADD(-S) is compared with add_threshold * diameter exactly as IsAddCorrect() (and so
    // g6d-bench-dataset) does, not normalized first.
    const std::vector<bool> add_matched =
        GreedyMatch(add, options.add_threshold * diameter_m, gt_count);
    tally.add_correct = static_cast<int>(std::count(add_matched.begin(), add_matched.end(), true));
    for (size_t t = 0; t < taus; ++t) {
      for (size_t k = 0; k < options.vsd_thresholds.size(); ++k) {
        tally.vsd_correct[t][k] = CountMatches(vsd[t], options.vsd_thresholds[k], gt_count);
      }
    }
    const auto mssd_relative = Divided(mssd, diameter_m);
    for (size_t k = 0; k < options.mssd_thresholds.size(); ++k) {
      tally.mssd_correct[k] = CountMatches(mssd_relative, options.mssd_thresholds[k], gt_count);
    }
    const auto mspd_scaled = Scaled(mspd, mspd_scale);
    for (size_t k = 0; k < options.mspd_thresholds_px.size(); ++k) {
      tally.mspd_correct[k] = CountMatches(mspd_scaled, options.mspd_thresholds_px[k], gt_count);
    }
    result.per_object.emplace(obj_id, std::move(tally));

    for (size_t g = 0; g < gt_count; ++g) {
      BopTargetReport target;
      target.scene_id = scene.scene_id;
      target.im_id = image.im_id;
      target.obj_id = obj_id;
      target.gt_idx = valid_gt[g];
      target.visib_fract = visib(valid_gt[g]);
      target.estimates = static_cast<int>(kept.size());
      target.add_m = target.mssd_m = target.mspd_px = target.vsd_mean = kInfinity;
      for (size_t e = 0; e < kept.size(); ++e) {
        target.add_m = std::min(target.add_m, add[e][g]);
        target.mssd_m = std::min(target.mssd_m, mssd[e][g]);
        target.mspd_px = std::min(target.mspd_px, mspd[e][g]);
        double vsd_sum = 0.0;
        for (size_t t = 0; t < taus; ++t) vsd_sum += vsd[t][e][g];
        target.vsd_mean = std::min(target.vsd_mean, vsd_sum / static_cast<double>(taus));
      }
      target.add_correct = add_matched[g];
      result.targets.push_back(target);
    }
  }
  return result;
}

std::string CheckThresholds(const std::vector<double>& values, const char* name) {
  if (values.empty()) return std::string("BopEvalOptions.") + name + " is empty";
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i]) || values[i] <= 0.0) {
      return std::string("BopEvalOptions.") + name + "[" + std::to_string(i) +
             "] must be finite and > 0 (got " + std::to_string(values[i]) + ")";
    }
  }
  return "";
}

}  // namespace

std::vector<double> BopMspdThresholdsPx() {
  std::vector<double> thresholds;
  for (int px = 5; px <= 50; px += 5) thresholds.push_back(px);
  return thresholds;
}

std::string BopEvalOptions::Check() const {
  const std::string vsd_problem = vsd.Check();
  if (!vsd_problem.empty()) return "BopEvalOptions.vsd: " + vsd_problem;
  for (const auto& [values, name] :
       {std::pair<const std::vector<double>*, const char*>{&vsd_thresholds, "vsd_thresholds"},
        {&mssd_thresholds, "mssd_thresholds"},
        {&mspd_thresholds_px, "mspd_thresholds_px"}}) {
    const std::string problem = CheckThresholds(*values, name);
    if (!problem.empty()) return problem;
  }
  if (!std::isfinite(mspd_reference_width_px) || mspd_reference_width_px <= 0.0) {
    return "BopEvalOptions.mspd_reference_width_px must be finite and > 0 (got " +
           std::to_string(mspd_reference_width_px) + ")";
  }
  if (!std::isfinite(add_threshold) || add_threshold <= 0.0) {
    return "BopEvalOptions.add_threshold must be finite and > 0 (got " +
           std::to_string(add_threshold) + ")";
  }
  if (add_max_points < 1) {
    return "BopEvalOptions.add_max_points must be >= 1 (got " + std::to_string(add_max_points) +
           ")";
  }
  if (!(max_symmetry_discretization_step > 0.0 && max_symmetry_discretization_step <= 1.0)) {
    return "BopEvalOptions.max_symmetry_discretization_step must be in (0, 1] (got " +
           std::to_string(max_symmetry_discretization_step) + ")";
  }
  return "";
}

BopEvalReport EvaluateBop(const BopDataset& dataset, const std::vector<BopTarget>& targets,
                          const std::vector<BopEstimate>& estimates, const BopEvalOptions& options,
                          Executor* executor) {
  const Stopwatch total_watch;
  const std::string problem = options.Check();
  if (!problem.empty()) G6D_THROW("EvaluateBop: " << problem);
  InlineExecutor inline_executor;
  if (executor == nullptr) executor = &inline_executor;

  BopEvalReport report;
  report.vsd_taus = options.vsd.taus;
  report.vsd_thresholds = options.vsd_thresholds;
  report.mssd_thresholds = options.mssd_thresholds;
  report.mspd_thresholds_px = options.mspd_thresholds_px;
  report.num_target_entries = static_cast<int>(targets.size());
  report.num_estimates = static_cast<int>(estimates.size());
  report.overall = EmptyRecall(options);

  // Targets by image. As bop_toolkit's dict, a repeated (scene, image, object) keeps the
  // last inst_count.
  std::map<std::pair<int, int>, ImageTargets> images;
  for (size_t i = 0; i < targets.size(); ++i) {
    const BopTarget& target = targets[i];
    if (!dataset.objects.count(target.obj_id)) {
      G6D_THROW("target " << i << " (scene " << target.scene_id << ", image " << target.im_id
                          << "): object " << target.obj_id << " is not in " << dataset.root
                          << "/models/models_info.json");
    }
    ImageTargets& image = images[{target.scene_id, target.im_id}];
    image.scene_id = target.scene_id;
    image.im_id = target.im_id;
    image.inst_counts[target.obj_id] = target.inst_count;
  }
  report.num_images = static_cast<int>(images.size());

  EstimateIndex estimate_index;
  for (size_t i = 0; i < estimates.size(); ++i) {
    const BopEstimate& estimate = estimates[i];
    if (!dataset.objects.count(estimate.obj_id)) {
      G6D_THROW("estimate " << i << " (scene " << estimate.scene_id << ", image " << estimate.im_id
                            << "): object " << estimate.obj_id << " is not in " << dataset.root
                            << "/models/models_info.json");
    }
    const auto image = images.find({estimate.scene_id, estimate.im_id});
    if (image == images.end() || !image->second.inst_counts.count(estimate.obj_id)) {
      ++report.num_estimates_ignored;
      continue;
    }
    estimate_index[{estimate.scene_id, estimate.im_id, estimate.obj_id}].push_back(
        static_cast<int>(i));
  }

  if (images.empty()) {
    report.message = "no targets to evaluate";
    report.total_ms = total_watch.ElapsedMs();
    return report;
  }

  // Scenes and object models (each mesh loaded once, in parallel).
  const Stopwatch load_watch;
  std::map<int, BopScene> scenes;
  std::set<int> obj_ids;
  for (const auto& [key, image] : images) {
    if (!scenes.count(image.scene_id)) {
      scenes.emplace(image.scene_id, LoadBopScene(dataset.root, image.scene_id, dataset.split));
    }
    for (const auto& [obj_id, count] : image.inst_counts) obj_ids.insert(obj_id);
  }
  const std::vector<int> object_list(obj_ids.begin(), obj_ids.end());
  std::vector<ObjectModel> loaded(object_list.size());
  executor->ParallelFor(static_cast<int>(object_list.size()), [&](int i) {
    loaded[i] = LoadObjectModel(dataset.Object(object_list[i]), options);
  });
  std::map<int, ObjectModel> models;
  for (size_t i = 0; i < object_list.size(); ++i) {
    models.emplace(object_list[i], std::move(loaded[i]));
  }
  report.load_ms = load_watch.ElapsedMs();

  // Errors and matching, one work item per image.
  const Stopwatch errors_watch;
  std::vector<const ImageTargets*> image_list;
  for (const auto& [key, image] : images) image_list.push_back(&image);
  std::vector<ImageResult> results(image_list.size());
  executor->ParallelFor(static_cast<int>(image_list.size()), [&](int i) {
    const ImageTargets& image = *image_list[i];
    results[i] =
        EvaluateImage(image, scenes.at(image.scene_id), models, estimates, estimate_index, options);
  });
  report.errors_ms = errors_watch.ElapsedMs();

  std::map<int, BopObjectReport> objects;
  for (int obj_id : object_list) {
    BopObjectReport& object = objects[obj_id];
    object.obj_id = obj_id;
    object.name = BopObjectName(obj_id);
    object.uses_adds = models.at(obj_id).uses_adds;
    object.recall = EmptyRecall(options);
  }
  for (const ImageResult& result : results) {
    for (const auto& [obj_id, tally] : result.per_object) {
      AddCounts(tally, &objects.at(obj_id).recall);
      AddCounts(tally, &report.overall);
    }
    report.targets.insert(report.targets.end(), result.targets.begin(), result.targets.end());
    report.num_estimates_evaluated += result.evaluated;
    report.num_estimates_beyond_count += result.beyond_count;
  }
  for (auto& [obj_id, object] : objects) {
    FinishRecall(&object.recall);
    report.objects.push_back(object);
  }
  FinishRecall(&report.overall);

  report.success = report.overall.targets > 0;
  report.message = report.success ? "ok" : "the targets match no GT instance";
  report.total_ms = total_watch.ElapsedMs();
  return report;
}

}  // namespace g6d
