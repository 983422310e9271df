// Tracking (lib/track and TrackPose) on synthetic frames rendered by the project's own
// renderer: a textured box that moves a little between frames, jumps, appears and expires.
#include "track/tracker.h"

#include <random>

#include <gtest/gtest.h>

#include "core/error.h"
#include "eval/metrics.h"
#include "mesh/mesh.h"
#include "bop_eval_scene.h"
#include "synthetic_scene.h"
#include "test_bank.h"

namespace g6d {
namespace {

const Camera kCamera{572.4, 573.6, 325.3, 242.0, 640, 480};

class TrackerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    mesh_ = new Mesh(test::MakeTexturedBox(0.10, 0.07, 0.05, 21));
    ThreadPool pool(2);
    bank_ = new TemplateBank(test::SharedTestBank("box21-default", *mesh_, "box", TemplateBuildOptions(), &pool));
    renderer_ = new GlRenderer(*mesh_);
  }
  static void TearDownTestSuite() {
    delete renderer_;
    delete bank_;
    delete mesh_;
  }

  // A frame of the box at `pose`, and its instance.
  static std::pair<Frame, Instance> View(const Eigen::Isometry3d& pose, uint64_t seed = 1) {
    test::SyntheticOptions options;
    options.seed = seed;
    const test::SyntheticView view = test::RenderSyntheticView(renderer_, *mesh_, kCamera, pose, options);
    Frame frame;
    frame.camera = kCamera;
    frame.rgb = view.rgb;
    frame.depth = view.depth;
    return {frame, Instance{"box", view.mask}};
  }
  static double ErrorD(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
    std::vector<Eigen::Vector3f> points(mesh_->vertices.begin(), mesh_->vertices.end());
    return ComputeAdd(estimate, truth, points) / bank_->diameter_m;
  }
  static BankLookup Banks() {
    return [](const std::string& id) -> const TemplateBank* { return id == "box" ? bank_ : nullptr; };
  }
  // The box 0.7 m ahead, tilted so that three faces show.
  static Eigen::Isometry3d StartPose() {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = (Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY())).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(0.02, -0.01, 0.7);
    return pose;
  }
  // `pose` moved by a small step: `mm` millimetres along x and `deg` degrees about y
  // (through the object's origin).
  static Eigen::Isometry3d Moved(const Eigen::Isometry3d& pose, double mm, double deg) {
    Eigen::Isometry3d moved = pose;
    moved.linear() = Eigen::AngleAxisd(deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix() * pose.linear();
    moved.translation() += Eigen::Vector3d(mm * 1e-3, 0.0, 0.0);
    return moved;
  }

  static Mesh* mesh_;
  static TemplateBank* bank_;
  static GlRenderer* renderer_;
};
Mesh* TrackerTest::mesh_ = nullptr;
TemplateBank* TrackerTest::bank_ = nullptr;
GlRenderer* TrackerTest::renderer_ = nullptr;

// One frame through a tracker, as the service runs it.
std::vector<TrackedAnswer> RunFrame(Tracker* tracker, double time_s, const Frame& frame, const std::vector<Instance>& instances,
                                    const BankLookup& banks, Executor* executor, std::vector<TrackPlan>* plans_out = nullptr) {
  const std::vector<TrackPlan> plans = tracker->Plan(time_s, instances, frame.camera, banks);
  std::vector<TrackedAnswer> answers;
  for (size_t i = 0; i < instances.size(); ++i) {
    answers.push_back(SolveWithPlan(frame, instances[i], *banks(instances[i].object_id), SolverOptions(), tracker->options(),
                                    plans[i], executor));
  }
  tracker->Update(time_s, plans, banks, &answers);
  if (plans_out) *plans_out = plans;
  return answers;
}

TEST_F(TrackerTest, TrackPoseConvergesFromANearbyStart) {
  ThreadPool pool(2);
  const Eigen::Isometry3d truth = StartPose();
  const auto [frame, instance] = View(truth);
  const Eigen::Isometry3d start = Moved(truth, 12.0, 10.0);
  ASSERT_GT(ErrorD(start, truth), 0.1);
  const PoseResult result = TrackPose(frame, instance, *bank_, SolverOptions(), TrackSolveOptions(), {start}, &pool);
  ASSERT_TRUE(result.success) << result.message;
  EXPECT_LT(ErrorD(result.cam_from_object, truth), 0.05);
  EXPECT_LT(result.score, 0.1);
  EXPECT_GT(result.details.iou, 0.8);
  EXPECT_GT(result.confidence, 0.5);
  EXPECT_GT(result.stages.icp_iterations, 0);
}

