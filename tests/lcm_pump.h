#pragma once
/// @file lcm_pump.h
/// LcmPump: runs lcm->handle() on a thread of its own for an LCM instance that no service
/// pumps (the tests' and benchmarks' listeners).

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <lcm/lcm-cpp.hpp>
#include <thread>

#include "core/error.h"

namespace g6d::test {

/// Waits on the LCM descriptor and a wake-up descriptor (no polling); the destructor wakes
/// and joins the thread.
class LcmPump {
 public:
  explicit LcmPump(lcm::LCM* lcm) : lcm_(lcm), wake_fd_(eventfd(0, EFD_CLOEXEC)) {
    if (wake_fd_ < 0) G6D_THROW("LcmPump: eventfd failed: " << std::strerror(errno));
    thread_ = std::thread([this] {
      pollfd fds[2] = {{lcm_->getFileno(), POLLIN, 0}, {wake_fd_, POLLIN, 0}};
      for (;;) {
        if (poll(fds, 2, -1) < 0) continue;  // EINTR
        if (fds[1].revents != 0) return;
        if (fds[0].revents & POLLIN) lcm_->handle();
      }
    });
  }
  ~LcmPump() {
    const uint64_t one = 1;
    (void)!write(wake_fd_, &one, sizeof(one));
    thread_.join();
    close(wake_fd_);
  }
  LcmPump(const LcmPump&) = delete;
  LcmPump& operator=(const LcmPump&) = delete;

 private:
  lcm::LCM* lcm_;
  int wake_fd_;
  std::thread thread_;
};

}  // namespace g6d::test
