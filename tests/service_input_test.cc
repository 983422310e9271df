// g6d::Service in-process over a real LCM bus (memq) with the other ways to say where the
// object is: a 2D detector's box instead of a mask (label 0), and instances of unknown
// identity (no object id: every loaded object, or the listed candidate ids). The box is
// solved within ADD 0.1 d and tracked; the identity search names the object and the
// runner-up identity; every bad box or candidate is answered with its status and a message
// naming it while the service keeps serving.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
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


constexpr int kNumViews = 2;
// A second object: the scene's box 1.3 times larger, with the same print (so its templates
// match the image and its solve finds a pose, which the depth then scores clearly worse).
constexpr char kLargeBoxId[] = "box_000002";
// The margin g6d-bench-dataset --degrade-masks box and g6d-bop2lcm --instances box add
// around the visible mask's bounding box, pixels.
constexpr int kBoxMarginPx = 6;

// The frame's instance 0 as a box: label 0, the bounding box of the view's mask grown by
// kBoxMarginPx, and no label image at all.
rgbd_frame_t AsBox(rgbd_frame_t frame, const cv::Mat& mask) {
  const cv::Rect box = cv::boundingRect(mask);
  instance_t& instance = frame.instances[0];
  instance.label = 0;
  instance.box[0] = box.x - kBoxMarginPx;
  instance.box[1] = box.y - kBoxMarginPx;
  instance.box[2] = box.width + 2 * kBoxMarginPx;
  instance.box[3] = box.height + 2 * kBoxMarginPx;
  frame.labels = image_t{};  // 0 x 0: no label image
  return frame;
}

// The frame's instance 0 without an object id, with these candidates (none: every object).
rgbd_frame_t AsUnknown(rgbd_frame_t frame, const std::vector<std::string>& candidates = {}) {
  instance_t& instance = frame.instances[0];
  instance.object_id.clear();
  instance.candidate_ids = candidates;
  instance.num_candidate_ids = static_cast<int32_t>(candidates.size());
  return frame;
}

using test::BoxPose;
using test::SmallStep;

using test::WithWall;

class ServiceInputTest : public test::InProcessServiceTest {
 protected:
  static void SetUpTestSuite() {
    // Banks built once per test binary, not once per case (test_bank.h).
    scene_ = new test::ServiceScene(
        test::MakeServiceScene(kNumViews, 11, test::SharedBankBuilder("service-input-box")));
    large_mesh_ = new Mesh(test::MakeTexturedBox(0.13, 0.091, 0.065, 21));
    ThreadPool pool(2);
    large_bank_ = new TemplateBank(test::SharedTestBank(
        "service-input-large-box", *large_mesh_, kLargeBoxId, test::QuickTemplateOptions(), &pool));
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete large_mesh_;
    delete large_bank_;
  }

  // The box's bank, and the larger box's when `with_large`.
  static TemplateStore Store(bool with_large) {
    TemplateStore store = test::StoreOf(scene_->bank);
    if (with_large) store.banks[kLargeBoxId] = std::make_shared<TemplateBank>(*large_bank_);
    return store;
  }

  void StartService(const std::string& suffix, bool with_large) {
    test::SetInProcessServiceOptions(suffix, &options_);
    InProcessServiceTest::StartService(options_, Store(with_large));
  }

  // The answer to `frame`, checked to be a whole-frame OK with one estimate per instance.
  pose_array_t Answer(const rgbd_frame_t& frame) {
    const pose_array_t answer = AnswerOk(frame);
    EXPECT_EQ(answer.num_estimates, frame.num_instances);
    return answer;
  }

  static void ExpectWithinTenthDiameter(const pose_estimate_t& estimate, const Mesh& mesh,
                                        double diameter_m, const Eigen::Isometry3d& truth) {
    ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK) << estimate.message;
    EXPECT_LT(ComputeAdd(test::PoseOf(estimate), truth, mesh.vertices), 0.1 * diameter_m)
        << "S_A " << estimate.score << ", mode " << EstimateModeName(estimate.mode);
  }

  static test::ServiceScene* scene_;
  static Mesh* large_mesh_;
  static TemplateBank* large_bank_;
};
test::ServiceScene* ServiceInputTest::scene_ = nullptr;
Mesh* ServiceInputTest::large_mesh_ = nullptr;
TemplateBank* ServiceInputTest::large_bank_ = nullptr;