TEST_F(TrackerTest, TrackPoseRefusesBadInput) {
  InlineExecutor inline_executor;
  const auto [frame, instance] = View(StartPose());
  const PoseResult no_start = TrackPose(frame, instance, *bank_, SolverOptions(), TrackSolveOptions(), {}, &inline_executor);
  EXPECT_FALSE(no_start.success);
  EXPECT_EQ(no_start.termination, Termination::kBadInput);
  EXPECT_NE(no_start.message.find("no start pose"), std::string::npos) << no_start.message;
  const Instance empty{"box", cv::Mat::zeros(frame.depth.size(), CV_8U)};
  const PoseResult empty_mask = TrackPose(frame, empty, *bank_, SolverOptions(), TrackSolveOptions(), {StartPose()}, &inline_executor);
  EXPECT_EQ(empty_mask.termination, Termination::kBadInput);
  EXPECT_NE(empty_mask.message.find("mask is empty"), std::string::npos) << empty_mask.message;
  TrackSolveOptions bad;
  bad.max_source_points = 3;
  const PoseResult bad_options = TrackPose(frame, instance, *bank_, SolverOptions(), bad, {StartPose()}, &inline_executor);
  EXPECT_EQ(bad_options.termination, Termination::kBadInput);
  EXPECT_NE(bad_options.message.find("max_source_points"), std::string::npos) << bad_options.message;
}

TEST_F(TrackerTest, ATrackContinuesThroughSmallMotions) {
  ThreadPool pool(2);
  Tracker tracker{TrackerOptions()};
  Eigen::Isometry3d truth = StartPose();
  for (int k = 0; k < 4; ++k) {
    const auto [frame, instance] = View(truth, static_cast<uint64_t>(k + 1));
    const std::vector<TrackedAnswer> answers = RunFrame(&tracker, k / 30.0, frame, {instance}, Banks(), &pool);
    ASSERT_EQ(answers.size(), 1u);
    const TrackedAnswer& a = answers[0];
    ASSERT_TRUE(a.result.success) << a.result.message;
    EXPECT_LT(ErrorD(a.result.cam_from_object, truth), 0.1) << "frame " << k;
    EXPECT_EQ(a.track_id, 1) << "frame " << k;
    EXPECT_EQ(a.mode, k == 0 ? AnswerMode::kDetected : AnswerMode::kTracked) << "frame " << k;
    EXPECT_EQ(a.frames_since_detection, k);
    if (k > 0) {
      EXPECT_GT(a.track_ms, 0.0);
      EXPECT_EQ(a.detect_ms, 0.0);
    }
    truth = Moved(truth, 3.0, 1.5);  // 9 cm/s and 45 deg/s at 30 Hz
  }
  ASSERT_EQ(tracker.tracks().size(), 1u);
  EXPECT_TRUE(tracker.tracks()[0].has_velocity);
  EXPECT_EQ(tracker.tracks()[0].answers, 4);
}

TEST_F(TrackerTest, ALostTrackIsRedetectedInTheSameFrame) {
  ThreadPool pool(2);
  Tracker tracker{TrackerOptions()};
  const Eigen::Isometry3d first = StartPose();
  {
    const auto [frame, instance] = View(first);
    ASSERT_EQ(RunFrame(&tracker, 0.0, frame, {instance}, Banks(), &pool)[0].mode, AnswerMode::kDetected);
  }
  // Turned 90 degrees about its own vertical axis in place: the mask still overlaps the
  // track's silhouette, but the tracked pose cannot explain it.
  Eigen::Isometry3d turned = first;
  turned.linear() = first.linear() * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto [frame, instance] = View(turned, 2);
  std::vector<TrackPlan> plans;
  const std::vector<TrackedAnswer> answers = RunFrame(&tracker, 1 / 30.0, frame, {instance}, Banks(), &pool, &plans);
  EXPECT_EQ(plans[0].track_id, 1);
  const TrackedAnswer& a = answers[0];
  ASSERT_TRUE(a.result.success) << a.result.message;
  EXPECT_EQ(a.mode, AnswerMode::kRedetected);
  EXPECT_TRUE(a.lost);
  EXPECT_FALSE(a.periodic);
  EXPECT_GT(a.tracked_score.s, TrackerOptions().loss_score);
  EXPECT_EQ(a.track_id, 1);
  EXPECT_EQ(a.frames_since_detection, 0);
  EXPECT_LT(ErrorD(a.result.cam_from_object, turned), 0.1);
  EXPECT_FALSE(tracker.tracks()[0].has_velocity);  // a jump is no velocity
}

