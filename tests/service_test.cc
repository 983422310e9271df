// g6d::Service in-process over a real LCM bus (memq): poses end to end, every kind of bad
// input interleaved with good frames, mailbox drops, stale frames, shutdown; an object cut
// by the image border, the runner-up and appearance fields, MakePoseEstimate; tracking
// (issue 14): tracks that continue, are lost and re-detected, start and expire, and
// tracking off answering exactly as EstimatePose.
#include "service/service.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "core/se3.h"
#include "eval/metrics.h"
#include "service_fixture.h"
#include "service_test_util.h"
#include "test_bank.h"
#include "wire/answer.h"
#include "wire/bad_frames.h"
#include "wire/names.h"

namespace g6d {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

constexpr int kNumViews = 4;

double QuaternionNorm(const double q[4]) {
  return std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
}

bool AllFinite(const double* values, int n) {
  return std::all_of(values, values + n, [](double x) { return std::isfinite(x); });
}

// The fields added with cache format 2 agree with each other and with the status: a
// runner-up is a finite pose with a unit quaternion and a finite S >= 0; without one its
// fields are 0 and the identity, and the answer is not ambiguous; the appearance agreement
// is a ZNCC in [-1, 1] when valid and 0 otherwise; a failure has no flag set at all.
void ExpectConsistentExtraFields(const pose_estimate_t& estimate) {
  SCOPED_TRACE("estimate of " + estimate.object_id + ": " + estimate.message);
  if (estimate.status != pose_estimate_t::STATUS_OK) {
    EXPECT_FALSE(estimate.truncated);
    EXPECT_FALSE(estimate.ambiguous);
    EXPECT_FALSE(estimate.has_runner_up);
    EXPECT_FALSE(estimate.appearance_valid);
    // A failure belongs to no track.
    EXPECT_EQ(estimate.mode, +pose_estimate_t::MODE_DETECTED);
    EXPECT_EQ(estimate.track_id, -1);
    EXPECT_EQ(estimate.frames_since_detection, 0);
  }
  if (estimate.has_runner_up) {
    EXPECT_TRUE(AllFinite(estimate.runner_up_position, 3));
    EXPECT_TRUE(AllFinite(estimate.runner_up_orientation, 4));
    EXPECT_NEAR(QuaternionNorm(estimate.runner_up_orientation), 1.0, 1e-9);
    EXPECT_TRUE(std::isfinite(estimate.runner_up_score));
    EXPECT_GE(estimate.runner_up_score, 0.0);
  } else {
    EXPECT_FALSE(estimate.ambiguous) << "ambiguous without a runner-up";
    for (int i = 0; i < 3; ++i) EXPECT_EQ(estimate.runner_up_position[i], 0.0);
    EXPECT_EQ(estimate.runner_up_orientation[0], 1.0);
    for (int i = 1; i < 4; ++i) EXPECT_EQ(estimate.runner_up_orientation[i], 0.0);
    EXPECT_EQ(estimate.runner_up_score, 0.0);
  }
  if (estimate.appearance_valid) {
    EXPECT_GE(estimate.appearance_agreement, -1.0);
    EXPECT_LE(estimate.appearance_agreement, 1.0);
  } else {
    EXPECT_EQ(estimate.appearance_agreement, 0.0);
  }
}

class ServiceTest : public test::InProcessServiceTest {
 protected:
  static void SetUpTestSuite() {
    scene_ = new test::ServiceScene(test::MakeServiceScene(kNumViews, 11, test::SharedBankBuilder("service-scene")));
  }
  static void TearDownTestSuite() { delete scene_; }

  static TemplateStore Store() {
    TemplateStore store = test::StoreOf(scene_->bank);
    store.loaded.push_back({"memory", test::kBoxId, static_cast<int>(scene_->bank.templates.size()),
                            scene_->bank.diameter_m, /*hash=*/"", FileSignature()});
    return store;
  }

  static ServiceOptions Options(const std::string& suffix) {
    return test::InProcessServiceOptions(suffix);
  }

  void StartService(const ServiceOptions& options) {
    InProcessServiceTest::StartService(options, Store());
  }

