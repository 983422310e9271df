#pragma once
/// @file soak_report.h
/// g6d-bench-soak's report: the verdict from the counts and the process samples, and its
/// outputs (the summary on stdout, the summary JSON, the samples CSV, the plot).

#include <sys/types.h>

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "soak_cases.h"
#include "soak_options.h"
#include "soak_process.h"

namespace g6d::soak {

/// The verdict and the numbers behind it.
struct SoakReport {
  bool success = false;
  std::vector<std::string> failures;  ///< one line per failed criterion
  std::vector<std::string> notes;     ///< things worth a look that do not fail the run
  double wall_s = 0.0;                ///< load phase
  int64_t sent = 0, publish_failures = 0;
  bool interrupted = false, drained = false;
  ServiceExit exit;
  bool crashed = false;  ///< died before the end of the load (or the drain)
  Tally tally;
  bool final_status = false;  ///< the status published at shutdown arrived
  // Accounting (from the service's last status).
  int64_t received = 0, processed = 0, dropped = 0, stale = 0, rejected = 0;
  int64_t answered = 0;         ///< answers matched to sent messages
  int64_t lost = 0;             ///< sent - answered - dropped - stale
  int64_t not_received = 0;     ///< sent - received: lost before the service
  int64_t unaccounted = 0;      ///< received - (processed + rejected) - dropped - stale
  int64_t answers_missing = 0;  ///< (processed + rejected) - answers: lost on the way back
  int64_t frame_error_sent = 0, frame_error_unanswered = 0;
  /// Kernel drops on the UDP sockets of the service and of the bench (-1 = unknown).
  int64_t service_udp_drops = -1, bench_udp_drops = -1;
  int64_t mailbox_sent = 0, mailbox_unanswered = 0;  ///< good + instance-error frames
  // Seq gaps (--withhold-every): good frames withheld, and the gaps the service should see:
  // withheld frames and bad messages it cannot read a seq from, each before a later
  // message it can (the service counts no gap before its first frame or after its last).
  int64_t withheld = 0, expected_gaps = 0;
  int64_t service_lost = 0, service_out_of_order = 0;  ///< from the service's last status
  // Process.
  double reference_s = 0.0;  ///< where the growth is measured from
  Sample reference, end;
  double rss_growth_pct = 0.0, rss_max_mib = 0.0;
  int threads_min = 0, threads_max = 0, fds_min = 0, fds_max = 0;
  double cpu_cores = 0.0, cpu_cores_after_reference = 0.0;
};

/// Fills the accounting, the process figures and the verdict of `report` (whose run
/// fields and tally the runner set) against the pass criteria of the options.
void Evaluate(const SoakOptions& options, const std::vector<BadCase>& cases,
              const std::vector<Sample>& samples, SoakReport* report);

/// The human-readable summary on stdout.
void PrintSummary(const SoakOptions& options, const std::vector<BadCase>& cases,
                  const std::string& url, pid_t pid, const SoakReport& r);

/// The summary as JSON (--summary-json).
nlohmann::ordered_json SummaryJson(const SoakOptions& options, const std::vector<BadCase>& cases,
                                   const std::string& url, pid_t pid, const SoakReport& r);

/// One row per sample: t, rss_mib, threads, fds, cpu_s, sent, answered, dropped. Throws
/// g6d::Error when the file cannot be written.
void WriteSamplesCsv(const std::string& path, const std::vector<Sample>& samples);

/// RSS, threads and file descriptors over time, one panel each, the reference time marked
/// (PNG). Nothing when there are no samples; throws g6d::Error when it cannot be written.
void DrawPlot(const std::string& path, const std::vector<Sample>& samples, double reference_s,
              const std::string& title);

}  // namespace g6d::soak