TEST_F(TrackerTest, AFlipOntoAShapeSymmetryIsLostByAppearance) {
  ThreadPool pool(2);
  Tracker tracker{TrackerOptions()};
  const Eigen::Isometry3d first = StartPose();
  {
    const auto [frame, instance] = View(first);
    ASSERT_EQ(RunFrame(&tracker, 0.0, frame, {instance}, Banks(), &pool)[0].mode, AnswerMode::kDetected);
    ASSERT_TRUE(tracker.tracks()[0].appearance_valid);
  }
  // Turned 180 degrees about its own z axis: the box's shape maps onto itself (same
  // silhouette, same depth, so the same S), its printed faces do not.
  Eigen::Isometry3d flipped = first;
  flipped.linear() = first.linear() * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto [frame, instance] = View(flipped, 2);
  const TrackedAnswer a = RunFrame(&tracker, 1 / 30.0, frame, {instance}, Banks(), &pool)[0];
  ASSERT_TRUE(a.result.success) << a.result.message;
  EXPECT_LT(a.tracked_score.s, TrackerOptions().loss_score);  // S cannot see it ...
  EXPECT_TRUE(a.lost_by_appearance);                           // ... appearance can
  EXPECT_EQ(a.mode, AnswerMode::kRedetected);
  EXPECT_LT(ErrorD(a.result.cam_from_object, flipped), 0.1);
  // With the appearance rule off, the flipped track is kept: confident and wrong.
  TrackerOptions off;
  off.appearance_drop = 0.0;
  Tracker blind(off);
  {
    const auto [first_frame, first_instance] = View(first);
    RunFrame(&blind, 0.0, first_frame, {first_instance}, Banks(), &pool);
  }
  const TrackedAnswer kept = RunFrame(&blind, 1 / 30.0, frame, {instance}, Banks(), &pool)[0];
  EXPECT_EQ(kept.mode, AnswerMode::kTracked);
  EXPECT_GT(ErrorD(kept.result.cam_from_object, flipped), 0.1);
}

TEST_F(TrackerTest, ANewInstanceStartsATrackAndOldTracksExpire) {
  ThreadPool pool(2);
  TrackerOptions options;
  options.max_age_s = 0.5;
  Tracker tracker(options);
  const Eigen::Isometry3d left = StartPose();
  const auto [frame, instance] = View(left);
  RunFrame(&tracker, 0.0, frame, {instance}, Banks(), &pool);
  // The same object at a disjoint place (another instance of it): no overlap, new track.
  Eigen::Isometry3d right = left;
  right.translation().x() += 0.25;
  const auto [right_frame, right_instance] = View(right, 3);
  std::vector<TrackPlan> plans;
  std::vector<TrackedAnswer> answers = RunFrame(&tracker, 0.1, right_frame, {right_instance}, Banks(), &pool, &plans);
  EXPECT_EQ(plans[0].track_id, -1);
  EXPECT_EQ(answers[0].mode, AnswerMode::kDetected);
  EXPECT_EQ(answers[0].track_id, 2);
  EXPECT_EQ(tracker.tracks().size(), 2u);
  // 0.45 s later the first track (last answer at 0) has expired, the second not yet.
  answers = RunFrame(&tracker, 0.55, right_frame, {right_instance}, Banks(), &pool);
  EXPECT_EQ(answers[0].mode, AnswerMode::kTracked);
  EXPECT_EQ(answers[0].track_id, 2);
  ASSERT_EQ(tracker.tracks().size(), 1u);
  EXPECT_EQ(tracker.tracks()[0].id, 2);
  // Much later, no track is left: a detection and a new track id.
  answers = RunFrame(&tracker, 5.0, frame, {instance}, Banks(), &pool);
  EXPECT_EQ(answers[0].mode, AnswerMode::kDetected);
  EXPECT_EQ(answers[0].track_id, 3);
  // Time going backwards (a log replayed again) forgets the tracks.
  answers = RunFrame(&tracker, 1.0, frame, {instance}, Banks(), &pool);
  EXPECT_EQ(answers[0].mode, AnswerMode::kDetected);
  EXPECT_EQ(answers[0].track_id, 4);
}