  static test::ServiceScene* scene_;
};
test::ServiceScene* ServiceTest::scene_ = nullptr;

TEST_F(ServiceTest, AnswersWithPosesWithinAddTenthDiameter) {
  ASSERT_TRUE(lcm_.good());
  StartService(Options("e2e"));
  const double diameter = scene_->bank.diameter_m;
  const int8_t compressions[] = {image_t::COMPRESSION_NONE, image_t::COMPRESSION_ZSTD,
                                 image_t::COMPRESSION_PNG, image_t::COMPRESSION_JPEG};
  for (int i = 0; i < kNumViews; ++i) {
    const test::SyntheticView& view = scene_->views[i];
    rgbd_frame_t frame =
        test::MakeRgbdFrame(view, 100 + i, test::kBoxId, "cam0", compressions[i % 4]);
    // Unrelated views: 2 s apart on the capture clock, more than the tracks' max age, so
    // each is a detection (a track continued from an unrelated pose can settle on a
    // geometric symmetry of the box; the tracking tests below move it as a camera would).
    frame.utime += i * 2000000LL;
    Publish(frame);
    const pose_array_t answer = NextAnswer();
    EXPECT_EQ(answer.seq, 100 + i);
    EXPECT_EQ(answer.camera_id, "cam0");
    EXPECT_EQ(answer.source, "service_test");
    EXPECT_EQ(answer.image_id, 100 + i);
    ASSERT_EQ(answer.status, +pose_array_t::STATUS_OK) << answer.message;
    ASSERT_EQ(answer.num_estimates, 1);
    const pose_estimate_t& estimate = answer.estimates[0];
    ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK) << estimate.message;
    EXPECT_EQ(estimate.object_id, test::kBoxId);
    EXPECT_EQ(estimate.label, 1);
    const double add =
        ComputeAdd(test::PoseOf(estimate), view.cam_from_object, scene_->mesh.vertices);
    EXPECT_LT(add, 0.1 * diameter)
        << "view " << i << " (" << CompressionName(compressions[i % 4]) << ")";
    const double norm = std::sqrt(estimate.orientation[0] * estimate.orientation[0] +
                                  estimate.orientation[1] * estimate.orientation[1] +
                                  estimate.orientation[2] * estimate.orientation[2] +
                                  estimate.orientation[3] * estimate.orientation[3]);
    EXPECT_NEAR(norm, 1.0, 1e-9);
    EXPECT_GE(estimate.score, 0.0);
    EXPECT_GT(estimate.confidence, 0.0);
    EXPECT_GT(estimate.iou, 0.5);
    EXPECT_GE(estimate.hypotheses, 1);
    // K = 2 PnP poses, and the point-pair-feature and outline poses beside them.
    EXPECT_LE(estimate.hypotheses, 2 + SolverOptions().ppf_hypotheses + SolverOptions().silhouette_hypotheses);
    EXPECT_GT(estimate.solve_time_s, 0.0);
    // The views keep the whole box inside the image; its printed texture is compared with
    // the image at the answer, and agrees with it at the right pose.
    EXPECT_FALSE(estimate.truncated);
    EXPECT_TRUE(estimate.appearance_valid);
    EXPECT_GT(estimate.appearance_agreement, 0.5);
    ExpectConsistentExtraFields(estimate);
    // Tracking is on by default: each frame starts a new track (the last one expired).
    EXPECT_EQ(estimate.mode, +pose_estimate_t::MODE_DETECTED);
    EXPECT_EQ(estimate.track_id, i + 1);
    EXPECT_EQ(estimate.frames_since_detection, 0);
    // Every named timing is there, and end to end covers decode + solve.
    ASSERT_EQ(answer.timing_names.size(), answer.timing_s.size());
    for (const char* name : {"queue_wait", "decode", "features", "match", "pnp", "observable",
                             "icp", "mhpo", "finalists", "track", "solve", "publish"}) {
      EXPECT_NE(std::find(answer.timing_names.begin(), answer.timing_names.end(), name),
                answer.timing_names.end())
          << name;
    }
    double decode_s = 0.0, solve_s = 0.0;
    for (size_t t = 0; t < answer.timing_names.size(); ++t) {
      EXPECT_GE(answer.timing_s[t], 0.0) << answer.timing_names[t];
      if (answer.timing_names[t] == "decode") decode_s = answer.timing_s[t];
      if (answer.timing_names[t] == "solve") solve_s = answer.timing_s[t];
    }
    EXPECT_GE(answer.total_s, decode_s + solve_s);
  }
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.frames_received, kNumViews);
  EXPECT_EQ(counters.frames_processed, kNumViews);
  EXPECT_EQ(counters.frames_rejected, 0);
  EXPECT_GT(counters.latency_p50_s, 0.0);
}

// ---- Bad input ------------------------------------------------------------------------

// The kinds of bad input and their expected answers are in bad_frames.h (shared with the
// soak benchmark).
using test::BadCase;
using test::MakeBadCases;
using test::PatchSeq;

TEST_F(ServiceTest, HundredGoodAndHundredBadFramesInterleaved) {
  StartService(Options("mixed"));
  // The bad messages of every view, built once; each send patches its sequence number in.
  std::vector<std::vector<BadCase>> bad_cases;
  for (int v = 0; v < kNumViews; ++v)
    bad_cases.push_back(MakeBadCases(test::MakeRgbdFrame(scene_->views[v], 0, test::kBoxId)));
  const size_t num_cases = bad_cases[0].size();
  // Under a sanitizer (5-20x slower; this test took 110 s of CI's TSan run) each bad case is
  // sent once between good frames: the same code paths and threads, a fifth of the frames.
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
  const int pairs = std::max(static_cast<int>(num_cases), kNumViews);
#else
  const int pairs = 100;
#endif
  int good_results = 0, error_results = 0, frame_rejects = 0;
  std::vector<int> seen_cases(num_cases, 0);
  for (int i = 0; i < 2 * pairs; ++i) {
    const int64_t seq = 1000 + i;
    if (i % 2 == 0) {
      const test::SyntheticView& view = scene_->views[(i / 2) % kNumViews];
      Publish(test::MakeRgbdFrame(view, seq, test::kBoxId));
      const pose_array_t answer = NextAnswer();
      EXPECT_EQ(answer.seq, seq);
      if (answer.status == pose_array_t::STATUS_OK && answer.num_estimates == 1 &&
          answer.estimates[0].status == pose_estimate_t::STATUS_OK) {
        ++good_results;
      } else {
        ADD_FAILURE() << "good frame " << seq << ": " << answer.message
                      << (answer.num_estimates > 0 ? " / " + answer.estimates[0].message : "");
      }
      continue;
    }
    const size_t which = static_cast<size_t>(i / 2) % num_cases;
    BadCase bad = bad_cases[which % kNumViews][which];
    if (bad.seq_known) PatchSeq(&bad.bytes, seq);
    SCOPED_TRACE(bad.name);
    ++seen_cases[which];
    ASSERT_EQ(lcm_.publish(options_.input_channel, bad.bytes.data(),
                           static_cast<unsigned>(bad.bytes.size())),
              0);
    const pose_array_t answer = NextAnswer();
    EXPECT_EQ(answer.seq, bad.seq_known ? seq : -1);
    EXPECT_EQ(answer.status, bad.frame_status) << answer.message;
    std::string message = answer.message;
    if (answer.status == pose_array_t::STATUS_OK) {
      ASSERT_EQ(answer.num_estimates, 1);
      EXPECT_EQ(answer.estimates[0].status, bad.estimate_status);
      message = answer.estimates[0].message;
    } else {
      EXPECT_EQ(answer.num_estimates, 0);
      ++frame_rejects;
    }
    EXPECT_NE(message.find(bad.words), std::string::npos)
        << "'" << bad.words << "' not in: " << message;
    const bool is_error =
        answer.status != pose_array_t::STATUS_OK ||
        (answer.num_estimates == 1 && answer.estimates[0].status != pose_estimate_t::STATUS_OK);
    error_results += is_error ? 1 : 0;
  }
  EXPECT_EQ(good_results, pairs);
  EXPECT_EQ(error_results, pairs);
  for (size_t c = 0; c < num_cases; ++c)
    EXPECT_GT(seen_cases[c], 0) << "case " << c << " never sent";

  // Still alive and answering: one more good frame, and the counters add up.
  Publish(test::MakeRgbdFrame(scene_->views[0], 5000, test::kBoxId));
  const pose_array_t last = NextAnswer();
  EXPECT_EQ(last.seq, 5000);
  ASSERT_EQ(last.num_estimates, 1);
  EXPECT_EQ(last.estimates[0].status, +pose_estimate_t::STATUS_OK);
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.frames_received, 2 * pairs + 1);
  EXPECT_EQ(counters.frames_rejected, frame_rejects);
  EXPECT_EQ(counters.frames_processed, 2 * pairs + 1 - frame_rejects);
  EXPECT_EQ(counters.frames_dropped, 0);
  // The status channel reports the same.
  const auto status = listener_->statuses.PopUntil(
      seconds(10), [pairs](const service_status_t& s) { return s.frames_received == 2 * pairs + 1; });
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->frames_rejected, frame_rejects);
  EXPECT_EQ(status->num_objects, 1);
  EXPECT_EQ(status->objects[0], test::kBoxId);
  EXPECT_EQ(status->hypotheses, 2);
  EXPECT_EQ(status->workers, 2);
}

