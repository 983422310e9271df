// g6d-bench-soak: soak benchmark of the g6d-service binary (not a unit test).
//
// Starts the real g6d-service as a child process on a private udpm bus (ttl=0, a port of
// its own), publishes a fixed-rate mix of good frames (an LCM log of g6d_rgbd_frame_t,
// cycled, each with a fresh seq and utime) and bad frames (every kind of
// tests/bad_frames.h, cycled) for a long time, and watches both the answers and the
// process:
//  - every answer is matched to the frame it answers (by seq; the two kinds that are not
//    our message type at all are answered with seq -1 and matched in send order);
//  - the service's status (frames received / processed / dropped / stale / rejected)
//    accounts for the frames without an answer: by design at 30 Hz most good frames are
//    replaced in the latest-frame mailbox while the previous one is solved;
//  - every second: VmRSS, Threads, open file descriptors and CPU time of the service from
//    /proc/<pid>, and whether it is still alive (waitpid WNOHANG).
// At the end the service gets SIGTERM and must exit with code 0. The run passes when the
// service never died, exited cleanly, its resident memory grew less than
// --max-rss-growth-pct from the reference time (1 min; 20% of the run when it is shorter
// than 2 min) to the end, its threads and descriptors were constant after the reference
// time, every bad frame was answered with an error (or, for the kinds that pass validation
// and only fail per instance, dropped in the mailbox like any frame), no good frame was
// rejected and no frame is unaccounted for; with --withhold-every N (every Nth good frame's
// seq skipped, nothing sent) the service's frames_lost must equal the seq gaps it was
// given (plus at most the frames the kernel dropped).
//
//   g6d-bench-soak --templates out/soak/sample/caches --log out/soak/sample/sample.lcmlog
//       [--duration-s 600] [--rate-hz 30] [--bad-every 2] [--withhold-every N]
//       [--service-bin build/service/g6d-service]
//       [--service-log service.log] [--summary-json F] [--samples-csv F] [--plot F.png]
//
// Exit code: 0 pass, 1 a criterion failed (the summary says which), 2 the run could not be
// set up (bad options, unreadable log, service binary missing or never ready).
//
// One concern a file: soak_options.h (options), soak_cases (what is sent and how answers
// are matched), soak_process (the service child, /proc), soak_runner (the run),
// soak_report (verdict, summary, JSON, CSV, plot); this file parses the command line.
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <exception>
#include <string>

#include "soak_options.h"
#include "soak_runner.h"

namespace {

// Set by SIGINT/SIGTERM: the load phase ends early, the service is stopped and the
// summary is still written (a bench executable, not lib/: the one global is the signal flag).
volatile std::sig_atomic_t g_interrupted = 0;
void OnInterrupt(int) { g_interrupted = 1; }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "g6d-bench-soak: g6d-service (a child process) under a fixed-rate mix of good and bad "
      "frames for a long time: answers, errors, crashes, memory, threads, descriptors"};
  g6d::soak::SoakOptions options;
  options.service_bin = std::string(G6D_BINARY_DIR) + "/service/g6d-service";
  app.add_option("--service-bin", options.service_bin, "g6d-service executable")
      ->capture_default_str();
  app.add_option("--templates", options.templates_dir, "template cache folder of the service")
      ->required();
  app.add_option("--log", options.log_path, "LCM log of g6d_rgbd_frame_t (the good frames)")
      ->required();
  app.add_option("--log-channel", options.log_channel, "frame channel in the log")
      ->capture_default_str();
  app.add_option("--lcm-url", options.lcm_url,
                 "LCM URL (default: udpm on a port of this process, ttl=0, 4 MB receive buffer)");
  app.add_option("--input", options.input_channel, "frame channel")->capture_default_str();
  app.add_option("--output", options.output_channel, "answer channel")->capture_default_str();
  app.add_option("--status", options.status_channel, "status channel")->capture_default_str();
  app.add_option("--duration-s", options.duration_s, "length of the load, seconds")
      ->capture_default_str();
  app.add_option("--rate-hz", options.rate_hz, "messages per second, good and bad")
      ->capture_default_str();
  app.add_option("--withhold-every", options.withhold_every,
                 "withhold every Nth good frame (its seq is skipped; the service must count "
                 "it lost; 0 = none)")
      ->capture_default_str();
  app.add_option("--bad-every", options.bad_every, "every Nth message is bad (0 = none)")
      ->capture_default_str();
  app.add_option("--workers", options.workers, "--workers of the service")->capture_default_str();
  app.add_option("--hypotheses", options.hypotheses,
                 "--hypotheses K of the service (0 = its default)")
      ->capture_default_str();
  app.add_option("--service-arg", options.service_args,
                 "one more argument for the service, repeatable (--service-arg=--max-age-ms=500)");
  app.add_option("--max-rss-growth-pct", options.max_rss_growth_pct,
                 "largest RSS growth from 1 min (20% of a short run) to the end that passes, %")
      ->capture_default_str();
  app.add_option("--startup-timeout-s", options.startup_timeout_s,
                 "wait for the service's first status, seconds")
      ->capture_default_str();
  app.add_option("--drain-timeout-s", options.drain_timeout_s,
                 "wait for the last answers after the load, seconds")
      ->capture_default_str();
  app.add_option("--exit-timeout-s", options.exit_timeout_s,
                 "wait for the exit after SIGTERM before SIGKILL, seconds")
      ->capture_default_str();
  app.add_option("--progress-s", options.progress_s, "period of the progress lines, seconds")
      ->capture_default_str();
  app.add_option("--service-log", options.service_log, "the service's stdout and stderr")
      ->capture_default_str();
  app.add_option("--summary-json", options.summary_json, "write the summary as JSON");
  app.add_option(
      "--samples-csv", options.samples_csv,
      "write one row per second: t, rss_mib, threads, fds, cpu_s, sent, answered, dropped");
  app.add_option("--plot", options.plot_png, "draw RSS, threads and descriptors over time (PNG)");
  CLI11_PARSE(app, argc, argv);
  if (const std::string error = options.Check(); !error.empty()) {
    std::fprintf(stderr, "g6d-bench-soak: %s\n", error.c_str());
    return 2;
  }
  // Line by line even into a pipe (scripts/soak.sh tees it): progress shows as it happens.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  std::signal(SIGPIPE, SIG_IGN);
  try {
    return g6d::soak::RunSoak(options, &g_interrupted);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-bench-soak: %s\n", e.what());
    return 2;
  }
}
