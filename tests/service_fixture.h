#pragma once
/// @file service_fixture.h
/// The base fixture of the in-process service tests (service_test, service_input_test,
/// service_detect_test, service_reload_test, debug_images_test): one g6d::Service on an
/// in-process LCM bus (memq), a listener on its answer and status channels, publish and
/// answer helpers, and the teardown. Each test adds its own scene, options and store.

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "service/service.h"
#include "service_test_util.h"
#include "test_bank.h"

namespace g6d::test {

/// Sets what an in-process test service needs in `options`, leaving the rest as it is:
/// channels G6D_{RGBD,POSES,STATUS}_<suffix>, two workers, the quick solver options, no
/// template folder (the store is given).
inline void SetInProcessServiceOptions(const std::string& suffix, ServiceOptions* options) {
  options->templates_dir = "unused-in-process";
  options->input_channel = "G6D_RGBD_" + suffix;
  options->output_channel = "G6D_POSES_" + suffix;
  options->status_channel = "G6D_STATUS_" + suffix;
  options->workers = 2;
  options->solver = QuickSolverOptions();
}

/// The defaults with SetInProcessServiceOptions() applied.
inline ServiceOptions InProcessServiceOptions(const std::string& suffix) {
  ServiceOptions options;
  SetInProcessServiceOptions(suffix, &options);
  return options;
}

/// A store that serves `bank` as `object_id` (no load record).
inline TemplateStore StoreOf(const TemplateBank& bank, const std::string& object_id = kBoxId) {
  TemplateStore store;
  store.banks[object_id] = std::make_shared<TemplateBank>(bank);
  return store;
}

/// `view` in front of a wall 0.3 m behind the object (the rendered views have no depth off
/// the object). Pixels without depth cannot tell the solver what part of a box is not the
/// object (region.h keeps them), so a box or a detection request needs a background the
/// depth sees, as a real camera sees a table or a wall.
inline SyntheticView WithWall(SyntheticView view) {
  const float wall_m = static_cast<float>(view.cam_from_object.translation().z() + 0.3);
  view.depth = view.depth.clone();  // the copy shares its pixels with the scene's view
  view.depth.setTo(wall_m, view.depth <= 0.0f);
  return view;
}

/// One service on a memq bus per test; stopped and released in TearDown.
class InProcessServiceTest : public ::testing::Test {
 protected:
  /// Starts the service with `options` (kept in options_) and `store`, after subscribing
  /// the listener to its answer and status channels.
  void StartService(const ServiceOptions& options, TemplateStore store) {
    options_ = options;
    listener_ =
        std::make_unique<ServiceListener>(&lcm_, options_.output_channel, options_.status_channel);
    service_ = std::make_unique<Service>(options_, std::move(store), &lcm_);
    service_->Start();
  }

  /// Publishes `frame` on the service's input channel.
  void Publish(const rgbd_frame_t& frame) {
    ASSERT_EQ(lcm_.publish(options_.input_channel, &frame), 0);
  }

  /// The next answer, failing the test (and returning an empty answer) when none arrives
  /// within `timeout`.
  pose_array_t NextAnswer(std::chrono::seconds timeout = std::chrono::seconds(60)) {
    std::optional<pose_array_t> answer = listener_->answers.Pop(timeout);
    if (!answer) ADD_FAILURE() << "no answer within " << timeout.count() << " s";
    return answer.value_or(pose_array_t{});
  }

  /// Publishes `frame` and returns its answer, checked to answer this frame's seq with a
  /// whole-frame STATUS_OK; fails the test (an empty answer) when none arrives within
  /// `timeout`.
  pose_array_t AnswerOk(const rgbd_frame_t& frame,
                        std::chrono::seconds timeout = std::chrono::seconds(120)) {
    EXPECT_EQ(lcm_.publish(options_.input_channel, &frame), 0);
    std::optional<pose_array_t> answer = listener_->answers.Pop(timeout);
    if (!answer) {
      ADD_FAILURE() << "no answer within " << timeout.count() << " s";
      return pose_array_t{};
    }
    EXPECT_EQ(answer->seq, frame.seq);
    EXPECT_EQ(answer->status, +pose_array_t::STATUS_OK) << answer->message;
    return *answer;
  }

  /// Stops the service, then releases it and the listener.
  void TearDown() override {
    if (service_) service_->Stop();
    service_.reset();
    listener_.reset();
  }

  lcm::LCM lcm_{"memq://"};
  ServiceOptions options_;
  std::unique_ptr<ServiceListener> listener_;
  std::unique_ptr<Service> service_;
};

}  // namespace g6d::test
