// g6d-bench-service: load benchmark of g6d-service (not a unit test).
//
// Publishes synthetic 640x480 RGB-D frames of a textured box (one instance each) at a
// fixed rate for a given duration, over a real LCM bus, and reports what the service did:
// frames sent / processed / dropped / stale / rejected / lost, end-to-end latency p50/p95
// (service receipt -> publish, and publisher -> answer), CPU use and resident memory at the
// start and end of the run. A second, sequential phase (one frame at a time, so the
// scheduler is idle whenever a frame arrives) measures the service overhead: everything
// but the solver (decode + scheduling + building/publishing the answer) = total_s - solve.
//
// By default the service runs in this process (its own LCM instance on a udpm URL with a
// port of its own); with --external it talks to a running g6d-service on --lcm-url and
// reads CPU and memory of --service-pid from /proc (give the service the same K).
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "proc_stats.h"
#include "service/service.h"
#include "synthetic/service_scene.h"
#include "synthetic/synthetic_scene.h"
#include "wire/lcm_loop.h"
#include "wire/synthetic_frame.h"

namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

double Percentile(std::vector<double> values, double q) {
  return g6d::Percentile(std::move(values), q);
}

using g6d::bench::CpuSeconds;
using g6d::bench::RssMiB;

/// What the bench saw of one answer.
struct Observed {
  int64_t seq = 0;
  double total_s = 0.0;   ///< service: receipt -> publish
  double client_s = 0.0;  ///< bench: publish -> answer received
  std::map<std::string, double> timings;
  bool ok = false;  ///< frame OK and the estimate OK
};

/// Collects answers on the bench's LCM instance, matched to send times by seq.
class AnswerLog {
 public:
  void Sent(int64_t seq) {
    std::lock_guard<std::mutex> lock(mutex_);
    sent_at_[seq] = Clock::now();
  }
  void OnAnswer(const lcm::ReceiveBuffer*, const std::string&, const g6d::pose_array_t* answer) {
    const Clock::time_point now = Clock::now();
    Observed observed;
    observed.seq = answer->seq;
    observed.total_s = answer->total_s;
    for (size_t i = 0; i < answer->timing_names.size(); ++i)
      observed.timings[answer->timing_names[i]] = answer->timing_s[i];
    observed.ok = answer->status == g6d::pose_array_t::STATUS_OK && answer->num_estimates == 1 &&
                  answer->estimates[0].status == g6d::pose_estimate_t::STATUS_OK;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto sent = sent_at_.find(answer->seq);
      if (sent != sent_at_.end()) observed.client_s = Seconds(now - sent->second);
      answers_.push_back(observed);
    }
    arrived_.notify_all();
  }
  void OnStatus(const lcm::ReceiveBuffer*, const std::string&,
                const g6d::service_status_t* status) {
    std::lock_guard<std::mutex> lock(mutex_);
    last_status_ = *status;
    has_status_ = true;
  }
  /// Waits until the answer to `seq` arrived or `timeout` passed.
  bool WaitFor(int64_t seq, std::chrono::seconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    return arrived_.wait_for(lock, timeout, [&] {
      return std::any_of(answers_.begin(), answers_.end(),
                         [&](const Observed& o) { return o.seq == seq; });
    });
  }
  std::vector<Observed> Take() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<Observed> out;
    out.swap(answers_);
    return out;
  }
  bool LastStatus(g6d::service_status_t* status) {
    std::lock_guard<std::mutex> lock(mutex_);
    *status = last_status_;
    return has_status_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::map<int64_t, Clock::time_point> sent_at_;
  std::vector<Observed> answers_;
  g6d::service_status_t last_status_{};
  bool has_status_ = false;
};

std::vector<double> Column(const std::vector<Observed>& answers, const std::string& name) {
  std::vector<double> values;
  for (const Observed& o : answers) {
    if (name == "total")
      values.push_back(o.total_s);
    else if (name == "client")
      values.push_back(o.client_s);
    else if (name == "overhead")
      values.push_back(o.total_s - o.timings.at("solve"));
    else if (o.timings.count(name))
      values.push_back(o.timings.at(name));
  }
  return values;
}

void PrintRow(const char* label, const std::vector<double>& values_s) {
  std::printf("  %-34s p50 %8.2f ms   p95 %8.2f ms   (n = %zu)\n", label,
              Percentile(values_s, 0.5) * 1e3, Percentile(values_s, 0.95) * 1e3, values_s.size());
}

