// g6d-bench-soak (bench/soak_main.cc says what it does and how to run it): the verdict and its
// outputs.
#include "soak_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"
#include "core/stats.h"

namespace g6d::soak {
namespace {

std::string Ordinal(int n) {
  if (n % 100 >= 11 && n % 100 <= 13) return std::to_string(n) + "th";
  const char* suffix[] = {"th", "st", "nd", "rd"};
  return std::to_string(n) + (n % 10 <= 3 ? suffix[n % 10] : "th");
}

/// A "nice" tick step (1, 2 or 5 x 10^k) giving about `ticks` ticks over `span`.
double TickStep(double span, int ticks) {
  const double raw = span / std::max(1, ticks);
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * power >= raw) return m * power;
  }
  return 10.0 * power;
}

}  // namespace

void Evaluate(const SoakOptions& options, const std::vector<BadCase>& cases,
              const std::vector<Sample>& samples, SoakReport* report) {
  const Tally& t = report->tally;
  if (t.has_status) {
    report->received = t.status.frames_received;
    report->processed = t.status.frames_processed;
    report->dropped = t.status.frames_dropped;
    report->stale = t.status.frames_stale;
    report->rejected = t.status.frames_rejected;
  }
  report->answered = t.good.answered;
  for (const KindCounts& k : t.kinds) report->answered += k.answered;
  report->service_lost = t.status.frames_lost;
  report->service_out_of_order = t.status.frames_out_of_order;
  report->lost = report->sent - report->answered - report->dropped - report->stale;
  report->not_received = report->sent - report->received;
  report->unaccounted =
      report->received - report->processed - report->rejected - report->dropped - report->stale;
  report->answers_missing = report->processed + report->rejected - t.answers;
  report->mailbox_sent = t.good.sent;
  report->mailbox_unanswered = t.good.sent - t.good.answered;
  for (size_t c = 0; c < cases.size(); ++c) {
    const KindCounts& k = t.kinds[c];
    if (cases[c].InstanceError()) {
      report->mailbox_sent += k.sent;
      report->mailbox_unanswered += k.sent - k.answered;
    } else {
      report->frame_error_sent += k.sent;
      report->frame_error_unanswered += k.sent - k.answered;
    }
  }

  // Process samples of the load phase: reference (first at or after reference_s) and end.
  report->reference_s = options.ReferenceTime();
  if (!samples.empty()) {
    report->end = samples.back();
    report->reference = samples.back();
    for (const Sample& s : samples) {
      if (s.t_s >= report->reference_s) {
        report->reference = s;
        break;
      }
    }
    report->threads_min = report->threads_max = report->reference.threads;
    report->fds_min = report->fds_max = report->reference.fds;
    for (const Sample& s : samples) {
      report->rss_max_mib = std::max(report->rss_max_mib, s.rss_mib);
      if (s.t_s < report->reference.t_s) continue;
      report->threads_min = std::min(report->threads_min, s.threads);
      report->threads_max = std::max(report->threads_max, s.threads);
      report->fds_min = std::min(report->fds_min, s.fds);
      report->fds_max = std::max(report->fds_max, s.fds);
    }
    if (report->reference.rss_mib > 0.0) {
      report->rss_growth_pct =
          100.0 * (report->end.rss_mib - report->reference.rss_mib) / report->reference.rss_mib;
    }
    const Sample& first = samples.front();
    if (report->end.t_s > first.t_s)
      report->cpu_cores = (report->end.cpu_s - first.cpu_s) / (report->end.t_s - first.t_s);
    if (report->end.t_s > report->reference.t_s) {
      report->cpu_cores_after_reference =
          (report->end.cpu_s - report->reference.cpu_s) / (report->end.t_s - report->reference.t_s);
    }
  }

  // The criteria.
  std::vector<std::string>& fail = report->failures;
  auto text = [](auto&&... parts) {
    std::ostringstream out;
    (out << ... << parts);
    return out.str();
  };
  if (report->interrupted) fail.push_back("interrupted before the end of the load phase");
  if (report->crashed) {
    fail.push_back(
        text("the service died at ", report->exit.at_s, " s: ", report->exit.Describe()));
  } else if (!report->exit.Clean()) {
    fail.push_back(text("after SIGTERM the service ended with ", report->exit.Describe(),
                        " (expected exit code 0)"));
  }
  if (samples.empty() || report->end.t_s <= report->reference.t_s) {
    fail.push_back("no process samples after the reference time");
  } else {
    if (!(report->rss_growth_pct < options.max_rss_growth_pct)) {
      fail.push_back(text("RSS grew ", report->rss_growth_pct, "% from ", report->reference.t_s,
                          " s to the end (limit ", options.max_rss_growth_pct, "%)"));
    }
    if (report->threads_min != report->threads_max) {
      fail.push_back(text("threads changed after ", report->reference.t_s,
                          " s: ", report->threads_min, "..", report->threads_max));
    }
    if (report->fds_min != report->fds_max) {
      fail.push_back(text("file descriptors changed after ", report->reference.t_s,
                          " s: ", report->fds_min, "..", report->fds_max));
    }
  }
  if (!t.has_status) fail.push_back("no status message from the service");
  if (!report->crashed && !report->drained)
    fail.push_back(text("the service did not settle within ", options.drain_timeout_s,
                        " s after the load (busy, or answers missing)"));
  if (report->publish_failures > 0)
    fail.push_back(text(report->publish_failures, " messages could not be published"));
  if (report->crashed) {
    // Counts stop at the last status before the crash; what was in flight is no finding.
    report->notes.push_back(
        "the service died: lost and unanswered counts include what was in flight then");
  } else if (report->lost != 0) {
    std::string where = "dropped before its handler";
    if (report->service_udp_drops == 0) {
      where =
          "no kernel drops on its sockets, so LCM discarded them: its subscription queue "
          "(--subscription-queue) was full";
    } else if (report->service_udp_drops > 0) {
      where = text(report->service_udp_drops, " datagrams dropped by the kernel on its sockets");
    }
    fail.push_back(text(report->lost, " messages lost (sent - answered - dropped - stale): ",
                        report->not_received, " never counted by the service (", where, "), ",
                        report->unaccounted, " received but neither answered nor dropped, ",
                        report->answers_missing, " answers published but not received"));
  }
  if (report->frame_error_unanswered != 0 && !report->crashed) {
    fail.push_back(
        text(report->frame_error_unanswered, " bad frames that fail validation got no answer"));
  }
  int64_t not_error = 0;
  for (size_t c = 0; c < cases.size(); ++c) {
    const KindCounts& k = t.kinds[c];
    not_error += k.not_error;
    if (k.not_error > 0) {
      fail.push_back(text("bad frames '", cases[c].name, "' answered without an error (",
                          k.not_error, "x): ", k.example));
    }
    if (k.other_error > 0) {
      report->notes.push_back(text("bad frames '", cases[c].name, "' answered with another error (",
                                   k.other_error, "x) than '", cases[c].words, "': ", k.example));
    }
  }
  if (t.good.rejected > 0)
    fail.push_back(text(t.good.rejected, " good frames rejected: ", t.good.example));
  // Every gap must be counted, and nothing else: frames the kernel dropped (not received)
  // are gaps too, so they widen the bound.
  if (t.has_status && !report->crashed &&
      (report->service_lost < report->expected_gaps ||
       report->service_lost > report->expected_gaps + report->not_received)) {
    fail.push_back(text("the service counted ", report->service_lost, " frames lost; expected ",
                        report->expected_gaps, " seq gaps (", report->withheld, " withheld)",
                        report->not_received > 0
                            ? text(" plus up to ", report->not_received, " not received")
                            : std::string()));
  }
  if (report->service_out_of_order > 0)
    report->notes.push_back(text(report->service_out_of_order, " frames out of order"));
  if (t.duplicates > 0) fail.push_back(text(t.duplicates, " duplicate answers"));
  if (t.unmatched > 0) fail.push_back(text(t.unmatched, " answers to no message of this run"));
  if (!report->final_status && report->exit.Clean())
    report->notes.push_back(
        "the status published at shutdown did not arrive; counts are from the last one before");
  report->success = fail.empty();
}

