// The per-frame work of g6d::Service (its declaration and the rest: service.cc): the
// instances of a decoded frame sorted by how they say where their object is, tracked or
// solved over the worker pool, identity searches, detection requests, the frame's
// instances read together (neighbours.h), and the answer published.
#include "service/service.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <set>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "service/service_util.h"
#include "solver/detect.h"
#include "solver/neighbours.h"
#include "solver/region.h"

namespace g6d {

using service_util::Clock;
using service_util::JoinIds;
using service_util::NowUtime;
using service_util::SecondsBetween;

std::optional<pose_estimate_t> Service::SolveInstance(const Job& job, size_t index,
                                                      const Instance& instance,
                                                      const TrackPlan& plan,
                                                      TrackedAnswer* answer) {
  const DecodedInstance& request = job.decoded.instances[index];
  if (abandon_) {
    return MakeFailedEstimate(request, pose_estimate_t::STATUS_INTERNAL_ERROR,
                              "abandoned: the service is shutting down");
  }
  try {
    *answer = SolveWithPlan(job.decoded.frame, instance, *frame_store_->banks.at(instance.object_id),
                            solver_options_, tracker_.options(), plan, pool_.get());
    return std::nullopt;
  } catch (const std::exception& e) {
    return MakeFailedEstimate(request, pose_estimate_t::STATUS_INTERNAL_ERROR,
                              std::string("solver error: ") + e.what());
  } catch (...) {
    return MakeFailedEstimate(request, pose_estimate_t::STATUS_INTERNAL_ERROR,
                              "solver error: unknown exception");
  }
}

BankLookup Service::LoadedBanks() const {
  return [this](const std::string& object_id) -> const TemplateBank* {
    const auto bank = frame_store_->banks.find(object_id);
    return bank == frame_store_->banks.end() ? nullptr : bank->second.get();
  };
}

std::vector<TrackPlan> Service::PlanFrame(const Job& job, double time_s,
                                          const std::vector<Instance>& instances) {
  try {
    return tracker_.Plan(time_s, instances, job.decoded.frame.camera, LoadedBanks());
  } catch (const std::exception& e) {
    // Nothing in planning should throw for a frame that decoded; if it does, this frame
    // is detected from scratch rather than lost.
    spdlog::error("frame seq {}: tracking plan failed ({}); tracks forgotten", job.header.seq,
                  e.what());
    tracker_.Clear();
    std::vector<TrackPlan> plans(instances.size());
    for (size_t i = 0; i < instances.size(); ++i) plans[i].object_id = instances[i].object_id;
    return plans;
  }
}

std::optional<pose_estimate_t> Service::CandidatesOf(const DecodedInstance& request, size_t index,
                                                     std::vector<const TemplateBank*>* banks) const {
  banks->clear();
  if (request.candidate_ids.empty()) {
    for (const auto& [object_id, bank] : frame_store_->banks) banks->push_back(bank.get());
    if (banks->empty()) {
      return MakeFailedEstimate(request, pose_estimate_t::STATUS_UNKNOWN_OBJECT,
                                "instance " + std::to_string(index) +
                                    " (identity unknown): no object is loaded to choose from");
    }
    return std::nullopt;
  }
  for (size_t c = 0; c < request.candidate_ids.size(); ++c) {
    const std::string& id = request.candidate_ids[c];
    const auto bank = frame_store_->banks.find(id);
    if (bank == frame_store_->banks.end()) {
      return MakeFailedEstimate(request, pose_estimate_t::STATUS_UNKNOWN_OBJECT,
                                "instance " + std::to_string(index) + " (identity unknown): candidate '" +
                                    id + "' has no template cache (loaded: " +
                                    JoinIds(frame_store_->ObjectIds()) + ")");
    }
    banks->push_back(bank->second.get());
  }
  return std::nullopt;
}

pose_estimate_t Service::IdentifyInstance(const Job& job, size_t index,
                                          const std::vector<const TemplateBank*>& candidates) {
  const DecodedInstance& request = job.decoded.instances[index];
  if (abandon_) {
    return MakeFailedEstimate(request, pose_estimate_t::STATUS_INTERNAL_ERROR,
                              "abandoned: the service is shutting down");
  }
  try {
    return MakeIdentifiedEstimate(
        request, EstimatePoseOfUnknownObject(job.decoded.frame, request.mask, candidates,
                                             solver_options_, pool_.get()));
  } catch (const std::exception& e) {
    return MakeFailedEstimate(request, pose_estimate_t::STATUS_INTERNAL_ERROR,
                              std::string("identity search error: ") + e.what());
  } catch (...) {
    return MakeFailedEstimate(request, pose_estimate_t::STATUS_INTERNAL_ERROR,
                              "identity search error: unknown exception");
  }
}

std::vector<Service::TrackProbe> Service::MakeTrackProbes(const Job& job, double time_s,
                                                          const std::vector<size_t>& detecting,
                                                          const std::vector<Instance>& masked) const {
  std::vector<TrackProbe> probes;
  if (!options_.tracking.enabled) return probes;
  const Frame& frame = job.decoded.frame;
  const cv::Rect whole(0, 0, frame.camera.width, frame.camera.height);
  std::set<std::string> probed;
  for (const Instance& instance : masked) probed.insert(instance.object_id);
  for (size_t i : detecting) {
    const DecodedInstance& request = job.decoded.instances[i];
    // A masked instance of the object in the same frame takes its tracks (Tracker::Plan by
    // mask overlap); a second request for the object finds it by detection.
    if (request.identity_unknown() || !probed.insert(request.object_id).second) continue;
    const auto bank = frame_store_->banks.find(request.object_id);
    if (bank == frame_store_->banks.end()) continue;
    // The object's live tracks (Plan drops the older ones at this frame time), best first.
    std::vector<const Track*> live;
    for (const Track& track : tracker_.tracks()) {
      if (track.object_id == request.object_id && time_s >= track.time_s &&
          time_s - track.time_s <= options_.tracking.max_age_s) {
        live.push_back(&track);
      }
    }
    std::stable_sort(live.begin(), live.end(),
                     [](const Track* a, const Track* b) { return a->score < b->score; });
    if (static_cast<int>(live.size()) > request.count) live.resize(static_cast<size_t>(request.count));
    for (const Track* track : live) {
      const Eigen::Isometry3d predicted =
          options_.tracking.constant_velocity ? PredictPose(*track, time_s) : track->cam_from_object;
      // The silhouette the track predicts, less what the depth shows hidden: the mask a
      // segmenter would have given, had the object not moved unpredictably.
      cv::Mat mask = CorrectedMask(frame.camera, bank->second->online_mesh, predicted, frame.depth,
                                   solver_options_.score.occlusion_margin_m,
                                   solver_options_.score.cull_backfaces, whole);
      if (cv::countNonZero(mask) < solver_options_.min_valid_depth_pixels) continue;  // hidden or gone
      probes.push_back(TrackProbe{i, Instance{request.object_id, std::move(mask)}});
    }
  }
  return probes;
}

void Service::ExplainNeighbours(const Job& job, const std::vector<Instance>& instances, size_t num_masked,
                                const std::vector<std::optional<pose_estimate_t>>& failures,
                                std::vector<TrackedAnswer>* answers) {
  // The frame's masked (and boxed) instances read together (neighbours.h): a doubtful one
  // is solved again without the pixels its confident neighbours' answers explain.
  std::vector<size_t> solved;
  std::vector<Instance> masked;
  std::vector<const TemplateBank*> banks;
  std::vector<PoseResult> results;
  std::vector<char> detected;  // a tracked answer keeps its pose (and explains its pixels)
  for (size_t k = 0; k < num_masked; ++k) {
    if (failures[k]) continue;
    solved.push_back(k);
    masked.push_back(instances[k]);
    banks.push_back(frame_store_->banks.at(instances[k].object_id).get());
    results.push_back((*answers)[k].result);
    detected.push_back((*answers)[k].from_track ? 0 : 1);
  }
  if (solved.size() < 2 || abandon_) return;
  try {
    ExplainAwayNeighbours(job.decoded.frame, masked, banks, detected, solver_options_, pool_.get(), &results);
  } catch (const std::exception& e) {
    spdlog::warn("frame seq {}: reading the instances together failed ({}); each answer stands", job.header.seq,
                 e.what());
    return;
  }
  for (size_t m = 0; m < solved.size(); ++m) (*answers)[solved[m]].result = std::move(results[m]);
}

TrackedAnswer Service::SolveProbe(const Job& job, const TrackProbe& probe, const TrackPlan& plan,
                                  bool* needs_detection) {
  *needs_detection = true;  // unless the track is accepted
  if (abandon_ || plan.track_id < 0) return TrackedAnswer();
  try {
    return TrackWithPlan(job.decoded.frame, probe.instance,
                         *frame_store_->banks.at(probe.instance.object_id), solver_options_,
                         tracker_.options(), plan, pool_.get(), needs_detection);
  } catch (const std::exception& e) {
    spdlog::warn("frame seq {}: tracking {} without a mask failed: {}", job.header.seq,
                 probe.instance.object_id, e.what());
    *needs_detection = true;
    return TrackedAnswer();
  }
}

void Service::ProcessJob(const Job& job) {
  const Clock::time_point picked = Clock::now();
  TakeStoreForFrame();
  const size_t n = job.decoded.instances.size();
  // The answers of each request instance, in request order: one estimate each, or, for a
  // detection request, one per instance found (request_index says which instance).
  std::vector<std::vector<pose_estimate_t>> answered(n);
  // The instances the solver can take (valid, with a bank) go to the tracker and the
  // solver; instances of unknown identity (valid, every candidate loaded) to the identity
  // search, without the tracker: they are solved in full every frame; detection requests
  // (neither mask nor box) to DetectObjects, all of the frame's in one call, after their
  // objects' tracks were tried. The others are answered here.
  std::vector<size_t> solvable;
  std::vector<Instance> instances;
  std::vector<size_t> searched;
  std::vector<std::vector<const TemplateBank*>> candidates;
  std::vector<size_t> detecting;
  std::vector<std::vector<const TemplateBank*>> detect_banks;
  for (size_t i = 0; i < n; ++i) {
    const DecodedInstance& request = job.decoded.instances[i];
    std::vector<const TemplateBank*> banks;
    if (!request.error.empty()) {
      answered[i] = {MakeFailedEstimate(request, pose_estimate_t::STATUS_BAD_INPUT, request.error)};
    } else if (request.identity_unknown()) {
      if (std::optional<pose_estimate_t> refused = CandidatesOf(request, i, &banks)) {
        answered[i] = {std::move(*refused)};
      } else if (request.detect) {
        detecting.push_back(i);
        detect_banks.push_back(std::move(banks));
      } else {
        searched.push_back(i);
        candidates.push_back(std::move(banks));
      }
    } else if (frame_store_->banks.count(request.object_id) == 0) {
      answered[i] = {MakeFailedEstimate(request, pose_estimate_t::STATUS_UNKNOWN_OBJECT,
                                        "no template cache for object id '" + request.object_id +
                                            "' (loaded: " + JoinIds(frame_store_->ObjectIds()) + ")")};
    } else if (request.detect) {
      detecting.push_back(i);
      detect_banks.push_back({frame_store_->banks.at(request.object_id).get()});
    } else {
      solvable.push_back(i);
      instances.push_back(Instance{request.object_id, request.mask});
    }
  }
  const bool untracked_identity =
      !searched.empty() || std::any_of(detecting.begin(), detecting.end(), [&](size_t i) {
        return job.decoded.instances[i].identity_unknown();
      });
  if (untracked_identity && options_.tracking.enabled && !logged_untracked_identity_) {
    spdlog::info(
        "frame seq {}: instances without an object id are solved in full every frame (the "
        "identity search over the candidates, or detection of each), not tracked",
        job.header.seq);
    logged_untracked_identity_ = true;
  }
  // Frame time from the capture utime: the tracks age with the camera's clock, not with
  // the time the service takes to get to a frame.
  const double time_s = static_cast<double>(job.header.utime) * 1e-6;
  ApplyBackgroundDetections();
  // The detection requests' live tracks are planned with the masked instances, each as
  // the instance its predicted silhouette would be (instances [num_masked, end)).
  const size_t num_masked = instances.size();
  const std::vector<TrackProbe> probes = MakeTrackProbes(job, time_s, detecting, instances);
  for (const TrackProbe& probe : probes) instances.push_back(probe.instance);
  const std::vector<TrackPlan> plans = PlanFrame(job, time_s, instances);
  std::vector<TrackedAnswer> answers(instances.size());
  std::vector<std::optional<pose_estimate_t>> failures(num_masked);
  std::vector<char> probe_lost(probes.size(), 1);
  // Instances fan out over the pool, and each solve fans its hypotheses (or TrackPose
  // starts, or the identity search's candidates' hypotheses) out over the same pool
  // (nested ParallelFor is safe: the caller always takes part).
  const int num_tracked = static_cast<int>(instances.size());
  pool_->ParallelFor(num_tracked + static_cast<int>(searched.size()), [&](int k) {
    if (k < static_cast<int>(num_masked)) {
      failures[k] = SolveInstance(job, solvable[k], instances[k], plans[k], &answers[k]);
    } else if (k < num_tracked) {
      const size_t p = static_cast<size_t>(k) - num_masked;
      bool lost = true;
      answers[k] = SolveProbe(job, probes[p], plans[k], &lost);
      probe_lost[p] = lost ? 1 : 0;
    } else {
      const size_t s = static_cast<size_t>(k - num_tracked);
      answered[searched[s]] = {IdentifyInstance(job, searched[s], candidates[s])};
    }
  });
  // A probe that was not accepted answers nothing: detection runs for its object, near it.
  for (size_t p = 0; p < probes.size(); ++p) {
    if (probe_lost[p]) answers[num_masked + p].result = PoseResult();
  }
  ExplainNeighbours(job, instances, num_masked, failures, &answers);

  // ---- Detection requests: one DetectObjects call for the frame, so that non-maximum
  // suppression spans every requested object.
  const Clock::time_point detect_start = Clock::now();
  // Per detection request and object: the accepted tracked answers and the lost probes.
  auto probes_of = [&](size_t request, const std::string& object_id, bool lost) {
    std::vector<size_t> found;  // indices into answers
    for (size_t p = 0; p < probes.size(); ++p) {
      if (probes[p].request == request && probes[p].instance.object_id == object_id &&
          (probe_lost[p] != 0) == lost && (lost || answers[num_masked + p].result.success)) {
        found.push_back(num_masked + p);
      }
    }
    return found;
  };
  std::vector<DetectRequest> detect_requests;
  std::vector<std::pair<size_t, size_t>> detect_owner;  // (index into detecting, bank)
  for (size_t d = 0; d < detecting.size(); ++d) {
    const DecodedInstance& request = job.decoded.instances[detecting[d]];
    for (size_t b = 0; b < detect_banks[d].size(); ++b) {
      const TemplateBank* bank = detect_banks[d][b];
      const int tracked = static_cast<int>(probes_of(detecting[d], bank->object_id, false).size());
      if (tracked >= request.count) continue;
      DetectRequest detect;
      detect.bank = bank;
      // The whole count: an instance already tracked may be found again, and is dropped below.
      detect.count = request.count;
      const std::vector<size_t> lost = probes_of(detecting[d], bank->object_id, true);
      for (size_t k : lost) {
        if (plans[k].track_id >= 0) {
          detect.near_point_m = plans[k].track.cam_from_object.translation();
          break;
        }
      }
      detect_requests.push_back(detect);
      detect_owner.emplace_back(d, b);
    }
  }
  DetectionReport report;
  std::vector<Detection> detections;
  std::string detect_error;
  if (!detect_requests.empty()) {
    if (abandon_) {
      detect_error = "abandoned: the service is shutting down";
    } else {
      try {
        detections = DetectObjects(job.decoded.frame, detect_requests, solver_options_,
                                   options_.detect, pool_.get(), &report);
      } catch (const std::exception& e) {
        detect_error = std::string("detection error: ") + e.what();
      }
    }
  }
  // The answers kept, best S_A first: at most the count per request and object, none
  // mostly inside an accepted tracked answer of the same object.
  struct Found {
    size_t request = 0;    // index in the frame's instances
    std::string object_id;
    size_t answer = 0;     // index into answers
    cv::Rect box;
    int pixels = 0;
  };
  std::vector<Found> found;
  for (size_t p = 0; p < probes.size(); ++p) {
    const TrackedAnswer& answer = answers[num_masked + p];
    if (probe_lost[p] || !answer.result.success) continue;
    found.push_back(Found{probes[p].request, probes[p].instance.object_id, num_masked + p,
                          cv::boundingRect(probes[p].instance.mask),
                          cv::countNonZero(probes[p].instance.mask)});
  }
  std::vector<Instance> detected_instances;
  std::vector<TrackPlan> detected_plans;
  std::vector<char> continued(plans.size(), 0);
  for (Detection& detection : detections) {
    const auto [d, b] = detect_owner.at(static_cast<size_t>(detection.request));
    const size_t i = detecting[d];
    const DecodedInstance& request = job.decoded.instances[i];
    const TemplateBank& bank = *detect_banks[d][b];
    int kept = 0;
    bool duplicate = false;
    for (const Found& other : found) {
      if (other.request != i || other.object_id != bank.object_id) continue;
      ++kept;
      const cv::Mat& theirs = answers[other.answer].result.corrected_mask;
      const cv::Mat& ours = detection.result.corrected_mask;
      if (!theirs.empty() && !ours.empty() && theirs.size() == ours.size()) {
        const int own = cv::countNonZero(ours);
        cv::Mat both;
        cv::bitwise_and(ours, theirs, both);
        if (own > 0 && cv::countNonZero(both) > options_.detect.max_overlap * own) duplicate = true;
      }
    }
    if (duplicate || kept >= request.count) continue;
    TrackedAnswer answer;
    answer.mode = AnswerMode::kDetected;
    answer.detect_ms = detection.result.stages.total_ms;
    TrackPlan plan;
    plan.object_id = bank.object_id;
    // A lost track of the object nearby (within its diameter) continues as re-detected.
    if (!request.identity_unknown()) {
      double best_m = bank.diameter_m;
      for (size_t k : probes_of(i, bank.object_id, true)) {
        if (continued[k] || plans[k].track_id < 0) continue;
        const double distance_m = (plans[k].track.cam_from_object.translation() -
                                   detection.result.cam_from_object.translation())
                                      .norm();
        if (distance_m < best_m) {
          best_m = distance_m;
          plan = plans[k];
          answer.mode = AnswerMode::kRedetected;
        }
      }
      for (size_t k = num_masked; k < plans.size(); ++k) {
        if (plan.track_id >= 0 && plans[k].track_id == plan.track_id) continued[k] = 1;
      }
    }
    answer.result = std::move(detection.result);
    const Proposal* proposal = detection.proposal >= 0 &&
                                       detection.proposal < static_cast<int>(report.proposals.size())
                                   ? &report.proposals[static_cast<size_t>(detection.proposal)]
                                   : nullptr;
    const cv::Rect box = proposal != nullptr ? proposal->box : cv::boundingRect(detection.region);
    const int pixels = proposal != nullptr ? proposal->pixels : cv::countNonZero(detection.region);
    found.push_back(Found{i, bank.object_id, answers.size(), box, pixels});
    answers.push_back(std::move(answer));
    // Instances without an object id are not tracked (as the identity search's).
    if (request.identity_unknown()) plan.object_id.clear();
    detected_plans.push_back(std::move(plan));
    detected_instances.push_back(Instance{bank.object_id, detection.region});
  }
  const Clock::time_point detect_end = Clock::now();

  // The tracks: the masked instances', the probes' and the detections' answers, in one
  // update (an untracked answer's plan has no object id and is left out).
  std::vector<TrackPlan> update_plans(plans.begin(), plans.end());
  std::vector<Instance> update_instances = instances;
  std::vector<size_t> untracked;  // answers Update must not see
  for (size_t k = 0; k < detected_plans.size(); ++k) {
    if (detected_plans[k].object_id.empty()) untracked.push_back(plans.size() + k);
    update_plans.push_back(detected_plans[k]);
    update_instances.push_back(detected_instances[k]);
  }
  {
    // Update records every successful answer: hide the untracked ones from it.
    std::vector<PoseResult> hidden;
    for (size_t k : untracked) {
      hidden.push_back(std::move(answers[k].result));
      answers[k].result = PoseResult();
    }
    // An abandoned or failed instance's answer is unsolved: Update leaves its track to expire.
    tracker_.Update(time_s, update_plans, LoadedBanks(), &answers);
    for (size_t u = 0; u < untracked.size(); ++u) {
      answers[untracked[u]].result = std::move(hidden[u]);
      answers[untracked[u]].track_id = -1;
    }
  }
  SubmitBackgroundDetections(job, update_instances, answers);
  const Clock::time_point solved = Clock::now();

  // Per-stage time of the full solver summed over the frame's instances (the CPU-side
  // cost of each stage), named and ordered as StageTimes gives them (one list for the
  // service, g6d-solve and the benchmarks); "track" is TrackPose's time summed the same
  // way, and the frame's wall time is "solve" below, as instances are solved in parallel.
  // An answer whose pose came from TrackPose carries TrackPose's stages: they are in
  // "track", not in the solver's stages.
  std::vector<StageTime> sum = StageTimes(StageReport());
  double track_ms = 0.0;
  for (size_t k = 0; k < solvable.size(); ++k) {
    const size_t i = solvable[k];
    const TrackedAnswer& answer = answers[k];
    answered[i] = {failures[k] ? *failures[k] : MakeTrackedEstimate(job.decoded.instances[i], answer)};
    if (failures[k]) continue;
    track_ms += answer.track_ms;
    if (answer.from_track) continue;
    const std::vector<StageTime> times = StageTimes(answer.result.stages);
    for (size_t s = 0; s < sum.size(); ++s) sum[s].ms += times[s].ms;
  }
  for (size_t k = num_masked; k < num_masked + probes.size(); ++k) track_ms += answers[k].track_ms;
  // The detection requests' answers (tracked or found), or why there is none.
  for (const Found& one : found) {
    const DecodedInstance& request = job.decoded.instances[one.request];
    const size_t d = static_cast<size_t>(
        std::find(detecting.begin(), detecting.end(), one.request) - detecting.begin());
    answered[one.request].push_back(MakeFoundEstimate(request, one.object_id, answers[one.answer],
                                                      one.box, one.pixels,
                                                      static_cast<int>(detect_banks[d].size())));
  }
  for (size_t d = 0; d < detecting.size(); ++d) {
    const size_t i = detecting[d];
    if (!answered[i].empty()) continue;
    const DecodedInstance& request = job.decoded.instances[i];
    const std::string name =
        "instance " + std::to_string(i) +
        (request.identity_unknown() ? std::string(" (identity unknown)") : " (" + request.object_id + ")");
    if (!detect_error.empty()) {
      answered[i] = {MakeFailedEstimate(request, pose_estimate_t::STATUS_INTERNAL_ERROR,
                                        name + ": " + detect_error)};
      continue;
    }
    int tried = 0, solved_here = 0;
    for (const CandidateTrial& trial : report.trials) {
      if (detect_owner.at(static_cast<size_t>(trial.request)).first != d) continue;
      ++tried;
      if (trial.solved) ++solved_here;
    }
    std::ostringstream message;
    message << name << ": not found without a mask: " << report.proposals.size()
            << " regions proposed, " << tried << " ranked for it, " << solved_here
            << " solved, none acceptable (S_A <= " << options_.detect.max_score << ", confidence >= "
            << options_.detect.min_confidence << ")";
    if (!report.success) message << "; detection: " << report.message;
    pose_estimate_t none =
        MakeFailedEstimate(request, pose_estimate_t::STATUS_NO_SOLUTION, message.str());
    none.candidates_tried = static_cast<int32_t>(detect_banks[d].size());
    answered[i] = {std::move(none)};
  }
  // The identity searches' solver time (every candidate's solve), summed like "track".
  double identify_s = 0.0;
  for (size_t i : searched) {
    for (const pose_estimate_t& estimate : answered[i]) identify_s += estimate.solve_time_s;
  }
  std::vector<pose_estimate_t> estimates;
  for (std::vector<pose_estimate_t>& some : answered) {
    for (pose_estimate_t& estimate : some) {
      CountAnswer(estimate);
      estimates.push_back(std::move(estimate));
    }
  }
  Timings timings = {{"queue_wait", SecondsBetween(job.queued, picked)}, {"decode", job.decode_s}};
  for (const StageTime& stage : sum) {
    if (std::string(stage.name) != "total") timings.emplace_back(stage.name, stage.ms * 1e-3);
  }
  timings.emplace_back("track", track_ms * 1e-3);
  timings.emplace_back("identify", identify_s);
  // DetectObjects' stages (one call for the frame; its solves fan out over the pool).
  for (const auto& [name, ms] : {std::pair<const char*, double>{"detect_support", report.support_ms},
                                 {"detect_segment", report.segment_ms},
                                 {"detect_propose", report.propose_ms},
                                 {"detect_rank", report.rank_ms},
                                 {"detect_solve", report.solve_ms},
                                 {"detect_select", report.select_ms}}) {
    timings.emplace_back(name, ms * 1e-3);
  }
  timings.emplace_back("detect", detect_requests.empty() ? 0.0 : SecondsBetween(detect_start, detect_end));
  timings.emplace_back("solve", SecondsBetween(picked, solved));
  timings.emplace_back("publish", 0.0);
  pose_array_t answer = MakePoseArray(job.header, pose_array_t::STATUS_OK, "ok",
                                      std::move(estimates), timings, 0.0, 0);
  // "publish" is the time spent building the answer after the solver; total_s runs from
  // the handler's first look at the message to just before it goes on the bus.
  const Clock::time_point now = Clock::now();
  answer.timing_s.back() = SecondsBetween(solved, now);
  answer.total_s = SecondsBetween(job.received, now);
  answer.utime = NowUtime();
  processed_.fetch_add(1);
  RecordLatency(answer.total_s);
  Publish(options_.output_channel, answer);
  if (options_.publish_rigid_transforms) PublishRigidTransforms(answer);
  if (debug_images_) OfferDebugImage(job, answer);
}

}  // namespace g6d
