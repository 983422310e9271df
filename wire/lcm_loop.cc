#include "wire/lcm_loop.h"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>

#include "core/error.h"

namespace g6d {

LcmHandleThread::LcmHandleThread(lcm::LCM* lcm, ErrorCallback on_error)
    : lcm_(lcm), on_error_(std::move(on_error)) {
  if (lcm_ == nullptr || !lcm_->good())
    G6D_THROW("LcmHandleThread: the LCM instance is not usable");
  wake_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) G6D_THROW("LcmHandleThread: eventfd failed: " << std::strerror(errno));
  thread_ = std::thread([this] { Run(); });
}

LcmHandleThread::~LcmHandleThread() {
  Stop();
  close(wake_fd_);
}

void LcmHandleThread::Stop() {
  if (!thread_.joinable()) return;
  const uint64_t one = 1;
  // An eventfd write of 1 only fails when the counter would overflow; EINTR is retried.
  while (write(wake_fd_, &one, sizeof(one)) < 0 && errno == EINTR) {
  }
  thread_.join();
}

void LcmHandleThread::Run() {
  const auto report = [this](const std::string& reason) {
    if (on_error_) on_error_(reason);
  };
  pollfd fds[2] = {{lcm_->getFileno(), POLLIN, 0}, {wake_fd_, POLLIN, 0}};
  for (;;) {
    fds[0].revents = fds[1].revents = 0;
    if (poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      report(std::string("poll failed: ") + std::strerror(errno) +
             "; no more messages are handled");
      return;
    }
    if (fds[1].revents != 0) return;  // Stop()
    // A broken descriptor would make poll() return at once forever: end instead.
    if (fds[0].revents & (POLLERR | POLLHUP | POLLNVAL)) {
      report("the LCM file descriptor failed; no more messages are handled");
      return;
    }
    if ((fds[0].revents & POLLIN) && lcm_->handle() != 0) report("lcm handle() reported an error");
  }
}

std::string LcmChannelRegex(const std::string& channel) {
  static const std::string kSpecial = R"(\.^$|()[]{}*+?)";
  std::string regex;
  for (char c : channel) {
    if (kSpecial.find(c) != std::string::npos) regex += '\\';
    regex += c;
  }
  return regex;
}

}  // namespace g6d
