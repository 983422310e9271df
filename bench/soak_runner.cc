// g6d-bench-soak (bench/soak_main.cc says what it does and how to run it): the run.
#include "soak_runner.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "soak_cases.h"
#include "soak_process.h"
#include "soak_report.h"
#include "wire/bad_frames.h"
#include "wire/lcm_loop.h"

namespace g6d::soak {

int RunSoak(const SoakOptions& options, const volatile std::sig_atomic_t* interrupted) {
  // 1. The messages.
  g6d::rgbd_frame_t first;
  std::vector<std::vector<uint8_t>> good_frames = LoadGoodFrames(options, &first);
  first.seq = 0;
  const std::vector<BadCase> cases = g6d::synthetic::MakeBadCases(first);
  std::vector<std::vector<uint8_t>> bad_frames;
  for (const BadCase& bad : cases) bad_frames.push_back(bad.bytes);
  std::printf("[soak] %zu good frames from %s (%.0f kB each), %zu kinds of bad frames\n",
              good_frames.size(), options.log_path.c_str(), good_frames[0].size() / 1024.0,
              cases.size());

  // 2. The service, on a bus of its own.
  const std::string url = options.lcm_url.empty()
                              ? "udpm://239.255.76.67:" + std::to_string(40000 + getpid() % 20000) +
                                    "?ttl=0&recv_buf_size=4194304"
                              : options.lcm_url;
  std::vector<std::string> argv = {options.service_bin,
                                   "--templates",
                                   options.templates_dir,
                                   "--lcm-url",
                                   url,
                                   "--input",
                                   options.input_channel,
                                   "--output",
                                   options.output_channel,
                                   "--status",
                                   options.status_channel,
                                   "--workers",
                                   std::to_string(options.workers)};
  if (options.hypotheses > 0) {
    argv.push_back("--hypotheses");
    argv.push_back(std::to_string(options.hypotheses));
  }
  argv.insert(argv.end(), options.service_args.begin(), options.service_args.end());
  // Subscribed before the service starts, so its first status is not missed.
  lcm::LCM lcm(url);
  if (!lcm.good()) G6D_THROW("cannot open LCM at " << url);
  AnswerCollector collector(&cases);
  // The channels hold no regular-expression characters (LCM subscribes by regex).
  lcm.subscribe(options.output_channel, &AnswerCollector::OnAnswer, &collector)
      ->setQueueCapacity(1000000);
  lcm.subscribe(options.status_channel, &AnswerCollector::OnStatus, &collector)
      ->setQueueCapacity(1000);

  ServiceProcess service(argv, options.service_log);
  std::printf("[soak] g6d-service pid %d on %s (log %s)\n", static_cast<int>(service.pid()),
              url.c_str(), options.service_log.c_str());
  LcmHandleThread pump(&lcm);
  {
    const Clock::time_point deadline =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::duration<double>(options.startup_timeout_s));
    bool ready = false;
    // One-second slices so that a service dying while it loads is seen at once.
    while (!ready && Clock::now() < deadline && !*interrupted) {
      ready = collector.WaitForStatusSince(0, std::chrono::seconds(1));
      if (!ready && service.Exited(0.0)) {
        std::fprintf(stderr, "[soak] g6d-service ended while starting: %s; its log:\n%s",
                     service.exit_info().Describe().c_str(), Tail(options.service_log, 20).c_str());
        return 1;
      }
    }
    if (!ready) {
      std::fprintf(stderr, "[soak] no status from g6d-service within %.0f s; its log:\n%s",
                   options.startup_timeout_s, Tail(options.service_log, 20).c_str());
      return 2;
    }
    if (collector.Snapshot().status.num_objects == 0)
      std::fprintf(stderr, "[soak] warning: the service loaded no template cache\n");
  }

