#include "detect_benchmark.h"

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
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
#include "eval/mask_degrade.h"
#include "eval/metrics.h"
#include "solver/proposals.h"

namespace g6d::bench {
namespace {

// The full-frame pixels of a region (its segments in its pass's labels, or its own mask).
cv::Mat ProposalPixels(const DetectionReport& report, const Proposal& proposal) {
  if (!proposal.mask.empty()) return proposal.mask;
  return RegionMask(report.passes[static_cast<size_t>(proposal.pass)].segmentation.labels, proposal);
}

double Iou(const cv::Mat& a, const cv::Mat& b) {
  const int both = cv::countNonZero(a & b), either = cv::countNonZero(a | b);
  return either > 0 ? static_cast<double>(both) / either : 0.0;
}

// Where detection lost the GT instances (DetectBenchmarkArgs::diagnose).
struct Diagnosis {
  int instances = 0, formed = 0, ranked = 0, solved = 0, correct = 0;
};

double MeanOf(const std::vector<double>& values) {
  double sum = 0.0;
  for (double value : values) sum += value;
  return values.empty() ? 0.0 : sum / static_cast<double>(values.size());
}

}  // namespace

cv::Mat BenchDepth(const BopScene& scene, int scene_id, int im_id, const Camera& camera, const cv::Mat& rgb,
                   const std::string& folder, bool simulate_sensor, const DepthSensorModel& sensor) {
  cv::Mat depth = LoadBopDepth(scene, im_id, folder);
  if (!simulate_sensor) return depth;
  return SimulateDepthSensor(depth, rgb, camera, sensor, MaskInstanceKey(scene_id, im_id, -1));
}

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
  std::map<std::string, std::vector<double>> solve_times;  // inside the solves, summed per image
  std::vector<double> image_ms, solves, regions;
  int done = 0;
  Diagnosis diagnosis;
  int absent_asked = 0, absent_answered = 0, absent_confident = 0;
  std::FILE* records = nullptr;
  if (!args.records_csv.empty()) {
    records = std::fopen(args.records_csv.c_str(), "w");
    if (!records) G6D_THROW("cannot write '" << args.records_csv << "'");
    std::fprintf(records,
                 "scene_id,im_id,obj_id,absent,score,confidence,ambiguous,on_surface,free_space,contour_support,"
                 "rendered_pixels,region_iou,size_term,colour_term,shape_term,rank,runner_up_margin,error_d,correct,in_image,area_term,appearance_valid,appearance_agreement,support_penetration_mm,bare_support_share,edge_support,solve_runner_up_gap,flips_checked,edge_chance,lightness_ratio,oriented_edge,oriented_edge_chance,free_space_band_px\n");
  }
  if (!args.pictures_dir.empty()) {  // made when missing, before an hour of solving
    std::error_code error;
    std::filesystem::create_directories(args.pictures_dir, error);
    if (error) G6D_THROW("cannot make the pictures folder '" << args.pictures_dir << "': " << error.message());
  }
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
    frame.camera.width = frame.rgb.cols;
    frame.camera.height = frame.rgb.rows;
    frame.depth = BenchDepth(scene, scene_id, im_id, frame.camera, frame.rgb, args.depth_folder, args.simulate_sensor, args.sensor);
    std::vector<DetectRequest> requests;
    std::vector<int> obj_of_request;
    std::vector<BopTarget> image_targets = targets_of.at(images[i]);
    std::set<int> present;
    for (const BopGtInstance& gt : bop_frame.gt) present.insert(gt.obj_id);
    if (args.absent_requests > 0) {
      std::vector<int> absent;
      for (const auto& [obj_id, info] : dataset.objects) {
        if (!present.count(obj_id)) absent.push_back(obj_id);
      }
      for (int k = 0; k < args.absent_requests && k < static_cast<int>(absent.size()); ++k) {
        BopTarget target;
        target.scene_id = scene_id;
        target.im_id = im_id;
        target.obj_id = absent[(i * static_cast<size_t>(args.absent_requests) + static_cast<size_t>(k)) % absent.size()];
        target.inst_count = 1;
        image_targets.push_back(target);
      }
    }
    for (const BopTarget& target : image_targets) {
      if (!objects.count(target.obj_id)) {
        objects.emplace(target.obj_id, LoadBenchObject(dataset, target.obj_id, args.caches_dir, args.adds_ids));
      }
      DetectRequest request;
      request.bank = &objects.at(target.obj_id).bank;
      request.count = target.inst_count;
      requests.push_back(request);
      obj_of_request.push_back(target.obj_id);
      if (present.count(target.obj_id)) {
        evaluated_targets.push_back(target);
      } else {
        ++absent_asked;
      }
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
    times["shape"].push_back(report.shape_ms);
    times["solve"].push_back(report.solve_ms);
    times["select"].push_back(report.select_ms);
    times["identity"].push_back(report.identity_ms);
    for (const StageTime& time : report.solve_stages) solve_times[time.name].push_back(time.ms);
    solve_times["frame check"].push_back(report.check_ms);
    ++done;
    std::fprintf(stderr, "[%d] scene %d im %d: %s, %.0f ms (support %.0f, segment %.0f, propose %.0f, ppf %.0f (%d regions), rank %.0f (shape %.0f), solve %.0f, identity %.0f: %d checked, %d dropped, %d replaced)\n",
                 done, scene_id, im_id, report.message.c_str(), ms, report.support_ms, report.segment_ms,
                 report.propose_ms, report.ppf_ms, report.ppf_regions, report.rank_ms, report.shape_ms, report.solve_ms,
                 report.identity_ms, report.identity_checked, report.identity_dropped, report.identity_replaced);
    for (const Detection& detection : detections) {
      const int obj_id = obj_of_request[static_cast<size_t>(detection.request)];
      const BenchObject& object = objects.at(obj_id);
      double best = std::numeric_limits<double>::infinity();
      for (const BopGtInstance& gt : bop_frame.gt) {
        if (gt.obj_id != obj_id) continue;
        best = std::min(best, object.symmetric ? ComputeAdds(detection.result.cam_from_object, gt.cam_from_object, object.points)
                                               : ComputeAdd(detection.result.cam_from_object, gt.cam_from_object, object.points));
      }
      const bool absent = !present.count(obj_id);
      const bool correct = !absent && IsAddCorrect(best, object.diameter_m);
      std::fprintf(stderr, "    %s: S %.3f conf %.2f free %.2f contour %.2f, %s, region %d (%zu segments)\n",
                   detection.object_id.c_str(), detection.result.score, detection.result.confidence,
                   detection.check.free_space, detection.check.contour_support,
                   absent ? "ABSENT object answered"
                          : (std::string("ADD") + (object.symmetric ? "-S" : "") + " to the nearest GT " +
                             std::to_string(static_cast<int>(std::lround(best * 1000))) + " mm" + (correct ? "" : " WRONG")).c_str(),
                   detection.proposal, report.proposals[static_cast<size_t>(detection.proposal)].segments.size());
      if (records) {
        const CandidateTrial* trial = nullptr;
        for (const CandidateTrial& t : report.trials) {
          if (t.request == detection.request && t.proposal == detection.proposal) trial = &t;
        }
        // The margin to the runner-up: the best S_A of the object's other solved regions
        // that do not overlap this answer's, less this S_A (2 when none).
        double runner_up = 2.0;
        for (const CandidateTrial& t : report.trials) {
          if (t.request != detection.request || !t.solved || !t.success || t.proposal == detection.proposal) continue;
          runner_up = std::min(runner_up, t.score);
        }
        // The share of the answer's agreeing pixels that are bare support (support, not raised).
        double bare_share = 0.0;
        const cv::Mat& agreeing = detection.result.corrected_mask;
        if (!agreeing.empty() && !report.support.empty()) {
          cv::Mat bare = agreeing & report.support;
          if (!report.raised.empty()) bare &= ~report.raised;
          bare_share = static_cast<double>(cv::countNonZero(bare)) / std::max(1, cv::countNonZero(agreeing));
        }
        std::fprintf(records, "%d,%d,%d,%d,%.6f,%.6f,%d,%.4f,%.4f,%.4f,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.6f,%.4f,%d,%.4f,%.4f,%d,%.4f,%.2f,%.4f,%.4f,%.6f,%d,%.4f,%.4f,%.4f,%.4f,%.4f\n", scene_id,
                     im_id, obj_id, absent ? 1 : 0, detection.result.score, detection.result.confidence,
                     detection.result.ambiguous ? 1 : 0, detection.check.on_surface, detection.check.free_space,
                     detection.check.contour_support, detection.check.rendered_pixels, detection.region_iou,
                     trial ? trial->size_term : 0.0, detection.colour_term, trial ? trial->shape_term : 0.5,
                     trial ? trial->rank : 0.0, runner_up - detection.result.score,
                     absent ? -1.0 : best / object.diameter_m, correct ? 1 : 0, detection.check.in_image,
                     trial ? trial->area_term : 1.0, detection.result.appearance_valid ? 1 : 0,
                     detection.result.appearance_agreement, 1000.0 * detection.result.stages.support_penetration_m, bare_share,
                     detection.check.edge_support,
                     RunnerUpGap(detection.result),
                     detection.result.stages.flips_checked, detection.check.edge_chance, detection.lightness_ratio,
                     detection.check.oriented_edge, detection.check.oriented_edge_chance, detection.check.free_space_band_px);
      }
      if (absent) {
        ++absent_answered;
        absent_confident += detection.result.confidence >= 0.9;
        continue;  // not an estimate of any target
      }
      BopEstimate estimate;
      estimate.scene_id = scene_id;
      estimate.im_id = im_id;
      estimate.obj_id = obj_id;
      estimate.score = detection.result.confidence;
      estimate.cam_from_object = detection.result.cam_from_object;
      estimate.time_s = ms / 1000.0;
      estimates.push_back(estimate);
    }
    if (args.diagnose) {
      // Each GT instance of a requested object: the best IoU of any region (all passes), of
      // the regions ranked for its object, and of those solved; then whether an answer of
      // its object is right for it.
      std::vector<cv::Mat> pixels(report.proposals.size());
      for (size_t p = 0; p < report.proposals.size(); ++p) pixels[p] = ProposalPixels(report, report.proposals[p]);
      // What each solved region holds: the GT instance of its object it overlaps most.
      std::vector<double> solved_holds(report.trials.size(), 0.0);
      std::vector<int> solved_holder(report.trials.size(), -1);  // the GT instance held
      for (size_t g = 0; g < bop_frame.gt.size(); ++g) {
        const BopGtInstance& gt = bop_frame.gt[g];
        const auto request = std::find(obj_of_request.begin(), obj_of_request.end(), gt.obj_id);
        if (request == obj_of_request.end()) continue;
        const cv::Mat visible = LoadBopMaskVisib(scene, im_id, static_cast<int>(g)) > 0;
        for (size_t t = 0; t < report.trials.size(); ++t) {
          const CandidateTrial& trial = report.trials[t];
          if (!trial.solved || trial.request != static_cast<int>(request - obj_of_request.begin())) continue;
          const double iou = Iou(pixels[static_cast<size_t>(trial.proposal)], visible);
          if (iou > solved_holds[t]) {
            solved_holds[t] = iou;
            solved_holder[t] = static_cast<int>(g);
          }
        }
      }
      // Every ranked pair, for an analysis of the ranking: what its region holds.
      std::vector<cv::Mat> visible_masks(bop_frame.gt.size());
      for (size_t g = 0; g < bop_frame.gt.size(); ++g) visible_masks[g] = LoadBopMaskVisib(scene, im_id, static_cast<int>(g)) > 0;
      for (size_t t = 0; t < report.trials.size(); ++t) {
        const CandidateTrial& trial = report.trials[t];
        double holds = 0.0;
        int held = -1;
        for (size_t g = 0; g < bop_frame.gt.size(); ++g) {
          if (obj_of_request[static_cast<size_t>(trial.request)] != bop_frame.gt[g].obj_id) continue;
          const double iou = Iou(pixels[static_cast<size_t>(trial.proposal)], visible_masks[g]);
          if (iou > holds) {
            holds = iou;
            held = static_cast<int>(g);
          }
        }
        const Proposal& proposal = report.proposals[static_cast<size_t>(trial.proposal)];
        std::fprintf(stderr, "      trial: request %d pass %d rank %.3f size %.3f colour %.3f shape %.3f area %.3f aterm %.3f pixels %d mask_pixels %d kind %s holds %.2f gt %d solved %d\n",
                     trial.request, trial.pass, trial.rank, trial.size_term, trial.colour_term, trial.shape_term,
                     trial.area_ratio, trial.area_term, proposal.pixels, proposal.mask_pixels,
                     proposal.ppf_request >= 0 ? "ppf" : proposal.mask.empty() ? "segments" : "island", holds, held, trial.solved ? 1 : 0);
      }
      for (size_t t = 0; t < report.trials.size(); ++t) {
        const CandidateTrial& trial = report.trials[t];
        if (!trial.solved) continue;
        // The answer of the solve against the instance its region holds (error / diameter).
        std::string verdict = trial.success ? "" : ", no pose";
        if (trial.success && solved_holds[t] >= 0.5) {
          const BopGtInstance& gt = bop_frame.gt[static_cast<size_t>(solved_holder[t])];
          const BenchObject& object = objects.at(gt.obj_id);
          const double error = object.symmetric ? ComputeAdds(trial.cam_from_object, gt.cam_from_object, object.points)
                                                : ComputeAdd(trial.cam_from_object, gt.cam_from_object, object.points);
          char text[96];
          std::snprintf(text, sizeof(text), ", S %.3f conf %.2f error %.2f d (GT %d)", trial.score, trial.confidence,
                        error / object.diameter_m, solved_holder[t]);
          verdict = text;
        } else if (trial.success) {
          char text[64];
          std::snprintf(text, sizeof(text), ", S %.3f conf %.2f", trial.score, trial.confidence);
          verdict = text;
        }
        std::fprintf(stderr, "      solved: request %d rank %.3f (size %.2f shape %.2f; %s) holds an instance at IoU %.2f%s%s\n",
                     trial.request, trial.rank, trial.size_term, trial.shape_term,
                     report.proposals[static_cast<size_t>(trial.proposal)].mask.empty() ? "segments" : "own mask",
                     solved_holds[t], solved_holds[t] < 0.5 ? " (NONE)" : "", verdict.c_str());
      }
      for (size_t g = 0; g < bop_frame.gt.size(); ++g) {
        const BopGtInstance& gt = bop_frame.gt[g];
        const auto request = std::find(obj_of_request.begin(), obj_of_request.end(), gt.obj_id);
        if (request == obj_of_request.end() || !gt.info || gt.info->visib_fract < 0.1) continue;
        const int r = static_cast<int>(request - obj_of_request.begin());
        const cv::Mat visible = LoadBopMaskVisib(scene, im_id, static_cast<int>(g)) > 0;
        const cv::Mat with_depth = visible & (frame.depth > 0.0f);
        const int depth_pixels = cv::countNonZero(with_depth);
        const double on_support =
            depth_pixels > 0 ? static_cast<double>(cv::countNonZero(with_depth & report.support)) / depth_pixels : 0.0;
        const double has_depth = static_cast<double>(depth_pixels) / std::max(1, cv::countNonZero(visible));
        const double raised = depth_pixels > 0 && !report.raised.empty()
                                  ? static_cast<double>(cv::countNonZero(with_depth & report.raised)) / depth_pixels
                                  : 0.0;
        double formed = 0.0, ranked = 0.0, solved = 0.0;
        for (size_t p = 0; p < pixels.size(); ++p) formed = std::max(formed, Iou(pixels[p], visible));
        // The best-holding ranked region's place among its pass's candidates for the object.
        int place = -1, of = 0;
        const CandidateTrial* holder = nullptr;
        for (size_t t = 0; t < report.trials.size(); ++t) {
          const CandidateTrial& trial = report.trials[t];
          if (trial.request != r) continue;
          const double iou = Iou(pixels[static_cast<size_t>(trial.proposal)], visible);
          if (iou > ranked) {
            ranked = iou;
            holder = &trial;
            place = 0;
            of = 0;
            for (const CandidateTrial& other : report.trials) {
              if (other.request != r || other.pass != trial.pass) continue;
              ++of;
              if (other.rank > trial.rank) ++place;
            }
          }
          if (trial.solved) solved = std::max(solved, iou);
        }
        if (holder != nullptr && holder->solved == false && ranked >= 0.5) {
          std::fprintf(stderr, "      holder: place %d of %d (rank %.3f: size %.2f colour %.2f shape %.2f; %s)\n", place + 1, of,
                       holder->rank, holder->size_term, holder->colour_term, holder->shape_term,
                       report.proposals[static_cast<size_t>(holder->proposal)].mask.empty() ? "segments" : "own mask");
        }
        const BenchObject& object = objects.at(gt.obj_id);
        bool correct = false;
        for (const Detection& detection : detections) {
          if (detection.request != r) continue;
          const double error = object.symmetric ? ComputeAdds(detection.result.cam_from_object, gt.cam_from_object, object.points)
                                                : ComputeAdd(detection.result.cam_from_object, gt.cam_from_object, object.points);
          correct = correct || IsAddCorrect(error, object.diameter_m);
        }
        ++diagnosis.instances;
        diagnosis.formed += formed >= 0.5;
        diagnosis.ranked += ranked >= 0.5;
        diagnosis.solved += solved >= 0.5;
        diagnosis.correct += correct;
        std::fprintf(stderr, "    GT %zu obj %d visib %.2f depth %.2f support %.2f raised %.2f: best region IoU %.2f, ranked %.2f, solved %.2f, %s\n",
                     g, gt.obj_id, gt.info->visib_fract, has_depth, on_support, raised, formed, ranked, solved, correct ? "found" : "MISSED");
      }
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
        std::fprintf(stderr, " [region %d rank %.2f (size %.2f colour %.2f shape %.2f) S %.3f IoU %.2f %.0f ms]", trial.proposal,
                     trial.rank, trial.size_term, trial.colour_term, trial.shape_term, trial.score, trial.region_iou, trial.ms);
      }
      std::fprintf(stderr, "\n");
    }
  }
  if (records) std::fclose(records);
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
  for (const char* stage : {"support", "segment", "propose", "ppf", "rank", "shape", "solve", "select", "identity"}) {
    std::printf("| %s | %.1f | %.1f |\n", stage, Percentile(times[stage], 0.5), Percentile(times[stage], 0.95));
  }
  // Inside the solve stage: each solve's stages summed over the image's solves (they run
  // side by side, so the sums exceed the solve stage's wall time on 2 threads).
  std::printf("\ninside the solves: stage times summed over an image's solves (ms)\n| stage | p50 | p95 |\n|---|---|---|\n");
  for (const char* stage : {"prepare", "features", "match", "pnp", "ppf", "observable", "icp", "mhpo", "post_refine",
                            "finalists", "mask_refine", "frame check", "total"}) {
    const auto found = solve_times.find(stage);
    if (found == solve_times.end() || found->second.empty()) continue;
    std::printf("| %s | %.1f | %.1f |\n", stage, Percentile(found->second, 0.5), Percentile(found->second, 0.95));
  }
  if (absent_asked > 0) {
    std::printf("\nrequests for absent objects: %d; answered NO_SOLUTION %d (%.1f%%); answered anyway %d, with "
                "confidence >= 0.9 %d\n",
                absent_asked, absent_asked - absent_answered, 100.0 * (absent_asked - absent_answered) / absent_asked,
                absent_answered, absent_confident);
  }
  if (args.diagnose) {
    auto share = [&](int n) { return diagnosis.instances > 0 ? 100.0 * n / diagnosis.instances : 0.0; };
    std::printf("\nwhere detection lost them (GT instances with visib_fract >= 0.1 of requested objects; a region "
                "\"holds\" an instance at IoU >= 0.5 with its visible mask):\n");
    std::printf("| instances | a region holds it | ... ranked for its object | ... solved | answered right |\n"
                "|---|---|---|---|---|\n| %d | %d (%.1f%%) | %d (%.1f%%) | %d (%.1f%%) | %d (%.1f%%) |\n",
                diagnosis.instances, diagnosis.formed, share(diagnosis.formed), diagnosis.ranked, share(diagnosis.ranked),
                diagnosis.solved, share(diagnosis.solved), diagnosis.correct, share(diagnosis.correct));
  }
  struct rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  std::printf("\npeak resident memory: %.0f MB\n", usage.ru_maxrss / 1024.0);
  return 0;
}

}  // namespace g6d::bench
