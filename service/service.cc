#include "service/service.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <set>
#include <sstream>
#include <system_error>

#include <opencv2/imgproc.hpp>

#include "bot_core/rigid_transform_t.hpp"
#include "core/error.h"
#include "solver/detect.h"
#include "solver/neighbours.h"
#include "solver/region.h"
#include "service/service_util.h"

namespace g6d {
namespace {

using service_util::Clock;
using service_util::JoinIds;
using service_util::NowUtime;
using service_util::SecondsBetween;

// `options` when they are valid; throws naming the bad field otherwise (before any member
// is built from them).
const ServiceOptions& Checked(const ServiceOptions& options) {
  if (const std::string error = options.Check(); !error.empty())
    G6D_THROW("ServiceOptions: " << error);
  return options;
}

}  // namespace

// Background re-detections waiting at most, and their threads' nice increment.
constexpr size_t kBackgroundQueue = 4;
constexpr int kBackgroundNice = 10;

Service::Service(const ServiceOptions& options, TemplateStore store, lcm::LCM* lcm)
    : options_(Checked(options)),
      store_(std::make_shared<const TemplateStore>(std::move(store))),
      frame_store_(store_),
      lcm_(lcm),
      tracker_(options_.tracking) {
  if (lcm_ == nullptr || !lcm_->good()) G6D_THROW("Service: the LCM instance is not usable");
  solver_options_ = options_.solver;
  // Shutdown cuts running solves short (each returns its best pose so far within about a
  // millisecond) instead of waiting for them or abandoning them.
  solver_options_.stop_requested = &stop_solves_;
  service_name_ = options_.name.empty() ? options_.input_channel : options_.name;
  pool_ = std::make_unique<ThreadPool>(options_.workers);
  receive_buffer_ = ProbeReceiveBuffer(options_.lcm_url);
  if (options_.tracking.enabled && options_.tracking.background_redetect) {
    // Its own stop flag (Stop() ends a running check at once); nice +10: the tracked
    // frames on the pool come first.
    SolverOptions background = options_.solver;
    background_ = std::make_unique<BackgroundDetector>(background, kBackgroundQueue, kBackgroundNice);
  }
  // Nice +10 as well: a picture takes what CPU the answers leave.
  if (options_.debug_images.enabled()) {
    debug_images_ =
        std::make_unique<DebugImagePublisher>(options_.debug_images, lcm_, kBackgroundNice);
  }
}

Service::~Service() { Stop(); }

void Service::Start() {
  std::lock_guard<std::mutex> lock(lifecycle_mutex_);
  if (started_) G6D_THROW("Service::Start: already started");
  subscription_ =
      lcm_->subscribe(LcmChannelRegex(options_.input_channel), &Service::OnMessage, this);
  if (subscription_ == nullptr) {
    G6D_THROW("Service::Start: cannot subscribe to '" << options_.input_channel << "'");
  }
  subscription_->setQueueCapacity(options_.subscription_queue);
  // Before the status thread, which reads watcher_.
  try {
    StartWatcher();
  } catch (...) {
    lcm_->unsubscribe(subscription_);
    subscription_ = nullptr;
    throw;
  }
  started_ = true;
  scheduler_thread_ = std::thread([this] { SchedulerLoop(); });
  status_thread_ = std::thread([this] { StatusLoop(); });
  lcm_thread_ = std::make_unique<LcmHandleThread>(
      lcm_, [](const std::string& reason) { spdlog::error("LCM thread: {}", reason); });
  spdlog::info("serving '{}' ({}) -> '{}' (status '{}'), {} workers, K = {}, objects: {}",
               options_.input_channel, InputTypeName(options_.input_type),
               options_.output_channel, options_.status_channel,
               options_.workers, solver_options_.num_hypotheses, JoinIds(Store()->ObjectIds()));
  if (debug_images_) {
    spdlog::info("debug images on '{}' ({}, JPEG quality {}), at most {} per second",
                 options_.debug_images.channel, DebugImageTypeName(options_.debug_images.type),
                 options_.debug_images.jpeg_quality, options_.debug_images.max_rate_hz);
  }
  CheckReceiveBuffer(kVgaFrameBytes, "a 640x480 RGB8 + depth U16 + labels U8 frame, uncompressed");
  const TrackerOptions& tracking = options_.tracking;
  if (tracking.enabled) {
    spdlog::info(
        "tracking on: max age {} s, min overlap {}, loss score {}, min IoU {}, appearance drop {}, "
        "re-detect every {} frames ({} per frame, {}), constant velocity {}",
        tracking.max_age_s, tracking.min_overlap, tracking.loss_score, tracking.min_iou,
        tracking.appearance_drop, tracking.redetect_every, tracking.max_periodic_per_frame,
        tracking.background_redetect ? "in the background" : "in the frame",
        tracking.constant_velocity ? "on" : "off");
  } else {
    spdlog::info("tracking off: every instance is solved by the full solver");
  }
}

void Service::Stop() {
  std::lock_guard<std::mutex> lock(lifecycle_mutex_);
  if (!started_ || stopped_) {
    stopped_ = true;
    return;
  }
  stopped_ = true;
  // 0. No more reloads.
  if (watcher_) watcher_->Stop();
  // 1. Take no more frames: wake the LCM thread out of poll() and join it.
  if (lcm_thread_) lcm_thread_->Stop();
  lcm_->unsubscribe(subscription_);
  subscription_ = nullptr;
  // 2. Drop the waiting frame, abandon instances not yet started, cut running ones short.
  abandon_ = true;
  stop_solves_ = true;
  if (mailbox_.Stop()) dropped_.fetch_add(1);
  scheduler_thread_.join();
  if (background_) background_->Stop();
  if (debug_images_) debug_images_->Stop();
  // 3. A last status, then the status thread.
  {
    std::lock_guard<std::mutex> status_lock(status_mutex_);
    status_stop_ = true;
  }
  status_wake_.notify_all();
  status_thread_.join();
  const ServiceCounters counters = Counters();
  spdlog::info(
      "stopped: received {}, processed {}, dropped {}, stale {}, rejected {}; "
      "answers detected {}, tracked {}, redetected {}; background re-detections {} "
      "(tracks corrected {}, refused when busy {})",
      counters.frames_received, counters.frames_processed, counters.frames_dropped,
      counters.frames_stale, counters.frames_rejected, counters.answers_detected,
      counters.answers_tracked, counters.answers_redetected,
      background_ ? background_->Completed() : 0, background_corrections_,
      background_ ? background_->Rejected() : 0);
  if (debug_images_) {
    spdlog::info("debug images on '{}': published {}, skipped {}, failed {}",
                 options_.debug_images.channel, debug_images_->Published(),
                 debug_images_->Skipped(), debug_images_->Failed());
  }
}

// ---- LCM thread ---------------------------------------------------------------------------

void Service::OnMessage(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  const Clock::time_point received = Clock::now();
  received_.fetch_add(1);
  // LCM calls this from C: nothing may escape.
  try {
    HandleMessage(buffer->data, buffer->data_size, received);
  } catch (const std::exception& e) {
    try {
      Reject(FrameHeader(), std::string("internal error while decoding: ") + e.what(), received,
             0.0);
    } catch (...) {
    }
  } catch (...) {
  }
}

void Service::HandleMessage(const void* data, int64_t size, Clock::time_point received) {
  FrameHeader header;
  rgbd_frame_t message;
  try {
    // The g6d type as it is; Drake and bot_core images through their adapters.
    message = AdaptMessage(options_.input_type, data, size, options_.adapter, options_.limits,
                           input_seq_.fetch_add(1), &header);
  } catch (const Error& e) {
    std::string camera_id;
    int64_t seq = 0;
    if (options_.input_type == InputType::kG6d && PeekRgbdFrameSource(data, size, &camera_id, &seq))
      CountSource(camera_id, seq, size);
    Reject(header, e.what(), received, SecondsBetween(received, Clock::now()));
    return;
  }
  header = HeaderOf(message);
  CountSource(message.camera_id, message.seq, size);
  if (IsStale(header.utime)) {
    stale_.fetch_add(1);
    return;
  }
  Job job;
  job.header = header;
  job.received = received;
  try {
    job.decoded = DecodeFrame(message, options_.limits);
  } catch (const std::exception& e) {
    Reject(header, e.what(), received, SecondsBetween(received, Clock::now()));
    return;
  }
  job.queued = Clock::now();
  job.decode_s = SecondsBetween(received, job.queued);
  if (mailbox_.Put(std::move(job)) != LatestMailbox<Job>::PutResult::kStored) dropped_.fetch_add(1);
}

void Service::Reject(const FrameHeader& header, const std::string& reason,
                     Clock::time_point received, double decode_s) {
  pose_array_t answer =
      MakePoseArray(header, pose_array_t::STATUS_BAD_FRAME, reason, {}, {{"decode", decode_s}},
                    SecondsBetween(received, Clock::now()), NowUtime());
  rejected_.fetch_add(1);
  Publish(options_.output_channel, answer);
  // At most one log line per second, so a flood of bad frames cannot flood the log.
  std::lock_guard<std::mutex> lock(log_mutex_);
  const Clock::time_point now = Clock::now();
  if (now - last_reject_log_ >= std::chrono::seconds(1)) {
    if (unlogged_rejects_ > 0) {
      spdlog::warn("rejected frame seq {}: {} ({} more rejected since the last message)",
                   header.seq, reason, unlogged_rejects_);
    } else {
      spdlog::warn("rejected frame seq {}: {}", header.seq, reason);
    }
    last_reject_log_ = now;
    unlogged_rejects_ = 0;
  } else {
    ++unlogged_rejects_;
  }
}

bool Service::IsStale(int64_t frame_utime) const {
  if (options_.max_age_ms <= 0.0) return false;
  return static_cast<double>(NowUtime() - frame_utime) > options_.max_age_ms * 1e3;
}

// ---- Scheduler ----------------------------------------------------------------------------

void Service::SchedulerLoop() {
  while (std::optional<Job> job = mailbox_.Take()) {
    if (IsStale(job->header.utime)) {
      stale_.fetch_add(1);
      continue;
    }
    busy_ = true;
    try {
      ProcessJob(*job);
    } catch (const std::exception& e) {
      // Only publishing can get here (every instance catches its own errors).
      spdlog::error("frame seq {}: {}", job->header.seq, e.what());
    }
    busy_ = false;
  }
}

void Service::OfferDebugImage(const Job& job, const pose_array_t& answer) {
  // Shares the decoded images (never written after decoding); the banks are held by
  // their shared pointers while the picture is made.
  DebugImageInput input;
  input.camera = job.decoded.frame.camera;
  input.rgb = job.decoded.frame.rgb;
  input.instances = job.decoded.instances;
  input.answer = answer;
  for (const pose_estimate_t& estimate : answer.estimates) {
    const auto bank = frame_store_->banks.find(estimate.object_id);
    if (estimate.status == pose_estimate_t::STATUS_OK && bank != frame_store_->banks.end()) {
      input.banks.emplace(estimate.object_id, bank->second);
    }
  }
  debug_images_->Offer(std::move(input));
}

void Service::ApplyBackgroundDetections() {
  if (!background_) return;
  for (const BackgroundDetector::Done& done : background_->TakeFinished()) {
    const BackgroundDetector::Job& check = done.job;
    if (tracker_.ApplyConfirmation(check.track_id, check.tracked, done.detection, check.bank->diameter_m)) {
      ++background_corrections_;
      spdlog::info("track {} ({}): a background re-detection ({:.0f} ms) found S {:.3f} where the track had {:.3f}; "
                   "track corrected",
                   check.track_id, check.instance.object_id, done.wall_ms, done.detection.score, check.tracked.score);
    }
  }
}

void Service::SubmitBackgroundDetections(const Job& job, const std::vector<Instance>& instances,
                                         const std::vector<TrackedAnswer>& answers) {
  if (!background_) return;
  for (size_t k = 0; k < answers.size(); ++k) {
    const TrackedAnswer& answer = answers[k];
    if (!answer.confirm_requested || !answer.result.success) continue;
    BackgroundDetector::Job check;
    check.track_id = answer.track_id;
    // Deep copies: the decoded images may share the message's buffers.
    check.frame = Frame{job.decoded.frame.camera, job.decoded.frame.rgb.clone(), job.decoded.frame.depth.clone()};
    check.instance = Instance{instances[k].object_id, instances[k].mask.clone()};
    check.bank = frame_store_->banks.at(instances[k].object_id);
    check.tracked = answer.result;
    if (!background_->Submit(std::move(check))) {
      // Busy: this check is skipped; the track is due again after redetect_every frames.
      tracker_.ApplyConfirmation(answer.track_id, answer.result, PoseResult(), 1.0);
    }
  }
}

void Service::CountAnswer(const pose_estimate_t& estimate) {
  if (estimate.status != pose_estimate_t::STATUS_OK) return;
  switch (estimate.mode) {
    case pose_estimate_t::MODE_TRACKED:
      tracked_.fetch_add(1);
      break;
    case pose_estimate_t::MODE_REDETECTED:
      redetected_.fetch_add(1);
      break;
    default:
      detected_.fetch_add(1);
      break;
  }
}

// ---- Status -------------------------------------------------------------------------------

void Service::StatusLoop() {
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(options_.status_period_s));
  Clock::time_point next = Clock::now();
  std::unique_lock<std::mutex> lock(status_mutex_);
  for (;;) {
    lock.unlock();
    Publish(options_.status_channel, MakeStatus());
    lock.lock();
    next += period;
    const Clock::time_point now = Clock::now();
    if (next < now) next = now + period;  // fell behind: do not burst
    if (status_wake_.wait_until(lock, next, [this] { return status_stop_; })) break;
  }
  lock.unlock();
  Publish(options_.status_channel, MakeStatus());  // the final counts
}