void PrintSummary(const SoakOptions& options, const std::vector<BadCase>& cases,
                  const std::string& url, pid_t pid, const SoakReport& r) {
  const Tally& t = r.tally;
  std::printf("\n== g6d-bench-soak: %.1f s at %.1f Hz (%lld messages, %.2f Hz achieved), ",
              r.wall_s, options.rate_hz, static_cast<long long>(r.sent),
              r.wall_s > 0 ? static_cast<double>(r.sent) / r.wall_s : 0.0);
  if (options.bad_every == 0) {
    std::printf("no bad messages ==\n");
  } else if (options.bad_every == 1) {
    std::printf("every message bad ==\n");
  } else {
    std::printf("every %s message bad ==\n", Ordinal(options.bad_every).c_str());
  }
  char ending[64] = "";
  if (r.crashed) std::snprintf(ending, sizeof(ending), "died at %.1f s: ", r.exit.at_s);
  std::printf("service    pid %d on %s; %s%s; crashes %d\n", static_cast<int>(pid), url.c_str(),
              r.crashed ? ending : "after SIGTERM: ", r.exit.Describe().c_str(), r.crashed ? 1 : 0);
  std::printf("messages   sent %lld = %lld good + %lld bad; received by the service %lld\n",
              static_cast<long long>(r.sent), static_cast<long long>(t.good.sent),
              static_cast<long long>(r.sent - t.good.sent), static_cast<long long>(r.received));
  std::printf(
      "           answered %lld, dropped in the mailbox %lld, stale %lld -> lost %lld "
      "(not received %lld, unaccounted %lld, answers missing %lld)\n",
      static_cast<long long>(r.answered), static_cast<long long>(r.dropped),
      static_cast<long long>(r.stale), static_cast<long long>(r.lost),
      static_cast<long long>(r.not_received), static_cast<long long>(r.unaccounted),
      static_cast<long long>(r.answers_missing));
  std::printf("           service: processed %lld (answered OK), rejected %lld (BAD_FRAME)\n",
              static_cast<long long>(r.processed), static_cast<long long>(r.rejected));
  std::printf(
      "seq gaps   withheld %lld good frames; expected gaps %lld; service: lost %lld, "
      "out of order %lld\n",
      static_cast<long long>(r.withheld), static_cast<long long>(r.expected_gaps),
      static_cast<long long>(r.service_lost), static_cast<long long>(r.service_out_of_order));
  std::printf("           kernel UDP drops: service sockets %lld, bench sockets %lld\n",
              static_cast<long long>(r.service_udp_drops),
              static_cast<long long>(r.bench_udp_drops));
  std::printf(
      "good       sent %lld, answered %lld (frame OK %lld, rejected %lld), not answered %lld\n",
      static_cast<long long>(t.good.sent), static_cast<long long>(t.good.answered),
      static_cast<long long>(t.good.frame_ok), static_cast<long long>(t.good.rejected),
      static_cast<long long>(t.good.sent - t.good.answered));
  std::printf("           estimates:");
  for (const auto& [name, count] : t.good.estimates)
    std::printf(" %s %lld", name.c_str(), static_cast<long long>(count));
  std::printf("%s\n", t.good.estimates.empty() ? " none" : "");
  int64_t bad_answered = 0, bad_errors = 0;
  for (const KindCounts& k : t.kinds) {
    bad_answered += k.answered;
    bad_errors += k.expected + k.other_error;
  }
  std::printf("bad        sent %lld, answered %lld, with an error %lld\n",
              static_cast<long long>(r.sent - t.good.sent), static_cast<long long>(bad_answered),
              static_cast<long long>(bad_errors));
  std::printf("  %-32s %7s %9s %9s %8s %9s %11s\n", "kind", "sent", "answered", "expected", "other",
              "no error", "unanswered");
  for (size_t c = 0; c < cases.size(); ++c) {
    const KindCounts& k = t.kinds[c];
    std::printf("  %-32s %7lld %9lld %9lld %8lld %9lld %11lld%s\n",
                (cases[c].name + (cases[c].InstanceError() ? " *" : "")).c_str(),
                static_cast<long long>(k.sent), static_cast<long long>(k.answered),
                static_cast<long long>(k.expected), static_cast<long long>(k.other_error),
                static_cast<long long>(k.not_error), static_cast<long long>(k.sent - k.answered),
                cases[c].seq_known ? "" : " (seq -1)");
  }
  std::printf(
      "  * passes validation, fails per instance: goes through the mailbox like a good frame\n");
  std::printf(
      "mailbox    good + * frames sent %lld, not answered %lld = dropped %lld + stale %lld %s\n",
      static_cast<long long>(r.mailbox_sent), static_cast<long long>(r.mailbox_unanswered),
      static_cast<long long>(r.dropped), static_cast<long long>(r.stale),
      r.mailbox_unanswered == r.dropped + r.stale ? "(exact)" : "(MISMATCH)");
  std::printf("           frames failing validation: sent %lld, not answered %lld\n",
              static_cast<long long>(r.frame_error_sent),
              static_cast<long long>(r.frame_error_unanswered));
  std::printf(
      "latency    good answers (%zu): publish -> answer p50 %.3f s, p95 %.3f s; service total_s "
      "p50 %.3f s, p95 %.3f s\n",
      t.good_latency_s.size(), g6d::Percentile(t.good_latency_s, 0.5),
      g6d::Percentile(t.good_latency_s, 0.95), g6d::Percentile(t.good_service_s, 0.5),
      g6d::Percentile(t.good_service_s, 0.95));
  std::printf("           error answers (%zu): publish -> answer p50 %.1f ms, p95 %.1f ms\n",
              t.error_latency_s.size(), g6d::Percentile(t.error_latency_s, 0.5) * 1e3,
              g6d::Percentile(t.error_latency_s, 0.95) * 1e3);
  std::printf("           service decode (LCM handler) p50 %.1f ms, p95 %.1f ms, max %.1f ms\n",
              g6d::Percentile(t.decode_s, 0.5) * 1e3, g6d::Percentile(t.decode_s, 0.95) * 1e3,
              g6d::Percentile(t.decode_s, 1.0) * 1e3);
  const bool short_run = options.duration_s < 120.0;
  std::printf(
      "memory     RSS at %.0f s%s %.1f MiB, at the end (%.0f s) %.1f MiB: growth %+.2f%% "
      "(limit %.1f%%); max %.1f MiB\n",
      r.reference.t_s, short_run ? " (20% of a run shorter than 2 min, instead of 1 min)" : "",
      r.reference.rss_mib, r.end.t_s, r.end.rss_mib, r.rss_growth_pct, options.max_rss_growth_pct,
      r.rss_max_mib);
  std::printf("threads    after %.0f s: min %d, max %d;  file descriptors: min %d, max %d\n",
              r.reference.t_s, r.threads_min, r.threads_max, r.fds_min, r.fds_max);
  std::printf("cpu        %.2f cores over the run (%.2f after %.0f s), %.1f s CPU\n", r.cpu_cores,
              r.cpu_cores_after_reference, r.reference.t_s, r.end.cpu_s);
  for (const std::string& note : r.notes) std::printf("note       %s\n", note.c_str());
  if (r.success) {
    std::printf("verdict    PASS\n");
  } else {
    std::printf("verdict    FAIL\n");
    for (const std::string& failure : r.failures) std::printf("  - %s\n", failure.c_str());
  }
}