TEST_F(ServiceTest, OneBadInstanceDoesNotSpoilTheOthers) {
  StartService(Options("instances"));
  rgbd_frame_t frame = test::MakeRgbdFrame(scene_->views[1], 7, test::kBoxId);
  instance_t empty = frame.instances[0];
  empty.label = 9;  // no pixels
  instance_t unknown = frame.instances[0];
  unknown.object_id = "obj_000404";  // label 1 again: the same mask, an object without cache
  frame.instances = {frame.instances[0], empty, unknown};
  frame.num_instances = 3;
  Publish(frame);
  const pose_array_t answer = NextAnswer();
  ASSERT_EQ(answer.status, +pose_array_t::STATUS_OK) << answer.message;
  ASSERT_EQ(answer.num_estimates, 3);
  EXPECT_EQ(answer.estimates[0].status, +pose_estimate_t::STATUS_OK) << answer.estimates[0].message;
  EXPECT_EQ(answer.estimates[1].status, +pose_estimate_t::STATUS_BAD_INPUT);
  EXPECT_EQ(answer.estimates[1].label, 9);
  EXPECT_EQ(answer.estimates[2].status, +pose_estimate_t::STATUS_UNKNOWN_OBJECT);
  EXPECT_EQ(answer.estimates[2].object_id, "obj_000404");
  for (const pose_estimate_t& estimate : answer.estimates) ExpectConsistentExtraFields(estimate);
}

TEST_F(ServiceTest, ObjectCutByTheImageBorderIsSolvedAndFlagged) {
  StartService(Options("truncated"));
  // The box 0.6 m away with its centre 25 px from the left edge of the image: about a
  // third of it is outside. The solver used to refuse such a mask; now it is solved.
  const Camera& camera = test::kServiceCamera;
  const Eigen::Isometry3d cam_from_object = MakePose(
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix(),
      camera.Backproject({25.0, 240.0}, 0.6));
  GlRenderer renderer(scene_->mesh);
  test::SyntheticOptions view_options;
  view_options.seed = 31;
  const test::SyntheticView cut =
      test::RenderSyntheticView(&renderer, scene_->mesh, camera, cam_from_object, view_options);
  const cv::Rect box = cv::boundingRect(cut.mask);
  ASSERT_EQ(box.x, 0) << "the view should be cut by the left border";
  ASSERT_GT(cv::countNonZero(cut.mask), 1000);

  Publish(test::MakeRgbdFrame(cut, 600, test::kBoxId));
  const pose_array_t answer = NextAnswer();
  ASSERT_EQ(answer.status, +pose_array_t::STATUS_OK) << answer.message;
  ASSERT_EQ(answer.num_estimates, 1);
  const pose_estimate_t& estimate = answer.estimates[0];
  ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK) << estimate.message;
  EXPECT_TRUE(estimate.truncated);
  EXPECT_NEAR(QuaternionNorm(estimate.orientation), 1.0, 1e-9);
  EXPECT_LT(ComputeAdd(test::PoseOf(estimate), cut.cam_from_object, scene_->mesh.vertices),
            0.1 * scene_->bank.diameter_m);
  ExpectConsistentExtraFields(estimate);

  // The same object inside the image is not flagged.
  Publish(test::MakeRgbdFrame(scene_->views[0], 601, test::kBoxId));
  const pose_array_t inside = NextAnswer();
  ASSERT_EQ(inside.num_estimates, 1);
  ASSERT_EQ(inside.estimates[0].status, +pose_estimate_t::STATUS_OK) << inside.estimates[0].message;
  EXPECT_FALSE(inside.estimates[0].truncated);
}