ServiceCounters Service::Counters() const {
  ServiceCounters counters;
  counters.frames_received = received_.load();
  counters.frames_processed = processed_.load();
  counters.frames_dropped = dropped_.load();
  counters.frames_stale = stale_.load();
  counters.frames_rejected = rejected_.load();
  std::vector<double> latencies;
  {
    std::lock_guard<std::mutex> lock(latency_mutex_);
    latencies.assign(latencies_s_.begin(), latencies_s_.end());
  }
  counters.latency_p50_s = Percentile(latencies, 0.50);
  counters.latency_p95_s = Percentile(latencies, 0.95);
  counters.answers_detected = detected_.load();
  counters.answers_tracked = tracked_.load();
  counters.answers_redetected = redetected_.load();
  if (debug_images_) {
    counters.debug_images_published = debug_images_->Published();
    counters.debug_images_skipped = debug_images_->Skipped();
  }
  counters.busy = busy_.load();
  counters.mailbox_full = mailbox_.Full();
  counters.uptime_s = SecondsBetween(start_time_, Clock::now());
  return counters;
}

service_status_t Service::MakeStatus() const {
  const ServiceCounters counters = Counters();
  service_status_t status;
  status.utime = NowUtime();
  status.service_name = service_name_;
  status.input_channel = options_.input_channel;
  status.output_channel = options_.output_channel;
  status.uptime_s = counters.uptime_s;
  status.frames_received = counters.frames_received;
  status.frames_processed = counters.frames_processed;
  status.frames_dropped = counters.frames_dropped;
  status.frames_stale = counters.frames_stale;
  status.frames_rejected = counters.frames_rejected;
  status.latency_p50_s = counters.latency_p50_s;
  status.latency_p95_s = counters.latency_p95_s;
  status.busy = counters.busy ? 1 : 0;
  status.mailbox_full = counters.mailbox_full ? 1 : 0;
  status.workers = options_.workers;
  status.hypotheses = solver_options_.num_hypotheses;
  FillStoreStatus(*Store(), watcher_ != nullptr, &status);
  status.tracking = options_.tracking.enabled ? 1 : 0;
  status.answers_detected = counters.answers_detected;
  status.answers_tracked = counters.answers_tracked;
  status.answers_redetected = counters.answers_redetected;
  FillSourceStatus(&status);
  return status;
}

