#include "replay.h"


#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <tuple>

#include "core/error.h"
#include "eval/bop.h"
#include "frame_log.h"
#include "wire/answer.h"
#include "wire/lcm_loop.h"
#include "wire/names.h"

namespace g6d {
namespace {

using Clock = std::chrono::steady_clock;

int64_t WallClockUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// The frames sent so far and their answers, shared by the sending thread and the LCM
// handle thread.
class AnswerCollector {
 public:
  // by_utime: answers are matched by the frame utime alone (foreign input types: their
  // answers carry no source and, for bot_core, the service's own seq).
  AnswerCollector(std::string results_channel, bool by_utime)
      : results_channel_(std::move(results_channel)), by_utime_(by_utime) {}

  // Registers a frame before it is published (so its answer cannot arrive first).
  size_t Expect(const ReplayedFrame& frame) {
    std::lock_guard<std::mutex> lock(mutex_);
    index_[Key(frame.source, frame.seq, frame.sent_utime)] = frames_.size();
    frames_.push_back(frame);
    sent_at_.push_back(Clock::now());
    return frames_.size() - 1;
  }

  // LCM handler. It is called from C, so nothing may escape it; only allocation can throw
  // here, and running out of memory is not something to recover from.
  void Handle(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
    const Clock::time_point now = Clock::now();
    pose_array_t answer;
    const bool decoded = answer.decode(buffer->data, 0, static_cast<int>(buffer->data_size)) >= 0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (channel != results_channel_) return;  // subscribe() takes a regex; be exact
      if (!decoded) {
        ++undecodable_answers_;
        return;
      }
      const auto it = index_.find(Key(answer.source, answer.seq, answer.source_utime));
      if (it == index_.end()) {
        ++unmatched_;
        return;
      }
      ReplayedFrame& frame = frames_[it->second];
      if (frame.answered) {
        ++duplicates_;
        return;
      }
      frame.answered = true;
      frame.latency_s = std::chrono::duration<double>(now - sent_at_[it->second]).count();
      frame.answer = std::move(answer);
      ++answered_;
    }
    changed_.notify_all();
  }

  // Waits until frame `index` is answered or `deadline` passes; true when answered.
  bool WaitAnswered(size_t index, Clock::time_point deadline) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_until(lock, deadline, [&] { return frames_[index].answered; });
  }

  // Waits until the answer count differs from `seen`, everything sent is answered, or
  // `deadline` passes; returns the answer count.
  int64_t WaitForAnswers(int64_t seen, Clock::time_point deadline) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait_until(lock, deadline, [&] {
      return answered_ != seen || answered_ == static_cast<int64_t>(frames_.size());
    });
    return answered_;
  }

  bool AllAnswered() {
    std::lock_guard<std::mutex> lock(mutex_);
    return answered_ == static_cast<int64_t>(frames_.size());
  }

  ReplayProgress Progress(int64_t total, const ReplayedFrame* last) {
    std::lock_guard<std::mutex> lock(mutex_);
    ReplayProgress progress;
    progress.sent = static_cast<int64_t>(frames_.size());
    progress.answered = answered_;
    progress.total = total;
    progress.last = last;
    return progress;
  }

  // A copy of one frame's record (the handle thread may still write to the original).
  ReplayedFrame Frame(size_t index) {
    std::lock_guard<std::mutex> lock(mutex_);
    return frames_[index];
  }

  // Moves the records out; call after the handle thread has stopped.
  void TakeResults(ReplayReport* report) {
    std::lock_guard<std::mutex> lock(mutex_);
    report->frames = std::move(frames_);
    report->unmatched_answers = unmatched_ + undecodable_answers_;
    report->duplicate_answers = duplicates_;
  }

 private:
  std::tuple<std::string, int64_t, int64_t> Key(const std::string& source, int64_t seq,
                                                int64_t utime) const {
    if (by_utime_) return {"", 0, utime};
    return {source, seq, utime};
  }

  const std::string results_channel_;
  const bool by_utime_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<ReplayedFrame> frames_;
  std::vector<Clock::time_point> sent_at_;
  std::map<std::tuple<std::string, int64_t, int64_t>, size_t> index_;
  int64_t answered_ = 0;
  int64_t unmatched_ = 0;
  int64_t undecodable_answers_ = 0;
  int64_t duplicates_ = 0;
};

// Unsubscribes when it goes out of scope.
class SubscriptionGuard {
 public:
  SubscriptionGuard(lcm::LCM* lcm, lcm::Subscription* subscription)
      : lcm_(lcm), subscription_(subscription) {}
  ~SubscriptionGuard() { lcm_->unsubscribe(subscription_); }
  SubscriptionGuard(const SubscriptionGuard&) = delete;
  SubscriptionGuard& operator=(const SubscriptionGuard&) = delete;