TEST_F(ServiceInputTest, BoxInstanceIsSolvedWithinAddTenthDiameter) {
  StartService("box", /*with_large=*/false);
  for (int i = 0; i < kNumViews; ++i) {
    SCOPED_TRACE("view " + std::to_string(i));
    const test::SyntheticView view = WithWall(scene_->views[i]);
    rgbd_frame_t frame = AsBox(test::MakeRgbdFrame(view, 10 + i, test::kBoxId), view.mask);
    frame.utime += i * 2000000LL;  // unrelated views: each one a detection
    const pose_array_t answer = Answer(frame);
    ASSERT_EQ(answer.num_estimates, 1);
    const pose_estimate_t& estimate = answer.estimates[0];
    ExpectWithinTenthDiameter(estimate, scene_->mesh, scene_->bank.diameter_m,
                              view.cam_from_object);
    EXPECT_EQ(estimate.object_id, test::kBoxId);
    EXPECT_EQ(estimate.label, 0);
    // The box holds the object and the background around it: the answer's mask fills part
    // of it only.
    EXPECT_GT(estimate.mask_iou, 0.3);
    EXPECT_LT(estimate.mask_iou, 0.95);
    EXPECT_FALSE(estimate.identity_searched);
    EXPECT_EQ(estimate.candidates_tried, 1);
    EXPECT_EQ(estimate.runner_up_object_id, "");
    EXPECT_EQ(estimate.runner_up_object_score, 0.0);
  }
}

TEST_F(ServiceInputTest, BoxInstanceIsTracked) {
  StartService("box_track", /*with_large=*/false);
  GlRenderer renderer(scene_->mesh);
  Eigen::Isometry3d truth = BoxPose();
  int track_id = -1;
  for (int k = 0; k < 2; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    test::SyntheticOptions options;
    options.seed = 41 + static_cast<uint64_t>(k);
    const test::SyntheticView view = WithWall(test::RenderSyntheticView(
        &renderer, scene_->mesh, test::kServiceCamera, truth, options));
    rgbd_frame_t frame = AsBox(test::MakeRgbdFrame(view, 20 + k, test::kBoxId), view.mask);
    frame.utime = 1700000000000000 + k * 33000;
    const pose_array_t answer = Answer(frame);
    ASSERT_EQ(answer.num_estimates, 1);
    const pose_estimate_t& estimate = answer.estimates[0];
    ExpectWithinTenthDiameter(estimate, scene_->mesh, scene_->bank.diameter_m, truth);
    // The filled box overlaps the track's predicted silhouette: the second frame continues
    // the first one's track.
    if (k == 0) {
      EXPECT_EQ(estimate.mode, +pose_estimate_t::MODE_DETECTED);
      track_id = estimate.track_id;
      EXPECT_GT(track_id, 0);
    } else {
      EXPECT_EQ(estimate.mode, +pose_estimate_t::MODE_TRACKED);
      EXPECT_EQ(estimate.track_id, track_id);
    }
    truth = SmallStep(truth);
  }
}

TEST_F(ServiceInputTest, UnknownIdentityIsChosenWithTheRunnerUp) {
  StartService("identity", /*with_large=*/true);
  // The box (the smaller object: the larger one cannot be ruled out by size), once with a
  // mask and no candidates (every loaded object), once as a box with both listed.
  for (int i = 0; i < kNumViews; ++i) {
    SCOPED_TRACE("view " + std::to_string(i));
    const test::SyntheticView view = WithWall(scene_->views[i]);
    rgbd_frame_t frame = test::MakeRgbdFrame(view, 30 + i, test::kBoxId);
    frame = i == 0 ? AsUnknown(frame) : AsUnknown(AsBox(frame, view.mask), {kLargeBoxId, test::kBoxId});
    frame.utime += i * 2000000LL;
    const pose_array_t answer = Answer(frame);
    ASSERT_EQ(answer.num_estimates, 1);
    const pose_estimate_t& estimate = answer.estimates[0];
    ExpectWithinTenthDiameter(estimate, scene_->mesh, scene_->bank.diameter_m,
                              view.cam_from_object);
    EXPECT_EQ(estimate.object_id, test::kBoxId);
    EXPECT_TRUE(estimate.identity_searched);
    EXPECT_EQ(estimate.candidates_tried, 2);
    EXPECT_EQ(estimate.runner_up_object_id, kLargeBoxId);
    EXPECT_GT(estimate.runner_up_object_score, estimate.score);
    EXPECT_GT(estimate.mask_iou, 0.3);
    // Never tracked: solved in full every frame.
    EXPECT_EQ(estimate.mode, +pose_estimate_t::MODE_DETECTED);
    EXPECT_EQ(estimate.track_id, -1);
    EXPECT_NE(std::find(answer.timing_names.begin(), answer.timing_names.end(), "identify"),
              answer.timing_names.end());
  }
  EXPECT_EQ(service_->Counters().answers_detected, kNumViews);
}