// ---- Sources (issue 24: lost frames are visible) -------------------------------------------

void Service::CountSource(const std::string& camera_id, int64_t seq, int64_t encoded_bytes) {
  // bot_core.images_t has no seq: the adapter numbers its frames, so gaps mean nothing.
  const bool has_seq = options_.input_type != InputType::kBotCore;
  const std::string warning = sources_.Record(camera_id, seq, has_seq);
  if (!warning.empty()) spdlog::warn("{}", warning);
  if (!checked_first_frame_) {
    checked_first_frame_ = true;
    CheckReceiveBuffer(encoded_bytes, "the first frame as sent: camera '" + camera_id +
                                          "' seq " + std::to_string(seq));
  }
}

void Service::CheckReceiveBuffer(int64_t frame_bytes, const std::string& what) const {
  const std::string warning = ReceiveBufferWarning(receive_buffer_, frame_bytes, what);
  if (!warning.empty()) spdlog::warn("{}", warning);
}

void Service::FillSourceStatus(service_status_t* status) const {
  const std::vector<SourceCounts> sources = sources_.Sources();
  status->frames_lost = 0;
  status->frames_out_of_order = 0;
  status->recv_buffer_bytes = receive_buffer_.granted_bytes;
  status->num_sources = static_cast<int32_t>(sources.size());
  for (const SourceCounts& source : sources) {
    status->frames_lost += source.lost;
    status->frames_out_of_order += source.out_of_order;
    status->source_ids.push_back(source.id);
    status->source_has_seq.push_back(source.has_seq ? 1 : 0);
    status->source_received.push_back(source.received);
    status->source_lost.push_back(source.lost);
    status->source_out_of_order.push_back(source.out_of_order);
    status->source_restarts.push_back(source.restarts);
    status->source_last_seq.push_back(source.last_seq);
  }
}