 private:
  lcm::LCM* lcm_;
  lcm::Subscription* subscription_;
};

// Remembers the first status of the wanted service.
class StatusWaiter {
 public:
  explicit StatusWaiter(std::string input_channel) : input_channel_(std::move(input_channel)) {}

  void Handle(const lcm::ReceiveBuffer*, const std::string&, const service_status_t* status) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (seen_ || (!input_channel_.empty() && status->input_channel != input_channel_)) return;
      status_ = *status;
      seen_ = true;
    }
    seen_changed_.notify_all();
  }

  bool Wait(std::chrono::milliseconds timeout, service_status_t* status) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!seen_changed_.wait_for(lock, timeout, [&] { return seen_; })) return false;
    if (status != nullptr) *status = status_;
    return true;
  }

 private:
  const std::string input_channel_;
  std::mutex mutex_;
  std::condition_variable seen_changed_;
  bool seen_ = false;
  service_status_t status_;
};

ReplayedFrame Describe(const rgbd_frame_t& frame) {
  ReplayedFrame record;
  record.seq = frame.seq;
  record.source = frame.source;
  record.scene_id = frame.scene_id;
  record.image_id = frame.image_id;
  record.instances = frame.num_instances;
  record.sent_utime = frame.utime;
  return record;
}

// Counts, percentiles and the final verdict from the per-frame records.
void Summarize(const ReplayOptions& options, ReplayReport* report) {
  std::vector<double> latencies, service_times;
  const double timeout_s = options.timeout_ms / 1000.0;
  for (ReplayedFrame& frame : report->frames) {
    ++report->sent;
    frame.timed_out = !frame.answered || frame.latency_s > timeout_s;
    report->timed_out += frame.timed_out;
    if (!frame.answered) {
      ++report->lost;
      continue;
    }
    ++report->answered;
    report->late += frame.timed_out;
    latencies.push_back(frame.latency_s);
    service_times.push_back(frame.answer.total_s);
    if (frame.answer.status == pose_array_t::STATUS_BAD_FRAME) ++report->rejected;
    for (const pose_estimate_t& estimate : frame.answer.estimates) {
      ++report->estimates;
      ++report->estimates_by_status[EstimateStatusName(estimate.status)];
      if (estimate.status == pose_estimate_t::STATUS_OK)
        ++report->estimates_by_mode[EstimateModeName(estimate.mode)];
    }
  }
  report->latency_p50_s = Percentile(latencies, 0.5);
  report->latency_p95_s = Percentile(latencies, 0.95);
  report->latency_max_s = Percentile(latencies, 1.0);
  report->service_p50_s = Percentile(service_times, 0.5);
  report->service_p95_s = Percentile(service_times, 0.95);
  report->service_max_s = Percentile(service_times, 1.0);
  report->success = report->sent > 0 && report->lost == 0;
  if (report->sent == 0) {
    report->message = "no frame was sent";
  } else if (report->lost > 0) {
    report->message = std::to_string(report->lost) + " of " + std::to_string(report->sent) +
                      " frame(s) got no answer on " + options.results_channel +
                      " (is g6d-service running on the same LCM URL and channels?)";
  } else {
    report->message = "ok";
  }
}

}  // namespace

std::string ReplayOptions::Check() const {
  if (channel.empty()) return "channel must not be empty";
  if (results_channel.empty()) return "results_channel must not be empty";
  if (results_channel == channel) return "results_channel must differ from channel";
  if (mode == ReplayMode::kRate && !(rate_hz > 0.0 && std::isfinite(rate_hz))) {
    return "rate_hz must be finite and > 0, got " + std::to_string(rate_hz);
  }
  if (timeout_ms <= 0) return "timeout_ms must be > 0, got " + std::to_string(timeout_ms);
  return "";
}

void ParseReplayMode(const std::string& text, ReplayOptions* options) {
  if (text == "wait") {
    options->mode = ReplayMode::kWait;
    return;
  }
  if (text == "realtime") {
    options->mode = ReplayMode::kRealtime;
    return;
  }
  const std::string prefix = "rate:";
  if (text.compare(0, prefix.size(), prefix) == 0) {
    const std::string number = text.substr(prefix.size());
    char* end = nullptr;
    const double hz = std::strtod(number.c_str(), &end);
    if (!number.empty() && end == number.c_str() + number.size() && hz > 0.0 && std::isfinite(hz)) {
      options->mode = ReplayMode::kRate;
      options->rate_hz = hz;
      return;
    }
  }
  G6D_THROW("replay mode '" << text << "' is not one of wait, realtime, rate:HZ (HZ > 0)");
}

