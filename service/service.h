#pragma once
/// @file service.h
/// g6d-service: answers g6d.rgbd_frame_t with g6d.pose_array_t over LCM.
///
/// Threads (DESIGN.md, "The service"):
///  - the LCM thread, the only one that calls lcm->handle(): it waits (poll) on the LCM
///    file descriptor and a wake-up descriptor, decodes and validates each frame and puts
///    it in a one-slot latest-frame mailbox (a newer frame replaces an unprocessed one and
///    counts as a drop). Frames that do not validate are answered at once with
///    STATUS_BAD_FRAME from this thread and never reach the mailbox.
///  - the scheduler thread: takes the newest frame, plans it with the Tracker (which
///    instance continues which track), solves every instance as planned (SolveWithPlan:
///    the full solver, or TrackPose from its track's pose) over the worker pool (instances
///    and each instance's hypotheses fan out over the same pool; the scheduler thread
///    takes part), records the answers in the Tracker, publishes the answer. The Tracker
///    is touched by this thread only.
///  - the status thread: publishes g6d.service_status_t every status_period_s.
///  - with options.reload, the CacheWatcher's loader thread: reads caches added to or
///    changed in the templates directory and swaps the store snapshot (cache_watcher.h).
///    The scheduler takes the snapshot once per frame, and first drops the tracks of the
///    objects whose cache was replaced or removed.
///  - options.workers - 1 pool threads.
///  - with --debug-images, the debug picture thread (DebugImagePublisher, nice +10): the
///    scheduler offers each answered frame after publishing its answer; the picture is
///    skipped when the rate limit says so or the previous one is still being made.
/// Nothing polls or sleeps: every wait is on a condition variable or a file descriptor.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "core/executor.h"
#include "core/stats.h"
#include "g6d/pose_array_t.hpp"
#include "g6d/service_status_t.hpp"
#include "service/background_detector.h"
#include "service/cache_watcher.h"
#include "service/debug_images.h"
#include "service/frame_sources.h"
#include "service/mailbox.h"
#include "service/service_options.h"
#include "service/template_store.h"
#include "track/tracker.h"
#include "wire/answer.h"
#include "wire/frame_codec.h"
#include "wire/lcm_loop.h"

namespace g6d {

/// A snapshot of the service's counters (what service_status_t carries).
struct ServiceCounters {
  int64_t frames_received = 0;  ///< messages on the input channel, garbage included
  int64_t frames_processed =
      0;                        ///< frames answered with STATUS_OK (per-instance failures included)
  int64_t frames_dropped = 0;   ///< replaced in the mailbox, or abandoned at shutdown
  int64_t frames_stale = 0;     ///< older than max_age_ms
  int64_t frames_rejected = 0;  ///< answered with STATUS_BAD_FRAME
  double latency_p50_s = 0.0;   ///< end-to-end, over the last latency_window frames
  double latency_p95_s = 0.0;
  int64_t answers_detected = 0;  ///< OK estimates by mode (pose_estimate_t::mode)
  int64_t answers_tracked = 0;
  int64_t answers_redetected = 0;
  int64_t debug_images_published = 0;  ///< debug pictures published (--debug-images)
  int64_t debug_images_skipped = 0;    ///< offers skipped: rate limit, or a picture in the making
  bool busy = false;          ///< a frame is being solved
  bool mailbox_full = false;  ///< a frame waits in the mailbox
  double uptime_s = 0.0;
};

/// One pose service for one camera. Start() begins serving, Stop() (or the destructor)
/// ends it: no new frames are taken, a frame waiting in the mailbox is dropped, instances
/// of the current frame that have not started are abandoned (answered with
/// STATUS_INTERNAL_ERROR "abandoned"), solver calls in flight finish, every thread joins.
class Service {
 public:
  /// `lcm` must outlive the service; while started, the service's LCM thread is the only
  /// one that may call lcm->handle() (other threads may publish and subscribe). With
  /// options.reload, `store` should be LoadTemplateStore(options.templates_dir): the
  /// watcher starts from it. Throws g6d::Error when options.Check() fails or `lcm` is
  /// not good.
  Service(const ServiceOptions& options, TemplateStore store, lcm::LCM* lcm);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  /// Subscribes and starts the threads. Throws g6d::Error on failure; call once.
  void Start();
  /// Stops and joins everything (see the class comment). Idempotent; never throws.
  void Stop();