  // 3. The load: a fixed-rate source (sleep_until, like a camera driver) and a sample of
  // the process every second.
  SoakReport report;
  std::vector<Sample> samples;
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / options.rate_hz));
  const int64_t total = std::max<int64_t>(1, std::llround(options.duration_s * options.rate_hz));
  const Clock::time_point start = Clock::now();
  Clock::time_point next_sample = start, next_progress = start;
  size_t next_good = 0, next_bad = 0;
  int64_t pending_gaps = 0;  // seqs the service cannot see since the last one it can
  bool named_sent = false;   // a message with a readable seq was sent
  std::printf("[soak] %lld messages at %.1f Hz for %.0f s; progress every %.0f s\n",
              static_cast<long long>(total), options.rate_hz, options.duration_s,
              options.progress_s);
  auto take_sample = [&](Clock::time_point at) {
    Sample sample;
    sample.t_s = Seconds(at - start);
    // A process that ends between the two calls is a zombie that ReadProcess() cannot read
    // and the second Exited() reaps.
    if (service.Exited(sample.t_s) ||
        (!ReadProcess(service.pid(), &sample) && service.Exited(sample.t_s))) {
      report.crashed = true;
      return;
    }
    sample.sent = report.sent;
    sample.answered = collector.answered();
    const Tally tally = collector.Snapshot();
    sample.dropped = tally.status.frames_dropped;
    samples.push_back(sample);
    if (at >= next_progress) {
      int64_t errors = 0;
      for (const KindCounts& k : tally.kinds) errors += k.expected + k.other_error;
      std::printf(
          "[soak] %5.0f s: sent %lld, answered %lld (%lld errors), dropped %lld, RSS %.1f MiB, "
          "threads %d, fds %d, cpu %.1f s\n",
          sample.t_s, static_cast<long long>(sample.sent), static_cast<long long>(sample.answered),
          static_cast<long long>(errors), static_cast<long long>(sample.dropped), sample.rss_mib,
          sample.threads, sample.fds, sample.cpu_s);
      next_progress += std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(options.progress_s));
    }
  };
  for (int64_t i = 0; i < total && !report.crashed && !*interrupted; ++i) {
    const Clock::time_point send_at = start + i * period;
    while (next_sample <= send_at && !report.crashed) {
      std::this_thread::sleep_until(next_sample);
      take_sample(next_sample);
      next_sample += std::chrono::seconds(1);
    }
    if (report.crashed) break;
    std::this_thread::sleep_until(send_at);
    const int64_t seq = i + 1;
    const bool bad = options.bad_every > 0 && (i + 1) % options.bad_every == 0;
    std::vector<uint8_t>* bytes;
    int kind = -1;
    if (bad) {
      kind = static_cast<int>(next_bad++ % bad_frames.size());
      bytes = &bad_frames[kind];
    } else {
      const size_t good_index = next_good++;
      if (options.withhold_every > 0 &&
          (good_index + 1) % static_cast<size_t>(options.withhold_every) == 0) {
        collector.Withheld(seq);
        ++report.withheld;
        ++pending_gaps;
        continue;
      }
      bytes = &good_frames[good_index % good_frames.size()];
    }
    // A seq the service can read ends the gap before it (none before its first one).
    if (kind >= 0 && !cases[kind].seq_known) {
      ++pending_gaps;
    } else {
      if (named_sent) report.expected_gaps += pending_gaps;
      pending_gaps = 0;
      named_sent = true;
    }
    if (kind < 0 || cases[kind].seq_known) {
      g6d::synthetic::PatchSeq(bytes, seq);
      g6d::synthetic::PatchUtime(bytes, NowUtime());
    }
    collector.Sent(seq, kind, Clock::now());
    if (lcm.publish(options.input_channel, bytes->data(), static_cast<unsigned>(bytes->size())) !=
        0)
      ++report.publish_failures;
    ++report.sent;
  }
  report.interrupted = *interrupted != 0;
  if (!report.crashed) {
    // The end of the load, one period after the last message (or now, when interrupted).
    const Clock::time_point end = report.interrupted ? Clock::now() : start + total * period;
    std::this_thread::sleep_until(end);
    take_sample(std::max(end, Clock::now()));
  }
  report.wall_s = Seconds(Clock::now() - start);

  // 4. Drain: the last frame in flight is solved and every published answer arrives.
  if (!report.crashed) {
    const int64_t load_end_utime = NowUtime();
    const Clock::time_point deadline =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::duration<double>(options.drain_timeout_s));
    while (!report.drained && Clock::now() < deadline) {
      report.drained = collector.WaitForDrain(load_end_utime, std::chrono::seconds(1));
      if (service.Exited(Seconds(Clock::now() - start))) {
        report.crashed = true;
        break;
      }
    }
  }

  // 5. SIGTERM and the exit; then the status it published while stopping.
  const int64_t stop_utime = NowUtime();
  if (!report.crashed) {
    report.service_udp_drops = UdpDrops(service.pid());
    report.bench_udp_drops = UdpDrops(0);
    service.Terminate(options.exit_timeout_s, Seconds(Clock::now() - start));
    report.final_status = collector.WaitForStatusSince(stop_utime, std::chrono::seconds(2));
  }
  report.exit = service.exit_info();
  report.tally = collector.Snapshot();
  Evaluate(options, cases, samples, &report);

  PrintSummary(options, cases, url, service.pid(), report);
  if (report.crashed)
    std::printf("the end of the service log (%s):\n%s", options.service_log.c_str(),
                Tail(options.service_log, 20).c_str());
  if (!options.summary_json.empty()) {
    std::ofstream out(options.summary_json);
    if (!out) G6D_THROW("cannot write " << options.summary_json);
    out << SummaryJson(options, cases, url, service.pid(), report).dump(2) << "\n";
  }
  if (!options.samples_csv.empty()) WriteSamplesCsv(options.samples_csv, samples);
  if (!options.plot_png.empty()) {
    char title[256];
    std::snprintf(title, sizeof(title),
                  "g6d-service soak: %.0f s at %.0f Hz, RSS %+.2f%% from %.0f s, %s", report.wall_s,
                  options.rate_hz, report.rss_growth_pct, report.reference.t_s,
                  report.success ? "PASS" : "FAIL");
    DrawPlot(options.plot_png, samples, report.reference.t_s, title);
  }
  return report.success ? 0 : 1;
}

}  // namespace g6d::soak