TEST_F(TrackerTest, PeriodicRedetectionIsDueAfterNFramesOnePerFrame) {
  ThreadPool pool(2);
  TrackerOptions options;
  options.redetect_every = 2;
  Tracker tracker(options);
  const auto [frame, instance] = View(StartPose());
  Eigen::Isometry3d other_pose = StartPose();
  other_pose.translation().x() -= 0.22;
  const auto [other_frame, other] = View(other_pose, 4);
  // Both instances in one frame: the masks of both renderings, one image (the solver only
  // reads the depth under each mask, and the two do not overlap).
  Frame both = frame;
  other_frame.depth.copyTo(both.depth, other.mask);
  other_frame.rgb.copyTo(both.rgb, other.mask);
  const std::vector<Instance> instances = {instance, other};
  std::vector<AnswerMode> modes;
  int periodic = 0;
  for (int k = 0; k < 4; ++k) {
    std::vector<TrackPlan> plans;
    const std::vector<TrackedAnswer> answers = RunFrame(&tracker, k / 30.0, both, instances, Banks(), &pool, &plans);
    int due = 0;
    for (const TrackPlan& plan : plans) due += plan.redetect;
    EXPECT_LE(due, options.max_periodic_per_frame) << "frame " << k;
    for (const TrackedAnswer& a : answers) {
      ASSERT_TRUE(a.result.success);
      periodic += a.periodic;
      modes.push_back(a.mode);
    }
  }
  // Frames 0: both detected; 1, 2: tracked; frame 3: both are due (2 tracked frames), one
  // is re-detected (periodic), the other waits.
  EXPECT_EQ(modes[0], AnswerMode::kDetected);
  EXPECT_EQ(modes[1], AnswerMode::kDetected);
  EXPECT_EQ(modes[2], AnswerMode::kTracked);
  EXPECT_EQ(modes[5], AnswerMode::kTracked);
  EXPECT_EQ(periodic, 1);
  EXPECT_EQ((modes[6] == AnswerMode::kRedetected) + (modes[7] == AnswerMode::kRedetected), 1);
}

TEST_F(TrackerTest, ABackgroundRedetectionCorrectsAConfidentlyWrongTrack) {
  ThreadPool pool(2);
  TrackerOptions options;
  options.redetect_every = 1;
  options.background_redetect = true;
  Tracker tracker(options);
  const Eigen::Isometry3d truth = StartPose();
  const auto [frame, instance] = View(truth);
  RunFrame(&tracker, 0.0, frame, {instance}, Banks(), &pool);
  RunFrame(&tracker, 1 / 30.0, frame, {instance}, Banks(), &pool);
  // Frame 2: due, answered by tracking at once, the re-detection requested.
  std::vector<TrackedAnswer> answers = RunFrame(&tracker, 2 / 30.0, frame, {instance}, Banks(), &pool);
  ASSERT_EQ(answers[0].mode, AnswerMode::kTracked);
  ASSERT_TRUE(answers[0].confirm_requested);
  EXPECT_EQ(answers[0].detect_ms, 0.0);
  EXPECT_TRUE(tracker.tracks()[0].confirmation_pending);
  // While it runs, the track is not due again.
  std::vector<TrackPlan> plans;
  answers = RunFrame(&tracker, 3 / 30.0, frame, {instance}, Banks(), &pool, &plans);
  EXPECT_FALSE(plans[0].redetect);
  // A detection that agrees changes nothing but the count.
  const PoseResult agreeing = EstimatePose(frame, instance, *bank_, SolverOptions(), &pool);
  const Eigen::Isometry3d tracked = answers[0].result.cam_from_object;
  EXPECT_FALSE(tracker.ApplyConfirmation(1, answers[0].result, agreeing, bank_->diameter_m));
  EXPECT_FALSE(tracker.tracks()[0].confirmation_pending);
  EXPECT_EQ(tracker.tracks()[0].frames_since_detection, 0);
  // One that scores clearly lower elsewhere moves the track by the motion tracked since:
  // here the track pretends to have moved 1 cm along x after the confirmed frame.
  PoseResult better = agreeing;
  better.cam_from_object.translation().z() += 0.03;
  better.score = 0.01;
  const Eigen::Isometry3d then = tracked;
  Eigen::Isometry3d shifted_then = then;
  shifted_then.translation().x() -= 0.01;  // the frame of the re-detection, 1 cm before now
  PoseResult then_answer = answers[0].result;
  then_answer.cam_from_object = shifted_then;
  then_answer.score = 0.5;
  ASSERT_TRUE(tracker.ApplyConfirmation(1, then_answer, better, bank_->diameter_m));
  const Track& track = tracker.tracks()[0];
  const Eigen::Isometry3d expected = tracked * shifted_then.inverse() * better.cam_from_object;
  EXPECT_TRUE(track.cam_from_object.isApprox(expected, 1e-12));
  EXPECT_TRUE(track.corrected);
  EXPECT_FALSE(track.has_velocity);
  // Unknown tracks are ignored.
  EXPECT_FALSE(tracker.ApplyConfirmation(99, then_answer, better, bank_->diameter_m));
}