void Service::RecordLatency(double total_s) {
  std::lock_guard<std::mutex> lock(latency_mutex_);
  latencies_s_.push_back(total_s);
  while (static_cast<int>(latencies_s_.size()) > options_.latency_window) latencies_s_.pop_front();
}

// ---- Reloading ----------------------------------------------------------------------------

void Service::StartWatcher() {
  if (!options_.reload) {
    spdlog::info("reload off: the caches loaded at start are served until the end");
    return;
  }
  std::error_code error;
  if (!std::filesystem::is_directory(options_.templates_dir, error)) {
    spdlog::warn("reload: '{}' is not a directory; caches are not reloaded", options_.templates_dir);
    return;
  }
  CacheWatcherOptions watch;
  watch.dir = options_.templates_dir;
  watch.scan_period_s = options_.reload_scan_period_s;
  watcher_ = std::make_unique<CacheWatcher>(
      watch, *Store(),
      [this](std::shared_ptr<const TemplateStore> store, const StoreChange& change) {
        OnStoreChanged(std::move(store), change);
      });
  watcher_->Start();
  spdlog::info("reload on: watching '{}' ({}, rescan every {} s, SIGHUP rescans now)", watch.dir,
               watcher_->Inotify() ? "inotify" : "no inotify", watch.scan_period_s);
}

