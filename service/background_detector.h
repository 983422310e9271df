#pragma once
/// @file background_detector.h
/// BackgroundDetector: the service's periodic re-detections of tracks (issue 14), run on
/// one thread of their own at a lower scheduling priority, so that a frame is answered by
/// tracking at once and the full solver's check arrives a few frames later
/// (TrackerOptions::background_redetect, Tracker::ApplyConfirmation). The tracked frames
/// keep the worker pool; the check uses what CPU they leave.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include <Eigen/Geometry>

#include "core/frame.h"
#include "solver/pipeline.h"
#include "templates/template_bank.h"

namespace g6d {

class BackgroundDetector {
 public:
  /// A re-detection to run: the frame and instance the track answered, and that answer.
  struct Job {
    int track_id = -1;
    Frame frame;        ///< shares the decoded images (never written after decoding)
    Instance instance;
    std::shared_ptr<const TemplateBank> bank;
    PoseResult tracked;  ///< the track's answer on that frame
  };
  /// A finished re-detection.
  struct Done {
    Job job;
    PoseResult detection;
    double wall_ms = 0.0;
  };

  /// `options` are the full solver's (their stop_requested is replaced by this object's
  /// own). At most `max_queued` jobs wait; the thread runs at `nice_increment` above the
  /// process's nice value (0 = same priority). Starts the thread.
  BackgroundDetector(const SolverOptions& options, size_t max_queued, int nice_increment);
  /// Stops (see Stop()).
  ~BackgroundDetector();
  BackgroundDetector(const BackgroundDetector&) = delete;
  BackgroundDetector& operator=(const BackgroundDetector&) = delete;

  /// Queues `job`; false (and the job is dropped) when max_queued jobs wait already or
  /// the detector is stopped.
  bool Submit(Job job);
  /// The re-detections finished since the last call, oldest first.
  std::vector<Done> TakeFinished();
  /// Ends a running solve early (its result is dropped), drops the waiting jobs and joins
  /// the thread. Idempotent.
  void Stop();

  int64_t Completed() const { return completed_.load(); }
  int64_t Rejected() const { return rejected_.load(); }

 private:
  void Loop(int nice_increment);

  SolverOptions options_;
  const size_t max_queued_;
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> completed_{0}, rejected_{0};
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job> queue_;
  std::vector<Done> finished_;
  std::thread thread_;
};

}  // namespace g6d
