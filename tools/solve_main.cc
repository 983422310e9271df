// g6d-solve: one frame from image files -> pose, S_A, confidence and the stage report.
// No LCM: the same EstimatePose the service runs. With --candidates the mask's object is
// not known: each candidate cache is tried and the lowest S_A wins. With --find / --find-all
// there is no mask at all: DetectObjects finds the objects in the frame (solver/detect.h).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/executor.h"
#include "render/overlay.h"
#include "solver/detect.h"
#include "solver/identify.h"
#include "solver/pipeline.h"
#include "templates/cache.h"

namespace {

std::vector<double> ParseList(const std::string& text, size_t expected, const std::string& what) {
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    try {
      values.push_back(std::stod(item));
    } catch (const std::exception&) {
      G6D_THROW(what << ": '" << item << "' is not a number");
    }
  }
  if (values.size() != expected) G6D_THROW(what << ": expected " << expected << " comma-separated numbers, got " << values.size());
  return values;
}

cv::Mat ReadImage(const std::string& path, int flags, const std::string& what) {
  cv::Mat image = cv::imread(path, flags);
  if (image.empty()) G6D_THROW(what << ": cannot read image '" << path << "'");
  return image;
}

// The banks of --cache: files, and folders of <id>.g6dcache files (sorted by name).
std::vector<g6d::TemplateBank> ReadCaches(const std::vector<std::string>& paths) {
  std::vector<g6d::TemplateBank> banks;
  for (const std::string& path : paths) {
    if (!std::filesystem::is_directory(path)) {
      banks.push_back(g6d::ReadTemplateCache(path));
      continue;
    }
    std::vector<std::string> files;
    for (const auto& entry : std::filesystem::directory_iterator(path)) {
      if (entry.path().extension() == ".g6dcache") files.push_back(entry.path().string());
    }
    if (files.empty()) G6D_THROW("--cache: no .g6dcache file in the folder '" << path << "'");
    std::sort(files.begin(), files.end());
    for (const std::string& file : files) banks.push_back(g6d::ReadTemplateCache(file));
  }
  return banks;
}

// The caches' object ids, for error messages.
std::string KnownObjects(const std::vector<g6d::TemplateBank>& banks) {
  std::string known;
  for (const g6d::TemplateBank& bank : banks) known += (known.empty() ? "" : ", ") + bank.object_id;
  return known;
}

// The candidates --candidates names among `banks`: "all", or object ids separated by commas.
std::vector<const g6d::TemplateBank*> SelectCandidates(const std::vector<g6d::TemplateBank>& banks,
                                                       const std::string& text) {
  std::vector<const g6d::TemplateBank*> selected;
  if (text == "all") {
    for (const g6d::TemplateBank& bank : banks) selected.push_back(&bank);
    return selected;
  }
  std::stringstream stream(text);
  std::string id;
  while (std::getline(stream, id, ',')) {
    const auto found = std::find_if(banks.begin(), banks.end(),
                                    [&](const g6d::TemplateBank& bank) { return bank.object_id == id; });
    if (found == banks.end()) {
      G6D_THROW("--candidates: no cache given for object '" << id << "' (the caches hold: " << KnownObjects(banks)
                                                              << ")");
    }
    selected.push_back(&*found);
  }
  if (selected.empty()) G6D_THROW("--candidates: no object id in '" << text << "' (give IDs or 'all')");
  return selected;
}

// Draws the model's projected silhouette contour (green) and its axes (x red, y green, z
// blue) on a BGR image: the overlay of the service's debug images (render/overlay.h).
void DrawOverlay(const g6d::TemplateBank& bank, const g6d::Camera& camera, const Eigen::Isometry3d& pose,
                 cv::Mat* bgr) {
  cv::Mat rgb;
  cv::cvtColor(*bgr, rgb, cv::COLOR_BGR2RGB);
  const g6d::OverlayModel model{&bank.online_mesh, bank.bounding_box.center(), bank.diameter_m};
  g6d::DrawPoseOverlay(model, camera, pose, g6d::OverlayStyle(), &rgb);
  cv::cvtColor(rgb, *bgr, cv::COLOR_RGB2BGR);
}