std::string ReplayModeName(const ReplayOptions& options) {
  switch (options.mode) {
    case ReplayMode::kWait:
      return "wait";
    case ReplayMode::kRealtime:
      return "realtime";
    case ReplayMode::kRate: {
      std::ostringstream text;
      text << "rate:" << options.rate_hz;
      return text.str();
    }
  }
  return "unknown";
}

void WriteAnswersLog(const std::string& path, const std::string& channel,
                     const std::vector<ReplayedFrame>& frames) {
  lcm::LogFile log(path, "w");
  if (!log.good()) G6D_THROW("cannot write the answers log '" << path << "'");
  int64_t number = 0;
  for (const ReplayedFrame& frame : frames) {
    if (!frame.answered) continue;
    std::vector<uint8_t> bytes(static_cast<size_t>(frame.answer.getEncodedSize()));
    G6D_CHECK(frame.answer.encode(bytes.data(), 0, static_cast<int>(bytes.size())) >= 0);
    lcm::LogEvent event;
    event.eventnum = number++;
    event.timestamp = frame.answer.utime;
    event.channel = channel;
    event.datalen = static_cast<int32_t>(bytes.size());
    event.data = bytes.data();
    if (log.writeEvent(&event) != 0) G6D_THROW("cannot write to the answers log '" << path << "'");
  }
}

ReplayReport RunReplay(const ReplayOptions& options, FrameLogReader* reader, lcm::LCM* lcm,
                       int64_t total_frames, const ReplayProgressCallback& progress) {
  const std::string bad = options.Check();
  if (!bad.empty()) G6D_THROW("replay options: " << bad);
  if (!lcm->good()) G6D_THROW("the LCM instance is not usable (bad URL or no network?)");
  const Clock::time_point start = Clock::now();
  const auto timeout = std::chrono::milliseconds(options.timeout_ms);
  auto report_progress = [&](AnswerCollector& collector, const ReplayedFrame* last) {
    if (progress) progress(collector.Progress(total_frames, last));
  };

  const bool foreign = options.input_type != InputType::kG6d;
  AnswerCollector collector(options.results_channel, /*by_utime=*/foreign);
  ReplayReport report;
  {
    // Destroyed in reverse order: the handle thread stops before the handler goes away.
    const SubscriptionGuard subscription(
        lcm, lcm->subscribe(options.results_channel, &AnswerCollector::Handle, &collector));
    LcmHandleThread handle_thread(lcm);
    FrameEvent event;
    int64_t first_timestamp_us = 0;
    int64_t answered_seen = 0;
    Clock::time_point last_send = start;
    for (int64_t index = 0; reader->Next(&event); ++index) {
      if (index == 0) first_timestamp_us = event.timestamp_us;
      if (options.mode != ReplayMode::kWait) {
        // Sleep until the send time, waking for every answer to report progress.
        const double offset_s =
            options.mode == ReplayMode::kRealtime
                ? std::max<double>(0.0, 1e-6 * (event.timestamp_us - first_timestamp_us))
                : index / options.rate_hz;
        const Clock::time_point send_at = start + std::chrono::duration_cast<Clock::duration>(
                                                      std::chrono::duration<double>(offset_s));
        while (Clock::now() < send_at) {
          const int64_t answered = collector.WaitForAnswers(answered_seen, send_at);
          if (answered != answered_seen) report_progress(collector, nullptr);
          answered_seen = answered;
        }
      }
      // A g6d frame gets the send time as utime (so stale checks and latency see now); a
      // foreign message goes out byte for byte as logged, matched by its own utime.
      if (!foreign) event.frame.utime = WallClockUtime();
      const size_t slot = collector.Expect(Describe(event.frame));
      last_send = Clock::now();
      if (foreign) {
        if (lcm->publish(options.channel, event.raw.data(), static_cast<unsigned int>(event.raw.size())) != 0)
          G6D_THROW("cannot publish event " << event.event_number << " on " << options.channel);
      } else if (lcm->publish(options.channel, &event.frame) != 0) {
        G6D_THROW("cannot publish frame seq " << event.frame.seq << " on " << options.channel
                                              << " (message of " << event.frame.getEncodedSize()
                                              << " bytes)");
      }
      if (options.mode == ReplayMode::kWait) {
        collector.WaitAnswered(slot, last_send + timeout);
        const ReplayedFrame record = collector.Frame(slot);
        report_progress(collector, &record);
      } else {
        report_progress(collector, nullptr);
      }
    }
    // The timed modes (and a wait-mode frame that timed out just now) may still have
    // answers in flight: wait for them up to the timeout after the last send.
    const Clock::time_point deadline = last_send + timeout;
    while (!collector.AllAnswered() && Clock::now() < deadline) {
      const int64_t answered = collector.WaitForAnswers(answered_seen, deadline);
      if (answered != answered_seen) report_progress(collector, nullptr);
      answered_seen = answered;
    }
  }
  collector.TakeResults(&report);
  Summarize(options, &report);
  report.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  return report;
}

