#include "eval/bop_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "bop_eval_scene.h"
#include "core/error.h"
#include "core/executor.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "test_meshes.h"
#include "test_util.h"

namespace g6d {
namespace {

using test::MakeEstimate;
using test::MakePose;
using test::SyntheticInstance;
using test::SyntheticObject;

constexpr int kCube = 1;
constexpr int kCylinder = 2;
// 10 cm cube: diameter = its space diagonal.
const double kCubeDiameter = 0.1 * std::sqrt(3.0);

SyntheticObject Cube() { return {kCube, test::MakeCube(0.05), kCubeDiameter, false}; }

// Radius 4 cm, height 12 cm, 36 facets (a rotation by any multiple of 10 degrees about z
// maps it onto itself), annotated with a continuous symmetry about z.
SyntheticObject Cylinder() {
  return {kCylinder, test::MakeCylinder(0.04, 0.06, 36), std::hypot(0.08, 0.12), true};
}

Eigen::Isometry3d At(double x, double y, double z) {
  return MakePose(Eigen::Matrix3d::Identity(), {x, y, z});
}

// A pose of `pose` moved by `offset_m` in the camera frame.
Eigen::Isometry3d Moved(const Eigen::Isometry3d& pose, const Eigen::Vector3d& offset_m) {
  Eigen::Isometry3d moved = pose;
  moved.translation() += offset_m;
  return moved;
}


TEST(BopEvalOptions, CheckNamesTheBadField) {
  BopEvalOptions options;
  EXPECT_EQ(options.Check(), "");
  options.mspd_thresholds_px.clear();
  EXPECT_NE(options.Check().find("mspd_thresholds_px"), std::string::npos);
  options = BopEvalOptions();
  options.add_threshold = 0.0;
  EXPECT_NE(options.Check().find("add_threshold"), std::string::npos);
  options = BopEvalOptions();
  options.vsd.delta_m = -1.0;
  EXPECT_NE(options.Check().find("delta_m"), std::string::npos);
}

TEST(EvaluateBop, GroundTruthIsPerfect) {
  const Eigen::Matrix3d tilted = test::AxisAngle(1.2, {1.0, 0.3, 0.0});
  const std::string root = test::WriteSyntheticBopDataset(
      "bop_eval_identity", {Cube(), Cylinder()},
      {{0, {{kCube, At(0.0, 0.0, 0.6)}, {kCylinder, MakePose(tilted, {0.15, 0.0, 0.7})}}},
       {1, {{kCube, At(-0.1, 0.0, 0.8)}, {kCube, At(0.1, 0.02, 0.8)}}}});
  const BopDataset dataset = LoadBopDataset(root);
  const BopEvalReport report = EvaluateBop(
      dataset, dataset.targets, test::GroundTruthEstimates(dataset), BopEvalOptions(), nullptr);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_EQ(report.overall.targets, 4);
  EXPECT_EQ(report.overall.with_estimate, 4);
  EXPECT_EQ(report.overall.add_recall, 1.0);
  EXPECT_EQ(report.overall.ar_vsd, 1.0);
  EXPECT_EQ(report.overall.ar_mssd, 1.0);
  EXPECT_EQ(report.overall.ar_mspd, 1.0);
  EXPECT_EQ(report.overall.ar, 1.0);
  ASSERT_EQ(report.objects.size(), 2u);
  EXPECT_FALSE(report.objects[0].uses_adds);
  EXPECT_TRUE(report.objects[1].uses_adds);
  ASSERT_EQ(report.targets.size(), 4u);
  for (const BopTargetReport& target : report.targets) {
    EXPECT_EQ(target.estimates, target.obj_id == kCube && target.im_id == 1 ? 2 : 1);
    EXPECT_EQ(target.add_m, 0.0);
    EXPECT_EQ(target.mssd_m, 0.0);
    EXPECT_EQ(target.mspd_px, 0.0);
    EXPECT_EQ(target.vsd_mean, 0.0);
    EXPECT_TRUE(target.add_correct);
  }
  EXPECT_EQ(report.num_estimates_evaluated, 4);
  EXPECT_EQ(report.num_estimates_ignored, 0);
}

// The cube at 0.6 m (front face at 0.55 m), the estimate 2 cm to the side.
// ADD = MSSD = 20 mm = 0.1155 d: ADD fails 0.1 d; MSSD passes 8 of the 10 thresholds
// (0.15 .. 0.5). MSPD = 500 px * 0.02 m / 0.55 m = 18.18 px at the front corners: passes
// 7 of 10 (20 .. 50 px).
TEST(EvaluateBop, TranslationOffsetGivesKnownErrors) {
  const Eigen::Isometry3d gt = At(0.0, 0.0, 0.6);
  const std::string root =
      test::WriteSyntheticBopDataset("bop_eval_offset", {Cube()}, {{0, {{kCube, gt}}}});
  const BopDataset dataset = LoadBopDataset(root);
  const std::vector<BopEstimate> estimates = {
      MakeEstimate(0, kCube, 0.7, Moved(gt, {0.02, 0.0, 0.0}))};
  const BopEvalReport report =
      EvaluateBop(dataset, dataset.targets, estimates, BopEvalOptions(), nullptr);
  ASSERT_TRUE(report.success) << report.message;
  ASSERT_EQ(report.targets.size(), 1u);
  const BopTargetReport& target = report.targets[0];
  EXPECT_NEAR(target.add_m, 0.02, 1e-9);
  EXPECT_NEAR(target.mssd_m, 0.02, 1e-9);
  EXPECT_NEAR(target.mspd_px, 500.0 * 0.02 / 0.55, 1e-4);
  EXPECT_FALSE(target.add_correct);
  EXPECT_EQ(report.overall.add_recall, 0.0);
  EXPECT_DOUBLE_EQ(report.overall.ar_mssd, 0.8);
  EXPECT_DOUBLE_EQ(report.overall.ar_mspd, 0.7);
  // VSD: the shifted silhouette overlaps most of the GT one at the same depth.
  EXPECT_GT(report.overall.ar_vsd, 0.0);
  EXPECT_LT(report.overall.ar_vsd, 1.0);
  EXPECT_DOUBLE_EQ(report.overall.ar,
                   (report.overall.ar_vsd + report.overall.ar_mssd + report.overall.ar_mspd) / 3);

  // 10 cm to the side: MSSD 0.577 d and MSPD 90.9 px fail every threshold.
  const BopEvalReport far = EvaluateBop(dataset, dataset.targets,
                                        {MakeEstimate(0, kCube, 0.7, Moved(gt, {0.1, 0.0, 0.0}))},
                                        BopEvalOptions(), nullptr);
  EXPECT_NEAR(far.targets[0].mspd_px, 500.0 * 0.1 / 0.55, 1e-4);
  EXPECT_EQ(far.overall.ar_mssd, 0.0);
  EXPECT_EQ(far.overall.ar_mspd, 0.0);
}

// A cylinder with a continuous symmetry about its axis, rotated about that axis by 40
// degrees (a multiple of both its 10 degree facets and BOP's 2*pi/315 discretization):
// the same surface, so MSSD, MSPD and VSD are (numerically) zero and ADD-S is zero, while
// plain ADD would be large.
TEST(EvaluateBop, SymmetricCylinderRotatedAboutItsAxisIsPerfect) {
  const Eigen::Isometry3d gt = MakePose(test::AxisAngle(0.9, {1.0, 0.0, 0.2}), {0.0, 0.0, 0.7});
  const std::string root =
      test::WriteSyntheticBopDataset("bop_eval_cylinder", {Cylinder()}, {{0, {{kCylinder, gt}}}});
  const BopDataset dataset = LoadBopDataset(root);
  const Eigen::Isometry3d rotated =
      gt * MakePose(test::AxisAngle(40.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()),
                    Eigen::Vector3d::Zero());
  const BopEvalReport report =
      EvaluateBop(dataset, dataset.targets, {MakeEstimate(0, kCylinder, 1.0, rotated)},
                  BopEvalOptions(), nullptr);
  ASSERT_TRUE(report.success) << report.message;
  ASSERT_EQ(report.targets.size(), 1u);
  EXPECT_LT(report.targets[0].mssd_m, 1e-6);
  EXPECT_LT(report.targets[0].mspd_px, 1e-3);
  EXPECT_LT(report.targets[0].add_m, 1e-6);  // ADD-S
  EXPECT_LT(report.targets[0].vsd_mean, 0.01);
  EXPECT_TRUE(report.objects[0].uses_adds);
  EXPECT_EQ(report.overall.ar, 1.0);
  EXPECT_EQ(report.overall.add_recall, 1.0);
  // Plain ADD of that pose: the rim moves by 2 * 4 cm * sin(20 deg) = 27 mm.
  const Mesh cylinder = Cylinder().mesh;
  EXPECT_GT(ComputeAdd(rotated, gt, cylinder.vertices), 0.02);
}

// Two cubes of the same object 2 cm apart, both targets (inst_count 2). Estimate A
// (score 0.9) is 8 mm from GT0 and 12 mm from GT1; estimate B (score 0.8) is 8 mm from GT0
// and 28 mm from GT1. Greedy matching by score: A takes GT0 (the smaller error); B can only
// take GT1 where its error is below the threshold.
//   ADD (threshold 17.3 mm): A -> GT0, B -> none: recall 1/2.
//   MSSD (errors 0.046 d, 0.069 d for A; 0.046 d, 0.162 d for B): thresholds 0.05..0.15
//   match one, 0.2..0.5 match both: AR_MSSD = (3 * 0.5 + 7 * 1) / 10 = 0.85.
// With the scores swapped B takes GT0 and A GT1: ADD recall 1; MSSD 0.05 matches one, the
// others both: AR_MSSD = 0.95.
TEST(EvaluateBop, GreedyMatchingFollowsTheScore) {
  const Eigen::Isometry3d gt0 = At(0.0, 0.0, 0.8);
  const Eigen::Isometry3d gt1 = At(0.02, 0.0, 0.8);
  const std::string root = test::WriteSyntheticBopDataset("bop_eval_greedy", {Cube()},
                                                          {{3, {{kCube, gt0}, {kCube, gt1}}}});
  const BopDataset dataset = LoadBopDataset(root);
  ASSERT_EQ(dataset.targets.size(), 1u);
  ASSERT_EQ(dataset.targets[0].inst_count, 2);
  const Eigen::Isometry3d a = At(0.008, 0.0, 0.8);
  const Eigen::Isometry3d b = At(-0.008, 0.0, 0.8);

  const BopEvalReport a_first = EvaluateBop(
      dataset, dataset.targets, {MakeEstimate(3, kCube, 0.8, b), MakeEstimate(3, kCube, 0.9, a)},
      BopEvalOptions(), nullptr);
  EXPECT_EQ(a_first.overall.targets, 2);
  EXPECT_EQ(a_first.overall.add_correct, 1);
  EXPECT_DOUBLE_EQ(a_first.overall.add_recall, 0.5);
  EXPECT_EQ(a_first.overall.mssd_correct, (std::vector<int>{1, 1, 1, 2, 2, 2, 2, 2, 2, 2}));
  EXPECT_DOUBLE_EQ(a_first.overall.ar_mssd, 0.85);
  ASSERT_EQ(a_first.targets.size(), 2u);
  EXPECT_TRUE(a_first.targets[0].add_correct);   // GT0
  EXPECT_FALSE(a_first.targets[1].add_correct);  // GT1

  const BopEvalReport b_first = EvaluateBop(
      dataset, dataset.targets, {MakeEstimate(3, kCube, 0.9, b), MakeEstimate(3, kCube, 0.8, a)},
      BopEvalOptions(), nullptr);
  EXPECT_DOUBLE_EQ(b_first.overall.add_recall, 1.0);
  EXPECT_EQ(b_first.overall.mssd_correct, (std::vector<int>{1, 2, 2, 2, 2, 2, 2, 2, 2, 2}));
  EXPECT_DOUBLE_EQ(b_first.overall.ar_mssd, 0.95);
}

// inst_count 1 with two GT instances: only the more visible GT is a target, and only the
// best-scored estimate is evaluated (BOP n_top = -1).
TEST(EvaluateBop, InstCountKeepsTheMostVisibleGtAndTheBestEstimate) {
  const Eigen::Isometry3d gt0 = At(0.0, 0.0, 0.8);
  const Eigen::Isometry3d gt1 = At(0.02, 0.0, 0.8);
  std::vector<SyntheticInstance> instances = {{kCube, gt0, 0.3}, {kCube, gt1, 0.8}};
  const std::string root =
      test::WriteSyntheticBopDataset("bop_eval_inst_count", {Cube()}, {{0, instances}});
  const BopDataset dataset = LoadBopDataset(root);
  const std::vector<BopTarget> one = {{1, 0, kCube, 1}};

  // The top estimate sits on GT0, which is not the target: 20 mm from GT1 fails ADD.
  const BopEvalReport wrong = EvaluateBop(
      dataset, one, {MakeEstimate(0, kCube, 0.9, gt0), MakeEstimate(0, kCube, 0.5, gt1)},
      BopEvalOptions(), nullptr);
  EXPECT_EQ(wrong.overall.targets, 1);
  ASSERT_EQ(wrong.targets.size(), 1u);
  EXPECT_EQ(wrong.targets[0].gt_idx, 1);
  EXPECT_DOUBLE_EQ(wrong.targets[0].visib_fract, 0.8);
  EXPECT_EQ(wrong.overall.add_recall, 0.0);
  EXPECT_EQ(wrong.num_estimates_evaluated, 1);
  EXPECT_EQ(wrong.num_estimates_beyond_count, 1);

  const BopEvalReport right = EvaluateBop(
      dataset, one, {MakeEstimate(0, kCube, 0.9, gt0), MakeEstimate(0, kCube, 0.95, gt1)},
      BopEvalOptions(), nullptr);
  EXPECT_EQ(right.overall.add_recall, 1.0);
  EXPECT_EQ(right.overall.ar, 1.0);
}

TEST(EvaluateBop, MissingEstimatesCountAsFailures) {
  const std::string root = test::WriteSyntheticBopDataset(
      "bop_eval_missing", {Cube(), Cylinder()},
      {{0, {{kCube, At(0.0, 0.0, 0.6)}}}, {2, {{kCube, At(0.0, 0.05, 0.7)}}}});
  const BopDataset dataset = LoadBopDataset(root);
  ASSERT_EQ(dataset.targets.size(), 2u);
  const std::vector<BopEstimate> estimates = {
      MakeEstimate(0, kCube, 1.0, At(0.0, 0.0, 0.6)),
      // Not targets: an image without targets, an object that is not in image 2.
      MakeEstimate(9, kCube, 1.0, At(0.0, 0.0, 0.6)),
      MakeEstimate(2, kCylinder, 1.0, At(0.0, 0.0, 0.6))};
  const BopEvalReport report =
      EvaluateBop(dataset, dataset.targets, estimates, BopEvalOptions(), nullptr);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_EQ(report.overall.targets, 2);
  EXPECT_EQ(report.overall.with_estimate, 1);
  EXPECT_EQ(report.num_estimates_ignored, 2);
  EXPECT_DOUBLE_EQ(report.overall.add_recall, 0.5);
  EXPECT_DOUBLE_EQ(report.overall.ar_vsd, 0.5);
  EXPECT_DOUBLE_EQ(report.overall.ar_mssd, 0.5);
  EXPECT_DOUBLE_EQ(report.overall.ar_mspd, 0.5);
  EXPECT_DOUBLE_EQ(report.overall.ar, 0.5);
  ASSERT_EQ(report.targets.size(), 2u);
  EXPECT_EQ(report.targets[1].im_id, 2);
  EXPECT_EQ(report.targets[1].estimates, 0);
  EXPECT_TRUE(std::isinf(report.targets[1].add_m));
  // Only the cube has targets, so only the cube is reported.
  ASSERT_EQ(report.objects.size(), 1u);

  // No estimates at all: everything 0, still a valid evaluation.
  const BopEvalReport none = EvaluateBop(dataset, dataset.targets, {}, BopEvalOptions(), nullptr);
  EXPECT_TRUE(none.success);
  EXPECT_EQ(none.overall.ar, 0.0);
  EXPECT_EQ(none.overall.add_recall, 0.0);

  // No targets: success = false, not an exception.
  const BopEvalReport empty = EvaluateBop(dataset, {}, estimates, BopEvalOptions(), nullptr);
  EXPECT_FALSE(empty.success);
}

TEST(EvaluateBop, UnknownObjectsAreErrors) {
  const std::string root = test::WriteSyntheticBopDataset("bop_eval_unknown", {Cube()},
                                                          {{0, {{kCube, At(0.0, 0.0, 0.6)}}}});
  const BopDataset dataset = LoadBopDataset(root);
  try {
    EvaluateBop(dataset, dataset.targets, {MakeEstimate(0, 7, 1.0, At(0.0, 0.0, 0.6))},
                BopEvalOptions(), nullptr);
    ADD_FAILURE() << "expected g6d::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("object 7 is not in"), std::string::npos) << e.what();
  }
  EXPECT_THROW(EvaluateBop(dataset, {{1, 0, 8, 1}}, {}, BopEvalOptions(), nullptr), Error);
  // A target image that is not in the scene.
  EXPECT_THROW(EvaluateBop(dataset, {{1, 5, kCube, 1}}, {}, BopEvalOptions(), nullptr), Error);
}

TEST(EvaluateBop, ThreadsGiveTheSameResult) {
  const std::string root = test::WriteSyntheticBopDataset(
      "bop_eval_threads", {Cube(), Cylinder()},
      {{0, {{kCube, At(0.0, 0.0, 0.6)}, {kCylinder, At(0.15, 0.0, 0.7)}}},
       {1, {{kCube, At(-0.1, 0.0, 0.8)}}},
       {2, {{kCylinder, At(0.0, 0.05, 0.7)}}}});
  const BopDataset dataset = LoadBopDataset(root);
  std::vector<BopEstimate> estimates = test::GroundTruthEstimates(dataset);
  for (size_t i = 0; i < estimates.size(); ++i) {
    estimates[i].cam_from_object.translation() += Eigen::Vector3d(0.004 * i, 0.0, 0.01);
  }
  ThreadPool pool(2);
  const BopEvalReport one =
      EvaluateBop(dataset, dataset.targets, estimates, BopEvalOptions(), nullptr);
  const BopEvalReport two =
      EvaluateBop(dataset, dataset.targets, estimates, BopEvalOptions(), &pool);
  EXPECT_EQ(one.overall.vsd_correct, two.overall.vsd_correct);
  EXPECT_EQ(one.overall.mssd_correct, two.overall.mssd_correct);
  EXPECT_EQ(one.overall.mspd_correct, two.overall.mspd_correct);
  EXPECT_EQ(one.overall.ar, two.overall.ar);
  ASSERT_EQ(one.targets.size(), two.targets.size());
  for (size_t i = 0; i < one.targets.size(); ++i) {
    EXPECT_EQ(one.targets[i].vsd_mean, two.targets[i].vsd_mean);
  }
}

// Real data: the LM-O GT poses written to a results CSV and read back score AR = 1 and
// ADD(-S) recall = 1 over the 449 BOP'19 targets of the developers' set. VSD of a pose
// against itself is exactly 0 whatever the depth image holds (both visibility masks are
// the same and the distances on them are equal), so the semi-synthetic LM-O depth does
// not matter here; only a target that is invisible in the depth image (empty union)
// would score VSD 1, and there is none.
TEST(EvaluateBop, LmoGroundTruthCsvIsPerfect) {
  G6D_REQUIRE_SHARED_DATA("lmo/test_targets_bop19.json");
  const BopDataset dataset = LoadBopDataset(test::SharedDataPath("lmo"));
  const std::string csv = test::TempDir("bop_eval_lmo") + "/gt.csv";
  WriteBopCsv(csv, test::GroundTruthEstimates(dataset));
  const std::vector<BopEstimate> estimates = ReadBopCsv(csv);
  ThreadPool pool(2);
  const BopEvalReport report =
      EvaluateBop(dataset, dataset.targets, estimates, BopEvalOptions(), &pool);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_EQ(report.overall.targets, 449);
  EXPECT_EQ(report.objects.size(), 8u);
  EXPECT_EQ(report.overall.add_recall, 1.0);
  EXPECT_EQ(report.overall.ar_vsd, 1.0);
  EXPECT_EQ(report.overall.ar_mssd, 1.0);
  EXPECT_EQ(report.overall.ar_mspd, 1.0);
  EXPECT_EQ(report.overall.ar, 1.0);
  for (const BopTargetReport& target : report.targets) {
    EXPECT_LT(target.mssd_m, 1e-9);
    EXPECT_LT(target.mspd_px, 1e-6);
    EXPECT_EQ(target.vsd_mean, 0.0);
  }
  // 484 GT instances, 35 of them are not BOP'19 targets (less than 10% visible in BOP's
  // original data).
  EXPECT_EQ(report.num_estimates_ignored, 35);

  // The same poses 2 cm further away: MSSD 20 mm is 0.08 d (ducks) .. 0.2 d (ape), so
  // recall drops at the small thresholds, and VSD sees the shift in the real depth.
  std::vector<BopEstimate> pushed = estimates;
  for (BopEstimate& e : pushed) e.cam_from_object.translation().z() += 0.02;
  const BopEvalReport worse =
      EvaluateBop(dataset, dataset.targets, pushed, BopEvalOptions(), &pool);
  EXPECT_GT(worse.overall.ar, 0.2);
  EXPECT_LT(worse.overall.ar, 0.9);
  EXPECT_LT(worse.overall.ar_vsd, 0.9);
}

// Real YCB-V depth (not rendered): the GT is still perfect.
TEST(EvaluateBop, YcbvGroundTruthIsPerfect) {
  G6D_REQUIRE_SHARED_DATA("ycbv_real/test_targets_bop19.json");
  const BopDataset dataset = LoadBopDataset(test::SharedDataPath("ycbv_real"));
  const BopEvalReport report = EvaluateBop(
      dataset, dataset.targets, test::GroundTruthEstimates(dataset), BopEvalOptions(), nullptr);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_EQ(report.overall.targets, 5);
  EXPECT_EQ(report.overall.ar, 1.0);
  EXPECT_EQ(report.overall.add_recall, 1.0);
}

}  // namespace
}  // namespace g6d
