// g6d::Service in-process over a real LCM bus (memq) with detection requests: instances
// with neither mask nor box, found by the service itself (DetectObjects over its own depth
// proposals). The box is found within ADD 0.1 d with its region and request index, the
// next frame continues its track without a mask, an absent object is answered by exactly
// one NO_SOLUTION estimate, and an unknown object id by STATUS_UNKNOWN_OBJECT.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/se3.h"
#include "eval/metrics.h"
#include "service/service.h"
#include "service_fixture.h"
#include "service_test_util.h"
#include "test_bank.h"
#include "wire/names.h"

namespace g6d {
namespace {


// A detection request: label 0, no box, `count` instances of `object_id`.
instance_t DetectionRequest(const std::string& object_id, int32_t count) {
  instance_t instance{};  // {}: label 0, no box, no candidates
  instance.object_id = object_id;
  instance.score = 1.0f;
  instance.gt_index = -1;
  instance.count = count;
  return instance;
}

// `frame` with these instances and no label image.
rgbd_frame_t WithRequests(rgbd_frame_t frame, const std::vector<instance_t>& instances) {
  frame.instances = instances;
  frame.num_instances = static_cast<int32_t>(instances.size());
  frame.labels = image_t{};  // 0 x 0: no label image
  return frame;
}

using test::BoxPose;
using test::SmallStep;

using test::WithWall;

class ServiceDetectTest : public test::InProcessServiceTest {
 protected:
  static void SetUpTestSuite() {
    // The bank built once per test binary (test_bank.h), shared with service_input_test.
    scene_ = new test::ServiceScene(
        test::MakeServiceScene(0, 11, test::SharedBankBuilder("service-input-box")));
  }
  static void TearDownTestSuite() { delete scene_; }

  void StartService(const std::string& suffix) {
    test::SetInProcessServiceOptions(suffix, &options_);
    InProcessServiceTest::StartService(options_, test::StoreOf(scene_->bank));
  }

  pose_array_t Answer(const rgbd_frame_t& frame) { return AnswerOk(frame); }

  test::SyntheticView Render(const Eigen::Isometry3d& pose, uint64_t seed) {
    GlRenderer renderer(scene_->mesh);
    test::SyntheticOptions options;
    options.seed = seed;
    return WithWall(
        test::RenderSyntheticView(&renderer, scene_->mesh, test::kServiceCamera, pose, options));
  }