TEST_F(ServiceTest, RunnerUpTravelsWithTheAnswer) {
  // Every finalist farther than a micrometre-scale fraction of the diameter from the answer
  // counts as a different answer, so the finalists of K = 3 distinct hypotheses leave a
  // runner-up on every frame where two of them did not converge to bit-identical poses.
  ServiceOptions options = Options("runner_up");
  options.solver.num_hypotheses = 3;
  options.solver.ambiguity_distance_fraction = 1e-6;
  StartService(options);
  int with_runner_up = 0;
  for (int i = 0; i < kNumViews; ++i) {
    Publish(test::MakeRgbdFrame(scene_->views[i], 700 + i, test::kBoxId));
    const pose_array_t answer = NextAnswer();
    ASSERT_EQ(answer.num_estimates, 1);
    const pose_estimate_t& estimate = answer.estimates[0];
    ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK) << estimate.message;
    ExpectConsistentExtraFields(estimate);
    if (!estimate.has_runner_up) continue;
    ++with_runner_up;
    // A different pose from the answer, not a copy of it.
    const Eigen::Isometry3d answer_pose = test::PoseOf(estimate);
    pose_estimate_t runner_up = estimate;
    std::copy(estimate.runner_up_position, estimate.runner_up_position + 3, runner_up.position);
    std::copy(estimate.runner_up_orientation, estimate.runner_up_orientation + 4,
              runner_up.orientation);
    EXPECT_GT(ComputeAdd(test::PoseOf(runner_up), answer_pose, scene_->mesh.vertices), 0.0);
  }
  EXPECT_GT(with_runner_up, 0) << "no frame had a runner-up";
}

TEST_F(ServiceTest, NewerFrameReplacesTheWaitingOne) {
  StartService(Options("drops"));
  // Published back to back: while the first is solved, later ones replace each other in
  // the mailbox. Whatever the timing, every frame is either answered or counted as a
  // drop, and the newest frame is always answered.
  const int kFrames = 4;
  for (int i = 0; i < kFrames; ++i)
    Publish(test::MakeRgbdFrame(scene_->views[i % kNumViews], 200 + i, test::kBoxId));
  int answered = 0;
  bool newest_answered = false;
  while (!newest_answered) {
    const std::optional<pose_array_t> answer = listener_->answers.Pop(seconds(60));
    ASSERT_TRUE(answer.has_value()) << "the newest frame was never answered";
    ++answered;
    newest_answered = answer->seq == 200 + kFrames - 1;
  }
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.frames_received, kFrames);
  EXPECT_EQ(answered + counters.frames_dropped, kFrames);
  EXPECT_EQ(counters.frames_processed, answered);
}

TEST_F(ServiceTest, StaleFramesAreDroppedAndCounted) {
  ServiceOptions options = Options("stale");
  options.max_age_ms = 2000;
  StartService(options);
  rgbd_frame_t old_frame = test::MakeRgbdFrame(scene_->views[0], 300, test::kBoxId);
  old_frame.utime -= 60 * 1000000LL;  // a minute old
  Publish(old_frame);
  // A fresh frame with an unknown object (answered without solving) shows the service has
  // handled everything published before it.
  rgbd_frame_t fresh = test::MakeRgbdFrame(scene_->views[0], 301, "obj_000404");
  Publish(fresh);
  const pose_array_t answer = NextAnswer();
  EXPECT_EQ(answer.seq, 301);
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.frames_received, 2);
  EXPECT_EQ(counters.frames_stale, 1);
  EXPECT_EQ(listener_->answers.Size(), 0u);
}

TEST_F(ServiceTest, StopWhileSolvingAbandonsOrFinishesAndJoins) {
  ServiceOptions options = Options("stop");
  options.status_period_s = 0.05;
  StartService(options);
  rgbd_frame_t frame = test::MakeRgbdFrame(scene_->views[2], 400, test::kBoxId);
  // Several instances of the same object: the ones not started when Stop() comes are
  // abandoned.
  frame.instances = std::vector<instance_t>(6, frame.instances[0]);
  frame.num_instances = 6;
  Publish(frame);
  // Stop once the service has taken the frame (usually in the middle of solving it).
  const auto taken = listener_->statuses.PopUntil(
      seconds(30), [](const service_status_t& status) { return status.frames_received == 1; });
  ASSERT_TRUE(taken.has_value());
  service_->Stop();
  const ServiceCounters counters = service_->Counters();
  EXPECT_FALSE(counters.busy);
  EXPECT_EQ(counters.frames_received, 1);
  EXPECT_EQ(counters.frames_processed + counters.frames_dropped, 1);
  service_->Stop();  // idempotent
}

// ---- Tracking (issue 14) --------------------------------------------------------------------

// Frames of a 30 Hz camera, on the capture clock the tracker ages its tracks with.
constexpr int64_t kStartUtime = 1700000000000000;
constexpr int64_t kFramePeriodUs = 33000;

// `pose` turned by `angle_rad` about `axis` (camera frame) around the object's origin, then
// moved by `translation_m` (camera frame).
Eigen::Isometry3d Moved(const Eigen::Isometry3d& pose, const Eigen::Vector3d& translation_m,
                        double angle_rad, const Eigen::Vector3d& axis) {
  Eigen::Isometry3d moved = pose;
  moved.linear() =
      Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix() * pose.linear();
  moved.translation() += translation_m;
  return moved;
}

using test::BoxPose;
using test::SmallStep;

// One frame of `view` at `utime`.
rgbd_frame_t FrameAt(const test::SyntheticView& view, int64_t seq, int64_t utime) {
  rgbd_frame_t frame = test::MakeRgbdFrame(view, seq, test::kBoxId);
  frame.utime = utime;
  return frame;
}

// One frame of two boxes that do not overlap in the image: `first` as label 1 (gt_index 0)
// and `second` pasted over its background as label 2 (gt_index 1).
rgbd_frame_t TwoBoxFrameAt(const test::SyntheticView& first, const test::SyntheticView& second,
                           int64_t seq, int64_t utime) {
  test::SyntheticView both = first;
  second.rgb.copyTo(both.rgb, second.mask);
  second.depth.copyTo(both.depth, second.mask);
  rgbd_frame_t frame = FrameAt(both, seq, utime);
  cv::Mat labels(first.mask.size(), CV_8U, cv::Scalar(0));
  labels.setTo(1, first.mask > 0);
  labels.setTo(2, second.mask > 0);
  frame.labels = EncodeImage(labels, image_t::FORMAT_LABEL_U8, image_t::COMPRESSION_ZSTD);
  instance_t instance = frame.instances[0];
  instance.label = 2;
  instance.gt_index = 1;
  frame.instances.push_back(instance);
  frame.num_instances = 2;
  return frame;
}