// Prints one answer of EstimatePose (status, flags, pose, S_A, the stage report, times);
// `mask_label` says how the mask was read ("depth", "exact", "region (depth)").
void PrintPose(const g6d::PoseResult& result, const std::string& mask_label) {
  const g6d::StageReport& s = result.stages;
  const Eigen::Quaterniond q(result.cam_from_object.linear());
  const Eigen::Vector3d t = result.cam_from_object.translation();
  std::printf("status      %s (%s)\n", result.success ? "ok" : "failed", g6d::TerminationName(result.termination));
  if (!result.success) std::printf("reason      %s\n", result.message.c_str());
  if (result.truncated) std::printf("truncated   the mask touches the image border: the object is cut off\n");
  if (result.has_runner_up) {
    const Eigen::Isometry3d difference = result.cam_from_object.inverse() * result.runner_up_cam_from_object;
    std::printf("runner-up   S %.4f (S_A + %.4f), %.1f deg and %.1f mm from T_A%s\n", result.runner_up_score,
                result.runner_up_score - result.score, Eigen::AngleAxisd(difference.linear()).angle() * 180.0 / M_PI,
                difference.translation().norm() * 1000.0, result.ambiguous ? ": AMBIGUOUS" : "");
  }
  if (result.appearance_valid) {
    std::printf("appearance  agreement %.3f (ZNCC, model colours vs image)", result.appearance_agreement);
    if (result.runner_up_appearance_valid) std::printf(", runner-up %.3f", result.runner_up_appearance_agreement);
    std::printf("\n");
  }
  std::printf("t (m)       %.4f %.4f %.4f\n", t.x(), t.y(), t.z());
  std::printf("q (wxyz)    %.5f %.5f %.5f %.5f\n", q.w(), q.x(), q.y(), q.z());
  std::printf("S_A         %.4f   confidence %.3f   IoU %.3f   depth residual %.4f\n", result.score,
              result.confidence, result.details.iou, result.details.depth_residual);
  std::printf("stages      features %d | sets %d (best Q %.1f) | PnP %d | kept %d (best E_obs %.3f) | ICP ok %d (best S %.3f) | MHPO best S %.3f\n",
              s.query_features, s.correspondence_sets, s.best_quality, s.pnp_hypotheses, s.kept_hypotheses,
              s.best_e_obs, s.icp_converged, s.best_s_after_icp, result.score);
  if (s.post_refine_ran) std::printf("post-refine %s\n", s.post_refine_accepted ? "accepted (lower S)" : "ran, T_A kept");
  if (result.success) {
    std::printf("mask        %s: %d px given", mask_label.c_str(), s.mask_given_pixels);
    if (s.mask_support_leak + s.mask_far_leak > 0 || s.support_plane) {
      std::printf(", leaks %d on the support plane%s, %d off the object's depth", s.mask_support_leak,
                  s.support_plane ? "" : " (none found)", s.mask_far_leak);
    }
    std::printf("; the answer's mask has IoU %.3f with it%s\n", result.mask_iou,
                result.mask_refined_rounds > 0 ? " (pose refined on it)" : "");
  }
  if (s.depth_regions_solved > 0) {
    std::printf("regions     %s; %d of the depth's regions inside it solved: %s (S on the mask %.3f)\n",
                s.mask_wider_than_object ? "the mask holds more than the object"
                : s.mask_is_box         ? "the mask is a box"
                                        : "the mask's answer was unsure",
                s.depth_regions_solved, s.depth_region_chosen ? "one gave T_A" : "the mask's answer stands",
                s.mask_answer_score);
  }
  std::printf("time (ms)  ");
  for (const g6d::StageTime& stage : g6d::StageTimes(s)) std::printf(" %s %.1f ", stage.name, stage.ms);
  std::printf("\n");
  std::printf("work        PnP sets %d, poses %d (%d merged as equal); ICP iterations %d\n", s.sets_tried,
              s.pnp_hypotheses, s.pnp_merged, s.icp_iterations);
  if (result.cut_short) std::printf("cut short   %s\n", result.message.c_str());
}

