// g6d-status: one line per running g6d-service, for people, refreshed in place like top.
//
//   g6d-status [--lcm-url URL] [--channel REGEX] [--period-s 1] [--stale-s 3]
//   g6d-status --once [--wait-s 2]        # listen, print once, exit (scripts, tests)
//
// Subscribes to every channel matching --channel (default ".*STATUS.*") and decodes what
// arrives as g6d_service_status_t (messages of other types on matching channels are
// skipped). A service whose status has not arrived for --stale-s is marked STALE: it
// stopped, hung, or its status no longer reaches this machine. Ages are measured with
// this machine's clock at arrival, so clocks of other machines do not matter.
//
// Exit code: 0; with --once, 1 when no status arrived within --wait-s; 2 on bad options
// or an LCM URL that does not open.
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <ctime>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "g6d/service_status_t.hpp"
#include "wire/lcm_loop.h"

namespace {

using Clock = std::chrono::steady_clock;

/// The last status of each channel and when it arrived.
class StatusBoard {
 public:
  struct Entry {
    g6d::service_status_t status;
    Clock::time_point arrived;
  };

  void OnMessage(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
    Entry entry;
    // Another type on a matching channel fails the fingerprint check: skipped.
    if (entry.status.decode(buffer->data, 0, static_cast<int>(buffer->data_size)) < 0) return;
    entry.arrived = Clock::now();
    std::lock_guard<std::mutex> lock(mutex_);
    entries_[channel] = std::move(entry);
  }

  std::map<std::string, Entry> Snapshot() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return entries_;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, Entry> entries_;  ///< by status channel
};

std::string Duration(double seconds) {
  const int64_t s = static_cast<int64_t>(seconds);
  char text[32];
  if (s >= 3600) {
    std::snprintf(text, sizeof(text), "%" PRId64 "h%02" PRId64 "m", s / 3600, s / 60 % 60);
  } else if (s >= 60) {
    std::snprintf(text, sizeof(text), "%" PRId64 "m%02" PRId64 "s", s / 60, s % 60);
  } else {
    std::snprintf(text, sizeof(text), "%" PRId64 "s", s);
  }
  return text;
}

std::string Sources(const g6d::service_status_t& status) {
  std::string sources;
  for (const std::string& id : status.source_ids) sources += (sources.empty() ? "" : ",") + id;
  return sources.empty() ? "-" : sources;
}

constexpr const char* kHeader =
    "SERVICE          SOURCES          UPTIME     RECV     PROC     DROP  STALE    REJ   LOST    OOO"
    "  P50_MS  P95_MS BUSY OBJ         AGE  CHANNEL";

std::string Line(const std::string& channel, const StatusBoard::Entry& entry, Clock::time_point now,
                 double stale_s) {
  const g6d::service_status_t& s = entry.status;
  const double age_s = std::chrono::duration<double>(now - entry.arrived).count();
  char age[32];
  std::snprintf(age, sizeof(age), "%.1fs%s", age_s, age_s > stale_s ? " STALE" : "");
  char line[512];
  std::snprintf(line, sizeof(line),
                "%-16s %-16s %6s %8" PRId64 " %8" PRId64 " %8" PRId64 " %6" PRId64 " %6" PRId64
                " %6" PRId64 " %6" PRId64 " %7.1f %7.1f %4s %3d %11s  %s",
                s.service_name.c_str(), Sources(s).c_str(), Duration(s.uptime_s).c_str(),
                s.frames_received, s.frames_processed, s.frames_dropped, s.frames_stale,
                s.frames_rejected, s.frames_lost, s.frames_out_of_order, s.latency_p50_s * 1e3,
                s.latency_p95_s * 1e3, s.busy ? "yes" : "no", s.num_objects, age, channel.c_str());
  return line;
}

void Print(const StatusBoard& board, double stale_s, bool clear) {
  const Clock::time_point now = Clock::now();
  std::string text = clear ? "\033[H\033[2J" : "";
  text += kHeader;
  text += '\n';
  const auto entries = board.Snapshot();
  for (const auto& [channel, entry] : entries) text += Line(channel, entry, now, stale_s) + '\n';
  if (entries.empty()) text += "(no g6d_service_status_t yet)\n";
  std::fputs(text.c_str(), stdout);
  std::fflush(stdout);
}

/// Waits up to `seconds` for SIGINT/SIGTERM (blocked in every thread); true if one came.
bool WaitForStopSignal(const sigset_t& signals, double seconds) {
  timespec timeout;
  timeout.tv_sec = static_cast<time_t>(seconds);
  timeout.tv_nsec = static_cast<long>((seconds - static_cast<double>(timeout.tv_sec)) * 1e9);
  for (;;) {
    const int signal = sigtimedwait(&signals, nullptr, &timeout);
    if (signal > 0) return true;
    if (errno == EAGAIN) return false;
    // EINTR: another signal interrupted the wait; the remaining time is not tracked
    // exactly, which only stretches one refresh.
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("g6d-status: one line per g6d-service from its g6d_service_status_t");
  std::string lcm_url, channel_regex = ".*STATUS.*";
  bool once = false;
  double period_s = 1.0, stale_s = 3.0, wait_s = 2.0;
  app.add_option("--lcm-url", lcm_url, "LCM URL (default: $LCM_DEFAULT_URL or LCM's default)");
  app.add_option("--channel", channel_regex, "status channels, an LCM channel regex")
      ->capture_default_str();
  app.add_flag("--once", once, "listen for --wait-s, print the lines once and exit");
  app.add_option("--wait-s", wait_s, "with --once: how long to listen, seconds")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--period-s", period_s, "refresh period, seconds")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--stale-s", stale_s, "mark a service STALE when its last status is older, seconds")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  // SIGINT/SIGTERM end the refresh loop; blocked before the LCM thread starts so that only
  // sigtimedwait() below takes them.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  lcm::LCM lcm(lcm_url);
  if (!lcm.good()) {
    std::fprintf(stderr, "g6d-status: cannot open LCM at '%s'\n",
                 lcm_url.empty() ? "<default>" : lcm_url.c_str());
    return 2;
  }
  StatusBoard board;
  lcm::Subscription* subscription = lcm.subscribe(channel_regex, &StatusBoard::OnMessage, &board);
  if (subscription == nullptr) {
    std::fprintf(stderr, "g6d-status: cannot subscribe to '%s'\n", channel_regex.c_str());
    return 2;
  }
  g6d::LcmHandleThread pump(&lcm, [](const std::string& reason) {
    std::fprintf(stderr, "g6d-status: LCM: %s\n", reason.c_str());
  });
  if (once) {
    WaitForStopSignal(stop_signals, wait_s);
    pump.Stop();
    Print(board, stale_s, false);
    return board.Snapshot().empty() ? 1 : 0;
  }
  const bool clear = isatty(STDOUT_FILENO) == 1;
  do {
    Print(board, stale_s, clear);
  } while (!WaitForStopSignal(stop_signals, period_s));
  pump.Stop();
  lcm.unsubscribe(subscription);
  return 0;
}