TEST(TrackerConfirmationTest, ADetectionWinsByLowerSOrByAppearanceAtTheSameS) {
  const TrackerOptions options;  // margin 0.02, appearance gain 0.1
  PoseResult tracked, detection;
  tracked.success = detection.success = true;
  tracked.score = 0.10;
  detection.score = 0.07;
  EXPECT_TRUE(DetectionIsBetter(options, tracked, detection));  // lower by more than the margin
  detection.score = 0.09;
  EXPECT_FALSE(DetectionIsBetter(options, tracked, detection));  // within the margin, no appearance
  tracked.appearance_valid = detection.appearance_valid = true;
  tracked.appearance_agreement = 0.3;
  detection.appearance_agreement = 0.45;
  EXPECT_TRUE(DetectionIsBetter(options, tracked, detection));  // same S, clearly better print
  detection.score = 0.115;
  EXPECT_TRUE(DetectionIsBetter(options, tracked, detection));  // a little worse S, clearly better print
  detection.score = 0.13;
  EXPECT_FALSE(DetectionIsBetter(options, tracked, detection));  // worse S beyond the margin
  detection.score = 0.10;
  detection.appearance_agreement = 0.35;
  EXPECT_FALSE(DetectionIsBetter(options, tracked, detection));  // print only a little better
  detection.success = false;
  EXPECT_FALSE(DetectionIsBetter(options, tracked, detection));
}

TEST_F(TrackerTest, TrackingOffGivesTheSingleFrameAnswersExactly) {
  ThreadPool pool(2);
  TrackerOptions options;
  options.enabled = false;
  Tracker tracker(options);
  Eigen::Isometry3d truth = StartPose();
  for (int k = 0; k < 3; ++k) {
    const auto [frame, instance] = View(truth, static_cast<uint64_t>(k + 7));
    const TrackedAnswer a = RunFrame(&tracker, k / 30.0, frame, {instance}, Banks(), &pool)[0];
    const PoseResult direct = EstimatePose(frame, instance, *bank_, SolverOptions(), &pool);
    EXPECT_EQ(a.mode, AnswerMode::kDetected);
    EXPECT_EQ(a.track_id, -1);
    EXPECT_TRUE(a.result.cam_from_object.matrix() == direct.cam_from_object.matrix()) << "frame " << k;
    EXPECT_EQ(a.result.score, direct.score);
    EXPECT_EQ(a.result.confidence, direct.confidence);
    EXPECT_EQ(a.result.has_runner_up, direct.has_runner_up);
    truth = Moved(truth, 3.0, 1.5);
  }
  EXPECT_TRUE(tracker.tracks().empty());
}

TEST(TrackerPredictionTest, ConstantVelocityExtrapolatesARigidMotion) {
  Track track;
  track.cam_from_object.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  track.cam_from_object.translation() = Eigen::Vector3d(0.1, 0.0, 0.8);
  track.time_s = 1.0;
  EXPECT_TRUE(PredictPose(track, 2.0).isApprox(track.cam_from_object));  // no velocity: the last pose
  track.has_velocity = true;
  track.velocity_m_s = Eigen::Vector3d(0.03, 0.0, -0.06);
  track.angular_rad_s = Eigen::Vector3d(0.0, 0.5, 0.0);
  const Eigen::Isometry3d half = PredictPose(track, 1.5);
  const Eigen::Isometry3d step = half * track.cam_from_object.inverse();
  EXPECT_NEAR(Eigen::AngleAxisd(step.linear()).angle(), 0.25, 1e-9);
  EXPECT_TRUE(step.translation().isApprox(Eigen::Vector3d(0.015, 0.0, -0.03)));
}

