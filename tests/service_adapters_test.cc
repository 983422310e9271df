// g6d-service with Drake and bot_core input on a real in-process LCM bus (memq): the same
// rendered view sent as drake.lcmt_image_array gets the very pose it gets as the
// equivalent g6d.rgbd_frame_t; bot_core.images_t with MJPEG colour is solved too; bad
// foreign messages get error answers that name the image; --publish-rigid-transforms
// publishes each OK pose as bot_core.rigid_transform_t.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "bot_core/images_t.hpp"
#include "bot_core/rigid_transform_t.hpp"
#include "drake/lcmt_image_array.hpp"
#include "eval/metrics.h"
#include "service/service.h"
#include "service_test_util.h"
#include "test_bank.h"
#include "wire/foreign_images.h"
#include "wire/input_adapters.h"

namespace g6d {
namespace {

using std::chrono::seconds;
using testing::HasSubstr;

drake::lcmt_image DrakeImage(const cv::Mat& image, int8_t pixel_format, int8_t channel_type) {
  return MakeDrakeImage(image, pixel_format, channel_type, true, 0, 5000, "drake_camera");
}

// The view as Drake's ImageToLcmImageArrayT publishes it: RGBA8, float depth, int16 labels.
drake::lcmt_image_array DrakeMessage(const test::SyntheticView& view, int32_t seq) {
  using I = drake::lcmt_image;
  cv::Mat rgba, labels;
  cv::cvtColor(view.rgb, rgba, cv::COLOR_RGB2RGBA);
  view.mask.convertTo(labels, CV_16S, 1.0 / 255.0);
  labels.setTo(32766, labels == 0);  // Drake's RenderLabel::kEmpty: not in the label map
  drake::lcmt_image_array message;
  message.header.seq = seq;
  message.header.utime = 5000 + seq;
  message.header.frame_name = "drake_camera";
  message.images = {DrakeImage(rgba, I::PIXEL_FORMAT_RGBA, I::CHANNEL_TYPE_UINT8),
                    DrakeImage(view.depth, I::PIXEL_FORMAT_DEPTH, I::CHANNEL_TYPE_FLOAT32),
                    DrakeImage(labels, I::PIXEL_FORMAT_LABEL, I::CHANNEL_TYPE_INT16)};
  message.num_images = 3;
  return message;
}

// The same planes as a g6d frame (lossless), the reference answer.
rgbd_frame_t NativeFrame(const test::SyntheticView& view, int32_t seq) {
  rgbd_frame_t frame = test::MakeRgbdFrame(view, seq, test::kBoxId, "native");
  frame.depth_scale_m = 1.0;
  frame.depth = EncodeImage(view.depth, image_t::FORMAT_DEPTH_F32, image_t::COMPRESSION_ZSTD);
  return frame;
}

bot_core::image_t BotImage(const cv::Mat& image, int32_t pixelformat, std::vector<uint8_t> data) {
  return MakeBotCoreImage(image, pixelformat, std::move(data), 9000);
}

bot_core::images_t BotCoreMessage(const test::SyntheticView& view) {
  cv::Mat bgr, depth_mm, mask;
  cv::cvtColor(view.rgb, bgr, cv::COLOR_RGB2BGR);
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90});
  view.depth.convertTo(depth_mm, CV_16U, 1000.0);
  cv::threshold(view.mask, mask, 0, 1, cv::THRESH_BINARY);
  bot_core::images_t message;
  message.utime = 9000;
  message.images = {
      BotImage(view.rgb, bot_core::image_t::PIXEL_FORMAT_MJPEG, jpeg),
      BotImage(depth_mm, bot_core::image_t::PIXEL_FORMAT_INVALID, ZlibCompress(PixelBytes(depth_mm))),
      BotImage(mask, bot_core::image_t::PIXEL_FORMAT_GRAY, ZlibCompress(PixelBytes(mask)))};
  message.image_types = {int16_t{bot_core::images_t::LEFT},
                         int16_t{bot_core::images_t::DEPTH_MM_ZIPPED},
                         int16_t{bot_core::images_t::MASK_ZIPPED}};
  message.n_images = 3;
  return message;
}

