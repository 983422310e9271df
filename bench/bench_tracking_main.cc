// g6d-bench-tracking: tracking (issue 14) on the consecutive frames of a BOP dataset with
// its GT visible masks, no LCM. Two modes:
//
//  sequence (default): every scene's images in im_id order at --fps; each frame is solved
//    twice, by the Tracker (lib/track, the service's code) and from scratch (EstimatePose,
//    the baseline), and the table gives per-frame ADD(-S) recall of both, the answers by
//    mode, tracked-solve and per-frame times, re-detections, and the frames where a wrong
//    pose (> 0.1 d) was published before and after --abrupt-frame. --drop-frames leaves
//    frames out as a busy service drops them (tracks then start from older poses).
//  --perturb N: for every target instance, N TrackPose solves from the GT pose moved by a
//    random rotation and translation; S_A and J of the tracked-correct and tracked-wrong
//    poses, and what loss thresholds accept and refuse (the loss threshold is measured here).
//
//   g6d-bench-tracking --dataset out/demo/sequence --caches out/demo/sequence/caches --abrupt-frame 45
//   g6d-bench-tracking --dataset ../shared/data/lmo --caches out/acc/caches/lmo --perturb 8
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/error.h"
#include "core/executor.h"
#include "core/timer.h"
#include "eval/bop.h"
#include "eval/metrics.h"
#include "mesh/mesh.h"
#include "solver/pipeline.h"
#include "templates/cache.h"
#include "track/tracker.h"
#include "bench_objects.h"
#include "core/stats.h"

namespace {

using g6d::Percentile;
using ObjectData = g6d::bench::BenchObject;

// The dataset's objects, loaded on first use.
class Objects {
 public:
  Objects(const g6d::BopDataset& dataset, std::string caches, std::vector<int> adds_ids)
      : dataset_(dataset), caches_(std::move(caches)), adds_ids_(std::move(adds_ids)) {}
  const ObjectData& Get(int obj_id) {
    auto found = objects_.find(obj_id);
    if (found != objects_.end()) return found->second;
    return objects_.emplace(obj_id, g6d::bench::LoadBenchObject(dataset_, obj_id, caches_, adds_ids_)).first->second;
  }
  // ADD(-S) error of `pose` against `gt`, as a fraction of the diameter.
  double ErrorD(int obj_id, const Eigen::Isometry3d& pose, const Eigen::Isometry3d& gt) {
    const ObjectData& object = Get(obj_id);
    const double error = object.symmetric ? g6d::ComputeAdds(pose, gt, object.points) : g6d::ComputeAdd(pose, gt, object.points);
    return error / object.diameter_m;
  }