// A rotation by `deg` about `axis` through `point` (object frame).
Eigen::Isometry3d TurnAbout(const Eigen::Vector3d& axis, const Eigen::Vector3d& point, double deg) {
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
  turn.translation() = point - turn.linear() * point;
  return turn;
}

// The turn of `pose` relative to `reference` about `axis` (object frame), degrees: the twist
// of reference^-1 * pose.
double TwistDeg(const Eigen::Isometry3d& reference, const Eigen::Isometry3d& pose, const Eigen::Vector3d& axis) {
  const Eigen::Quaterniond delta(Eigen::Matrix3d(reference.linear().transpose() * pose.linear()));
  double twist = 2.0 * std::atan2(delta.vec().dot(axis.normalized()), delta.w()) * 180.0 / M_PI;
  if (twist > 180.0) twist -= 360.0;
  if (twist < -180.0) twist += 360.0;
  return twist;
}

MeshSymmetries CanShape() {
  MeshSymmetries shape;
  shape.revolution = true;
  shape.axis = Eigen::Vector3d(0.0, 0.6, 0.8);
  shape.point = Eigen::Vector3d(0.01, -0.02, 0.03);
  return shape;
}

TEST(TrackerPredictionTest, ASurfaceOfRevolutionsTurnAboutItsAxisIsNotExtrapolated) {
  const MeshSymmetries shape = CanShape();
  Eigen::Isometry3d before = Eigen::Isometry3d::Identity();
  before.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix();
  before.translation() = Eigen::Vector3d(0.05, 0.02, 0.7);
  // A tilt of the camera (about the camera's x axis), a spin of 12 degrees about the
  // can's axis, and a shift of the can's centre, in 1/30 s.
  Eigen::Isometry3d tilt = Eigen::Isometry3d::Identity();
  tilt.linear() = Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  Eigen::Isometry3d after = tilt * before * TurnAbout(shape.axis, shape.point, 12.0);
  after.translation() += Eigen::Vector3d(0.003, -0.001, 0.002);
  const double dt = 1.0 / 30.0;

  Track track;
  track.cam_from_object = after;
  track.time_s = 1.0;
  track.has_velocity = true;
  // Without a shape: the whole step, spin included, is the velocity.
  TrackMotion(before, after, dt, nullptr, &track.velocity_m_s, &track.angular_rad_s);
  EXPECT_TRUE((PredictPose(track, 1.0 + dt) * after.inverse()).isApprox(after * before.inverse(), 1e-9));
  // With the can's shape: the spin is left out, the tilt and the centre's motion kept.
  TrackMotion(before, after, dt, &shape, &track.velocity_m_s, &track.angular_rad_s);
  const Eigen::Isometry3d predicted = PredictPose(track, 1.0 + dt);
  EXPECT_NEAR(std::abs(TwistDeg(after, predicted, shape.axis)), 0.0, 1e-6);
  const Eigen::Vector3d axis_after = after.linear() * shape.axis, axis_predicted = predicted.linear() * shape.axis;
  const Eigen::Vector3d axis_before = before.linear() * shape.axis;
  // The axis turns on as it did (the tilt), and the centre moves on by the same step (to
  // the second order of the step: a tilt and a spin in one step do not commute).
  EXPECT_NEAR(std::acos(std::min(1.0, axis_after.dot(axis_predicted))), std::acos(std::min(1.0, axis_before.dot(axis_after))), 1e-3);
  const Eigen::Vector3d centre_step = after * shape.point - before * shape.point;
  ASSERT_GT(centre_step.norm(), 0.02);
  EXPECT_LT((predicted * shape.point - (after * shape.point + tilt.linear() * centre_step)).norm(), 1e-3);
  EXPECT_THROW(TrackMotion(before, after, 0.0, &shape, &track.velocity_m_s, &track.angular_rad_s), Error);
}