class ServiceAdapters : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { scene_ = new test::ServiceScene(test::MakeServiceScene(1, 23, test::SharedBankBuilder("service-scene"))); }
  static void TearDownTestSuite() { delete scene_; }

  // One service with `type` input on channels suffixed by the type's name.
  void Start(InputType type) {
    ServiceOptions options;
    options.templates_dir = "unused-in-process";
    const std::string suffix = InputTypeName(type);
    options.input_channel = "IN_" + suffix;
    options.output_channel = "POSES_" + suffix;
    options.status_channel = "STATUS_" + suffix;
    options.workers = 1;  // one thread: answers are exactly reproducible
    options.solver = test::QuickSolverOptions();
    options.input_type = type;
    options.adapter.camera = test::kServiceCamera;
    options.adapter.label_objects = {{1, test::kBoxId}};
    options.publish_rigid_transforms = true;
    options.rigid_transform_prefix = "POSE_" + suffix + "_";
    ASSERT_EQ(options.Check(), "");
    TemplateStore store;
    store.banks[test::kBoxId] = std::make_shared<TemplateBank>(scene_->bank);
    auto listener = std::make_unique<test::ServiceListener>(&lcm_, options.output_channel,
                                                            options.status_channel);
    lcm_.subscribe(options.rigid_transform_prefix + test::kBoxId, &ServiceAdapters::OnTransform,
                   this);
    auto service = std::make_unique<Service>(options, std::move(store), &lcm_);
    service->Start();
    listeners_.push_back(std::move(listener));
    services_.push_back(std::move(service));
  }

  pose_array_t NextAnswer(size_t service) {
    std::optional<pose_array_t> answer = listeners_[service]->answers.Pop(seconds(60));
    if (!answer) ADD_FAILURE() << "no answer within 60 s";
    return answer.value_or(pose_array_t{});
  }

  void OnTransform(const lcm::ReceiveBuffer*, const std::string& channel,
                   const bot_core::rigid_transform_t* transform) {
    transforms_.Push({channel, *transform});
  }

  void TearDown() override {
    for (auto& service : services_) service->Stop();
  }

  static test::ServiceScene* scene_;
  lcm::LCM lcm_{"memq://"};
  std::vector<std::unique_ptr<test::ServiceListener>> listeners_;
  std::vector<std::unique_ptr<Service>> services_;
  test::Inbox<std::pair<std::string, bot_core::rigid_transform_t>> transforms_;
};

test::ServiceScene* ServiceAdapters::scene_ = nullptr;

TEST_F(ServiceAdapters, DrakeImagesGetTheNativePoseAndARigidTransform) {
  Start(InputType::kG6d);
  Start(InputType::kDrake);
  const test::SyntheticView& view = scene_->views[0];
  const rgbd_frame_t native = NativeFrame(view, 7);
  ASSERT_EQ(lcm_.publish("IN_g6d", &native), 0);
  const pose_array_t reference = NextAnswer(0);
  const drake::lcmt_image_array drake_message = DrakeMessage(view, 7);
  ASSERT_EQ(lcm_.publish("IN_drake", &drake_message), 0);
  const pose_array_t answer = NextAnswer(1);

  ASSERT_EQ(answer.status, +pose_array_t::STATUS_OK) << answer.message;
  EXPECT_EQ(answer.seq, 7);
  EXPECT_EQ(answer.source_utime, 5007);
  EXPECT_EQ(answer.camera_id, "drake_camera");
  EXPECT_EQ(answer.source, "drake");
  // Drake's header carries a seq: the status counts it under the frame name.
  const auto status = listeners_[1]->statuses.PopUntil(
      seconds(30), [](const service_status_t& s) { return s.frames_processed == 1; });
  ASSERT_TRUE(status.has_value());
  ASSERT_EQ(status->num_sources, 1);
  EXPECT_EQ(status->source_ids[0], "drake_camera");
  EXPECT_EQ(status->source_has_seq[0], 1);
  EXPECT_EQ(status->source_last_seq[0], 7);
  ASSERT_EQ(answer.num_estimates, 1);
  ASSERT_EQ(reference.num_estimates, 1);
  const pose_estimate_t& estimate = answer.estimates[0];
  ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK) << estimate.message;
  EXPECT_EQ(estimate.object_id, test::kBoxId);
  EXPECT_LT(ComputeAdd(test::PoseOf(estimate), view.cam_from_object, scene_->mesh.vertices),
            0.1 * scene_->bank.diameter_m);
  // Bit-identical to the native frame's answer: the adapter loses nothing.
  for (int i = 0; i < 3; ++i) EXPECT_EQ(estimate.position[i], reference.estimates[0].position[i]);
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(estimate.orientation[i], reference.estimates[0].orientation[i]);
  EXPECT_EQ(estimate.score, reference.estimates[0].score);

  // Both services publish a rigid transform per OK estimate; the Drake one's carries the
  // Drake image time and the pose of the answer.
  bool found = false;
  for (int k = 0; k < 2 && !found; ++k) {
    const auto transform = transforms_.Pop(std::chrono::milliseconds(10000));
    ASSERT_TRUE(transform.has_value()) << "no bot_core.rigid_transform_t";
    if (transform->first != std::string("POSE_drake_") + test::kBoxId) continue;
    found = true;
    EXPECT_EQ(transform->second.utime, 5007);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(transform->second.trans[i], estimate.position[i]);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(transform->second.quat[i], estimate.orientation[i]);
  }
  EXPECT_TRUE(found);
}