  /// The counters now.
  ServiceCounters Counters() const;
  /// The status message the status thread would publish now.
  service_status_t MakeStatus() const;
  /// What the service serves now (a snapshot: a reload replaces it, never changes it).
  std::shared_ptr<const TemplateStore> Store() const;
  /// Rescans the templates directory now (SIGHUP); nothing when reloading is off.
  void ReloadCaches();

 private:
  using Clock = std::chrono::steady_clock;

  /// A decoded frame waiting for the scheduler.
  struct Job {
    FrameHeader header;
    DecodedFrame decoded;
    Clock::time_point received;  ///< when the handler started on the message
    Clock::time_point queued;    ///< when it entered the mailbox
    double decode_s = 0.0;       ///< LCM decode + validation + image decoding
  };

  void SchedulerLoop();
  void StatusLoop();
  /// The raw LCM handler: never throws (LCM calls it from C).
  void OnMessage(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  void HandleMessage(const void* data, int64_t size, Clock::time_point received);
  void Reject(const FrameHeader& header, const std::string& reason, Clock::time_point received,
              double decode_s);
  void ProcessJob(const Job& job);
  /// Solves instance `index` of the job (valid, with a bank; `instance` is its solver
  /// input) as `plan` says into *answer. Returns the failed estimate of an abandoned
  /// instance or of a solver exception (*answer then stays unsolved), else nothing.
  std::optional<pose_estimate_t> SolveInstance(const Job& job, size_t index,
                                               const Instance& instance, const TrackPlan& plan,
                                               TrackedAnswer* answer);
  /// The banks of an instance of unknown identity's candidates (every loaded bank when it
  /// lists none) into *banks; or, when one is not loaded (or nothing is), its
  /// STATUS_UNKNOWN_OBJECT estimate naming it.
  std::optional<pose_estimate_t> CandidatesOf(const DecodedInstance& request, size_t index,
                                              std::vector<const TemplateBank*>* banks) const;
  /// EstimatePoseOfUnknownObject of instance `index` of the job over `candidates` (on the
  /// worker pool, never tracked) as an estimate; a failed estimate when abandoned or when
  /// the search throws.
  pose_estimate_t IdentifyInstance(const Job& job, size_t index,
                                   const std::vector<const TemplateBank*>& candidates);
  /// A live track tried first for a detection request of its object (issue 23): the
  /// instance to track is the track's predicted silhouette in this frame (CorrectedMask).
  struct TrackProbe {
    size_t request = 0;  ///< the detection request's index in the frame's instances
    Instance instance;   ///< object id and the predicted corrected mask
  };
  /// The probes of the frame's detection requests `detecting` (those with an object id
  /// that no masked instance of the frame names): the live tracks of each object at
  /// `time_s`, lowest S_A first, at most the request's count. Scheduler thread.
  std::vector<TrackProbe> MakeTrackProbes(const Job& job, double time_s,
                                          const std::vector<size_t>& detecting,
                                          const std::vector<Instance>& masked) const;
  /// TrackWithPlan of one probe (a plan that continues a track); *needs_detection when the
  /// track was not accepted. A failed answer when abandoned or on an exception.
  TrackedAnswer SolveProbe(const Job& job, const TrackProbe& probe, const TrackPlan& plan,
                           bool* needs_detection);
  /// ExplainAwayNeighbours over the frame's first `num_masked` answers (the masked and
  /// boxed instances that were solved, `failures` empty): a doubtful answer is solved again
  /// without the pixels its confident neighbours explain. Scheduler thread.
  void ExplainNeighbours(const Job& job, const std::vector<Instance>& instances, size_t num_masked,
                         const std::vector<std::optional<pose_estimate_t>>& failures,
                         std::vector<TrackedAnswer>* answers);
  /// Tracker::Plan of the job's solvable `instances` at frame time `time_s`, or detection
  /// plans (and the tracks forgotten) if it throws.
  std::vector<TrackPlan> PlanFrame(const Job& job, double time_s,
                                   const std::vector<Instance>& instances);
  /// The loaded banks by object id, for the tracker (nullptr for an id not loaded).
  BankLookup LoadedBanks() const;
  void CountAnswer(const pose_estimate_t& estimate);
  /// Hands finished background re-detections to the tracker (before planning a frame).
  void ApplyBackgroundDetections();
  /// Queues the periodic re-detections the frame's answers asked for.
  void SubmitBackgroundDetections(const Job& job, const std::vector<Instance>& instances,
                                  const std::vector<TrackedAnswer>& answers);
  bool IsStale(int64_t frame_utime) const;
  void Publish(const std::string& channel, const pose_array_t& answer);
  void Publish(const std::string& channel, const service_status_t& status);
  /// bot_core.rigid_transform_t of every OK estimate (publish_rigid_transforms).
  void PublishRigidTransforms(const pose_array_t& answer);
  void RecordLatency(double total_s);
  /// Offers the job's frame and its published answer to the debug picture thread.
  void OfferDebugImage(const Job& job, const pose_array_t& answer);
  /// Counts the frame under its camera_id (seq gaps, out of order; frame_sources.h), logs
  /// a rate-limited loss warning, and checks the receive buffer against the first frame's
  /// `encoded_bytes`. LCM thread.
  void CountSource(const std::string& camera_id, int64_t seq, int64_t encoded_bytes);
  /// Warns when the LCM receive buffer cannot hold a frame of `frame_bytes`.
  void CheckReceiveBuffer(int64_t frame_bytes, const std::string& what) const;
  /// The per-source fields of the status (issue 24).
  void FillSourceStatus(service_status_t* status) const;
  /// The CacheWatcher's callback (its loader thread): the new store, and the objects
  /// whose tracks go.
  void OnStoreChanged(std::shared_ptr<const TemplateStore> store, const StoreChange& change);
  /// Scheduler thread, before planning a frame: takes the store snapshot into
  /// frame_store_ and drops the tracks of replaced and removed objects.
  void TakeStoreForFrame();
  /// Starts the CacheWatcher when options.reload is on and templates_dir is a directory.
  void StartWatcher();

  const ServiceOptions options_;
  /// What the service serves; replaced whole by a reload (store_mutex_).
  mutable std::mutex store_mutex_;
  std::shared_ptr<const TemplateStore> store_;
  /// Objects whose tracks the scheduler drops before it plans its next frame (store_mutex_).
  std::vector<std::string> forget_objects_;
  /// The snapshot of the frame being processed: set by the scheduler thread before it
  /// plans the frame; the pool threads read it while they solve that frame.
  std::shared_ptr<const TemplateStore> frame_store_;
  std::unique_ptr<CacheWatcher> watcher_;  ///< null when reloading is off
  lcm::LCM* const lcm_;
  SolverOptions solver_options_;
  std::string service_name_;
  const Clock::time_point start_time_ = Clock::now();

  std::unique_ptr<ThreadPool> pool_;
  Tracker tracker_;  ///< the camera's tracks; the scheduler thread's only
  /// Periodic re-detections of tracks (tracking.background_redetect); null when off.
  std::unique_ptr<BackgroundDetector> background_;
  int64_t background_corrections_ = 0;  ///< tracks a background re-detection moved (scheduler thread)
  /// The log said once that instances of unknown identity are not tracked (scheduler thread).
  bool logged_untracked_identity_ = false;
  /// The debug pictures (--debug-images); null when off.
  std::unique_ptr<DebugImagePublisher> debug_images_;
  LatestMailbox<Job> mailbox_;
  lcm::Subscription* subscription_ = nullptr;

  std::unique_ptr<LcmHandleThread> lcm_thread_;  ///< the only caller of lcm_->handle()
  std::thread scheduler_thread_, status_thread_;
  std::mutex lifecycle_mutex_;  ///< serializes Start() and Stop()
  bool started_ = false, stopped_ = false;
  std::atomic<bool> abandon_{false};  ///< instances not yet started are abandoned
  std::atomic<bool> stop_solves_{false};  ///< running solves end now (SolverOptions::stop_requested)

  std::mutex status_mutex_;
  std::condition_variable status_wake_;
  bool status_stop_ = false;

  std::atomic<int64_t> input_seq_{0};  ///< seq given to inputs that carry none (bot_core)
  std::atomic<int64_t> received_{0}, processed_{0}, dropped_{0}, stale_{0}, rejected_{0};
  std::atomic<int64_t> detected_{0}, tracked_{0}, redetected_{0};  ///< OK estimates by mode
  std::atomic<bool> busy_{false};
  mutable std::mutex latency_mutex_;
  std::deque<double> latencies_s_;  ///< the last latency_window end-to-end latencies
  FrameSources sources_;           ///< arrivals per camera_id: lost, out of order
  ReceiveBuffer receive_buffer_;   ///< what the kernel grants the udpm socket (probed at construction)
  bool checked_first_frame_ = false;  ///< the receive buffer was compared with a frame (LCM thread)
  std::mutex log_mutex_;
  Clock::time_point last_reject_log_;
  int64_t unlogged_rejects_ = 0;
};

}  // namespace g6d
