#pragma once
/// @file service_test_util.h
/// Helpers for the service tests and the service load benchmark: a synthetic object with a
/// small template bank, rendered frames encoded as g6d_rgbd_frame_t, an LCM pump thread
/// and a listener that collects answers and status messages.

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

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
#include "g6d/pose_array_t.hpp"
#include "g6d/rgbd_frame_t.hpp"
#include "g6d/service_status_t.hpp"
#include "lcm_pump.h"
#include "mesh/mesh.h"
#include "render/gl_renderer.h"
#include "service/frame_codec.h"
#include "solver/pipeline.h"
#include "synthetic_scene.h"
#include "templates/template_bank.h"

namespace g6d::test {

/// The camera of the synthetic service scenes (LM-O-like intrinsics, 640 x 480).
inline const Camera kServiceCamera{572.4, 573.6, 325.3, 242.0, 640, 480};

/// Object id of the synthetic box in the service tests.
inline const char kBoxId[] = "box_000001";

/// A textured box, a small template bank for it and some rendered views.
struct ServiceScene {
  Mesh mesh;
  TemplateBank bank;
  std::vector<SyntheticView> views;
};

/// Template options for quick tests: fewer views than the paper's 324.
inline TemplateBuildOptions QuickTemplateOptions() {
  TemplateBuildOptions options;
  options.views.num_directions = 60;
  options.views.num_inplane = 3;
  return options;
}

/// Solver options that keep one instance well under a second on one core (K = 2, fewer
/// correspondence sets and MHPO rounds than the paper's defaults).
inline SolverOptions QuickSolverOptions() {
  SolverOptions options;
  options.num_hypotheses = 2;
  options.match.max_sets = 48;
  options.query_orb.max_features = 300;
  options.mhpo.max_rounds = 2;
  return options;
}

/// Builds the box, its bank and `num_views` views at random poses 0.5-0.8 m away.
inline ServiceScene MakeServiceScene(int num_views, uint64_t seed) {
  ServiceScene scene;
  scene.mesh = MakeTexturedBox(0.10, 0.07, 0.05, 21);
  ThreadPool pool(2);
  scene.bank = BuildTemplateBank(scene.mesh, kBoxId, QuickTemplateOptions(), &pool);
  GlRenderer renderer(scene.mesh);
  std::mt19937_64 rng(seed);
  for (int i = 0; i < num_views; ++i) {
    SyntheticOptions options;
    options.seed = seed + static_cast<uint64_t>(i);
    scene.views.push_back(RenderSyntheticView(&renderer, scene.mesh, kServiceCamera,
                                              RandomPose(kServiceCamera, 0.5, 0.8, &rng), options));
  }
  return scene;
}

/// Encodes `view` as one frame with one instance (label 1) of `object_id`: colour RGB8
/// (`color_compression`), depth DEPTH_U16 in millimetres (zstd), labels LABEL_U8 (zstd).
inline rgbd_frame_t MakeRgbdFrame(const SyntheticView& view, int64_t seq,
                                  const std::string& object_id,
                                  const std::string& camera_id = "cam0",
                                  int8_t color_compression = image_t::COMPRESSION_NONE) {
  rgbd_frame_t frame;
  frame.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                    std::chrono::system_clock::now().time_since_epoch())
                    .count();
  frame.seq = seq;
  frame.camera_id = camera_id;
  frame.source = "service_test";
  frame.scene_id = 1;
  frame.image_id = static_cast<int32_t>(seq);
  frame.fx = kServiceCamera.fx;
  frame.fy = kServiceCamera.fy;
  frame.cx = kServiceCamera.cx;
  frame.cy = kServiceCamera.cy;
  frame.depth_scale_m = 0.001;
  frame.color = EncodeImage(view.rgb, image_t::FORMAT_RGB8, color_compression);
  cv::Mat depth_mm;
  view.depth.convertTo(depth_mm, CV_16U, 1000.0);
  frame.depth = EncodeImage(depth_mm, image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_ZSTD);
  cv::Mat labels;
  cv::threshold(view.mask, labels, 0, 1, cv::THRESH_BINARY);
  frame.labels = EncodeImage(labels, image_t::FORMAT_LABEL_U8, image_t::COMPRESSION_ZSTD);
  instance_t instance;
  instance.object_id = object_id;
  instance.label = 1;
  instance.score = 1.0f;
  instance.gt_index = 0;
  frame.instances = {instance};
  frame.num_instances = 1;
  return frame;
}

/// cam_from_object of an estimate.
inline Eigen::Isometry3d PoseOf(const pose_estimate_t& estimate) {
  const Eigen::Quaterniond rotation(estimate.orientation[0], estimate.orientation[1],
                                    estimate.orientation[2], estimate.orientation[3]);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation.normalized().toRotationMatrix();
  pose.translation() =
      Eigen::Vector3d(estimate.position[0], estimate.position[1], estimate.position[2]);
  return pose;
}


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