TEST_F(ServiceAdapters, BotCoreMjpegImagesAreSolved) {
  Start(InputType::kBotCore);
  const test::SyntheticView& view = scene_->views[0];
  const bot_core::images_t message = BotCoreMessage(view);
  ASSERT_EQ(lcm_.publish("IN_bot_core", &message), 0);
  const pose_array_t answer = NextAnswer(0);
  ASSERT_EQ(answer.status, +pose_array_t::STATUS_OK) << answer.message;
  EXPECT_EQ(answer.source_utime, 9000);
  EXPECT_EQ(answer.camera_id, "bot_core");
  ASSERT_EQ(answer.num_estimates, 1);
  ASSERT_EQ(answer.estimates[0].status, +pose_estimate_t::STATUS_OK) << answer.estimates[0].message;
  EXPECT_LT(
      ComputeAdd(test::PoseOf(answer.estimates[0]), view.cam_from_object, scene_->mesh.vertices),
      0.1 * scene_->bank.diameter_m);
  // bot_core.images_t has no seq: its source counts frames received, never lost.
  const auto status = listeners_[0]->statuses.PopUntil(
      seconds(30), [](const service_status_t& s) { return s.frames_processed == 1; });
  ASSERT_TRUE(status.has_value());
  ASSERT_EQ(status->num_sources, 1);
  EXPECT_EQ(status->source_ids[0], "bot_core");
  EXPECT_EQ(status->source_has_seq[0], 0);
  EXPECT_EQ(status->source_received[0], 1);
  EXPECT_EQ(status->source_last_seq[0], -1);
  EXPECT_EQ(status->frames_lost, 0);
}

TEST_F(ServiceAdapters, BadForeignMessagesGetErrorAnswers) {
  Start(InputType::kDrake);
  Start(InputType::kBotCore);
  drake::lcmt_image_array drake_message = DrakeMessage(scene_->views[0], 3);
  drake_message.images[1].data[20] ^= 0xFF;  // corrupt the zlib depth
  ASSERT_EQ(lcm_.publish("IN_drake", &drake_message), 0);
  const pose_array_t drake_answer = NextAnswer(0);
  EXPECT_EQ(drake_answer.status, +pose_array_t::STATUS_BAD_FRAME);
  EXPECT_THAT(drake_answer.message, HasSubstr("drake: depth image: zlib data is corrupted"));
  EXPECT_EQ(drake_answer.seq, 3);  // the frame is still named

  // A g6d frame on the bot_core channel: the fingerprint says what it is not.
  const rgbd_frame_t wrong_type = NativeFrame(scene_->views[0], 4);
  ASSERT_EQ(lcm_.publish("IN_bot_core", &wrong_type), 0);
  const pose_array_t bot_answer = NextAnswer(1);
  EXPECT_EQ(bot_answer.status, +pose_array_t::STATUS_BAD_FRAME);
  EXPECT_THAT(bot_answer.message, HasSubstr("is not bot_core.images_t's"));
}

}  // namespace
}  // namespace g6d