nlohmann::ordered_json SummaryJson(const SoakOptions& options, const std::vector<BadCase>& cases,
                                   const std::string& url, pid_t pid, const SoakReport& r) {
  using Json = nlohmann::ordered_json;
  const Tally& t = r.tally;
  Json kinds = Json::array();
  for (size_t c = 0; c < cases.size(); ++c) {
    const KindCounts& k = t.kinds[c];
    kinds.push_back({{"name", cases[c].name},
                     {"instance_error", cases[c].InstanceError()},
                     {"expected_words", cases[c].words},
                     {"sent", k.sent},
                     {"answered", k.answered},
                     {"expected", k.expected},
                     {"other_error", k.other_error},
                     {"not_error", k.not_error},
                     {"unanswered", k.sent - k.answered},
                     {"example", k.example}});
  }
  auto percentiles = [](const std::vector<double>& values) {
    return Json{{"n", values.size()},
                {"p50", g6d::Percentile(values, 0.5)},
                {"p95", g6d::Percentile(values, 0.95)},
                {"max", g6d::Percentile(values, 1.0)}};
  };
  auto sample = [](const Sample& s) {
    return Json{{"t_s", s.t_s},
                {"rss_mib", s.rss_mib},
                {"threads", s.threads},
                {"fds", s.fds},
                {"cpu_s", s.cpu_s}};
  };
  Json out;
  out["success"] = r.success;
  out["failures"] = r.failures;
  out["notes"] = r.notes;
  out["options"] = {{"service_bin", options.service_bin},
                    {"templates", options.templates_dir},
                    {"log", options.log_path},
                    {"lcm_url", url},
                    {"duration_s", options.duration_s},
                    {"rate_hz", options.rate_hz},
                    {"bad_every", options.bad_every},
                    {"withhold_every", options.withhold_every},
                    {"workers", options.workers},
                    {"hypotheses", options.hypotheses},
                    {"service_args", options.service_args},
                    {"max_rss_growth_pct", options.max_rss_growth_pct}};
  out["wall_s"] = r.wall_s;
  out["interrupted"] = r.interrupted;
  out["service"] = {{"pid", pid},
                    {"crashes", r.crashed ? 1 : 0},
                    {"exit", r.exit.Describe()},
                    {"exit_code", r.exit.code},
                    {"exit_signal", r.exit.signal},
                    {"clean_exit", r.exit.Clean()},
                    {"died_at_s", r.crashed ? r.exit.at_s : -1.0}};
  out["messages"] = {{"sent", r.sent},
                     {"sent_good", t.good.sent},
                     {"sent_bad", r.sent - t.good.sent},
                     {"publish_failures", r.publish_failures},
                     {"received_by_service", r.received},
                     {"answered", r.answered},
                     {"processed", r.processed},
                     {"rejected", r.rejected},
                     {"dropped", r.dropped},
                     {"stale", r.stale},
                     {"lost", r.lost},
                     {"not_received", r.not_received},
                     {"unaccounted", r.unaccounted},
                     {"answers_missing", r.answers_missing},
                     {"service_udp_drops", r.service_udp_drops},
                     {"bench_udp_drops", r.bench_udp_drops},
                     {"duplicate_answers", t.duplicates},
                     {"unmatched_answers", t.unmatched},
                     {"mailbox_sent", r.mailbox_sent},
                     {"mailbox_unanswered", r.mailbox_unanswered},
                     {"frame_error_sent", r.frame_error_sent},
                     {"frame_error_unanswered", r.frame_error_unanswered},
                     {"withheld", r.withheld},
                     {"expected_gaps", r.expected_gaps},
                     {"service_lost", r.service_lost},
                     {"service_out_of_order", r.service_out_of_order}};
  out["good"] = {{"sent", t.good.sent},
                 {"answered", t.good.answered},
                 {"frame_ok", t.good.frame_ok},
                 {"rejected", t.good.rejected},
                 {"estimates", t.good.estimates},
                 {"latency_s", percentiles(t.good_latency_s)},
                 {"service_total_s", percentiles(t.good_service_s)}};
  out["bad"] = {{"kinds", kinds}, {"latency_s", percentiles(t.error_latency_s)}};
  out["service_decode_s"] = percentiles(t.decode_s);
  out["process"] = {{"reference_s", r.reference.t_s},
                    {"reference", sample(r.reference)},
                    {"end", sample(r.end)},
                    {"rss_growth_pct", r.rss_growth_pct},
                    {"rss_max_mib", r.rss_max_mib},
                    {"threads_min", r.threads_min},
                    {"threads_max", r.threads_max},
                    {"fds_min", r.fds_min},
                    {"fds_max", r.fds_max},
                    {"cpu_cores", r.cpu_cores},
                    {"cpu_cores_after_reference", r.cpu_cores_after_reference}};
  return out;
}