class ServiceTrackingTest : public ServiceTest {
 protected:
  // The box at `cam_from_object`, with the scene's depth noise (seed per view).
  test::SyntheticView Render(const Eigen::Isometry3d& cam_from_object, uint64_t seed) {
    if (!renderer_) renderer_ = std::make_unique<GlRenderer>(scene_->mesh);
    test::SyntheticOptions options;
    options.seed = seed;
    return test::RenderSyntheticView(renderer_.get(), scene_->mesh, test::kServiceCamera,
                                     cam_from_object, options);
  }

  // The single OK estimate of the answer to `frame`, checked against the ground truth
  // (ADD < 0.1 d).
  pose_estimate_t Solve(const rgbd_frame_t& frame, const Eigen::Isometry3d& truth) {
    Publish(frame);
    const pose_array_t answer = NextAnswer();
    EXPECT_EQ(answer.seq, frame.seq);
    EXPECT_EQ(answer.num_estimates, 1);
    if (answer.num_estimates != 1) return pose_estimate_t{};
    const pose_estimate_t& estimate = answer.estimates[0];
    EXPECT_EQ(estimate.status, +pose_estimate_t::STATUS_OK) << estimate.message;
    ExpectNear(estimate, truth);
    return estimate;
  }

  static void ExpectNear(const pose_estimate_t& estimate, const Eigen::Isometry3d& truth) {
    EXPECT_LT(ComputeAdd(test::PoseOf(estimate), truth, scene_->mesh.vertices),
              0.1 * scene_->bank.diameter_m)
        << "mode " << EstimateModeName(estimate.mode) << ", S_A " << estimate.score;
    ExpectConsistentExtraFields(estimate);
  }

  std::unique_ptr<GlRenderer> renderer_;
};

TEST_F(ServiceTrackingTest, TrackContinuesOverConsecutiveFrames) {
  StartService(Options("track_continues"));
  Eigen::Isometry3d truth = BoxPose();
  const pose_estimate_t first = Solve(FrameAt(Render(truth, 41), 1, kStartUtime), truth);
  EXPECT_EQ(first.mode, +pose_estimate_t::MODE_DETECTED);
  EXPECT_GT(first.track_id, 0);
  EXPECT_EQ(first.frames_since_detection, 0);
  for (int frame = 1; frame <= 2; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame + 1));
    truth = SmallStep(truth);
    const pose_estimate_t next = Solve(
        FrameAt(Render(truth, 41 + frame), 1 + frame, kStartUtime + frame * kFramePeriodUs), truth);
    EXPECT_EQ(next.mode, +pose_estimate_t::MODE_TRACKED);
    EXPECT_EQ(next.track_id, first.track_id);
    EXPECT_EQ(next.frames_since_detection, frame);
    EXPECT_GT(next.solve_time_s, 0.0);
  }
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.answers_detected, 1);
  EXPECT_EQ(counters.answers_tracked, 2);
  EXPECT_EQ(counters.answers_redetected, 0);
  const service_status_t status = service_->MakeStatus();
  EXPECT_EQ(status.tracking, 1);
  EXPECT_EQ(status.answers_detected, 1);
  EXPECT_EQ(status.answers_tracked, 2);
  EXPECT_EQ(status.answers_redetected, 0);
}

TEST_F(ServiceTrackingTest, LostTrackIsRedetectedWithTheSameId) {
  StartService(Options("track_lost"));
  const Eigen::Isometry3d truth = BoxPose();
  const pose_estimate_t first = Solve(FrameAt(Render(truth, 51), 1, kStartUtime), truth);
  ASSERT_GT(first.track_id, 0);
  // Turned 90 degrees in place about the line of sight: the mask still overlaps the track's
  // silhouette, but the last pose is far from the answer.
  const Eigen::Isometry3d turned =
      Moved(truth, Eigen::Vector3d::Zero(), M_PI / 2, truth.translation());
  const pose_estimate_t second =
      Solve(FrameAt(Render(turned, 52), 2, kStartUtime + kFramePeriodUs), turned);
  EXPECT_EQ(second.mode, +pose_estimate_t::MODE_REDETECTED);
  EXPECT_EQ(second.track_id, first.track_id);
  EXPECT_EQ(second.frames_since_detection, 0);
  EXPECT_EQ(service_->Counters().answers_redetected, 1);
}

