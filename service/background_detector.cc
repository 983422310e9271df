#include "service/background_detector.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "core/executor.h"
#include "core/timer.h"

namespace g6d {

BackgroundDetector::BackgroundDetector(const SolverOptions& options, size_t max_queued, int nice_increment)
    : options_(options), max_queued_(max_queued) {
  options_.stop_requested = &stop_;
  thread_ = std::thread([this, nice_increment] { Loop(nice_increment); });
}

BackgroundDetector::~BackgroundDetector() { Stop(); }

bool BackgroundDetector::Submit(Job job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_ || queue_.size() >= max_queued_) {
      rejected_.fetch_add(1);
      return false;
    }
    queue_.push_back(std::move(job));
  }
  wake_.notify_one();
  return true;
}

std::vector<BackgroundDetector::Done> BackgroundDetector::TakeFinished() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Done> done;
  done.swap(finished_);
  return done;
}

void BackgroundDetector::Stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    queue_.clear();
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void BackgroundDetector::Loop(int nice_increment) {
  // Linux applies a nice value per thread (setpriority on the thread id).
  if (nice_increment > 0) {
    const id_t tid = static_cast<id_t>(::syscall(SYS_gettid));
    const int current = ::getpriority(PRIO_PROCESS, tid);
    ::setpriority(PRIO_PROCESS, tid, current + nice_increment);
  }
  InlineExecutor executor;
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      job = std::move(queue_.front());
      queue_.pop_front();
    }
    const Stopwatch watch;
    PoseResult detection = EstimatePose(job.frame, job.instance, *job.bank, options_, &executor);
    const double wall_ms = watch.ElapsedMs();
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_) return;  // cut short by Stop(): not a check worth applying
    finished_.push_back(Done{std::move(job), std::move(detection), wall_ms});
    completed_.fetch_add(1);
  }
}

}  // namespace g6d
