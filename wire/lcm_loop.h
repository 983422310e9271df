#pragma once
/// @file lcm_loop.h
/// The one LCM handle loop of the project: LcmHandleThread runs lcm->handle() on a thread
/// of its own (LCM allows one handling thread per instance), for the service, g6d-replay,
/// the benchmarks and the tests. It waits in poll() on the LCM descriptor and on an
/// eventfd, so Stop() takes effect at once and nothing sleeps in a loop.

#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <thread>

namespace g6d {

/// Runs lcm->handle() on its own thread from construction until Stop() (or destruction).
/// LCM's descriptor becomes readable only when a whole message is queued, so handle()
/// never blocks on this thread. The loop ends on Stop(), or by itself when poll() or the
/// LCM descriptor fails (then `on_error` is told why and no more messages are handled).
class LcmHandleThread {
 public:
  /// Called on the handle thread with a one-line reason: a failed poll(), a broken LCM
  /// descriptor (the loop then ends) or a handle() that reported an error (it goes on).
  using ErrorCallback = std::function<void(const std::string& reason)>;

  /// Starts the thread. `lcm` must outlive this object and no other thread may call its
  /// handle() meanwhile. Throws g6d::Error when `lcm` is null or not good, or the eventfd
  /// cannot be created.
  explicit LcmHandleThread(lcm::LCM* lcm, ErrorCallback on_error = {});
  /// Stop().
  ~LcmHandleThread();
  LcmHandleThread(const LcmHandleThread&) = delete;
  LcmHandleThread& operator=(const LcmHandleThread&) = delete;

  /// Wakes the thread and joins it; a handler running now finishes first. Idempotent; call
  /// it from any thread but the handle thread itself (i.e. not from an LCM handler).
  void Stop();

 private:
  void Run();

  lcm::LCM* const lcm_;
  const ErrorCallback on_error_;
  int wake_fd_ = -1;
  std::thread thread_;
};

/// Escapes regular-expression characters: LCM subscribes by regex, channels are literal.
std::string LcmChannelRegex(const std::string& channel);

}  // namespace g6d