TEST_F(ServiceTrackingTest, NewInstanceStartsItsOwnTrack) {
  StartService(Options("track_new"));
  Eigen::Isometry3d first_truth = BoxPose();
  const pose_estimate_t alone =
      Solve(FrameAt(Render(first_truth, 61), 1, kStartUtime), first_truth);
  ASSERT_GT(alone.track_id, 0);
  // A second box appears to the right, apart from the first in the image.
  Eigen::Isometry3d second_truth = MakePose(
      Eigen::AngleAxisd(-0.9, Eigen::Vector3d(1.0, 0.4, 0.3).normalized()).toRotationMatrix(),
      {0.12, 0.02, 0.65});
  for (int frame = 1; frame <= 2; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame + 1));
    first_truth = SmallStep(first_truth);
    if (frame > 1) second_truth = SmallStep(second_truth);
    const test::SyntheticView first_view = Render(first_truth, 61 + frame);
    const test::SyntheticView second_view = Render(second_truth, 71 + frame);
    cv::Mat shared;
    cv::bitwise_and(first_view.mask, second_view.mask, shared);
    ASSERT_EQ(cv::countNonZero(shared), 0) << "the boxes should not overlap in the image";
    Publish(
        TwoBoxFrameAt(first_view, second_view, 1 + frame, kStartUtime + frame * kFramePeriodUs));
    const pose_array_t answer = NextAnswer();
    ASSERT_EQ(answer.num_estimates, 2);
    const pose_estimate_t& first = answer.estimates[0];
    const pose_estimate_t& second = answer.estimates[1];
    ASSERT_EQ(first.status, +pose_estimate_t::STATUS_OK) << first.message;
    ASSERT_EQ(second.status, +pose_estimate_t::STATUS_OK) << second.message;
    ExpectNear(first, first_truth);
    ExpectNear(second, second_truth);
    // The first box keeps its track; the second starts one in its first frame and keeps
    // it in the next.
    EXPECT_EQ(first.mode, +pose_estimate_t::MODE_TRACKED);
    EXPECT_EQ(first.track_id, alone.track_id);
    EXPECT_EQ(first.frames_since_detection, frame);
    EXPECT_GT(second.track_id, 0);
    EXPECT_NE(second.track_id, alone.track_id);
    if (frame == 1) {
      EXPECT_EQ(second.mode, +pose_estimate_t::MODE_DETECTED);
      EXPECT_EQ(second.frames_since_detection, 0);
    } else {
      EXPECT_EQ(second.mode, +pose_estimate_t::MODE_TRACKED);
      EXPECT_EQ(second.frames_since_detection, 1);
    }
  }
}

TEST_F(ServiceTrackingTest, TrackExpiresAfterMaxAge) {
  ServiceOptions options = Options("track_expiry");
  options.tracking.max_age_s = 0.5;
  StartService(options);
  const Eigen::Isometry3d truth = BoxPose();
  const test::SyntheticView view = Render(truth, 81);
  const pose_estimate_t first = Solve(FrameAt(view, 1, kStartUtime), truth);
  ASSERT_GT(first.track_id, 0);
  // The same frame 0.4 s later (within max_age_s) continues the track ...
  const pose_estimate_t within = Solve(FrameAt(view, 2, kStartUtime + 400000), truth);
  EXPECT_EQ(within.mode, +pose_estimate_t::MODE_TRACKED);
  EXPECT_EQ(within.track_id, first.track_id);
  // ... and 0.6 s after that answer the track is gone: a new one starts.
  const pose_estimate_t after = Solve(FrameAt(view, 3, kStartUtime + 1000000), truth);
  EXPECT_EQ(after.mode, +pose_estimate_t::MODE_DETECTED);
  EXPECT_GT(after.track_id, first.track_id);
  EXPECT_EQ(after.frames_since_detection, 0);
}

TEST_F(ServiceTrackingTest, PeriodicRedetectionKeepsTheTrack) {
  ServiceOptions options = Options("track_periodic");
  options.tracking.redetect_every = 2;
  options.tracking.background_redetect = false;  // in the frame (the background's test is below)
  StartService(options);
  Eigen::Isometry3d truth = BoxPose();
  const pose_estimate_t first = Solve(FrameAt(Render(truth, 85), 1, kStartUtime), truth);
  ASSERT_GT(first.track_id, 0);
  // Two tracked answers, then the due re-detection (the tracked pose is fine: the answer is
  // the better of the two by S), then tracking again from 0.
  const int expected_mode[4] = {pose_estimate_t::MODE_TRACKED, pose_estimate_t::MODE_TRACKED,
                                pose_estimate_t::MODE_REDETECTED, pose_estimate_t::MODE_TRACKED};
  const int expected_frames[4] = {1, 2, 0, 1};
  for (int frame = 1; frame <= 4; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame + 1));
    truth = SmallStep(truth);
    const pose_estimate_t next = Solve(
        FrameAt(Render(truth, 85 + frame), 1 + frame, kStartUtime + frame * kFramePeriodUs), truth);
    EXPECT_EQ(next.mode, expected_mode[frame - 1]);
    EXPECT_EQ(next.track_id, first.track_id);
    EXPECT_EQ(next.frames_since_detection, expected_frames[frame - 1]);
  }
}

TEST_F(ServiceTrackingTest, BackgroundRedetectionChecksTheTrackWithoutHoldingTheFrame) {
  ServiceOptions options = Options("track_background");
  options.tracking.redetect_every = 2;
  ASSERT_TRUE(options.tracking.background_redetect);  // the service's default
  StartService(options);
  Eigen::Isometry3d truth = BoxPose();
  const pose_estimate_t first = Solve(FrameAt(Render(truth, 95), 1, kStartUtime), truth);
  ASSERT_GT(first.track_id, 0);
  // Every frame is answered by tracking; once the check of the due frame (the third)
  // has come back, the count since the last detection restarts.
  int previous = 0;
  bool restarted = false;
  for (int frame = 1; frame <= 60 && !restarted; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame + 1));
    truth = SmallStep(truth);
    const pose_estimate_t next = Solve(
        FrameAt(Render(truth, 95 + frame % 4), 1 + frame, kStartUtime + frame * kFramePeriodUs), truth);
    EXPECT_EQ(next.mode, static_cast<int8_t>(pose_estimate_t::MODE_TRACKED));
    EXPECT_EQ(next.track_id, first.track_id);
    restarted = next.frames_since_detection < previous;
    previous = next.frames_since_detection;
    // Give the background thread time to finish its check (a wait, not a timing assertion).
    if (frame >= 3) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(restarted) << "the background re-detection never came back";
}