/// Replaces the flat background of a rendered view by a textured wall 1.2 m away with
/// depth noise, so that compressed frames are as large as real ones (a flat background
/// compresses to almost nothing and would flatter the decode time).
void AddClutteredBackground(g6d::synthetic::SyntheticView* view, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat wall(view->rgb.size(), CV_8UC3);
  rng.fill(wall, cv::RNG::UNIFORM, cv::Scalar::all(40), cv::Scalar::all(220));
  cv::GaussianBlur(wall, wall, cv::Size(0, 0), 1.5);
  for (int i = 0; i < 200; ++i) {
    const cv::Point centre(rng.uniform(0, wall.cols), rng.uniform(0, wall.rows));
    cv::circle(wall, centre, rng.uniform(3, 40),
               cv::Scalar(rng.uniform(0, 256), rng.uniform(0, 256), rng.uniform(0, 256)),
               cv::FILLED);
  }
  cv::Mat noise(view->depth.size(), CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 0.003);
  for (int v = 0; v < view->depth.rows; ++v) {
    for (int u = 0; u < view->depth.cols; ++u) {
      float& z = view->depth.at<float>(v, u);
      if (z > 0.0f) continue;  // the object (or the occluder)
      z = 1.2f + 0.0004f * static_cast<float>(v) + noise.at<float>(v, u);
      view->rgb.at<cv::Vec3b>(v, u) = wall.at<cv::Vec3b>(v, u);
    }
  }
}