std::shared_ptr<const TemplateStore> Service::Store() const {
  std::lock_guard<std::mutex> lock(store_mutex_);
  return store_;
}

void Service::ReloadCaches() {
  if (watcher_) {
    spdlog::info("reload: rescanning '{}' now", options_.templates_dir);
    watcher_->Rescan();
  } else {
    spdlog::info("reload is off: nothing to rescan");
  }
}

void Service::OnStoreChanged(std::shared_ptr<const TemplateStore> store, const StoreChange& change) {
  std::lock_guard<std::mutex> lock(store_mutex_);
  store_ = std::move(store);
  forget_objects_.insert(forget_objects_.end(), change.replaced.begin(), change.replaced.end());
  forget_objects_.insert(forget_objects_.end(), change.removed.begin(), change.removed.end());
}

void Service::TakeStoreForFrame() {
  std::vector<std::string> forget;
  {
    std::lock_guard<std::mutex> lock(store_mutex_);
    frame_store_ = store_;
    forget.swap(forget_objects_);
  }
  // The Tracker is this thread's only: the forgetting happens here, before the plan.
  for (const std::string& object_id : forget) {
    const int dropped = tracker_.ForgetObject(object_id);
    if (dropped > 0) {
      spdlog::info("object '{}': cache {}; {} track(s) dropped", object_id,
                   frame_store_->banks.count(object_id) ? "replaced" : "removed", dropped);
    }
  }
}

// ---- Publishing ---------------------------------------------------------------------------
// No lock of ours around lcm publish: LCM serializes publishers itself, and while the LCM
// thread dispatches a handler it holds LCM's own lock, so a lock taken here both inside a
// handler (Reject) and around a publish from another thread could deadlock.

void Service::Publish(const std::string& channel, const pose_array_t& answer) {
  if (lcm_->publish(channel, &answer) != 0) spdlog::warn("publish on '{}' failed", channel);
}

void Service::PublishRigidTransforms(const pose_array_t& answer) {
  for (const pose_estimate_t& estimate : answer.estimates) {
    if (estimate.status != pose_estimate_t::STATUS_OK) continue;
    bot_core::rigid_transform_t transform;
    transform.utime = answer.source_utime;  // the time of the image the pose is about
    std::copy(estimate.position, estimate.position + 3, transform.trans);
    std::copy(estimate.orientation, estimate.orientation + 4, transform.quat);
    const std::string channel = options_.rigid_transform_prefix + estimate.object_id;
    if (lcm_->publish(channel, &transform) != 0) spdlog::warn("publish on '{}' failed", channel);
  }
}

void Service::Publish(const std::string& channel, const service_status_t& status) {
  if (lcm_->publish(channel, &status) != 0) spdlog::warn("publish on '{}' failed", channel);
}

}  // namespace g6d
