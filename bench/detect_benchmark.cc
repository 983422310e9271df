#include "detect_benchmark.h"

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <map>
#include <set>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench_objects.h"
#include "core/error.h"
#include "core/executor.h"
#include "core/stats.h"
#include "core/timer.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "eval/bop_eval.h"
#include "eval/metrics.h"

namespace g6d::bench {
namespace {

double MeanOf(const std::vector<double>& values) {
  double sum = 0.0;
  for (double value : values) sum += value;
  return values.empty() ? 0.0 : sum / static_cast<double>(values.size());
}

}  // namespace

int RunDetectBenchmark(const DetectBenchmarkArgs& args) {
  BopDataset dataset = LoadBopDataset(args.dataset_dir);
  if (!args.targets_file.empty()) {
    dataset.targets = LoadBopTargets(args.targets_file);
  } else if (!dataset.has_targets) {
    G6D_THROW("'" << args.dataset_dir << "' has no test_targets_bop19.json (pass --targets FILE)");
  }
  if (args.every < 1) G6D_THROW("--every must be >= 1 (got " << args.every << ")");
  // Images in target order, each with its objects and counts.
  std::vector<std::pair<int, int>> images;
  std::map<std::pair<int, int>, std::vector<BopTarget>> targets_of;
  for (const BopTarget& target : dataset.targets) {
    const std::pair<int, int> key{target.scene_id, target.im_id};
    if (!targets_of.count(key)) images.push_back(key);
    targets_of[key].push_back(target);
  }
  ThreadPool pool(std::max(1, args.threads));
  std::map<int, BenchObject> objects;
  std::map<int, BopScene> scenes;
  std::vector<BopEstimate> estimates;
  std::vector<BopTarget> evaluated_targets;
  std::map<std::string, std::vector<double>> times;
  std::vector<double> image_ms, solves, regions;
  int done = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    if (static_cast<int>(i) % args.every != 0) continue;
    if (args.limit > 0 && done >= args.limit) break;
    const auto [scene_id, im_id] = images[i];
    if (!scenes.count(scene_id)) scenes.emplace(scene_id, LoadBopScene(args.dataset_dir, scene_id));
    const BopScene& scene = scenes.at(scene_id);
    const BopFrame& bop_frame = scene.Frame(im_id);
    Frame frame;
    frame.camera = bop_frame.camera;
    frame.rgb = LoadBopRgb(scene, im_id);
    frame.depth = LoadBopDepth(scene, im_id);
    frame.camera.width = frame.rgb.cols;
    frame.camera.height = frame.rgb.rows;
    std::vector<DetectRequest> requests;
    std::vector<int> obj_of_request;
    for (const BopTarget& target : targets_of.at(images[i])) {
      if (!objects.count(target.obj_id)) {
        objects.emplace(target.obj_id, LoadBenchObject(dataset, target.obj_id, args.caches_dir, args.adds_ids));
      }
      DetectRequest request;
      request.bank = &objects.at(target.obj_id).bank;
      request.count = target.inst_count;
      requests.push_back(request);
      obj_of_request.push_back(target.obj_id);
      evaluated_targets.push_back(target);
    }
    DetectionReport report;
    const Stopwatch watch;
    const std::vector<Detection> detections = DetectObjects(frame, requests, args.solver, args.detect, &pool, &report);
    const double ms = watch.ElapsedMs();
    image_ms.push_back(ms);
    solves.push_back(report.solves);
    regions.push_back(static_cast<double>(report.proposals.size()));
    times["support"].push_back(report.support_ms);
    times["segment"].push_back(report.segment_ms);
    times["propose"].push_back(report.propose_ms);
    times["ppf"].push_back(report.ppf_ms);
    times["rank"].push_back(report.rank_ms);
    times["solve"].push_back(report.solve_ms);
    times["select"].push_back(report.select_ms);
    ++done;
    std::fprintf(stderr, "[%d] scene %d im %d: %s, %.0f ms (support %.0f, segment %.0f, propose %.0f, ppf %.0f (%d regions), rank %.0f, solve %.0f)\n",
                 done, scene_id, im_id, report.message.c_str(), ms, report.support_ms, report.segment_ms,
                 report.propose_ms, report.ppf_ms, report.ppf_regions, report.rank_ms, report.solve_ms);
    for (const Detection& detection : detections) {
      const int obj_id = obj_of_request[static_cast<size_t>(detection.request)];
      const BenchObject& object = objects.at(obj_id);
      double best = std::numeric_limits<double>::infinity();
      for (const BopGtInstance& gt : bop_frame.gt) {
        if (gt.obj_id != obj_id) continue;
        best = std::min(best, object.symmetric ? ComputeAdds(detection.result.cam_from_object, gt.cam_from_object, object.points)
                                               : ComputeAdd(detection.result.cam_from_object, gt.cam_from_object, object.points));
      }
      std::fprintf(stderr, "    %s: S %.3f conf %.2f free %.2f contour %.2f, ADD%s to the nearest GT %.1f mm (%.2f d)%s, region %d (%zu segments)\n",
                   detection.object_id.c_str(), detection.result.score, detection.result.confidence,
                   detection.check.free_space, detection.check.contour_support,
                   object.symmetric ? "-S" : "", best * 1000, best / object.diameter_m,
                   IsAddCorrect(best, object.diameter_m) ? "" : " WRONG", detection.proposal,
                   report.proposals[static_cast<size_t>(detection.proposal)].segments.size());
      BopEstimate estimate;
      estimate.scene_id = scene_id;
      estimate.im_id = im_id;
      estimate.obj_id = obj_id;
      estimate.score = detection.result.confidence;
      estimate.cam_from_object = detection.result.cam_from_object;
      estimate.time_s = ms / 1000.0;
      estimates.push_back(estimate);
    }
    if (!args.pictures_dir.empty()) {
      cv::Mat picture;
      cv::cvtColor(DrawDetectionPicture(frame, requests, report, detections), picture, cv::COLOR_RGB2BGR);
      char name[64];
      std::snprintf(name, sizeof(name), "/%06d_%06d.png", scene_id, im_id);
      if (!cv::imwrite(args.pictures_dir + name, picture)) G6D_THROW("cannot write " << args.pictures_dir << name);
    }
    for (size_t r = 0; r < requests.size(); ++r) {
      int tried = 0, succeeded = 0;
      for (const CandidateTrial& trial : report.trials) {
        if (trial.request != static_cast<int>(r)) continue;
        if (trial.solved) ++tried;
        if (trial.success) ++succeeded;
      }
      std::fprintf(stderr, "    %s: %d candidates, %d solved (%d with a pose):", requests[r].bank->object_id.c_str(),
                   static_cast<int>(std::count_if(report.trials.begin(), report.trials.end(),
                                                  [&](const CandidateTrial& t) { return t.request == static_cast<int>(r); })),
                   tried, succeeded);
      for (const CandidateTrial& trial : report.trials) {
        if (trial.request != static_cast<int>(r) || !trial.solved) continue;
        std::fprintf(stderr, " [region %d rank %.2f (size %.2f colour %.2f) S %.3f IoU %.2f %.0f ms]", trial.proposal, trial.rank,
                     trial.size_term, trial.colour_term, trial.score, trial.region_iou, trial.ms);
      }
      std::fprintf(stderr, "\n");
    }
  }
  if (!args.out_csv.empty()) WriteBopCsv(args.out_csv, estimates);