// Every field but the solver's wall time, bit for bit.
void ExpectSameEstimate(const pose_estimate_t& got, const pose_estimate_t& expected) {
  EXPECT_EQ(got.object_id, expected.object_id);
  EXPECT_EQ(got.label, expected.label);
  EXPECT_EQ(got.gt_index, expected.gt_index);
  EXPECT_EQ(got.status, expected.status);
  EXPECT_EQ(got.message, expected.message);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(got.position[i], expected.position[i]) << i;
  for (int i = 0; i < 4; ++i) EXPECT_EQ(got.orientation[i], expected.orientation[i]) << i;
  EXPECT_EQ(got.score, expected.score);
  EXPECT_EQ(got.confidence, expected.confidence);
  EXPECT_EQ(got.iou, expected.iou);
  EXPECT_EQ(got.depth_residual, expected.depth_residual);
  EXPECT_EQ(got.hypotheses, expected.hypotheses);
  EXPECT_EQ(got.truncated, expected.truncated);
  EXPECT_EQ(got.ambiguous, expected.ambiguous);
  EXPECT_EQ(got.has_runner_up, expected.has_runner_up);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(got.runner_up_position[i], expected.runner_up_position[i]);
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(got.runner_up_orientation[i], expected.runner_up_orientation[i]);
  EXPECT_EQ(got.runner_up_score, expected.runner_up_score);
  EXPECT_EQ(got.appearance_valid, expected.appearance_valid);
  EXPECT_EQ(got.appearance_agreement, expected.appearance_agreement);
  EXPECT_EQ(got.cut_short, expected.cut_short);
  EXPECT_EQ(got.mode, expected.mode);
  EXPECT_EQ(got.track_id, expected.track_id);
  EXPECT_EQ(got.frames_since_detection, expected.frames_since_detection);
}

TEST_F(ServiceTrackingTest, TrackingOffAnswersExactlyAsEstimatePose) {
  ServiceOptions options = Options("track_off");
  options.tracking.enabled = false;
  StartService(options);
  // Frames that tracking on would track: with it off each is solved from scratch, and
  // the answer is EstimatePose's on the decoded frame, whatever came before.
  ThreadPool pool(1);
  Eigen::Isometry3d truth = BoxPose();
  for (int frame = 0; frame < 3; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    const rgbd_frame_t message =
        FrameAt(Render(truth, 91 + frame), 1 + frame, kStartUtime + frame * kFramePeriodUs);
    const pose_estimate_t got = Solve(message, truth);
    const DecodedFrame decoded = DecodeFrame(message, options.limits);
    const PoseResult direct =
        EstimatePose(decoded.frame, Instance{test::kBoxId, decoded.instances[0].mask}, scene_->bank,
                     options.solver, &pool);
    const pose_estimate_t expected = MakePoseEstimate(decoded.instances[0], direct);
    ExpectSameEstimate(got, expected);
    EXPECT_EQ(got.mode, +pose_estimate_t::MODE_DETECTED);
    EXPECT_EQ(got.track_id, -1);
    EXPECT_EQ(got.frames_since_detection, 0);
    truth = SmallStep(truth);
  }
  const service_status_t status = service_->MakeStatus();
  EXPECT_EQ(status.tracking, 0);
  EXPECT_EQ(status.answers_detected, 3);
  EXPECT_EQ(status.answers_tracked + status.answers_redetected, 0);
}

// With tracking on, a detection is EstimatePose's answer too (tracking only adds the
// track's fields).
TEST_F(ServiceTrackingTest, DetectionWithTrackingOnIsEstimatePoseAnswer) {
  StartService(Options("track_detect"));
  ThreadPool pool(1);
  const Eigen::Isometry3d truth = BoxPose();
  const rgbd_frame_t message = FrameAt(Render(truth, 95), 1, kStartUtime);
  const pose_estimate_t got = Solve(message, truth);
  const DecodedFrame decoded = DecodeFrame(message, options_.limits);
  pose_estimate_t expected = MakePoseEstimate(
      decoded.instances[0],
      EstimatePose(decoded.frame, Instance{test::kBoxId, decoded.instances[0].mask}, scene_->bank,
                   options_.solver, &pool));
  expected.track_id = got.track_id;
  ExpectSameEstimate(got, expected);
  EXPECT_GT(got.track_id, 0);
}

// ---- Building estimates -------------------------------------------------------------------

// An encode/decode round trip of one estimate, as a subscriber receives it.
pose_estimate_t ThroughLcmBytes(const pose_estimate_t& estimate) {
  std::vector<uint8_t> bytes(static_cast<size_t>(estimate.getEncodedSize()));
  EXPECT_EQ(estimate.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  pose_estimate_t decoded;
  EXPECT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  return decoded;
}

DecodedInstance BoxInstance() {
  DecodedInstance instance;
  instance.object_id = test::kBoxId;
  instance.label = 1;
  instance.gt_index = 4;
  return instance;
}

TEST(MakePoseEstimate, CopiesTruncationRunnerUpAndAppearance) {
  PoseResult result;
  result.success = true;
  result.termination = Termination::kConverged;
  result.cam_from_object = MakePose(
      Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()).toRotationMatrix(), {0.01, -0.02, 0.6});
  result.score = 0.08;
  result.truncated = true;
  result.ambiguous = true;
  result.has_runner_up = true;
  const Eigen::Quaterniond runner_up_rotation(
      Eigen::AngleAxisd(2.0, Eigen::Vector3d(1.0, 2.0, -0.5).normalized()));
  result.runner_up_cam_from_object =
      MakePose(runner_up_rotation.toRotationMatrix(), {0.03, 0.04, 0.65});
  result.runner_up_score = 0.095;
  result.appearance_valid = true;
  result.appearance_agreement = -0.25;
  const pose_estimate_t estimate = ThroughLcmBytes(MakePoseEstimate(BoxInstance(), result));
  ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK);
  EXPECT_TRUE(estimate.truncated);
  EXPECT_TRUE(estimate.ambiguous);
  ASSERT_TRUE(estimate.has_runner_up);
  EXPECT_DOUBLE_EQ(estimate.runner_up_position[0], 0.03);
  EXPECT_DOUBLE_EQ(estimate.runner_up_position[1], 0.04);
  EXPECT_DOUBLE_EQ(estimate.runner_up_position[2], 0.65);
  const Eigen::Quaterniond received(
      estimate.runner_up_orientation[0], estimate.runner_up_orientation[1],
      estimate.runner_up_orientation[2], estimate.runner_up_orientation[3]);
  EXPECT_NEAR(received.angularDistance(runner_up_rotation), 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(estimate.runner_up_score, 0.095);
  EXPECT_TRUE(estimate.appearance_valid);
  EXPECT_DOUBLE_EQ(estimate.appearance_agreement, -0.25);
  ExpectConsistentExtraFields(estimate);
}

