// g6d-replay: feeds the frames of an LCM log to a running g6d-service, collects the
// answers, and writes the BOP results CSV and a summary JSON.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <map>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <string>

#include "core/error.h"
#include "eval/bop_csv.h"
#include "foreign_log.h"
#include "frame_log.h"
#include "replay.h"

namespace {

// Progress on stderr: a bar redrawn in place on a terminal, plain lines otherwise (logs,
// CI, pipes).
class ProgressPrinter {
 public:
  ProgressPrinter() : terminal_(::isatty(STDERR_FILENO) != 0) {}

  void Update(const g6d::ReplayProgress& progress) {
    if (terminal_) {
      DrawBar(progress);
    } else if (progress.last != nullptr) {
      PrintFrameLine(progress);
    } else if (progress.sent != last_line_sent_ &&
               (progress.sent % 10 == 0 || progress.sent == progress.total)) {
      last_line_sent_ = progress.sent;
      std::fprintf(stderr, "g6d-replay: sent %lld/%lld, answered %lld\n",
                   static_cast<long long>(progress.sent), static_cast<long long>(progress.total),
                   static_cast<long long>(progress.answered));
    }
  }

  void Finish() {
    if (terminal_ && drawn_) std::fprintf(stderr, "\n");
  }

 private:
  void DrawBar(const g6d::ReplayProgress& progress) {
    constexpr int kWidth = 30;
    const double fraction =
        progress.total > 0 ? static_cast<double>(progress.sent) / progress.total : 0.0;
    const int filled = static_cast<int>(fraction * kWidth + 0.5);
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::fprintf(stderr, "\r[%s] %lld/%lld sent, %lld answered", bar.c_str(),
                 static_cast<long long>(progress.sent), static_cast<long long>(progress.total),
                 static_cast<long long>(progress.answered));
    if (progress.last != nullptr && progress.last->answered) {
      std::fprintf(stderr, ", last %.2f s   ", progress.last->latency_s);
    }
    std::fflush(stderr);
    drawn_ = true;
  }

  void PrintFrameLine(const g6d::ReplayProgress& progress) {
    const g6d::ReplayedFrame& frame = *progress.last;
    std::fprintf(stderr, "g6d-replay: [%lld/%lld] %s scene %d image %d seq %lld: ",
                 static_cast<long long>(progress.sent), static_cast<long long>(progress.total),
                 frame.source.c_str(), frame.scene_id, frame.image_id,
                 static_cast<long long>(frame.seq));
    if (!frame.answered) {
      std::fprintf(stderr, "no answer (timed out)\n");
      return;
    }
    int ok = 0;
    for (const g6d::pose_estimate_t& estimate : frame.answer.estimates) {
      ok += estimate.status == g6d::pose_estimate_t::STATUS_OK;
    }
    if (frame.answer.status != g6d::pose_array_t::STATUS_OK) {
      std::fprintf(stderr, "rejected: %s\n", frame.answer.message.c_str());
      return;
    }
    std::fprintf(stderr, "%d/%d estimates ok, %.2f s (service %.2f s)\n", ok,
                 frame.answer.num_estimates, frame.latency_s, frame.answer.total_s);
  }

