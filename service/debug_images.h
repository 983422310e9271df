#pragma once
/// @file debug_images.h
/// DebugImagePublisher: the service's live picture (--debug-images CHANNEL). After an
/// answer is published, the scheduler offers the frame and its answer; a picture is made
/// (wire/debug_image.h: render + draw + JPEG) and published on a thread of its own at a
/// lower scheduling priority, so the answers never wait for it. An offer is skipped (and
/// counted) when the previous picture was accepted less than 1 / max_rate_hz ago or is
/// still being made: at most one picture is in the making, none queue up.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "wire/debug_image.h"

namespace g6d {

/// Options of the debug pictures (ServiceOptions::debug_images).
struct DebugImageOptions {
  std::string channel;       ///< LCM channel of the pictures; empty = off (the default)
  double max_rate_hz = 2.0;  ///< at most this many pictures per second (wall clock)
  DebugImageType type = DebugImageType::kBotCore;  ///< message type on `channel`
  int jpeg_quality = 80;                           ///< JPEG quality 1..100

  bool enabled() const { return !channel.empty(); }
  /// Empty when valid, else names the bad field (checked when enabled or not).
  std::string Check() const;
};

class DebugImagePublisher {
 public:
  /// Publishes on `lcm` (which must outlive this object) as `options` say; the thread runs
  /// at `nice_increment` above the process's nice value. Throws g6d::Error when
  /// options.Check() fails or the channel is empty. Starts the thread.
  DebugImagePublisher(const DebugImageOptions& options, lcm::LCM* lcm, int nice_increment);
  /// Stops (see Stop()).
  ~DebugImagePublisher();
  DebugImagePublisher(const DebugImagePublisher&) = delete;
  DebugImagePublisher& operator=(const DebugImagePublisher&) = delete;

  /// Takes `input` for a picture unless the rate limit or a picture in the making says
  /// skip; true when taken. Never blocks on the picture; cheap when skipped.
  bool Offer(DebugImageInput input);
  /// Drops a picture not yet started (counted as skipped), lets the one in the making
  /// finish, joins the thread. Idempotent.
  void Stop();

  int64_t Published() const { return published_.load(); }
  int64_t Skipped() const { return skipped_.load(); }
  int64_t Failed() const { return failed_.load(); }  ///< drawing or publishing failed

 private:
  using Clock = std::chrono::steady_clock;

  void Loop(int nice_increment);
  void MakeAndPublish(const DebugImageInput& input);

  const DebugImageOptions options_;
  lcm::LCM* const lcm_;
  const Clock::duration min_interval_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<DebugImageInput> pending_;  ///< taken, not yet started
  bool in_the_making_ = false;              ///< taken and not yet published (pending or drawing)
  std::optional<Clock::time_point> last_taken_;
  bool stop_ = false;
  std::atomic<int64_t> published_{0}, skipped_{0}, failed_{0};
  std::thread thread_;
};

}  // namespace g6d