TEST(MakePoseEstimate, WithoutRunnerUpOrAppearanceTheirFieldsAreZero) {
  PoseResult result;
  result.success = true;
  result.termination = Termination::kConverged;
  result.score = 0.05;
  result.runner_up_score = 2.0;       // the solver's "none" value stays off the wire
  result.appearance_agreement = 0.9;  // not valid: not sent
  const pose_estimate_t estimate = ThroughLcmBytes(MakePoseEstimate(BoxInstance(), result));
  ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK);
  EXPECT_FALSE(estimate.truncated);
  EXPECT_FALSE(estimate.has_runner_up);
  EXPECT_FALSE(estimate.appearance_valid);
  ExpectConsistentExtraFields(estimate);
}

TEST(MakePoseEstimate, FailuresCarryNoFlags) {
  // A solver failure after the mask was seen to touch the border: the flag describes a
  // pose, and there is none.
  PoseResult result;
  result.termination = Termination::kNoHypothesis;
  result.message = "no correspondences";
  result.truncated = true;
  const pose_estimate_t failed = ThroughLcmBytes(MakePoseEstimate(BoxInstance(), result));
  EXPECT_EQ(failed.status, +pose_estimate_t::STATUS_NO_SOLUTION);
  ExpectConsistentExtraFields(failed);
  const pose_estimate_t refused = ThroughLcmBytes(
      MakeFailedEstimate(BoxInstance(), pose_estimate_t::STATUS_BAD_INPUT, "empty mask"));
  EXPECT_EQ(refused.status, +pose_estimate_t::STATUS_BAD_INPUT);
  ExpectConsistentExtraFields(refused);
}

TEST(MakeTrackedEstimate, CopiesModeTrackAndFramesSinceDetection) {
  TrackedAnswer answer;
  answer.result.success = true;
  answer.result.termination = Termination::kConverged;
  answer.result.score = 0.07;
  answer.result.stages.total_ms = 4.0;
  answer.mode = AnswerMode::kTracked;
  answer.track_id = 7;
  answer.frames_since_detection = 3;
  answer.track_ms = 5.0;
  pose_estimate_t estimate = ThroughLcmBytes(MakeTrackedEstimate(BoxInstance(), answer));
  ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK);
  EXPECT_EQ(estimate.mode, +pose_estimate_t::MODE_TRACKED);
  EXPECT_EQ(estimate.track_id, 7);
  EXPECT_EQ(estimate.frames_since_detection, 3);
  EXPECT_DOUBLE_EQ(estimate.solve_time_s, 0.005);
  // A re-detection took TrackPose's time and the full solver's.
  answer.mode = AnswerMode::kRedetected;
  answer.frames_since_detection = 0;
  answer.detect_ms = 20.0;
  estimate = ThroughLcmBytes(MakeTrackedEstimate(BoxInstance(), answer));
  EXPECT_EQ(estimate.mode, +pose_estimate_t::MODE_REDETECTED);
  EXPECT_EQ(estimate.track_id, 7);
  EXPECT_DOUBLE_EQ(estimate.solve_time_s, 0.025);
  // A detection is MakePoseEstimate's, plus the track.
  answer.mode = AnswerMode::kDetected;
  answer.track_id = 8;
  estimate = ThroughLcmBytes(MakeTrackedEstimate(BoxInstance(), answer));
  EXPECT_EQ(estimate.mode, +pose_estimate_t::MODE_DETECTED);
  EXPECT_EQ(estimate.track_id, 8);
  EXPECT_DOUBLE_EQ(estimate.solve_time_s, 0.004);
}

TEST(MakeTrackedEstimate, FailureBelongsToNoTrack) {
  TrackedAnswer answer;
  answer.result.termination = Termination::kNoHypothesis;
  answer.mode = AnswerMode::kRedetected;
  answer.track_id = 4;
  answer.frames_since_detection = 2;
  const pose_estimate_t estimate = ThroughLcmBytes(MakeTrackedEstimate(BoxInstance(), answer));
  EXPECT_EQ(estimate.status, +pose_estimate_t::STATUS_NO_SOLUTION);
  ExpectConsistentExtraFields(estimate);
  // An answer without tracking: detected, no track.
  const pose_estimate_t plain = ThroughLcmBytes(MakePoseEstimate(BoxInstance(), PoseResult()));
  EXPECT_EQ(plain.mode, +pose_estimate_t::MODE_DETECTED);
  EXPECT_EQ(plain.track_id, -1);
}

TEST(Percentile, NearestRank) {
  EXPECT_EQ(Percentile({}, 0.5), 0.0);
  EXPECT_EQ(Percentile({3.0}, 0.95), 3.0);
  EXPECT_EQ(Percentile({4, 1, 3, 2}, 0.5), 2.0);
  EXPECT_EQ(Percentile({4, 1, 3, 2}, 0.95), 4.0);
  std::vector<double> hundred;
  for (int i = 1; i <= 100; ++i) hundred.push_back(i);
  EXPECT_EQ(Percentile(hundred, 0.95), 95.0);
}

TEST(LcmChannelRegex, EscapesRegexCharacters) {
  EXPECT_EQ(LcmChannelRegex("G6D_RGBD"), "G6D_RGBD");
  EXPECT_EQ(LcmChannelRegex("CAM.1(x)"), "CAM\\.1\\(x\\)");
}

}  // namespace
}  // namespace g6d