TEST(TrackPoseTurnTest, KeepTurnAboutAxisDropsTheTwistAndKeepsTheRest) {
  const MeshSymmetries shape = CanShape();
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  start.linear() = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  start.translation() = Eigen::Vector3d(-0.03, 0.01, 0.8);
  // A tilt of 5 degrees about an axis across the can's, then a spin of 30 about its own.
  const Eigen::Vector3d across = shape.axis.cross(Eigen::Vector3d::UnitX()).normalized();
  const Eigen::Isometry3d swung = start * TurnAbout(across, shape.point, 5.0);
  const Eigen::Isometry3d pose = swung * TurnAbout(shape.axis, shape.point, 30.0);
  const Eigen::Isometry3d kept = KeepTurnAboutAxis(shape, start, pose);
  EXPECT_TRUE(kept.isApprox(swung, 1e-9));
  EXPECT_NEAR(TwistDeg(start, kept, shape.axis), 0.0, 1e-6);
  EXPECT_LT((kept * shape.point - pose * shape.point).norm(), 1e-12);  // the centre stays
  // No revolution: the pose as it is.
  MeshSymmetries box;
  EXPECT_TRUE(KeepTurnAboutAxis(box, start, pose).isApprox(pose));
}

// An untextured can (a 64-sided closed cylinder): TrackPose from a start turned about its
// axis, and moved off it, sets the position and the axis right and keeps the start's turn,
// which neither its depth nor its silhouette can tell.
TEST(TrackPoseTurnTest, AnUntexturedCanKeepsTheTurnOfItsStart) {
  const Mesh can = test::MakeCylinder(0.04, 0.06, 64);
  ThreadPool pool(2);
  const TemplateBank bank = test::SharedTestBank("can64-default", can, "can", TemplateBuildOptions(), &pool);
  ASSERT_TRUE(bank.geometric_symmetries.revolution) << bank.geometric_symmetries.Describe();
  const Eigen::Vector3d axis = bank.geometric_symmetries.axis;
  GlRenderer renderer(can);
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  truth.translation() = Eigen::Vector3d(0.01, 0.0, 0.6);
  test::SyntheticOptions options;
  options.seed = 5;
  const test::SyntheticView view = test::RenderSyntheticView(&renderer, can, kCamera, truth, options);
  Frame frame;
  frame.camera = kCamera;
  frame.rgb = view.rgb;
  frame.depth = view.depth;
  const Instance instance{"can", view.mask};
  for (const double turn_deg : {25.0, -60.0}) {
    Eigen::Isometry3d start = truth * TurnAbout(axis, bank.geometric_symmetries.point, turn_deg);
    start.linear() = Eigen::AngleAxisd(4.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix() * start.linear();
    start.translation() += Eigen::Vector3d(0.006, -0.004, 0.005);
    const PoseResult result = TrackPose(frame, instance, bank, SolverOptions(), TrackSolveOptions(), {start}, &pool);
    ASSERT_TRUE(result.success) << result.message;
    const Eigen::Vector3d centre = bank.geometric_symmetries.point;
    EXPECT_LT((result.cam_from_object * centre - truth * centre).norm(), 0.002) << "turn " << turn_deg;
    const double axis_error_deg =
        std::acos(std::min(1.0, (result.cam_from_object.linear() * axis).dot(truth.linear() * axis))) * 180.0 / M_PI;
    EXPECT_LT(axis_error_deg, 1.5) << "turn " << turn_deg;
    EXPECT_NEAR(TwistDeg(start, result.cam_from_object, axis), 0.0, 0.5) << "turn " << turn_deg;
    EXPECT_NEAR(TwistDeg(truth, result.cam_from_object, axis), turn_deg, 5.0) << "turn " << turn_deg;
    EXPECT_LT(result.score, 0.1) << "turn " << turn_deg;  // the same surface: as good as the truth
  }
}

TEST(TrackerOptionsTest, BadOptionsAreRefusedByName) {
  TrackerOptions options;
  EXPECT_EQ(options.Check(), "");
  options.max_age_s = 0.0;
  EXPECT_NE(options.Check().find("max_age_s"), std::string::npos);
  options = TrackerOptions();
  options.min_overlap = 1.5;
  EXPECT_NE(options.Check().find("min_overlap"), std::string::npos);
  options = TrackerOptions();
  options.redetect_every = -1;
  EXPECT_NE(options.Check().find("redetect_every"), std::string::npos);
  options = TrackerOptions();
  options.solve.mhpo_rounds = -2;
  EXPECT_NE(options.Check().find("mhpo_rounds"), std::string::npos);
  EXPECT_THROW(Tracker{options}, Error);
}

}  // namespace
}  // namespace g6d