 private:
  const g6d::BopDataset& dataset_;
  std::string caches_;
  std::vector<int> adds_ids_;
  std::map<int, ObjectData> objects_;
};

g6d::Frame LoadFrame(const g6d::BopScene& scene, int im_id) {
  g6d::Frame frame;
  frame.camera = scene.Frame(im_id).camera;
  frame.rgb = g6d::LoadBopRgb(scene, im_id);
  frame.depth = g6d::LoadBopDepth(scene, im_id);
  frame.camera.width = frame.rgb.cols;
  frame.camera.height = frame.rgb.rows;
  return frame;
}

// The images of each scene that have targets, in im_id order, and the target objects.
std::map<int, std::map<int, std::vector<int>>> TargetsByScene(const g6d::BopDataset& dataset) {
  std::map<int, std::map<int, std::vector<int>>> scenes;  // scene -> im_id -> obj ids
  for (const g6d::BopTarget& target : dataset.targets) scenes[target.scene_id][target.im_id].push_back(target.obj_id);
  return scenes;
}

constexpr double kCorrectD = 0.1;  // ADD(-S) < 0.1 d

int RunSequence(const g6d::BopDataset& dataset, const std::string& dataset_dir, Objects* objects,
                const g6d::SolverOptions& solver, const g6d::TrackerOptions& tracker_options, double fps,
                int abrupt_frame, const std::vector<int>& drop_frames, bool baseline, g6d::Executor* pool,
                std::FILE* records) {
  int instances = 0, tracked_correct = 0, baseline_correct = 0;
  std::map<g6d::AnswerMode, int> modes;
  int lost = 0, lost_by_appearance = 0, periodic = 0, wrong_before = 0, wrong_after = 0, instances_before = 0, instances_after = 0;
  int longest_wrong_run_after = 0;
  std::vector<double> track_ms, tracked_answer_ms, frame_tracking_ms, frame_baseline_ms, detect_ms, background_ms;
  int corrections = 0;
  // S and J of every TrackPose result, by correctness.
  std::vector<double> s_correct, s_wrong;
  for (const auto& [scene_id, images] : TargetsByScene(dataset)) {
    const g6d::BopScene scene = g6d::LoadBopScene(dataset_dir, scene_id);
    g6d::Tracker tracker(tracker_options);
    std::map<int, int> wrong_run;  // gt_idx -> consecutive wrong frames
    for (const auto& [im_id, obj_ids] : images) {
      // A frame a busy service drops: the tracker never sees it.
      if (std::count(drop_frames.begin(), drop_frames.end(), im_id) > 0) continue;
      const g6d::Frame frame = LoadFrame(scene, im_id);
      const g6d::BopFrame& bop_frame = scene.Frame(im_id);
      std::vector<g6d::Instance> batch;
      std::vector<size_t> gt_index;
      for (size_t gt_idx = 0; gt_idx < bop_frame.gt.size(); ++gt_idx) {
        const int obj_id = bop_frame.gt[gt_idx].obj_id;
        if (std::count(obj_ids.begin(), obj_ids.end(), obj_id) == 0) continue;
        batch.push_back(g6d::Instance{objects->Get(obj_id).bank.object_id,
                                      g6d::LoadBopMaskVisib(scene, im_id, static_cast<int>(gt_idx))});
        gt_index.push_back(gt_idx);
      }
      const double time_s = im_id / fps;
      std::map<std::string, const g6d::TemplateBank*> banks;
      for (size_t i = 0; i < batch.size(); ++i) banks[batch[i].object_id] = &objects->Get(bop_frame.gt[gt_index[i]].obj_id).bank;
      const g6d::BankLookup lookup = [&](const std::string& id) -> const g6d::TemplateBank* {
        auto found = banks.find(id);
        return found == banks.end() ? nullptr : found->second;
      };
      g6d::Stopwatch watch;
      const std::vector<g6d::TrackPlan> plans = tracker.Plan(time_s, batch, frame.camera, lookup);
      std::vector<g6d::TrackedAnswer> answers(batch.size());
      for (size_t i = 0; i < batch.size(); ++i) {
        answers[i] = g6d::SolveWithPlan(frame, batch[i], *lookup(batch[i].object_id), solver, tracker_options, plans[i], pool);
      }
      tracker.Update(time_s, plans, lookup, &answers);
      frame_tracking_ms.push_back(watch.ElapsedMs());
      // Background re-detections (the service runs them on a spare thread): solved here,
      // outside the frame's time, and applied before the next frame.
      for (size_t i = 0; i < batch.size(); ++i) {
        const g6d::TrackedAnswer& a = answers[i];
        if (!a.confirm_requested) continue;
        watch.Restart();
        const g6d::PoseResult detection = g6d::EstimatePose(frame, batch[i], *lookup(batch[i].object_id), solver, pool);
        background_ms.push_back(watch.ElapsedMs());
        corrections += tracker.ApplyConfirmation(a.track_id, a.result, detection,
                                                 lookup(batch[i].object_id)->diameter_m);
      }
      std::vector<g6d::PoseResult> detections(batch.size());
      if (baseline) {
        watch.Restart();
        for (size_t i = 0; i < batch.size(); ++i) {
          detections[i] = g6d::EstimatePose(frame, batch[i], *lookup(batch[i].object_id), solver, pool);
        }
        frame_baseline_ms.push_back(watch.ElapsedMs());
      }
      const bool after = abrupt_frame >= 0 && im_id >= abrupt_frame;
      for (size_t i = 0; i < batch.size(); ++i) {
        const g6d::BopGtInstance& gt = bop_frame.gt[gt_index[i]];
        const g6d::TrackedAnswer& a = answers[i];
        const double error = a.result.success ? objects->ErrorD(gt.obj_id, a.result.cam_from_object, gt.cam_from_object) : 1e9;
        const bool correct = error < kCorrectD;
        const double baseline_error =
            baseline && detections[i].success ? objects->ErrorD(gt.obj_id, detections[i].cam_from_object, gt.cam_from_object) : 1e9;
        ++instances;
        tracked_correct += correct;
        baseline_correct += baseline_error < kCorrectD;
        ++modes[a.mode];
        lost += a.lost;
        lost_by_appearance += a.lost_by_appearance;
        periodic += a.periodic;
        if (a.track_ms > 0.0) track_ms.push_back(a.track_ms);
        if (a.detect_ms > 0.0) detect_ms.push_back(a.detect_ms);
        if (a.mode == g6d::AnswerMode::kTracked) tracked_answer_ms.push_back(a.track_ms);
        double tracked_error = -1.0;
        if (a.track_ms > 0.0) {
          tracked_error = objects->ErrorD(gt.obj_id, a.tracked_pose, gt.cam_from_object);
          (tracked_error < kCorrectD ? s_correct : s_wrong).push_back(a.tracked_score.s);
        }
        (after ? instances_after : instances_before) += 1;
        (after ? wrong_after : wrong_before) += !correct;
        int& run = wrong_run[static_cast<int>(gt_index[i])];
        run = correct ? 0 : run + 1;
        if (after) longest_wrong_run_after = std::max(longest_wrong_run_after, run);
        std::fprintf(stderr, "scene %d im %d obj %d: %s track %d S %.3f err %.3f d%s (baseline %.3f d) %.1f ms\n", scene_id, im_id,
                     gt.obj_id, g6d::AnswerModeName(a.mode), a.track_id, a.result.score, error, correct ? "" : " WRONG",
                     baseline_error, a.track_ms + a.detect_ms);
        if (records) {
          std::fprintf(records, "%d,%d,%d,%zu,%s,%d,%d,%d,%d,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.3f,%.3f\n", scene_id, im_id, gt.obj_id,
                       gt_index[i], g6d::AnswerModeName(a.mode), a.track_id, a.frames_since_detection, a.lost ? 1 : 0,
                       a.periodic ? 1 : 0, a.result.score, error, baseline_error, a.tracked_score.s, a.tracked_score.iou,
                       tracked_error, a.track_ms, a.detect_ms);
        }
      }
    }
  }
  auto pct = [](int n, int d) { return 100.0 * n / std::max(1, d); };
  std::printf("\n| frames x instances | ADD(-S) tracking | ADD(-S) every frame | detected | tracked | re-detected (lost / periodic) |\n");
  std::printf("|---|---|---|---|---|---|\n");
  std::printf("| %d | %.1f%% | %s | %d | %d | %d (%d / %d) |\n", instances, pct(tracked_correct, instances),
              baseline ? (std::to_string(pct(baseline_correct, instances)).substr(0, 5) + "%").c_str() : "-",
              modes[g6d::AnswerMode::kDetected], modes[g6d::AnswerMode::kTracked], modes[g6d::AnswerMode::kRedetected], lost,
              periodic);
  std::printf("\n| time (ms) | p50 | p95 | n |\n|---|---|---|---|\n");
  std::printf("| tracked solve (TrackPose), per instance | %.1f | %.1f | %zu |\n", Percentile(track_ms, 0.5), Percentile(track_ms, 0.95), track_ms.size());
  std::printf("| full solve (EstimatePose), per instance | %.1f | %.1f | %zu |\n", Percentile(detect_ms, 0.5), Percentile(detect_ms, 0.95), detect_ms.size());
  std::printf("| frame, tracking | %.1f | %.1f | %zu |\n", Percentile(frame_tracking_ms, 0.5), Percentile(frame_tracking_ms, 0.95), frame_tracking_ms.size());
  if (baseline) {
    std::printf("| frame, every frame solved | %.1f | %.1f | %zu |\n", Percentile(frame_baseline_ms, 0.5), Percentile(frame_baseline_ms, 0.95), frame_baseline_ms.size());
  }
  std::printf("\nlost tracked poses: %d (by the appearance drop alone: %d)\n", lost, lost_by_appearance);
  if (!background_ms.empty()) {
    std::printf("| background re-detection, per instance (not in the frame) | %.1f | %.1f | %zu |\n", Percentile(background_ms, 0.5),
                Percentile(background_ms, 0.95), background_ms.size());
    std::printf("\nbackground re-detections: %zu, tracks corrected by them: %d\n", background_ms.size(), corrections);
  }
  std::printf("\nwrong poses published (ADD(-S) >= 0.1 d): %d of %d before", wrong_before, instances_before);
  if (abrupt_frame >= 0) {
    std::printf(", %d of %d from the abrupt move at frame %d on; longest run of wrong frames of one instance after it: %d",
                wrong_after, instances_after, abrupt_frame, longest_wrong_run_after);
  }
  std::printf("\nTrackPose S_A: correct n %zu p50 %.3f p95 %.3f max %.3f; wrong n %zu min %.3f p50 %.3f\n", s_correct.size(),
              Percentile(s_correct, 0.5), Percentile(s_correct, 0.95), Percentile(s_correct, 1.0), s_wrong.size(),
              Percentile(s_wrong, 0.0), Percentile(s_wrong, 0.5));
  return 0;
}

// One TrackPose outcome from a perturbed GT start.
struct Probe {
  double rotation_deg = 0.0, translation_d = 0.0;
  double s = 2.0, iou = 0.0, error_d = 1e9, ms = 0.0, prepare_ms = 0.0, icp_ms = 0.0, mhpo_ms = 0.0, appearance_ms = 0.0;
  bool appearance_valid = false;
  double appearance = 0.0, gt_appearance = 0.0;  // agreement of the answer and of the GT pose
  bool success = false;
};

int RunPerturb(const g6d::BopDataset& dataset, const std::string& dataset_dir, Objects* objects, const g6d::SolverOptions& solver,
               const g6d::TrackerOptions& tracker_options, int per_instance, double max_rotation_deg, double max_translation_d,
               int every, g6d::Executor* pool, std::FILE* records) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto random_axis = [&] {
    Eigen::Vector3d v(normal(rng), normal(rng), normal(rng));
    return Eigen::Vector3d(v.normalized());
  };
  std::vector<Probe> probes;
  int seen = 0;
  std::map<int, g6d::BopScene> scenes;
  for (const g6d::BopTarget& target : dataset.targets) {
    if (!scenes.count(target.scene_id)) scenes.emplace(target.scene_id, g6d::LoadBopScene(dataset_dir, target.scene_id));
    const g6d::BopScene& scene = scenes.at(target.scene_id);
    const g6d::BopFrame& bop_frame = scene.Frame(target.im_id);
    const ObjectData& object = objects->Get(target.obj_id);
    g6d::Frame frame;
    bool loaded = false;
    for (const int gt_index : g6d::TargetGtIndices(bop_frame, target.obj_id, target.inst_count)) {
      const size_t gt_idx = static_cast<size_t>(gt_index);
      const g6d::BopGtInstance& gt = bop_frame.gt[gt_idx];
      if (seen++ % every != 0) continue;
      if (!loaded) frame = LoadFrame(scene, target.im_id), loaded = true;
      const g6d::Instance instance{object.bank.object_id, g6d::LoadBopMaskVisib(scene, target.im_id, static_cast<int>(gt_idx))};
      const Eigen::Vector3d centre = gt.cam_from_object * object.bank.bounding_box.center();
      // The agreement at the GT pose: what a correct detection of this instance reports.
      const g6d::AppearanceScore gt_appearance =
          object.bank.appearance.Empty()
              ? g6d::AppearanceScore()
              : g6d::ScoreAppearance(solver.appearance, object.bank.appearance, object.bank.online_mesh, frame.camera,
                                     frame.rgb, instance.mask > 0, gt.cam_from_object);
      for (int k = 0; k < per_instance; ++k) {
        Probe probe;
        probe.rotation_deg = max_rotation_deg * unit(rng);
        probe.translation_d = max_translation_d * unit(rng);
        // Rotation about the object's centre, then a translation, both in the camera frame.
        Eigen::Isometry3d move = Eigen::Isometry3d::Identity();
        move.linear() = Eigen::AngleAxisd(probe.rotation_deg * M_PI / 180.0, random_axis()).toRotationMatrix();
        move.translation() = centre - move.linear() * centre + probe.translation_d * object.diameter_m * random_axis();
        const Eigen::Isometry3d start = move * gt.cam_from_object;
        const g6d::PoseResult result = g6d::TrackPose(frame, instance, object.bank, solver, tracker_options.solve, {start}, pool);
        probe.success = result.success;
        probe.s = result.score;
        probe.iou = result.details.iou;
        probe.ms = result.stages.total_ms;
        probe.prepare_ms = result.stages.prepare_ms;
        probe.icp_ms = result.stages.icp_ms;
        probe.mhpo_ms = result.stages.mhpo_ms;
        probe.appearance_ms = result.stages.finalists_ms;
        probe.appearance_valid = result.appearance_valid && gt_appearance.valid;
        probe.appearance = result.appearance_agreement;
        probe.gt_appearance = gt_appearance.agreement;
        if (result.success) probe.error_d = objects->ErrorD(target.obj_id, result.cam_from_object, gt.cam_from_object);
        probes.push_back(probe);
        if (records) {
          std::fprintf(records, "%d,%d,%d,%zu,%.3f,%.4f,%d,%.6f,%.6f,%.6f,%.3f,%d,%.4f,%.4f\n", target.scene_id, target.im_id,
                       target.obj_id, gt_idx, probe.rotation_deg, probe.translation_d, probe.success ? 1 : 0, probe.s, probe.iou,
                       probe.error_d, probe.ms, probe.appearance_valid ? 1 : 0, probe.appearance, probe.gt_appearance);
        }
      }
    }
  }
  // Convergence by start error, then the S / J separation and candidate thresholds.
  std::printf("\nTrackPose from the GT moved by a random rotation (deg) and translation (fraction of d): %zu solves\n", probes.size());
  std::printf("| start rotation | start translation | n | correct after | S p50 correct | S p50 wrong |\n|---|---|---|---|---|---|\n");
  for (int bin = 0; bin < 4; ++bin) {
    const double r0 = max_rotation_deg * bin / 4.0, r1 = max_rotation_deg * (bin + 1) / 4.0;
    std::vector<double> sc, sw;
    int n = 0, ok = 0;
    for (const Probe& p : probes) {
      if (p.rotation_deg < r0 || p.rotation_deg >= r1) continue;
      ++n;
      const bool correct = p.error_d < kCorrectD;
      ok += correct;
      (correct ? sc : sw).push_back(p.s);
    }
    std::printf("| %.0f-%.0f | 0-%.2f | %d | %.1f%% | %.3f | %.3f |\n", r0, r1, max_translation_d, n, 100.0 * ok / std::max(1, n),
                Percentile(sc, 0.5), Percentile(sw, 0.5));
  }
  std::printf("\nloss rule: a tracked pose is kept when S_A <= loss_score and J >= min_iou (J = %.2f here)\n", tracker_options.min_iou);
  std::printf("| loss_score | correct kept | wrong kept (published wrong) | correct refused (costs a re-detection) |\n|---|---|---|---|\n");
  int correct_total = 0, wrong_total = 0;
  for (const Probe& p : probes) (p.error_d < kCorrectD ? correct_total : wrong_total) += 1;
  for (double threshold : {0.10, 0.15, 0.20, 0.25, 0.30, 0.40}) {
    int correct_kept = 0, wrong_kept = 0;
    for (const Probe& p : probes) {
      const bool kept = p.success && p.s <= threshold && p.iou >= tracker_options.min_iou;
      if (!kept) continue;
      (p.error_d < kCorrectD ? correct_kept : wrong_kept) += 1;
    }
    std::printf("| %.2f | %d of %d | %d of %d (%.1f%%) | %.1f%% |\n", threshold, correct_kept, correct_total, wrong_kept, wrong_total,
                100.0 * wrong_kept / std::max(1, wrong_total), 100.0 * (correct_total - correct_kept) / std::max(1, correct_total));
  }
  std::vector<double> ms, prepare, icp, mhpo;
  for (const Probe& p : probes) {
    ms.push_back(p.ms);
    prepare.push_back(p.prepare_ms);
    icp.push_back(p.icp_ms);
    mhpo.push_back(p.mhpo_ms);
  }
  std::printf("\nTrackPose time per solve (ms): total p50 %.1f p95 %.1f; prepare %.1f / %.1f, ICP %.1f / %.1f, MHPO %.1f / %.1f\n",
              Percentile(ms, 0.5), Percentile(ms, 0.95), Percentile(prepare, 0.5), Percentile(prepare, 0.95), Percentile(icp, 0.5),
              Percentile(icp, 0.95), Percentile(mhpo, 0.5), Percentile(mhpo, 0.95));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"g6d-bench-tracking: tracking vs solving every frame on consecutive BOP frames (GT visible masks)"};
  std::string dataset_dir, caches_dir, records_csv;
  int hypotheses = g6d::SolverOptions().num_hypotheses, threads = 2, abrupt_frame = -1, perturb = 0, every = 1;
  double fps = 30.0, max_rotation_deg = 40.0, max_translation_d = 0.3;
  bool no_baseline = false, no_velocity = false;
  std::vector<int> adds_ids, drop_frames;
  g6d::TrackerOptions tracker;
  app.add_option("--dataset", dataset_dir, "BOP dataset folder (models/, test/, ...)")->required();
  app.add_option("--caches", caches_dir, "folder with <obj_XXXXXX>.g6dcache files")->required();
  app.add_option("--hypotheses", hypotheses, "K = N_H of the full solver")->capture_default_str();
  app.add_option("--threads", threads, "threads (including the main one)")->capture_default_str();
  app.add_option("--fps", fps, "frame rate: frame time = im_id / fps")->capture_default_str();
  app.add_option("--abrupt-frame", abrupt_frame, "im_id of an abrupt move: wrong answers are counted before and after it (-1 = none)");
  app.add_option("--adds-ids", adds_ids, "object ids scored with ADD-S besides models_info's symmetric ones")->delimiter(',');
  app.add_option("--drop-frames", drop_frames,
                 "im_ids the tracker never sees, as the frames a busy service drops (e.g. 1,2,3,4,46: the demo's real-time run)")
      ->delimiter(',');
  app.add_flag("--no-baseline", no_baseline, "do not also solve every frame from scratch");
  app.add_option("--records", records_csv, "per-answer CSV");
  app.add_option("--perturb", perturb, "calibration: N TrackPose solves per target from the GT moved at random (0 = sequence mode)");
  app.add_option("--every", every, "--perturb: every N-th target instance only")->capture_default_str();
  app.add_option("--max-rotation-deg", max_rotation_deg, "--perturb: start rotation error at most")->capture_default_str();
  app.add_option("--max-translation-d", max_translation_d, "--perturb: start translation error at most, fraction of d")->capture_default_str();
  app.add_option("--loss-score", tracker.loss_score, "tracked pose lost when S_A is above this")->capture_default_str();
  app.add_option("--min-iou", tracker.min_iou, "tracked pose lost when J is below this")->capture_default_str();
  app.add_option("--appearance-drop", tracker.appearance_drop, "tracked pose lost when its appearance agreement fell by more than this (<= 0: off)")
      ->capture_default_str();
  app.add_option("--redetect-every", tracker.redetect_every, "periodic re-detection after N tracked frames (0 = never)")->capture_default_str();
  app.add_option("--max-age-s", tracker.max_age_s, "tracks expire after this long without an answer")->capture_default_str();
  app.add_option("--min-overlap", tracker.min_overlap, "association: mask / predicted silhouette overlap at least")->capture_default_str();
  app.add_flag("--no-constant-velocity", no_velocity, "start only from the last pose");
  bool redetect_in_frame = false;
  app.add_flag("--redetect-in-frame", redetect_in_frame,
               "periodic re-detections in the frame (default: outside it, as the service runs them in the background, "
               "applied before the next frame)");
  app.add_option("--track-icp-iterations", tracker.solve.icp_iterations, "ICP iterations of a tracked solve")->capture_default_str();
  app.add_option("--track-mhpo-rounds", tracker.solve.mhpo_rounds, "MHPO rounds of a tracked solve")->capture_default_str();
  app.add_option("--track-source-points", tracker.solve.max_source_points, "ICP source points of a tracked solve")->capture_default_str();
  app.add_option("--track-observed-points", tracker.solve.max_observed_points, "observed points of a tracked solve")->capture_default_str();
  bool tracking_off = false;
  app.add_flag("--tracking-off", tracking_off, "every frame detected (the tracker disabled): the single-frame answers");
  CLI11_PARSE(app, argc, argv);
  try {
    if (!(fps > 0.0)) G6D_THROW("--fps must be > 0 (got " << fps << ")");
    if (every < 1) G6D_THROW("--every must be >= 1 (got " << every << ")");
    tracker.constant_velocity = !no_velocity;
    tracker.background_redetect = !redetect_in_frame;
    tracker.enabled = !tracking_off;
    const std::string bad = tracker.Check();
    if (!bad.empty()) G6D_THROW(bad);
    g6d::BopDataset dataset = g6d::LoadBopDataset(dataset_dir);
    if (!dataset.has_targets) G6D_THROW("'" << dataset_dir << "' has no test_targets_bop19.json");
    g6d::SolverOptions solver;
    solver.num_hypotheses = hypotheses;
    Objects objects(dataset, caches_dir, adds_ids);
    g6d::ThreadPool pool(std::max(1, threads));
    std::FILE* records = nullptr;
    if (!records_csv.empty()) {
      records = std::fopen(records_csv.c_str(), "w");
      if (!records) G6D_THROW("cannot write '" << records_csv << "'");
      std::fprintf(records, perturb > 0 ? "scene_id,im_id,obj_id,gt_idx,start_rotation_deg,start_translation_d,success,score,iou,error_d,ms,"
                                          "appearance_valid,appearance,gt_appearance\n"
                                        : "scene_id,im_id,obj_id,gt_idx,mode,track_id,frames_since_detection,lost,periodic,score,"
                                          "error_d,baseline_error_d,tracked_score,tracked_iou,tracked_error_d,track_ms,detect_ms\n");
    }
    const int status = perturb > 0 ? RunPerturb(dataset, dataset_dir, &objects, solver, tracker, perturb, max_rotation_deg,
                                                max_translation_d, every, &pool, records)
                                   : RunSequence(dataset, dataset_dir, &objects, solver, tracker, fps, abrupt_frame, drop_frames,
                                                 !no_baseline, &pool, records);
    if (records) std::fclose(records);
    return status;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-bench-tracking: error: %s\n", e.what());
    return 2;
  }
}