  static test::ServiceScene* scene_;
};
test::ServiceScene* ServiceDetectTest::scene_ = nullptr;

TEST_F(ServiceDetectTest, BoxIsFoundWithoutAMaskAndThenTracked) {
  StartService("detect");
  Eigen::Isometry3d truth = BoxPose();
  int track_id = -1;
  for (int k = 0; k < 2; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    const test::SyntheticView view = Render(truth, 51 + static_cast<uint64_t>(k));
    rgbd_frame_t frame = WithRequests(test::MakeRgbdFrame(view, 60 + k, test::kBoxId),
                                      {DetectionRequest("obj_000404", 1),
                                       DetectionRequest(test::kBoxId, 1)});
    frame.utime = 1700000000000000 + k * 33000;
    const pose_array_t answer = Answer(frame);
    ASSERT_EQ(answer.num_estimates, 2);
    // In request order: the unknown object first, then the box's one answer.
    const pose_estimate_t& unknown = answer.estimates[0];
    EXPECT_EQ(unknown.status, +pose_estimate_t::STATUS_UNKNOWN_OBJECT) << unknown.message;
    EXPECT_EQ(unknown.request_index, 0);
    EXPECT_FALSE(unknown.found_without_mask);
    const pose_estimate_t& box = answer.estimates[1];
    ASSERT_EQ(box.status, +pose_estimate_t::STATUS_OK) << box.message;
    EXPECT_EQ(box.request_index, 1);
    EXPECT_EQ(box.object_id, test::kBoxId);
    EXPECT_TRUE(box.found_without_mask);
    EXPECT_LT(ComputeAdd(test::PoseOf(box), truth, scene_->mesh.vertices),
              0.1 * scene_->bank.diameter_m)
        << "S_A " << box.score << ", mode " << EstimateModeName(box.mode);
    // The region it was solved on lies inside the image and holds the object's pixels.
    const cv::Rect region(box.region_box[0], box.region_box[1], box.region_box[2],
                          box.region_box[3]);
    EXPECT_GT(region.area(), 0);
    EXPECT_EQ(region & cv::Rect(0, 0, test::kServiceCamera.width, test::kServiceCamera.height),
              region);
    const cv::Rect visible = cv::boundingRect(view.mask);
    EXPECT_GT((region & visible).area(), visible.area() / 2);
    EXPECT_GT(box.region_pixels, 0);
    EXPECT_LE(box.region_pixels, region.area());
    if (k == 0) {
      // Found in the service's own proposals; the detection stages are timed.
      EXPECT_EQ(box.mode, +pose_estimate_t::MODE_DETECTED);
      track_id = box.track_id;
      EXPECT_GT(track_id, 0);
      for (const char* stage : {"detect_support", "detect_segment", "detect_propose",
                                "detect_rank", "detect_solve", "detect_select", "detect"}) {
        const auto name = std::find(answer.timing_names.begin(), answer.timing_names.end(), stage);
        ASSERT_NE(name, answer.timing_names.end()) << stage;
        EXPECT_GE(answer.timing_s[static_cast<size_t>(name - answer.timing_names.begin())], 0.0);
      }
    } else {
      // The next frame continues the track from its predicted silhouette: no detection.
      EXPECT_EQ(box.mode, +pose_estimate_t::MODE_TRACKED);
      EXPECT_EQ(box.track_id, track_id);
    }
    truth = SmallStep(truth);
  }
  EXPECT_EQ(service_->Counters().answers_detected, 1);
  EXPECT_EQ(service_->Counters().answers_tracked, 1);
}

// A track lost in a frame without masks (the box turned by 90 degrees between two frames, as
// when a robot picks it up and puts it back): the track's try is refused, detection runs and
// finds the box near the track's last position, which continues the same track re-detected.
TEST_F(ServiceDetectTest, ALostTrackFallsBackToDetectionNearIt) {
  StartService("detect_lost");
  const Eigen::Isometry3d first = BoxPose();
  Eigen::Isometry3d turned = first;
  turned.linear() = first.linear() * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  turned.translation() += Eigen::Vector3d(0.01, 0.0, 0.0);
  int track_id = -1;
  const Eigen::Isometry3d poses[2] = {first, turned};
  for (int k = 0; k < 2; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    rgbd_frame_t frame = WithRequests(test::MakeRgbdFrame(Render(poses[k], 81 + static_cast<uint64_t>(k)), 80 + k,
                                                          test::kBoxId),
                                      {DetectionRequest(test::kBoxId, 1)});
    frame.utime = 1700000000000000 + k * 33000;
    const pose_array_t answer = Answer(frame);
    ASSERT_EQ(answer.num_estimates, 1);
    const pose_estimate_t& box = answer.estimates[0];
    ASSERT_EQ(box.status, +pose_estimate_t::STATUS_OK) << box.message;
    EXPECT_TRUE(box.found_without_mask);
    EXPECT_LT(ComputeAdd(test::PoseOf(box), poses[k], scene_->mesh.vertices), 0.1 * scene_->bank.diameter_m)
        << "S_A " << box.score << ", mode " << EstimateModeName(box.mode);
    if (k == 0) {
      EXPECT_EQ(box.mode, +pose_estimate_t::MODE_DETECTED);
      track_id = box.track_id;
    } else {
      EXPECT_EQ(box.mode, +pose_estimate_t::MODE_REDETECTED);
      EXPECT_EQ(box.track_id, track_id);
    }
  }
}

TEST_F(ServiceDetectTest, AbsentObjectGetsExactlyOneNoSolution) {
  StartService("detect_absent");
  test::SyntheticView view = Render(BoxPose(), 71);
  // The depth of the wall alone: the object is not there (whatever the colour says).
  const float wall_m = static_cast<float>(view.cam_from_object.translation().z() + 0.3);
  view.depth = cv::Mat(view.depth.size(), CV_32F, cv::Scalar(wall_m));
  const rgbd_frame_t frame = WithRequests(test::MakeRgbdFrame(view, 70, test::kBoxId),
                                          {DetectionRequest(test::kBoxId, 2)});
  const pose_array_t answer = Answer(frame);
  ASSERT_EQ(answer.num_estimates, 1);
  const pose_estimate_t& none = answer.estimates[0];
  EXPECT_EQ(none.status, +pose_estimate_t::STATUS_NO_SOLUTION);
  EXPECT_EQ(none.request_index, 0);
  EXPECT_EQ(none.object_id, test::kBoxId);
  EXPECT_FALSE(none.found_without_mask);
  EXPECT_NE(none.message.find("instance 0 (box_000001): not found without a mask: "),
            std::string::npos)
      << none.message;
  EXPECT_NE(none.message.find("regions proposed"), std::string::npos) << none.message;
  EXPECT_NE(none.message.find("solved"), std::string::npos) << none.message;
  for (int i = 0; i < 4; ++i) EXPECT_EQ(none.region_box[i], 0);
  EXPECT_EQ(none.track_id, -1);
  // Still serving, and nothing was rejected.
  EXPECT_EQ(service_->Counters().frames_rejected, 0);
  EXPECT_EQ(service_->Counters().frames_processed, 1);
}

}  // namespace
}  // namespace g6d
