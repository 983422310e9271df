#pragma once
/// @file service_test_util.h
/// Helpers for the service tests: the synthetic service scene and its frames (from
/// lib/synthetic and wire/, shared with the benchmarks), and a listener that collects
/// answers and status messages.

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/executor.h"
#include "core/se3.h"
#include "g6d/pose_array_t.hpp"
#include "g6d/rgbd_frame_t.hpp"
#include "g6d/service_status_t.hpp"
#include "mesh/mesh.h"
#include "render/gl_renderer.h"
#include "solver/pipeline.h"
#include "synthetic/service_scene.h"
#include "synthetic/synthetic_scene.h"
#include "wire/answer.h"
#include "templates/template_bank.h"
#include "wire/frame_codec.h"
#include "wire/lcm_loop.h"
#include "wire/synthetic_frame.h"

namespace g6d::test {

/// The service tests' box pose: 0.6 m ahead, left of the image centre, a textured side seen.
inline Eigen::Isometry3d BoxPose() {
  return MakePose(
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix(),
      {-0.06, 0.0, 0.6});
}

/// The step between consecutive frames of a 30 Hz camera watching the box move: 2 mm along
/// x and 1 degree about (0.2, 1, 0.1).
inline Eigen::Isometry3d SmallStep(const Eigen::Isometry3d& pose) {
  Eigen::Isometry3d moved = pose;
  moved.linear() = Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d(0.2, 1.0, 0.1).normalized())
                       .toRotationMatrix() *
                   pose.linear();
  moved.translation() += Eigen::Vector3d(0.002, 0.0, 0.0);
  return moved;
}

// The shared generators keep their test:: names in the tests.
using namespace g6d::synthetic;  // NOLINT(build/namespaces)

/// cam_from_object of an estimate.
inline Eigen::Isometry3d PoseOf(const pose_estimate_t& estimate) { return CamFromObjectOf(estimate); }


/// A blocking queue of received messages of one type.
template <typename T>
class Inbox {
 public:
  void Push(const T& item) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      items_.push_back(item);
    }
    changed_.notify_all();
  }
  /// The oldest item, waiting up to `timeout`; nothing on timeout.
  std::optional<T> Pop(std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!changed_.wait_for(lock, timeout, [this] { return !items_.empty(); })) return std::nullopt;
    T item = std::move(items_.front());
    items_.pop_front();
    return item;
  }
  /// The first item for which `accept` holds (earlier ones are discarded), up to `timeout`.
  template <typename Predicate>
  std::optional<T> PopUntil(std::chrono::milliseconds timeout, Predicate accept) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      while (!items_.empty()) {
        T item = std::move(items_.front());
        items_.pop_front();
        if (accept(item)) return item;
      }
      if (!changed_.wait_until(lock, deadline, [this] { return !items_.empty(); }))
        return std::nullopt;
    }
  }
  size_t Size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.size();
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<T> items_;
};

/// Collects pose arrays and status messages from one service's channels.
class ServiceListener {
 public:
  ServiceListener(lcm::LCM* lcm, const std::string& output_channel,
                  const std::string& status_channel)
      : lcm_(lcm) {
    subscriptions_.push_back(lcm->subscribe(output_channel, &ServiceListener::OnAnswer, this));
    subscriptions_.push_back(lcm->subscribe(status_channel, &ServiceListener::OnStatus, this));
    for (lcm::Subscription* subscription : subscriptions_) subscription->setQueueCapacity(10000);
  }
  ~ServiceListener() {
    for (lcm::Subscription* subscription : subscriptions_) lcm_->unsubscribe(subscription);
  }
  Inbox<pose_array_t> answers;
  Inbox<service_status_t> statuses;

 private:
  void OnAnswer(const lcm::ReceiveBuffer*, const std::string&, const pose_array_t* answer) {
    answers.Push(*answer);
  }
  void OnStatus(const lcm::ReceiveBuffer*, const std::string&, const service_status_t* status) {
    statuses.Push(*status);
  }
  lcm::LCM* lcm_;
  std::vector<lcm::Subscription*> subscriptions_;
};

}  // namespace g6d::test