  const bool terminal_;
  bool drawn_ = false;
  int64_t last_line_sent_ = -1;
};

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) G6D_THROW("cannot write '" << path << "'");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "g6d-replay: feed an LCM log of g6d_rgbd_frame_t to a running g6d-service and collect its "
      "answers"};
  std::string log_path, lcm_url, mode = "wait", results_csv, summary_json, estimates_jsonl,
      answers_log, status_channel = "G6D_STATUS", input_type = "g6d", frame_ids;
  int wait_for_service_ms = 0;
  g6d::ReplayOptions options;
  app.add_option("--log", log_path, "LCM log of g6d_rgbd_frame_t (e.g. from g6d-bop2lcm)")
      ->required();
  app.add_option("--channel", options.channel, "frame channel, in the log and on the bus")
      ->capture_default_str();
  app.add_option("--results-channel", options.results_channel,
                 "channel of the service's g6d_pose_array_t answers")
      ->capture_default_str();
  app.add_option("--lcm-url", lcm_url,
                 "LCM URL, e.g. udpm://239.255.76.67:7667?ttl=0 (default: LCM's default)");
  app.add_option("--mode", mode,
                 "wait: next frame after the answer (or timeout); realtime: at the log timestamps; "
                 "rate:HZ: at a fixed rate")
      ->capture_default_str();
  app.add_option("--timeout-ms", options.timeout_ms,
                 "wait for an answer at most this long after sending, ms")
      ->capture_default_str();
  app.add_option("--results-csv", results_csv,
                 "BOP results CSV to write (estimates with status ok)");
  app.add_option("--summary-json", summary_json, "summary JSON to write");
  app.add_option("--estimates-jsonl", estimates_jsonl,
                 "JSON lines to write, one per estimate: ids, status, S_A, confidence, IoU, "
                 "solve time, pose");
  app.add_option("--input-type", input_type,
                 "message type of the log's frames: g6d, drake (lcmt_image_array) or bot_core "
                 "(images_t); foreign messages are sent as logged and matched by utime")
      ->capture_default_str();
  app.add_option("--frame-ids", frame_ids,
                 "scene/image ids of a drake/bot_core log by utime (default: <log>.ids.csv "
                 "when it exists, as g6d-bop2lcm --as writes it)");
  app.add_option("--answers-log", answers_log,
                 "LCM log to write with every answer received (g6d_pose_array_t on the results "
                 "channel; lcm-logger's format, e.g. for examples/print_poses.py)");
  app.add_option(
         "--wait-for-service-ms", wait_for_service_ms,
         "first wait (at most this long) for a status of the service serving --channel; 0 = "
         "do not wait")
      ->capture_default_str();
  app.add_option("--status-channel", status_channel,
                 "channel of the service's g6d_service_status_t")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    g6d::ParseReplayMode(mode, &options);
    options.input_type = g6d::ParseInputType(input_type);
    std::map<int64_t, g6d::ForeignFrameIds> ids;
    if (options.input_type != g6d::InputType::kG6d) {
      if (frame_ids.empty() && std::filesystem::exists(log_path + ".ids.csv"))
        frame_ids = log_path + ".ids.csv";
      if (!frame_ids.empty()) ids = g6d::ReadForeignFrameIds(frame_ids);
      if (ids.empty())
        std::fprintf(stderr, "g6d-replay: warning: no frame ids file: answers to %s messages "
                             "have no scene/image ids, the BOP CSV gets -1\n",
                     input_type.c_str());
    }
    const std::string bad = options.Check();
    if (!bad.empty()) G6D_THROW("bad option: " << bad);

    // Read the log once first: counts for the progress bar, and its problems up front.
    const g6d::FrameLogStats scan = g6d::ScanFrameLog(log_path, options.channel, options.input_type);
    for (const std::string& problem : scan.Problems())
      std::fprintf(stderr, "g6d-replay: warning: %s\n", problem.c_str());
    if (scan.frames == 0)
      G6D_THROW("nothing to replay: " << log_path << " holds no frame on channel "
                                      << options.channel);

    lcm::LCM lcm(lcm_url);
    if (!lcm.good()) G6D_THROW("cannot open LCM with URL '" << lcm_url << "'");
    if (wait_for_service_ms > 0) {
      g6d::service_status_t status;
      if (!g6d::WaitForService(&lcm, status_channel, options.channel, wait_for_service_ms,
                               &status)) {
        G6D_THROW("no g6d-service serving "
                  << options.channel << " reported on " << status_channel << " within "
                  << wait_for_service_ms << " ms (is it running, on LCM URL '" << lcm_url << "'?)");
      }
      std::fprintf(
          stderr, "g6d-replay: service '%s' is up: %s -> %s, %d object(s), K = %d, %d worker(s)\n",
          status.service_name.c_str(), status.input_channel.c_str(), status.output_channel.c_str(),
          status.num_objects, status.hypotheses, status.workers);
    }
    g6d::FrameLogReader reader(log_path, options.channel, options.input_type, ids);
    ProgressPrinter printer;
    const g6d::ReplayReport report =
        g6d::RunReplay(options, &reader, &lcm, scan.frames,
                       [&](const g6d::ReplayProgress& progress) { printer.Update(progress); });
    printer.Finish();

    int64_t skipped_ids = 0;
    const std::vector<g6d::BopEstimate> rows =
        g6d::AnswersToBopEstimates(report.frames, &skipped_ids);
    if (skipped_ids > 0) {
      std::fprintf(stderr,
                   "g6d-replay: warning: %lld estimate(s) have an object id that is not a BOP stem "
                   "(obj_NNNNNN); they are not in the CSV\n",
                   static_cast<long long>(skipped_ids));
    }
    if (!results_csv.empty()) g6d::WriteBopCsv(results_csv, rows);
    if (!summary_json.empty())
      WriteText(summary_json, g6d::ReplaySummaryJson(options, reader.stats(), report));
    if (!estimates_jsonl.empty())
      WriteText(estimates_jsonl, g6d::EstimatesJsonLines(report.frames));
    if (!answers_log.empty())
      g6d::WriteAnswersLog(answers_log, options.results_channel, report.frames);

    const int64_t ok =
        report.estimates_by_status.count("ok") ? report.estimates_by_status.at("ok") : 0;
    std::printf(
        "g6d-replay: %s: sent %lld, answered %lld, lost %lld, timed out %lld, rejected %lld; "
        "estimates %lld ok / %lld failed",
        log_path.c_str(), static_cast<long long>(report.sent),
        static_cast<long long>(report.answered), static_cast<long long>(report.lost),
        static_cast<long long>(report.timed_out), static_cast<long long>(report.rejected),
        static_cast<long long>(ok), static_cast<long long>(report.estimates - ok));
    for (const auto& [name, count] : report.estimates_by_status) {
      if (name != "ok") std::printf(" (%s %lld)", name.c_str(), static_cast<long long>(count));
    }
    if (ok > 0) {
      const auto count = [&](const char* mode) {
        const auto found = report.estimates_by_mode.find(mode);
        return static_cast<long long>(found == report.estimates_by_mode.end() ? 0 : found->second);
      };
      std::printf(" [detected %lld, tracked %lld, redetected %lld]", count("detected"),
                  count("tracked"), count("redetected"));
    }
    std::printf("; latency p50 %.3f s, p95 %.3f s, max %.3f s; %.1f s in all\n",
                report.latency_p50_s, report.latency_p95_s, report.latency_max_s, report.wall_s);
    if (report.unmatched_answers > 0) {
      std::fprintf(stderr,
                   "g6d-replay: note: %lld answer(s) on %s matched no frame of this run (another "
                   "publisher, or late answers to an earlier run)\n",
                   static_cast<long long>(report.unmatched_answers),
                   options.results_channel.c_str());
    }
    if (!report.success) {
      std::fprintf(stderr, "g6d-replay: %s\n", report.message.c_str());
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-replay: error: %s\n", e.what());
    return 2;
  }
}