  BopEvalOptions eval_options;
  eval_options.adds_obj_ids = args.adds_ids;
  const BopEvalReport evaluation = EvaluateBop(dataset, evaluated_targets, estimates, eval_options, &pool);
  if (!evaluation.success) G6D_THROW("evaluation failed: " << evaluation.message);
  std::printf("\nBOP localization without masks (ids and counts given), K = %d, %d threads, %d images\n",
              args.solver.num_hypotheses, args.threads, done);
  std::printf("| object | targets | answered | ADD(-S)@0.1d (%%) | AR | AR_VSD | AR_MSSD | AR_MSPD |\n|---|---|---|---|---|---|---|---|\n");
  auto row = [](const std::string& name, const BopRecall& recall) {
    std::printf("| %s | %d | %d | %.1f | %.3f | %.3f | %.3f | %.3f |\n", name.c_str(), recall.targets,
                recall.with_estimate, 100.0 * recall.add_recall, recall.ar, recall.ar_vsd, recall.ar_mssd, recall.ar_mspd);
  };
  for (const BopObjectReport& object : evaluation.objects) {
    row(object.name + (object.uses_adds ? " (ADD-S)" : ""), object.recall);
  }
  row("**all**", evaluation.overall);
  std::printf("\nlatency per image (ms): p50 %.1f, p95 %.1f, mean %.1f; solves per image p50 %.0f, regions p50 %.0f\n",
              Percentile(image_ms, 0.5), Percentile(image_ms, 0.95), MeanOf(image_ms), Percentile(solves, 0.5),
              Percentile(regions, 0.5));
  std::printf("| stage | p50 | p95 |\n|---|---|---|\n");
  for (const char* stage : {"support", "segment", "propose", "ppf", "rank", "solve", "select"}) {
    std::printf("| %s | %.1f | %.1f |\n", stage, Percentile(times[stage], 0.5), Percentile(times[stage], 0.95));
  }
  struct rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  std::printf("\npeak resident memory: %.0f MB\n", usage.ru_maxrss / 1024.0);
  return 0;
}

}  // namespace g6d::bench
