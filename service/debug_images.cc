#include "service/debug_images.h"

#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cmath>
#include <sstream>

#include "core/error.h"

namespace g6d {
namespace {

// The options when they are valid and enabled; throws naming the bad field otherwise.
const DebugImageOptions& Checked(const DebugImageOptions& options) {
  if (const std::string error = options.Check(); !error.empty())
    G6D_THROW("DebugImageOptions: " << error);
  if (!options.enabled()) G6D_THROW("DebugImagePublisher: no channel given");
  return options;
}

}  // namespace

std::string DebugImageOptions::Check() const {
  std::ostringstream out;
  if (!std::isfinite(max_rate_hz) || max_rate_hz <= 0.0 || max_rate_hz > 1000.0)
    out << "debug_images_hz must be in (0, 1000] (got " << max_rate_hz << ")";
  else if (jpeg_quality < 1 || jpeg_quality > 100)
    out << "debug_images_jpeg_quality must be in 1..100 (got " << jpeg_quality << ")";
  return out.str();
}

DebugImagePublisher::DebugImagePublisher(const DebugImageOptions& options, lcm::LCM* lcm,
                                         int nice_increment)
    : options_(Checked(options)),
      lcm_(lcm),
      min_interval_(std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(1.0 / options.max_rate_hz))) {
  if (lcm_ == nullptr) G6D_THROW("DebugImagePublisher: no LCM instance");
  thread_ = std::thread([this, nice_increment] { Loop(nice_increment); });
}

DebugImagePublisher::~DebugImagePublisher() { Stop(); }

bool DebugImagePublisher::Offer(DebugImageInput input) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const Clock::time_point now = Clock::now();
    const bool too_soon = last_taken_ && now - *last_taken_ < min_interval_;
    if (stop_ || in_the_making_ || too_soon) {
      skipped_.fetch_add(1);
      return false;
    }
    pending_ = std::move(input);
    in_the_making_ = true;
    last_taken_ = now;
  }
  wake_.notify_one();
  return true;
}

void DebugImagePublisher::Stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    // A picture taken but not started is never made: counted as skipped.
    if (pending_) skipped_.fetch_add(1);
    pending_.reset();
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void DebugImagePublisher::Loop(int nice_increment) {
  // Linux applies a nice value per thread (setpriority on the thread id): the solver's
  // threads come first, a picture uses what CPU they leave.
  if (nice_increment > 0) {
    const id_t tid = static_cast<id_t>(::syscall(SYS_gettid));
    const int current = ::getpriority(PRIO_PROCESS, tid);
    ::setpriority(PRIO_PROCESS, tid, current + nice_increment);
  }
  for (;;) {
    DebugImageInput input;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || pending_.has_value(); });
      if (stop_) return;
      input = std::move(*pending_);
      pending_.reset();
    }
    MakeAndPublish(input);
    std::lock_guard<std::mutex> lock(mutex_);
    in_the_making_ = false;
  }
}

void DebugImagePublisher::MakeAndPublish(const DebugImageInput& input) {
  // Nothing may escape this thread; a picture that cannot be made is counted and logged.
  try {
    const cv::Mat picture = DrawDebugImage(input, OverlayStyle());
    int status = 0;
    if (options_.type == DebugImageType::kG6d) {
      const image_t message = MakeG6dJpeg(picture, options_.jpeg_quality);
      status = lcm_->publish(options_.channel, &message);
    } else {
      const bot_core::image_t message =
          MakeBotCoreJpeg(picture, options_.jpeg_quality, input.answer.source_utime);
      status = lcm_->publish(options_.channel, &message);
    }
    if (status != 0) G6D_THROW("publish on '" << options_.channel << "' failed");
    published_.fetch_add(1);
  } catch (const std::exception& e) {
    if (failed_.fetch_add(1) == 0)
      spdlog::warn("debug image of frame seq {}: {}", input.answer.seq, e.what());
  }
}

}  // namespace g6d