bool WaitForService(lcm::LCM* lcm, const std::string& status_channel,
                    const std::string& input_channel, int timeout_ms, service_status_t* status) {
  if (!lcm->good()) G6D_THROW("the LCM instance is not usable (bad URL or no network?)");
  StatusWaiter waiter(input_channel);
  const SubscriptionGuard subscription(
      lcm, lcm->subscribe(status_channel, &StatusWaiter::Handle, &waiter));
  LcmHandleThread handle_thread(lcm);
  return waiter.Wait(std::chrono::milliseconds(std::max(0, timeout_ms)), status);
}

std::vector<BopEstimate> AnswersToBopEstimates(const std::vector<ReplayedFrame>& frames,
                                               int64_t* skipped_ids) {
  std::vector<BopEstimate> rows;
  int64_t skipped = 0;
  for (const ReplayedFrame& frame : frames) {
    if (!frame.answered) continue;
    const pose_array_t& answer = frame.answer;
    for (const pose_estimate_t& estimate : answer.estimates) {
      if (estimate.status != pose_estimate_t::STATUS_OK) continue;
      BopEstimate row;
      try {
        row.obj_id = ParseBopObjectName(estimate.object_id);
      } catch (const Error&) {
        ++skipped;
        continue;
      }
      // Foreign input types echo no ids: the request's (from the frame ids file) then.
      row.scene_id = answer.scene_id >= 0 ? answer.scene_id : frame.scene_id;
      row.im_id = answer.image_id >= 0 ? answer.image_id : frame.image_id;
      row.score = estimate.confidence;
      row.cam_from_object = CamFromObjectOf(estimate);
      row.time_s = answer.total_s;
      rows.push_back(row);
    }
  }
  if (skipped_ids != nullptr) *skipped_ids = skipped;
  return rows;
}

std::string ReplaySummaryJson(const ReplayOptions& options, const FrameLogStats& log,
                              const ReplayReport& report) {
  using Json = nlohmann::ordered_json;
  auto percentiles = [](double p50, double p95, double max) {
    return Json{{"p50", p50}, {"p95", p95}, {"max", max}};
  };
  const int64_t ok =
      report.estimates_by_status.count("ok") ? report.estimates_by_status.at("ok") : 0;
  Json by_status = Json::object();
  for (const auto& [name, count] : report.estimates_by_status) by_status[name] = count;
  // Every mode, zeros included, so that a run without tracking says so.
  Json by_mode = {{"detected", 0}, {"tracked", 0}, {"redetected", 0}};
  for (const auto& [name, count] : report.estimates_by_mode) by_mode[name] = count;
  Json foreign = Json::object();
  for (const auto& [name, count] : log.foreign_channels) foreign[name] = count;
  Json summary = {
      {"success", report.success},
      {"message", report.message},
      {"log",
       {{"path", log.path},
        {"bytes", log.file_bytes},
        {"events", log.events},
        {"frames", log.frames},
        {"foreign_events", log.ForeignEvents()},
        {"foreign_channels", foreign},
        {"undecodable_events", log.undecodable},
        {"skipped_bytes", log.skipped_bytes},
        {"truncated", log.Truncated()},
        {"trailing_bytes", log.trailing_bytes}}},
      {"channel", options.channel},
      {"results_channel", options.results_channel},
      {"mode", ReplayModeName(options)},
      {"timeout_ms", options.timeout_ms},
      {"sent", report.sent},
      {"answered", report.answered},
      {"lost", report.lost},
      {"timed_out", report.timed_out},
      {"late", report.late},
      {"rejected_frames", report.rejected},
      {"unmatched_answers", report.unmatched_answers},
      {"duplicate_answers", report.duplicate_answers},
      {"estimates",
       {{"total", report.estimates},
        {"ok", ok},
        {"failed", report.estimates - ok},
        {"by_status", by_status},
        {"by_mode", by_mode}}},
      {"latency_s", percentiles(report.latency_p50_s, report.latency_p95_s, report.latency_max_s)},
      {"service_total_s",
       percentiles(report.service_p50_s, report.service_p95_s, report.service_max_s)},
      {"wall_s", report.wall_s},
  };
  Json frames = Json::array();
  for (const ReplayedFrame& frame : report.frames) {
    Json entry = {{"seq", frame.seq},
                  {"source", frame.source},
                  {"scene_id", frame.scene_id},
                  {"image_id", frame.image_id},
                  {"instances", frame.instances},
                  {"answered", frame.answered},
                  {"timed_out", frame.timed_out}};
    if (frame.answered) {
      entry["latency_s"] = frame.latency_s;
      entry["service_total_s"] = frame.answer.total_s;
      entry["status"] = frame.answer.status == pose_array_t::STATUS_OK ? "ok" : "bad_frame";
      if (frame.answer.status != pose_array_t::STATUS_OK) entry["message"] = frame.answer.message;
      Json estimates = Json::array();
      for (const pose_estimate_t& estimate : frame.answer.estimates) {
        Json item = {{"object_id", estimate.object_id},
                     {"gt_index", estimate.gt_index},
                     {"status", EstimateStatusName(estimate.status)},
                     {"mode", EstimateModeName(estimate.mode)},
                     {"track_id", estimate.track_id},
                     {"solve_time_s", estimate.solve_time_s}};
        if (estimate.status != pose_estimate_t::STATUS_OK) item["message"] = estimate.message;
        estimates.push_back(item);
      }
      entry["estimates"] = estimates;
    }
    frames.push_back(entry);
  }
  summary["frames"] = frames;
  return summary.dump(2) + "\n";
}