TEST_F(ServiceInputTest, BadBoxesAndCandidatesAreAnsweredAndTheServiceKeepsServing) {
  StartService("bad_input", /*with_large=*/false);
  const test::SyntheticView& view = scene_->views[0];
  rgbd_frame_t frame = test::MakeRgbdFrame(view, 40, test::kBoxId);
  const instance_t good = frame.instances[0];
  auto with_box = [&](int32_t label, int32_t x, int32_t y, int32_t width, int32_t height) {
    instance_t instance = good;
    instance.label = label;
    const int32_t box[4] = {x, y, width, height};
    std::copy(box, box + 4, instance.box);
    return instance;
  };
  auto unknown = [&](const std::vector<std::string>& candidates) {
    instance_t instance = good;
    instance.object_id.clear();
    instance.candidate_ids = candidates;
    instance.num_candidate_ids = static_cast<int32_t>(candidates.size());
    return instance;
  };
  struct Expected {
    int8_t status;
    std::string words;
  };
  const std::vector<std::pair<instance_t, Expected>> cases = {
      // A label wins over a box: this one's box (outside the image) is never read.
      {with_box(1, 5000, 5000, 10, 10), {pose_estimate_t::STATUS_OK, "ok"}},
      {with_box(0, 10, 10, 40, -3), {pose_estimate_t::STATUS_BAD_INPUT, "instance 1 (box_000001): box height must be > 0"}},
      {with_box(0, 700, 10, 40, 30),
       {pose_estimate_t::STATUS_BAD_INPUT,
        "box (x 700, y 10, width 40, height 30) lies outside the 640x480 image"}},
      {with_box(0, -100, -50, 60, 30), {pose_estimate_t::STATUS_BAD_INPUT, "lies outside"}},
      {with_box(0, 10, 10, 40, 0), {pose_estimate_t::STATUS_BAD_INPUT, "box height must be > 0 (got 0)"}},
      {with_box(-1, 10, 10, 40, 30), {pose_estimate_t::STATUS_BAD_INPUT, "label must be > 0 for a mask"}},
      {with_box(9, 10, 10, 40, 30), {pose_estimate_t::STATUS_BAD_INPUT, "label 9 has no pixels"}},
      {unknown({test::kBoxId, "obj_000404"}),
       {pose_estimate_t::STATUS_UNKNOWN_OBJECT,
        "instance 7 (identity unknown): candidate 'obj_000404' has no template cache (loaded: "
        "box_000001)"}},
      {unknown({""}), {pose_estimate_t::STATUS_BAD_INPUT, "candidate_ids[0] is empty"}},
  };
  frame.instances.clear();
  for (const auto& [instance, expected] : cases) frame.instances.push_back(instance);
  frame.num_instances = static_cast<int32_t>(frame.instances.size());
  const pose_array_t answer = Answer(frame);
  ASSERT_EQ(answer.num_estimates, static_cast<int32_t>(cases.size()));
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE("instance " + std::to_string(i));
    const pose_estimate_t& estimate = answer.estimates[i];
    EXPECT_EQ(estimate.status, cases[i].second.status) << estimate.message;
    EXPECT_NE(estimate.message.find(cases[i].second.words), std::string::npos)
        << "'" << cases[i].second.words << "' not in: " << estimate.message;
    if (estimate.status != pose_estimate_t::STATUS_OK) {
      EXPECT_EQ(estimate.mask_iou, 0.0);
      EXPECT_EQ(estimate.candidates_tried, 0);
      EXPECT_EQ(estimate.identity_searched != 0, cases[i].first.object_id.empty());
    }
  }
  ExpectWithinTenthDiameter(answer.estimates[0], scene_->mesh, scene_->bank.diameter_m,
                            view.cam_from_object);

  // Still serving: the next frame, a box, is solved.
  const test::SyntheticView wall_view = WithWall(scene_->views[1]);
  const rgbd_frame_t next =
      AsBox(test::MakeRgbdFrame(wall_view, 41, test::kBoxId), wall_view.mask);
  const pose_array_t after = Answer(next);
  ASSERT_EQ(after.num_estimates, 1);
  ExpectWithinTenthDiameter(after.estimates[0], scene_->mesh, scene_->bank.diameter_m,
                            scene_->views[1].cam_from_object);
  EXPECT_EQ(service_->Counters().frames_rejected, 0);
}

}  // namespace
}  // namespace g6d