int8_t CompressionFromName(const std::string& name) {
  if (name == "none") return g6d::image_t::COMPRESSION_NONE;
  if (name == "zstd") return g6d::image_t::COMPRESSION_ZSTD;
  if (name == "png") return g6d::image_t::COMPRESSION_PNG;
  if (name == "jpeg") return g6d::image_t::COMPRESSION_JPEG;
  G6D_THROW("--color must be none, zstd, png or jpeg (got '" << name << "')");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"g6d-bench-service: g6d-service under a fixed frame rate (load benchmark)"};
  double duration_s = 60.0, rate_hz = 30.0;
  int hypotheses = 4, workers = 2, views = 8, overhead_frames = 60;
  std::string lcm_url, color = "jpeg", input = "G6D_RGBD_BENCH", output = "G6D_POSES_BENCH",
                       status_channel = "G6D_STATUS_BENCH";
  bool external = false, quick = false, plain_background = false;
  // The cycled views are unrelated poses a few tens of milliseconds apart: a track would
  // continue from an unrelated pose. The benchmark measures detection unless asked.
  std::string tracking = "off";
  pid_t service_pid = 0;
  app.add_option("--duration-s", duration_s, "length of the load phase, seconds")
      ->capture_default_str();
  app.add_option("--rate-hz", rate_hz, "frames per second published")->capture_default_str();
  app.add_option("--hypotheses", hypotheses, "K of the in-process service")->capture_default_str();
  app.add_option("--tracking", tracking,
                 "on|off: tracking in the in-process service (the views are unrelated poses)")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app.add_option("--workers", workers, "worker threads of the in-process service")
      ->capture_default_str();
  app.add_option("--views", views, "distinct rendered frames, cycled")->capture_default_str();
  app.add_option("--overhead-frames", overhead_frames, "frames of the sequential overhead phase")
      ->capture_default_str();
  app.add_option("--color", color, "colour compression: none, zstd, png, jpeg")
      ->capture_default_str();
  app.add_option("--lcm-url", lcm_url,
                 "LCM URL (default: udpm on a port of this process, ttl=0, 8 MB receive buffer)");
  app.add_option("--input", input, "frame channel")->capture_default_str();
  app.add_option("--output", output, "answer channel")->capture_default_str();
  app.add_option("--status", status_channel, "status channel")->capture_default_str();
  app.add_flag("--external", external, "use a running g6d-service instead of starting one");
  app.add_option("--service-pid", service_pid, "pid of the external service (CPU and memory)");
  app.add_flag("--plain-background", plain_background,
               "keep the flat rendered background (tiny frames)");
  app.add_flag("--quick", quick,
               "quick solver settings of the tests instead of the paper's (except K)");
  CLI11_PARSE(app, argc, argv);
  if (lcm_url.empty()) {
    lcm_url = "udpm://239.255.76.67:" + std::to_string(30000 + getpid() % 20000) +
              "?ttl=0&recv_buf_size=8388608";
  }

  try {
    // The scene: a textured box, its template bank (the paper's 324 views), rendered views.
    std::printf("building the synthetic object, its template bank and %d views...\n", views);
    g6d::synthetic::ServiceScene scene;
    {
      scene.mesh = g6d::synthetic::MakeTexturedBox(0.10, 0.07, 0.05, 21);
      g6d::ThreadPool pool(2);
      scene.bank =
          g6d::BuildTemplateBank(scene.mesh, g6d::synthetic::kBoxId, g6d::TemplateBuildOptions(), &pool);
      g6d::GlRenderer renderer(scene.mesh);
      std::mt19937_64 rng(5);
      for (int i = 0; i < views; ++i) {
        g6d::synthetic::SyntheticOptions options;
        options.seed = static_cast<uint64_t>(i);
        scene.views.push_back(g6d::synthetic::RenderSyntheticView(
            &renderer, scene.mesh, g6d::synthetic::kServiceCamera,
            g6d::synthetic::RandomPose(g6d::synthetic::kServiceCamera, 0.5, 0.8, &rng), options));
        if (!plain_background)
          AddClutteredBackground(&scene.views.back(), static_cast<uint64_t>(i));
      }
    }
    std::vector<g6d::rgbd_frame_t> frames;
    for (int i = 0; i < views; ++i) {
      frames.push_back(g6d::synthetic::MakeRgbdFrame(scene.views[i], i, g6d::synthetic::kBoxId, "bench",
                                                CompressionFromName(color)));
    }
    const int frame_bytes = frames[0].getEncodedSize();

    // The service (in process: its own LCM instance, as a separate process would have).
    std::unique_ptr<lcm::LCM> service_lcm;
    std::unique_ptr<g6d::Service> service;
    if (!external) {
      g6d::ServiceOptions options;
      options.templates_dir = "in-process";
      options.input_channel = input;
      options.output_channel = output;
      options.status_channel = status_channel;
      options.workers = workers;
      options.solver = quick ? g6d::synthetic::QuickSolverOptions() : g6d::SolverOptions();
      options.solver.num_hypotheses = hypotheses;
      options.tracking.enabled = tracking == "on";
      g6d::TemplateStore store;
      store.banks[g6d::synthetic::kBoxId] = std::make_shared<g6d::TemplateBank>(scene.bank);
      service_lcm = std::make_unique<lcm::LCM>(lcm_url);
      if (!service_lcm->good()) G6D_THROW("cannot open LCM at " << lcm_url);
      service = std::make_unique<g6d::Service>(options, std::move(store), service_lcm.get());
      service->Start();
    }

    lcm::LCM lcm(lcm_url);
    if (!lcm.good()) G6D_THROW("cannot open LCM at " << lcm_url);
    AnswerLog log;
    lcm.subscribe(g6d::LcmChannelRegex(output), &AnswerLog::OnAnswer, &log)
        ->setQueueCapacity(100000);
    lcm.subscribe(g6d::LcmChannelRegex(status_channel), &AnswerLog::OnStatus, &log);
    g6d::LcmHandleThread pump(&lcm);
    int64_t seq = 0;
    auto publish = [&](int64_t s) {
      g6d::rgbd_frame_t frame = frames[static_cast<size_t>(s) % frames.size()];
      frame.seq = s;
      frame.image_id = static_cast<int32_t>(s);
      frame.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                        std::chrono::system_clock::now().time_since_epoch())
                        .count();
      log.Sent(s);
      lcm.publish(input, &frame);
    };

    // Warm-up: a few frames one at a time (first touches of every code path and buffer).
    for (int i = 0; i < 3; ++i) {
      publish(seq);
      if (!log.WaitFor(seq, std::chrono::seconds(120)))
        G6D_THROW("no answer to the warm-up frame " << seq);
      ++seq;
    }
    log.Take();

    // ---- Load phase: fixed rate for duration_s ----
    const pid_t measured_pid = external ? service_pid : 0;
    g6d::ServiceCounters before;
    if (service) before = service->Counters();
    const double cpu_start = CpuSeconds(measured_pid), rss_start = RssMiB(measured_pid);
    double rss_max = rss_start;
    std::vector<double> rss_samples;  // every 10 s of the load phase, MiB
    const Clock::time_point start = Clock::now();
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_hz));
    const int64_t first_load_seq = seq;
    const int64_t total_frames = static_cast<int64_t>(duration_s * rate_hz);
    std::printf(
        "load: %lld frames of %.0f kB at %.0f Hz for %.0f s, K = %d, %d workers, colour %s, %s\n",
        static_cast<long long>(total_frames), frame_bytes / 1024.0, rate_hz, duration_s, hypotheses,
        workers, color.c_str(), lcm_url.c_str());
    Clock::time_point next = start;
    for (int64_t i = 0; i < total_frames; ++i) {
      std::this_thread::sleep_until(next);  // a fixed-rate source, like a camera driver
      publish(seq++);
      next += period;
      if (i % static_cast<int64_t>(rate_hz) == 0) {
        const double rss = RssMiB(measured_pid);
        rss_max = std::max(rss_max, rss);
        if (i % static_cast<int64_t>(10 * rate_hz) == 0) rss_samples.push_back(rss);
      }
    }
    const int64_t last_load_seq = seq - 1;
    // Let the last frame in flight finish (it may have been dropped: bounded wait).
    log.WaitFor(last_load_seq, std::chrono::seconds(30));
    const double wall_s = Seconds(Clock::now() - start);
    const double cpu_s = CpuSeconds(measured_pid) - cpu_start;
    const double rss_end = RssMiB(measured_pid);
    const std::vector<Observed> load_answers = log.Take();
    g6d::ServiceCounters after;
    g6d::service_status_t status{};
    if (service) {
      after = service->Counters();
    } else if (log.LastStatus(&status)) {
      after.frames_received = status.frames_received;
      after.frames_processed = status.frames_processed;
      after.frames_dropped = status.frames_dropped;
      after.frames_stale = status.frames_stale;
      after.frames_rejected = status.frames_rejected;
    }
    int ok = 0;
    for (const Observed& o : load_answers) ok += o.ok ? 1 : 0;
    const int64_t sent = last_load_seq - first_load_seq + 1;
    const int64_t received = after.frames_received - before.frames_received;

    // ---- Overhead phase: one frame at a time ----
    for (int i = 0; i < overhead_frames; ++i) {
      publish(seq);
      if (!log.WaitFor(seq, std::chrono::seconds(60))) G6D_THROW("no answer to frame " << seq);
      ++seq;
    }
    const std::vector<Observed> sequential = log.Take();
    if (service) service->Stop();

    std::printf("\n== load phase: %.1f s at %.0f Hz, K = %d, %d workers, %s solver ==\n", wall_s,
                rate_hz, hypotheses, workers, quick ? "quick" : "paper-default");
    std::printf("  frames sent %lld, received by the service %lld (lost on the bus %lld)\n",
                static_cast<long long>(sent), static_cast<long long>(received),
                static_cast<long long>(sent - received));
    std::printf(
        "  processed %lld (answers with a pose: %d), dropped %lld, stale %lld, rejected %lld\n",
        static_cast<long long>(after.frames_processed - before.frames_processed), ok,
        static_cast<long long>(after.frames_dropped - before.frames_dropped),
        static_cast<long long>(after.frames_stale - before.frames_stale),
        static_cast<long long>(after.frames_rejected - before.frames_rejected));
    std::printf("  throughput %.2f frames/s\n", load_answers.size() / wall_s);
    PrintRow("end to end (receipt -> publish)", Column(load_answers, "total"));
    PrintRow("client (publish -> answer)", Column(load_answers, "client"));
    PrintRow("queue_wait", Column(load_answers, "queue_wait"));
    PrintRow("decode", Column(load_answers, "decode"));
    PrintRow("solve", Column(load_answers, "solve"));
    PrintRow("publish", Column(load_answers, "publish"));
    std::printf("  CPU %.1f s in %.1f s = %.2f cores (%s)\n", cpu_s, wall_s, cpu_s / wall_s,
                external ? "service process" : "this process: service + publisher");
    std::printf("  RSS start %.1f MiB, end %.1f MiB, max %.1f MiB; every 10 s:", rss_start, rss_end,
                rss_max);
    for (double rss : rss_samples) std::printf(" %.1f", rss);
    std::printf("\n");
    std::printf("\n== overhead phase: %d frames one at a time ==\n", overhead_frames);
    PrintRow("overhead (total - solve)", Column(sequential, "overhead"));
    PrintRow("  decode", Column(sequential, "decode"));
    PrintRow("  queue_wait (scheduler wake-up)", Column(sequential, "queue_wait"));
    PrintRow("  publish (answer building)", Column(sequential, "publish"));
    PrintRow("solve", Column(sequential, "solve"));
    PrintRow("end to end (receipt -> publish)", Column(sequential, "total"));
    PrintRow("client (publish -> answer)", Column(sequential, "client"));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-bench-service: %s\n", e.what());
    return 1;
  }
  return 0;
}