std::string EstimatesJsonLines(const std::vector<ReplayedFrame>& frames) {
  using Json = nlohmann::ordered_json;
  std::string lines;
  for (const ReplayedFrame& frame : frames) {
    if (!frame.answered || frame.answer.status != pose_array_t::STATUS_OK) continue;
    for (const pose_estimate_t& estimate : frame.answer.estimates) {
      // null, not a number, where the service says there is none.
      const Json runner_up_score =
          estimate.has_runner_up ? Json(estimate.runner_up_score) : Json(nullptr);
      const Json appearance_agreement =
          estimate.appearance_valid ? Json(estimate.appearance_agreement) : Json(nullptr);
      const bool has_runner_up_object = !estimate.runner_up_object_id.empty();
      const Json runner_up_object_id =
          has_runner_up_object ? Json(estimate.runner_up_object_id) : Json(nullptr);
      const Json runner_up_object_score =
          has_runner_up_object ? Json(estimate.runner_up_object_score) : Json(nullptr);
      const Json line = {
          {"scene_id", frame.answer.scene_id},
          {"image_id", frame.answer.image_id},
          {"seq", frame.seq},
          {"source", frame.answer.source},
          {"object_id", estimate.object_id},
          {"label", estimate.label},
          {"gt_index", estimate.gt_index},
          {"status", EstimateStatusName(estimate.status)},
          {"message", estimate.message},
          {"score", estimate.score},
          {"confidence", estimate.confidence},
          {"iou", estimate.iou},
          {"depth_residual", estimate.depth_residual},
          {"truncated", estimate.truncated != 0},
          {"ambiguous", estimate.ambiguous != 0},
          {"cut_short", estimate.cut_short != 0},
          {"runner_up_score", runner_up_score},
          {"appearance_agreement", appearance_agreement},
          {"hypotheses", estimate.hypotheses},
          {"solve_time_s", estimate.solve_time_s},
          {"mode", EstimateModeName(estimate.mode)},
          {"track_id", estimate.track_id},
          {"frames_since_detection", estimate.frames_since_detection},
          {"mask_iou", estimate.mask_iou},
          {"identity_searched", estimate.identity_searched != 0},
          {"runner_up_object_id", runner_up_object_id},
          {"runner_up_object_score", runner_up_object_score},
          {"candidates_tried", estimate.candidates_tried},
          {"request_index", estimate.request_index},
          {"found_without_mask", estimate.found_without_mask != 0},
          {"region_box",
           {estimate.region_box[0], estimate.region_box[1], estimate.region_box[2],
            estimate.region_box[3]}},
          {"region_pixels", estimate.region_pixels},
          {"position", {estimate.position[0], estimate.position[1], estimate.position[2]}},
          {"orientation",
           {estimate.orientation[0], estimate.orientation[1], estimate.orientation[2],
            estimate.orientation[3]}},
          {"latency_s", frame.latency_s},
          {"service_total_s", frame.answer.total_s}};
      lines += line.dump() + "\n";
    }
  }
  return lines;
}

}  // namespace g6d
