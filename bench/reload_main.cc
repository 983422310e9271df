// g6d-bench-reload: how long a cache copied into a running service's templates folder
// takes to be answered (issue 24). Not a unit test.
//
// The service runs in this process on a memq LCM bus with one object loaded (--start-object).
// Each round removes --object's cache from the folder (and waits until a frame naming it
// is answered UNKNOWN_OBJECT), copies the cache in (a plain copy: the watcher sees its
// IN_CLOSE_WRITE), then sends a real BOP frame naming the object back to back until one is
// answered by its bank. It reports, per round, copy -> the frame that found the object sent
// (the load: event, read, hash, parse, swap) and copy -> that frame's answer (load + one
// full solve), and the read of the cache alone (ReadCacheFile).
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "bop_to_lcm.h"
#include "core/error.h"
#include "core/stats.h"
#include "eval/bop.h"
#include "service/service.h"

namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

/// The answers of the service, in order.
class Answers {
 public:
  void OnAnswer(const lcm::ReceiveBuffer*, const std::string&, const g6d::pose_array_t* answer) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      answers_.push_back(*answer);
    }
    changed_.notify_all();
  }
  /// The answer to frame `seq`, waiting at most 120 s.
  std::optional<g6d::pose_array_t> Wait(int64_t seq) {
    std::unique_lock<std::mutex> lock(mutex_);
    const auto deadline = Clock::now() + std::chrono::seconds(120);
    for (;;) {
      while (!answers_.empty()) {
        g6d::pose_array_t answer = std::move(answers_.front());
        answers_.pop_front();
        if (answer.seq == seq) return answer;
      }
      if (!changed_.wait_until(lock, deadline, [this] { return !answers_.empty(); })) return std::nullopt;
    }
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<g6d::pose_array_t> answers_;
};

std::string CachePath(const std::string& dir, const std::string& object_id) {
  return dir + "/" + object_id + ".g6dcache";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("g6d-bench-reload: copy -> first answer of a cache added to a running service");
  std::string dataset, caches, object_id = "obj_000005", start_object = "obj_000001";
  int scene_id = 2, repeats = 5, workers = 2, hypotheses = g6d::SolverOptions().num_hypotheses;
  app.add_option("--dataset", dataset, "BOP dataset folder (e.g. ../shared/data/lmo)")->required();
  app.add_option("--caches", caches, "folder of the dataset's template caches (read only)")->required();
  app.add_option("--object", object_id, "the object whose cache is copied in")->capture_default_str();
  app.add_option("--start-object", start_object, "the object loaded at start")->capture_default_str();
  app.add_option("--scene", scene_id, "BOP scene id")->capture_default_str();
  app.add_option("--repeats", repeats, "rounds")->capture_default_str();
  app.add_option("--workers", workers, "service workers")->capture_default_str();
  app.add_option("--hypotheses", hypotheses, "K")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    namespace fs = std::filesystem;
    const int obj_id = g6d::ParseBopObjectName(object_id);
    const g6d::BopScene scene = g6d::LoadBopScene(dataset, scene_id);
    const g6d::BopFrame* frame = nullptr;
    int gt_index = -1;
    for (const g6d::BopFrame& candidate : scene.frames) {
      for (size_t g = 0; g < candidate.gt.size() && !frame; ++g) {
        if (candidate.gt[g].obj_id == obj_id) {
          frame = &candidate;
          gt_index = static_cast<int>(g);
        }
      }
      if (frame) break;
    }
    if (!frame) G6D_THROW("scene " << scene_id << " has no instance of " << object_id);

    const std::string dir = (fs::temp_directory_path() / ("g6d_bench_reload_" + std::to_string(::getpid()))).string();
    fs::remove_all(dir);
    fs::create_directories(dir);
    fs::copy_file(CachePath(caches, start_object), CachePath(dir, start_object));

    // The read alone: open, hash, parse, derive the online meshes.
    const Clock::time_point read_start = Clock::now();
    const g6d::CacheFileRead read = g6d::ReadCacheFile(CachePath(caches, object_id));
    const double read_s = Seconds(Clock::now() - read_start);
    if (!read.bank) G6D_THROW(read.error);

    lcm::LCM lcm("memq://");
    g6d::ServiceOptions options;
    options.templates_dir = dir;
    options.workers = workers;
    options.solver.num_hypotheses = hypotheses;
    options.tracking.enabled = false;  // every OK answer is a full solve
    Answers answers;
    lcm.subscribe(options.output_channel, &Answers::OnAnswer, &answers)->setQueueCapacity(1000);
    g6d::Service service(options, g6d::LoadTemplateStore(dir), &lcm);
    service.Start();

    int64_t seq = 1;
    g6d::rgbd_frame_t message =
        g6d::MakeBopFrameMessage(scene, *frame, {gt_index}, "lmo", g6d::BopToLcmOptions(), seq, 0);
    // Sends the frame again (a new seq and utime); returns its answer's estimate and the send time.
    auto send = [&](Clock::time_point* sent) {
      message.seq = seq;
      message.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
      *sent = Clock::now();
      lcm.publish(options.input_channel, &message);
      const std::optional<g6d::pose_array_t> answer = answers.Wait(seq++);
      if (!answer || answer->num_estimates != 1) G6D_THROW("no answer to frame " << seq - 1);
      return answer->estimates[0];
    };
    std::printf("g6d-bench-reload: %s (%.1f MB cache, read alone %.3f s), scene %d image %d, K = %d, %d workers\n",
                object_id.c_str(), static_cast<double>(fs::file_size(CachePath(caches, object_id))) / 1e6, read_s,
                scene_id, frame->im_id, hypotheses, workers);
    std::vector<double> load_s, answer_s;
    for (int round = 0; round < repeats; ++round) {
      fs::remove(CachePath(dir, object_id));
      Clock::time_point sent;
      while (send(&sent).status != g6d::pose_estimate_t::STATUS_UNKNOWN_OBJECT) {
      }
      const Clock::time_point copied = Clock::now();
      fs::copy_file(CachePath(caches, object_id), CachePath(dir, object_id));
      int unknown = 0;
      g6d::pose_estimate_t estimate;
      while ((estimate = send(&sent)).status == g6d::pose_estimate_t::STATUS_UNKNOWN_OBJECT) ++unknown;
      const double answered = Seconds(Clock::now() - copied);
      load_s.push_back(Seconds(sent - copied));
      answer_s.push_back(answered);
      std::printf("round %d: copy -> found %.3f s (%d frames answered UNKNOWN_OBJECT before), copy -> answer %.3f s"
                  " (status %d, S %.3f)\n",
                  round + 1, load_s.back(), unknown, answered, estimate.status, estimate.score);
    }
    service.Stop();
    fs::remove_all(dir);
    std::printf("copy -> found: median %.3f s, max %.3f s; copy -> answer: median %.3f s, max %.3f s\n",
                g6d::Percentile(load_s, 0.5), *std::max_element(load_s.begin(), load_s.end()),
                g6d::Percentile(answer_s, 0.5), *std::max_element(answer_s.begin(), answer_s.end()));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-bench-reload: %s\n", e.what());
    return 1;
  }
  return 0;
}