// The JSON fields of one answer of EstimatePose (both modes write them).
nlohmann::json PoseJson(const g6d::PoseResult& result, const std::string& mask_trust) {
  const g6d::StageReport& s = result.stages;
  const Eigen::Quaterniond q(result.cam_from_object.linear());
  const Eigen::Vector3d t = result.cam_from_object.translation();
  nlohmann::json j;
  j["success"] = result.success;
  j["termination"] = g6d::TerminationName(result.termination);
  j["message"] = result.message;
  j["position_m"] = {t.x(), t.y(), t.z()};
  j["orientation_wxyz"] = {q.w(), q.x(), q.y(), q.z()};
  j["score"] = result.score;
  j["confidence"] = result.confidence;
  j["iou"] = result.details.iou;
  j["depth_residual"] = result.details.depth_residual;
  j["truncated"] = result.truncated;
  j["ambiguous"] = result.ambiguous;
  if (result.has_runner_up) {
    const Eigen::Quaterniond rq(result.runner_up_cam_from_object.linear());
    const Eigen::Vector3d rt = result.runner_up_cam_from_object.translation();
    j["runner_up"] = {{"score", result.runner_up_score},
                      {"position_m", {rt.x(), rt.y(), rt.z()}},
                      {"orientation_wxyz", {rq.w(), rq.x(), rq.y(), rq.z()}}};
  }
  if (result.appearance_valid) j["appearance_agreement"] = result.appearance_agreement;
  j["stages"] = {{"query_features", s.query_features}, {"correspondence_sets", s.correspondence_sets},
                 {"pnp_hypotheses", s.pnp_hypotheses}, {"kept_hypotheses", s.kept_hypotheses},
                 {"icp_converged", s.icp_converged}, {"best_e_obs", s.best_e_obs},
                 {"best_s_after_icp", s.best_s_after_icp}};
  j["mask"] = {{"trust", mask_trust},
               {"given_pixels", s.mask_given_pixels},
               {"support_plane", s.support_plane},
               {"support_leak_pixels", s.mask_support_leak},
               {"far_leak_pixels", s.mask_far_leak},
               {"surface_tolerance_m", s.surface_tolerance_m},
               {"answer_mask_iou", result.mask_iou},
               {"refined_rounds", result.mask_refined_rounds},
               {"wider_than_object", s.mask_wider_than_object},
               {"is_box", s.mask_is_box},
               {"depth_regions_solved", s.depth_regions_solved},
               {"depth_region_chosen", s.depth_region_chosen},
               {"answer_score_on_mask", s.mask_answer_score}};
  j["cut_short"] = result.cut_short;
  for (const g6d::StageTime& stage : g6d::StageTimes(s)) j["time_ms"][stage.name] = stage.ms;
  return j;
}