void WriteSamplesCsv(const std::string& path, const std::vector<Sample>& samples) {
  std::ofstream out(path);
  if (!out) G6D_THROW("cannot write " << path);
  out << "t,rss_mib,threads,fds,cpu_s,sent,answered,dropped\n";
  char line[256];
  for (const Sample& s : samples) {
    std::snprintf(line, sizeof(line), "%.3f,%.3f,%d,%d,%.3f,%lld,%lld,%lld\n", s.t_s, s.rss_mib,
                  s.threads, s.fds, s.cpu_s, static_cast<long long>(s.sent),
                  static_cast<long long>(s.answered), static_cast<long long>(s.dropped));
    out << line;
  }
}

void DrawPlot(const std::string& path, const std::vector<Sample>& samples, double reference_s,
              const std::string& title) {
  if (samples.empty()) return;
  constexpr int kWidth = 1000, kPanelHeight = 220, kLeft = 80, kRight = 20, kTop = 40, kGap = 40;
  const int height = kTop + 3 * (kPanelHeight + kGap);
  cv::Mat image(height, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  const cv::Scalar kBlack(0, 0, 0), kGrey(200, 200, 200), kRed(40, 40, 210);
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  cv::putText(image, title, {kLeft, 25}, font, 0.6, kBlack, 1, cv::LINE_AA);
  const double t_max = std::max(1.0, samples.back().t_s);
  const int plot_width = kWidth - kLeft - kRight;
  struct Series {
    const char* name;
    double (*value)(const Sample&);
    cv::Scalar colour;
  };
  const Series series[] = {
      {"RSS (MiB)", [](const Sample& s) { return s.rss_mib; }, cv::Scalar(180, 90, 20)},
      {"threads", [](const Sample& s) { return static_cast<double>(s.threads); },
       cv::Scalar(30, 140, 30)},
      {"file descriptors", [](const Sample& s) { return static_cast<double>(s.fds); },
       cv::Scalar(20, 120, 200)}};
  for (int p = 0; p < 3; ++p) {
    const Series& s = series[p];
    const int top = kTop + p * (kPanelHeight + kGap) + 15, bottom = top + kPanelHeight - 15;
    double min_value = s.value(samples.front()), max_value = min_value;
    for (const Sample& sample : samples) {
      min_value = std::min(min_value, s.value(sample));
      max_value = std::max(max_value, s.value(sample));
    }
    // Integer series: one unit of margin; RSS: 5% of its level, so small drifts stay small.
    const double margin = p == 0 ? std::max(1.0, 0.05 * max_value) : 1.0;
    const double lo = std::max(0.0, min_value - margin), hi = max_value + margin;
    auto x_of = [&](double t) { return kLeft + static_cast<int>(plot_width * t / t_max); };
    auto y_of = [&](double v) {
      return bottom - static_cast<int>((bottom - top) * (v - lo) / (hi - lo));
    };
    const bool integer = p > 0;
    const double y_step = integer ? std::max(1.0, TickStep(hi - lo, 4)) : TickStep(hi - lo, 4);
    for (double v = std::ceil(lo / y_step) * y_step; v <= hi; v += y_step) {
      cv::line(image, {kLeft, y_of(v)}, {kWidth - kRight, y_of(v)}, kGrey, 1);
      char label[32];
      std::snprintf(label, sizeof(label), y_step < 1.0 ? "%.1f" : "%.0f", v);
      cv::putText(image, label, {5, y_of(v) + 4}, font, 0.4, kBlack, 1, cv::LINE_AA);
    }
    const double t_step = TickStep(t_max, 10);
    for (double t = 0.0; t <= t_max + 1e-9; t += t_step) {
      cv::line(image, {x_of(t), bottom}, {x_of(t), bottom + 4}, kBlack, 1);
      char label[32];
      std::snprintf(label, sizeof(label), "%.0f", t);
      cv::putText(image, label, {x_of(t) - 8, bottom + 16}, font, 0.35, kBlack, 1, cv::LINE_AA);
    }
    cv::rectangle(image, {kLeft, top}, {kWidth - kRight, bottom}, kBlack, 1);
    cv::line(image, {x_of(reference_s), top}, {x_of(reference_s), bottom}, kRed, 1);
    std::vector<cv::Point> points;
    for (const Sample& sample : samples)
      points.emplace_back(x_of(sample.t_s), y_of(s.value(sample)));
    cv::polylines(image, points, false, s.colour, 2, cv::LINE_AA);
    char heading[128];
    std::snprintf(heading, sizeof(heading),
                  integer ? "%s  (min %.0f, max %.0f; red line: reference %.0f s; x: time, s)"
                          : "%s  (min %.1f, max %.1f; red line: reference %.0f s; x: time, s)",
                  s.name, min_value, max_value, reference_s);
    cv::putText(image, heading, {kLeft, top - 5}, font, 0.45, kBlack, 1, cv::LINE_AA);
  }
  if (!cv::imwrite(path, image)) G6D_THROW("cannot write " << path);
}

}  // namespace g6d::soak
