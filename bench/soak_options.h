#pragma once
/// @file soak_options.h
/// g6d-bench-soak's options and clock (bench/soak_main.cc describes the benchmark; its
/// files: soak_cases (what is sent, how answers are matched), soak_process (the service
/// child and /proc), soak_runner (the run), soak_report (verdict and output)).

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace g6d::soak {

using Clock = std::chrono::steady_clock;

inline double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

/// Wall-clock time, microseconds since the epoch (the frames' utime).
inline int64_t NowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// Everything the soak can be told.
struct SoakOptions {
  std::string service_bin;               ///< g6d-service executable
  std::string templates_dir;             ///< --templates of the service (template caches)
  std::string log_path;                  ///< LCM log of g6d_rgbd_frame_t: the good frames, cycled
  std::string log_channel = "G6D_RGBD";  ///< frame channel inside the log
  /// LCM URL of the private bus; empty = udpm on a port derived from this process's pid,
  /// ttl=0, 4 MB receive buffer.
  std::string lcm_url;
  std::string input_channel = "G6D_RGBD";     ///< frames to the service
  std::string output_channel = "G6D_POSES";   ///< its answers
  std::string status_channel = "G6D_STATUS";  ///< its status
  double duration_s = 600.0;                  ///< length of the load phase, seconds
  double rate_hz = 30.0;                      ///< messages per second (good and bad together)
  int bad_every = 2;                          ///< every Nth message is bad (0 = none, 1 = all)
  /// Every Nth good frame is withheld: its seq is skipped, nothing is sent, and the
  /// service must count it lost (frames_lost); 0 = none.
  int withhold_every = 0;
  int workers = 2;     ///< --workers of the service
  int hypotheses = 0;  ///< --hypotheses K of the service; 0 = the service's default
  std::vector<std::string> service_args;    ///< more arguments for the service, as given
  double max_rss_growth_pct = 5.0;          ///< pass limit of RSS growth, reference -> end, percent
  double startup_timeout_s = 120.0;         ///< wait for the service's first status, seconds
  double drain_timeout_s = 60.0;            ///< wait for the last answers after the load, seconds
  double exit_timeout_s = 30.0;             ///< wait for exit after SIGTERM before SIGKILL, seconds
  double progress_s = 30.0;                 ///< period of the progress lines, seconds
  std::string service_log = "service.log";  ///< the service's stdout and stderr
  std::string summary_json;                 ///< summary file (empty = none)
  std::string samples_csv;                  ///< one row per second (empty = none)
  std::string plot_png;                     ///< RSS / threads / fds plot (empty = none)

  /// Empty when valid, else names the bad field.
  std::string Check() const {
    if (service_bin.empty()) return "--service-bin is empty";
    if (templates_dir.empty()) return "--templates is required";
    if (log_path.empty()) return "--log is required";
    if (!(duration_s > 0.0)) return "--duration-s must be > 0";
    if (!(rate_hz > 0.0) || rate_hz > 1000.0) return "--rate-hz must be in (0, 1000]";
    if (bad_every < 0) return "--bad-every must be >= 0";
    if (withhold_every < 0) return "--withhold-every must be >= 0";
    if (workers < 1) return "--workers must be >= 1";
    if (hypotheses < 0) return "--hypotheses must be >= 0";
    if (!(max_rss_growth_pct >= 0.0)) return "--max-rss-growth-pct must be >= 0";
    if (!(startup_timeout_s > 0.0)) return "--startup-timeout-s must be > 0";
    if (!(drain_timeout_s >= 0.0)) return "--drain-timeout-s must be >= 0";
    if (!(exit_timeout_s > 0.0)) return "--exit-timeout-s must be > 0";
    if (!(progress_s > 0.0)) return "--progress-s must be > 0";
    if (service_log.empty()) return "--service-log is empty";
    return {};
  }

  /// Seconds after the start of the load from which memory growth is measured and threads
  /// and descriptors must stay constant: 1 min, or 20% of a run shorter than 2 min.
  double ReferenceTime() const { return duration_s >= 120.0 ? 60.0 : 0.2 * duration_s; }
};

}  // namespace g6d::soak