// The objects to find: each --find OBJ[:COUNT] (count 1 when not given), or with --find-all
// every cache given once.
std::vector<g6d::DetectRequest> FindRequests(const std::vector<g6d::TemplateBank>& banks,
                                             const std::vector<std::string>& finds, bool find_all) {
  std::vector<g6d::DetectRequest> requests;
  if (find_all) {
    for (const g6d::TemplateBank& bank : banks) requests.push_back({&bank, 1});
    return requests;
  }
  for (const std::string& text : finds) {
    const size_t colon = text.rfind(':');
    const std::string id = text.substr(0, colon);
    int count = 1;
    if (colon != std::string::npos) {
      const std::string count_text = text.substr(colon + 1);
      size_t used = 0;
      try {
        count = std::stoi(count_text, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (count_text.empty() || used != count_text.size()) {
        G6D_THROW("--find " << text << ": the count '" << count_text << "' is not a whole number (OBJ or OBJ:COUNT)");
      }
      if (count < 1) G6D_THROW("--find " << text << ": the count must be >= 1 (got " << count << ")");
    }
    if (id.empty()) G6D_THROW("--find " << text << ": no object id (OBJ or OBJ:COUNT)");
    const auto found = std::find_if(banks.begin(), banks.end(),
                                    [&](const g6d::TemplateBank& bank) { return bank.object_id == id; });
    if (found == banks.end()) {
      G6D_THROW("--find " << text << ": no cache given for object '" << id << "' (the caches hold: " << KnownObjects(banks)
                          << ")");
    }
    for (const g6d::DetectRequest& request : requests) {
      if (request.bank == &*found) G6D_THROW("--find: object '" << id << "' is given twice (ask once, with OBJ:COUNT)");
    }
    requests.push_back({&*found, count});
  }
  return requests;
}

// Why a solved candidate is not an answer (DetectObjects' selection, solver/detect.h).
std::string TrialVerdict(const g6d::CandidateTrial& trial, const std::vector<g6d::Detection>& detections,
                         const g6d::DetectOptions& options) {
  for (size_t d = 0; d < detections.size(); ++d) {
    if (detections[d].request == trial.request && detections[d].proposal == trial.proposal) {
      return "answer " + std::to_string(d + 1);
    }
  }
  if (!trial.success) return "no pose";
  if (trial.score > options.max_score) return "S above the max score";
  return "overlaps a better answer, or the count is full";
}

// Runs DetectObjects on `frame` for `requests` and prints (and writes) what it found and how.
// Returns the exit code: 0 with at least one answer, 3 with none.
int RunFind(const g6d::Frame& frame, const std::vector<g6d::DetectRequest>& requests,
            const g6d::SolverOptions& solver_options, const g6d::DetectOptions& detect_options, g6d::Executor* executor,
            const std::string& overlay_path, const std::string& json_path) {
  g6d::DetectionReport report;
  const std::vector<g6d::Detection> detections =
      g6d::DetectObjects(frame, requests, solver_options, detect_options, executor, &report);
  std::printf("mode        find (no mask):");
  for (const g6d::DetectRequest& request : requests) std::printf(" %s x%d", request.bank->object_id.c_str(), request.count);
  std::printf("\n");
  std::printf("detection   %s: %s\n", report.success ? "ok" : "failed", report.message.c_str());
  std::printf("support     %d plane(s), %d px removed; %d px of concave creases split the rest\n",
              report.support_planes, report.support.empty() ? 0 : cv::countNonZero(report.support),
              report.creases.empty() ? 0 : cv::countNonZero(report.creases));
  std::printf("regions     %zu from %zu segments; %d solved, %d answers, %d suppressed; %d explain-away pass(es)\n",
              report.proposals.size(), report.segmentation.segments.size(), report.solves, report.answers,
              report.suppressed, report.explain_away_passes);
  for (size_t d = 0; d < detections.size(); ++d) {
    const g6d::Detection& detection = detections[d];
    const g6d::Proposal& proposal = report.proposals[static_cast<size_t>(detection.proposal)];
    std::printf("\nanswer %-4zu %s\n", d + 1, detection.object_id.c_str());
    std::printf("region      #%d: box x %d y %d w %d h %d, %d px with depth, %zu segment(s), extent %.1f mm at %.3f m"
                "%s\n",
                detection.proposal, proposal.box.x, proposal.box.y, proposal.box.width, proposal.box.height,
                proposal.pixels, proposal.segments.size(), proposal.extent_m * 1000.0, proposal.depth_m,
                proposal.pass > 0 ? (", explain-away pass " + std::to_string(proposal.pass)).c_str() : "");
    PrintPose(detection.result, "region (depth)");
  }
  std::printf("\n");
  for (size_t r = 0; r < requests.size(); ++r) {
    const int found = static_cast<int>(std::count_if(detections.begin(), detections.end(), [&](const g6d::Detection& d) {
      return d.request == static_cast<int>(r);
    }));
    int ranked = 0, solved = 0;
    for (const g6d::CandidateTrial& trial : report.trials) {
      if (trial.request != static_cast<int>(r)) continue;
      ++ranked;
      solved += trial.solved;
    }
    std::printf("candidates  %s: asked %d, found %d; %d ranked, %d solved\n", requests[r].bank->object_id.c_str(),
                requests[r].count, found, ranked, solved);
    int position = 0;
    for (const g6d::CandidateTrial& trial : report.trials) {
      if (trial.request != static_cast<int>(r)) continue;
      ++position;
      if (!trial.solved) continue;
      const g6d::Proposal& proposal = report.proposals[static_cast<size_t>(trial.proposal)];
      std::printf("  #%-3d pass %d region %-4d box %d,%d %dx%d  %6d px  size %.2f area %.2f colour %.2f rank %.3f  ",
                  position, trial.pass, trial.proposal, proposal.box.x, proposal.box.y, proposal.box.width,
                  proposal.box.height, proposal.pixels, trial.size_term, trial.area_term, trial.colour_term, trial.rank);
      if (trial.success) std::printf("S %.4f conf %.2f region IoU %.2f", trial.score, trial.confidence, trial.region_iou);
      std::printf("  %.1f ms  %s\n", trial.ms, TrialVerdict(trial, detections, detect_options).c_str());
    }
    if (ranked > solved) std::printf("  %d more ranked, not solved\n", ranked - solved);
  }
  std::printf("time (ms)   support %.1f  segment %.1f  propose %.1f  rank %.1f  solve %.1f  select %.1f  total %.1f\n",
              report.support_ms, report.segment_ms, report.propose_ms, report.rank_ms, report.solve_ms, report.select_ms,
              report.total_ms);
  if (!overlay_path.empty()) {
    cv::Mat picture;
    cv::cvtColor(g6d::DrawDetectionPicture(frame, requests, report, detections), picture, cv::COLOR_RGB2BGR);
    if (!cv::imwrite(overlay_path, picture)) G6D_THROW("--overlay: cannot write '" << overlay_path << "'");
    std::printf("overlay     %s\n", overlay_path.c_str());
  }
  if (!json_path.empty()) {
    nlohmann::json j;
    j["mode"] = "find";
    j["success"] = !detections.empty();
    j["message"] = report.message;
    j["answers"] = nlohmann::json::array();
    for (const g6d::Detection& detection : detections) {
      const g6d::Proposal& proposal = report.proposals[static_cast<size_t>(detection.proposal)];
      nlohmann::json answer = PoseJson(detection.result, "depth");
      answer["object_id"] = detection.object_id;
      answer["region"] = {{"proposal", detection.proposal},
                          {"pass", proposal.pass},
                          {"box", {proposal.box.x, proposal.box.y, proposal.box.width, proposal.box.height}},
                          {"pixels", proposal.pixels},
                          {"segments", proposal.segments.size()},
                          {"extent_m", proposal.extent_m},
                          {"depth_m", proposal.depth_m}};
      j["answers"].push_back(answer);
    }
    j["objects"] = nlohmann::json::array();
    for (size_t r = 0; r < requests.size(); ++r) {
      nlohmann::json candidates = nlohmann::json::array();
      int position = 0, found = 0;
      for (const g6d::Detection& detection : detections) found += detection.request == static_cast<int>(r);
      for (const g6d::CandidateTrial& trial : report.trials) {
        if (trial.request != static_cast<int>(r)) continue;
        nlohmann::json entry = {{"position", ++position}, {"pass", trial.pass}, {"proposal", trial.proposal},
                                {"size_term", trial.size_term}, {"area_ratio", trial.area_ratio},
                                {"area_term", trial.area_term}, {"shape_term", trial.shape_term},
                                {"colour_term", trial.colour_term}, {"rank", trial.rank}, {"solved", trial.solved}};
        if (trial.solved) {
          entry["success"] = trial.success;
          entry["score"] = trial.success ? nlohmann::json(trial.score) : nlohmann::json();
          entry["region_iou"] = trial.region_iou;
          entry["confidence"] = trial.success ? nlohmann::json(trial.confidence) : nlohmann::json();
          entry["ms"] = trial.ms;
          entry["verdict"] = TrialVerdict(trial, detections, detect_options);
        }
        candidates.push_back(entry);
      }
      j["objects"].push_back({{"object_id", requests[r].bank->object_id},
                              {"count", requests[r].count},
                              {"found", found},
                              {"candidates", candidates}});
    }
    j["detection"] = {{"success", report.success},
                      {"support_planes", report.support_planes},
                      {"support_pixels", report.support.empty() ? 0 : cv::countNonZero(report.support)},
                      {"creases_pixels", report.creases.empty() ? 0 : cv::countNonZero(report.creases)},
                      {"segments", report.segmentation.segments.size()},
                      {"explain_away_passes", report.explain_away_passes},
                      {"regions", report.proposals.size()},
                      {"solves", report.solves},
                      {"answers", report.answers},
                      {"suppressed", report.suppressed},
                      {"options",
                       {{"extra_candidates", detect_options.extra_candidates},
                        {"colour_weight", detect_options.colour_weight},
                        {"max_score", detect_options.max_score}}}};
    j["time_ms"] = {{"support", report.support_ms}, {"segment", report.segment_ms}, {"propose", report.propose_ms},
                    {"rank", report.rank_ms},       {"solve", report.solve_ms},     {"select", report.select_ms},
                    {"total", report.total_ms}};
    std::ofstream out(json_path);
    if (!out) G6D_THROW("--json: cannot write '" << json_path << "'");
    out << j.dump(2) << "\n";
  }
  if (detections.empty()) std::printf("reason      no answer: %s\n", report.message.c_str());
  return detections.empty() ? 3 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"g6d-solve: estimate one object's 6D pose from RGB-D + mask files, or find known objects without a mask"};
  std::string rgb_path, depth_path, mask_path, k_text, overlay_path, json_path, candidates_text;
  std::vector<std::string> cache_paths;
  double depth_scale_mm = 1.0;
  int hypotheses = g6d::SolverOptions().num_hypotheses, threads = 2;
  bool no_mhpo = false;
  app.add_option("--cache", cache_paths,
                 "template cache file (g6d-build-templates), or a folder of them; repeat it to give several "
                 "(with --candidates, --find or --find-all)")
      ->required();
  app.add_option("--candidates", candidates_text,
                 "the mask's object is not known: try these objects (IDs separated by commas, or 'all' for every "
                 "cache given); the lowest S_A wins, and the runner-up object is reported");
  bool no_prescreen = false;
  app.add_flag("--no-prescreen", no_prescreen,
               "with --candidates: solve every candidate (do not rule out objects shorter than the mask's depth "
               "extent)");
  app.add_option("--rgb", rgb_path, "colour image (PNG/JPEG)")->required();
  app.add_option("--depth", depth_path, "16-bit depth PNG")->required();
  app.add_option("--depth-scale", depth_scale_mm, "millimetres per depth unit (BOP depth_scale)")->capture_default_str();
  app.add_option("--mask", mask_path,
                 "8-bit instance mask PNG (non-zero = object); without it give --find or --find-all");
  std::vector<std::string> finds;
  bool find_all = false;
  g6d::DetectOptions detect_options;
  app.add_option("--find", finds,
                 "no mask: find this object (OBJ or OBJ:COUNT, at most COUNT instances, default 1) in the frame; "
                 "repeat it for several objects (each needs its --cache)");
  app.add_flag("--find-all", find_all, "no mask: find one instance of every object whose cache is given");
  app.add_option("--detect-extra", detect_options.extra_candidates,
                 "--find: candidate regions solved per object beyond its count")
      ->capture_default_str();
  app.add_option("--detect-colour-weight", detect_options.colour_weight,
                 "--find: weight of the colour agreement against the size agreement in the ranking of regions, "
                 "[0, 1] (0 = size only)")
      ->capture_default_str();
  app.add_option("--detect-max-score", detect_options.max_score,
                 "--find: an answer whose S_A is above this is no answer")
      ->capture_default_str();
  app.add_option("--K", k_text, "intrinsics fx,fy,cx,cy in pixels (pixel centres at +0.5)")->required();
  app.add_option("--hypotheses", hypotheses, "K = N_H, hypotheses refined by ICP and MHPO")->capture_default_str();
  app.add_option("--threads", threads, "worker threads")->capture_default_str();
  double budget_ms = 0.0;
  app.add_option("--budget-ms", budget_ms, "time budget of the solve, ms (0 = none): when it runs out the best pose so far is returned, marked cut short")->check(CLI::NonNegativeNumber);
  app.add_flag("--no-mhpo", no_mhpo, "skip MHPO (ablation)");
  bool no_silhouettes = false;
  app.add_flag("--no-silhouettes", no_silhouettes, "no poses from the mask's outline (ablation)");
  bool post_refine = false, allow_border = false, reject_border = false;
  std::string mask_trust = g6d::MaskTrustName(g6d::SolverOptions().mask_trust);
  app.add_option("--mask-trust", mask_trust,
                 "how the mask is read: depth (evidence: leaks onto the table, the background and occluders removed, "
                 "object the mask missed counted by the depth) or exact (the paper's: every mask pixel is object)")
      ->check(CLI::IsMember({"depth", "exact"}))
      ->capture_default_str();
  app.add_flag("--post-refine", post_refine, "optional stage 6: retry a poor pose from flipped / re-centred hypotheses");
  app.add_flag("--allow-border-masks", allow_border, "solve a mask that touches the image border (the default; kept for old scripts)");
  app.add_flag("--reject-border-masks", reject_border, "refuse a mask that touches the image border (a truncated object)");
  app.add_option("--overlay", overlay_path, "write the image with the projected model contour and axes");
  app.add_option("--json", json_path, "write the result as JSON");
  std::string corrected_mask_path;
  app.add_option("--corrected-mask", corrected_mask_path,
                 "write the mask the answer implies (its silhouette less what the depth shows hidden) as a PNG");
  CLI11_PARSE(app, argc, argv);

  try {
    const std::vector<double> k = ParseList(k_text, 4, "--K");
    const bool find_mode = !finds.empty() || find_all;
    if (find_mode) {
      const std::string find_flag = finds.empty() ? "--find-all" : "--find";
      if (!finds.empty() && find_all) G6D_THROW("--find and --find-all contradict each other: give one of them");
      // The flags of a mask contradict finding the objects without one.
      const std::pair<bool, const char*> mask_flags[] = {{!mask_path.empty(), "--mask"},
                                                         {!candidates_text.empty(), "--candidates"},
                                                         {no_prescreen, "--no-prescreen"},
                                                         {!corrected_mask_path.empty(), "--corrected-mask"},
                                                         {mask_trust == "exact", "--mask-trust exact"}};
      for (const auto& [given, flag] : mask_flags) {
        if (given) {
          G6D_THROW(find_flag << " finds the objects without a mask: " << flag
                              << " cannot be given with it (drop one of them)");
        }
      }
      if (detect_options.extra_candidates < 0) {
        G6D_THROW("--detect-extra must be >= 0 (got " << detect_options.extra_candidates << ")");
      }
      if (!(detect_options.colour_weight >= 0.0 && detect_options.colour_weight <= 1.0)) {
        G6D_THROW("--detect-colour-weight must be in [0, 1] (got " << detect_options.colour_weight << ")");
      }
      if (!(detect_options.max_score > 0.0)) {
        G6D_THROW("--detect-max-score must be > 0 (got " << detect_options.max_score << ")");
      }
    } else {
      if (mask_path.empty()) {
        G6D_THROW("no mask: give --mask FILE (the object's pixels), or --find OBJ[:COUNT] / --find-all to find the "
                  "objects in the frame without one");
      }
      for (const char* flag : {"--detect-extra", "--detect-colour-weight", "--detect-max-score"}) {
        if (app.count(flag) > 0) G6D_THROW(flag << " needs --find or --find-all");
      }
    }
    const std::vector<g6d::TemplateBank> banks = ReadCaches(cache_paths);
    const bool unknown_identity = !candidates_text.empty();
    std::vector<g6d::DetectRequest> requests;           // --find, --find-all
    std::vector<const g6d::TemplateBank*> candidates;  // --mask
    if (find_mode) {
      requests = FindRequests(banks, finds, find_all);
    } else {
      if (!unknown_identity && banks.size() != 1) {
        G6D_THROW(banks.size() << " caches given: with several, pass --candidates all (or ID1,ID2,...) to choose the "
                               "object among them, or --find / --find-all to find them without a mask");
      }
      if (!unknown_identity && no_prescreen) G6D_THROW("--no-prescreen needs --candidates");
      candidates =
          unknown_identity ? SelectCandidates(banks, candidates_text) : std::vector<const g6d::TemplateBank*>{&banks[0]};
    }
    const cv::Mat bgr = ReadImage(rgb_path, cv::IMREAD_COLOR, "--rgb");
    const cv::Mat depth_raw = ReadImage(depth_path, cv::IMREAD_ANYDEPTH, "--depth");
    if (depth_raw.type() != CV_16U) G6D_THROW("--depth: '" << depth_path << "' is not a 16-bit image");
    if (depth_raw.size() != bgr.size()) {
      G6D_THROW("--depth: '" << depth_path << "' is " << depth_raw.cols << "x" << depth_raw.rows
                             << " pixels, the colour image " << bgr.cols << "x" << bgr.rows);
    }
    g6d::Frame frame;
    frame.camera = {k[0], k[1], k[2], k[3], bgr.cols, bgr.rows};
    cv::cvtColor(bgr, frame.rgb, cv::COLOR_BGR2RGB);
    depth_raw.convertTo(frame.depth, CV_32F, depth_scale_mm / 1000.0);

    g6d::SolverOptions options;
    options.num_hypotheses = hypotheses;
    options.budget_ms = budget_ms;
    options.run_mhpo = !no_mhpo;
    options.use_silhouettes = !no_silhouettes;
    options.post_refine = post_refine;
    options.mask_trust = g6d::ParseMaskTrust(mask_trust);
    if (allow_border && reject_border) G6D_THROW("--allow-border-masks and --reject-border-masks contradict each other");
    options.reject_border_masks = reject_border;
    g6d::ThreadPool pool(std::max(1, threads));
    if (find_mode) return RunFind(frame, requests, options, detect_options, &pool, overlay_path, json_path);

    const cv::Mat mask_raw = ReadImage(mask_path, cv::IMREAD_GRAYSCALE, "--mask");
    g6d::IdentifiedPose identified;
    if (unknown_identity) {
      g6d::IdentifyOptions identify_options;
      identify_options.prescreen = !no_prescreen;
      identified = g6d::EstimatePoseOfUnknownObject(frame, mask_raw, candidates, options, identify_options, &pool);
    } else {
      identified.result = g6d::EstimatePose(frame, {banks[0].object_id, mask_raw}, banks[0], options, &pool);
      identified.object_id = banks[0].object_id;
    }
    const g6d::PoseResult& result = identified.result;
    // The chosen object's bank (the overlay draws it); null when no candidate was solved.
    const g6d::TemplateBank* chosen = nullptr;
    for (const g6d::TemplateBank* bank : candidates) {
      if (bank->object_id == identified.object_id) chosen = bank;
    }
    std::printf("object      %s\n", chosen != nullptr ? chosen->object_id.c_str() : "(none)");
    if (unknown_identity) {
      std::printf("identity    %zu candidates in %.1f ms", identified.candidates.size(), identified.total_ms);
      if (chosen != nullptr) std::printf(": %s S %.4f", chosen->object_id.c_str(), result.score);
      if (!identified.runner_up_id.empty()) {
        std::printf(", runner-up %s S %.4f (+%.4f)%s", identified.runner_up_id.c_str(), identified.runner_up_score,
                    identified.runner_up_score - result.score, identified.ambiguous ? ": AMBIGUOUS" : "");
      }
      if (identified.screened_out > 0) std::printf(", %d screened out", identified.screened_out);
      std::printf("\n");
      for (const g6d::IdentityCandidate& candidate : identified.candidates) {
        std::printf("  candidate %-14s %7.1f ms  ", candidate.object_id.c_str(), candidate.ms);
        if (candidate.success) {
          std::printf("S %.4f\n", candidate.score);
        } else {
          std::printf("%s\n", candidate.message.c_str());
        }
      }
    }
    PrintPose(result, mask_trust);
    if (!overlay_path.empty()) {
      cv::Mat overlay = bgr.clone();
      if (result.success && chosen != nullptr) DrawOverlay(*chosen, frame.camera, result.cam_from_object, &overlay);
      if (!cv::imwrite(overlay_path, overlay)) G6D_THROW("--overlay: cannot write '" << overlay_path << "'");
      std::printf("overlay     %s\n", overlay_path.c_str());
    }
    if (!corrected_mask_path.empty() && result.success) {
      if (!cv::imwrite(corrected_mask_path, result.corrected_mask)) {
        G6D_THROW("--corrected-mask: cannot write '" << corrected_mask_path << "'");
      }
      std::printf("mask out    %s\n", corrected_mask_path.c_str());
    }
    if (!json_path.empty()) {
      nlohmann::json j;
      j["object_id"] = chosen != nullptr ? chosen->object_id : "";
      if (unknown_identity) {
        nlohmann::json tried = nlohmann::json::array();
        for (const g6d::IdentityCandidate& candidate : identified.candidates) {
          nlohmann::json entry = {{"object_id", candidate.object_id}, {"success", candidate.success},
                                  {"screened_out", candidate.screened_out}, {"ms", candidate.ms},
                                  {"message", candidate.message}, {"diameter_m", candidate.diameter_m}};
          if (candidate.success) entry["score"] = candidate.score;
          if (candidate.extent_m > 0.0) entry["mask_extent_m"] = candidate.extent_m;
          tried.push_back(entry);
        }
        j["identity"] = {{"chosen", identified.object_id},
                         {"score", result.success ? nlohmann::json(result.score) : nlohmann::json()},
                         {"runner_up", identified.runner_up_id},
                         {"runner_up_score", identified.runner_up_id.empty() ? nlohmann::json()
                                                                            : nlohmann::json(identified.runner_up_score)},
                         {"ambiguous", identified.ambiguous},
                         {"screened_out", identified.screened_out},
                         {"total_ms", identified.total_ms},
                         {"candidates", tried}};
      }
      j.update(PoseJson(result, mask_trust));
      std::ofstream out(json_path);
      if (!out) G6D_THROW("--json: cannot write '" << json_path << "'");
      out << j.dump(2) << "\n";
    }
    return result.success ? 0 : 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-solve: error: %s\n", e.what());
    return 2;
  }
}
