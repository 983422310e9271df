// MHPO residuals: analytic Jacobians against central differences; refinement lowers S.
#include "solver/mhpo.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/se3.h"
#include "render/raster.h"
#include "synthetic_scene.h"

namespace g6d {
namespace {

// Observation of a box on a 120 x 120 grid with smooth (sloped) depth.
struct Fixture {
  Mesh mesh = test::MakeTexturedBox(0.08, 0.06, 0.04, 5);
  Camera camera{300, 300, 60, 60, 120, 120};
  Eigen::Isometry3d truth = MakePose(ExpSO3(Eigen::Vector3d(0.4, 0.5, 0.2)), Eigen::Vector3d(0.0, 0.0, 0.5));
  EvaluationGrid grid;
  double z_m = 0.0;
  Fixture() {
    RasterImage raster;
    Rasterize(mesh, camera, truth, RasterOptions(), &raster);
    grid.camera = camera;
    grid.mask = raster.Mask();
    grid.depth = raster.depth.clone();
    grid.mask_pixels = raster.pixel_count;
    z_m = MeanMaskedDepth(grid.mask, grid.depth);
  }
};

// The Jacobian of `function` at `point` against central differences of the residual at
// the point moved by small left increments: p + h e_i (i < 3), R(h e_(i-3)) p.
template <typename Function>
void ExpectJacobianMatchesNumeric(const Function& function, const Eigen::Vector3d& point) {
  double analytic[6];
  function(point, analytic);
  const double h = 1e-6;
  for (int i = 0; i < 6; ++i) {
    auto moved = [&](double step) -> Eigen::Vector3d {
      if (i < 3) return point + step * Eigen::Vector3d::Unit(i);
      return Eigen::AngleAxisd(step, Eigen::Vector3d::Unit(i - 3)) * point;
    };
    const double numeric = (function(moved(h), nullptr) - function(moved(-h), nullptr)) / (2 * h);
    EXPECT_NEAR(analytic[i], numeric, 1e-4 * std::max(1.0, std::abs(numeric))) << "parameter " << i;
  }
}

TEST(EvaluateSilhouetteResidual, JacobianMatchesCentralDifferences) {
  Fixture f;
  const MhpoTarget target = MakeMhpoTarget(f.grid, f.z_m);
  // Points near (not on) the boundary, where the signed distance is smooth.
  for (const Eigen::Vector3d& point : {Eigen::Vector3d(0.03, 0.01, 0.52), Eigen::Vector3d(-0.02, 0.025, 0.49)}) {
    ExpectJacobianMatchesNumeric(
        [&](const Eigen::Vector3d& p, double* j) { return EvaluateSilhouetteResidual(target, p, j); },
        point);
  }
}

TEST(EvaluateDepthResidual, JacobianMatchesCentralDifferences) {
  Fixture f;
  const MhpoTarget target = MakeMhpoTarget(f.grid, f.z_m);
  const Eigen::Vector3d point = f.truth * Eigen::Vector3d(0.0, 0.0, 0.02);
  ExpectJacobianMatchesNumeric(
      [&](const Eigen::Vector3d& p, double* j) { return EvaluateDepthResidual(target, p, j); },
      point);
}

TEST(MakeMhpoTarget, SignedDistanceIsNegativeInsidePositiveOutside) {
  Fixture f;
  const MhpoTarget target = MakeMhpoTarget(f.grid, f.z_m);
  const cv::Point inside = [&] {
    cv::Moments m = cv::moments(f.grid.mask, true);
    return cv::Point(static_cast<int>(m.m10 / m.m00), static_cast<int>(m.m01 / m.m00));
  }();
  EXPECT_LT(target.signed_distance.at<float>(inside), 0.0f);
  EXPECT_GT(target.signed_distance.at<float>(0, 0), 0.0f);
}

TEST(RefineByMhpo, LowersScoreFromPerturbedPoses) {
  Fixture f;
  const MhpoTarget target = MakeMhpoTarget(f.grid, f.z_m);
  std::vector<Eigen::Isometry3d> hypotheses;
  for (int k = 0; k < 3; ++k) {
    Eigen::Isometry3d pose = f.truth;
    pose.linear() = ExpSO3(Eigen::Vector3d(0.05 * (k - 1), 0.04, -0.03)) * pose.linear();
    pose.translation() += Eigen::Vector3d(0.004, -0.003 * k, 0.006);
    hypotheses.push_back(pose);
  }
  MhpoOptions options;
  options.early_stop_score = 0.0;
  Eigen::Isometry3d best;
  MhpoReport report;
  InlineExecutor executor;
  RefineByMhpo(options, ScoreOptions(), target, f.mesh, hypotheses, &executor, &best, &report);
  ASSERT_TRUE(report.success) << report.message;
  double best_initial = 1e9;
  for (const auto& h : report.hypotheses) best_initial = std::min(best_initial, h.initial_s);
  EXPECT_LT(report.best_score.s, 0.7 * best_initial);
  EXPECT_LT(TranslationError(best, f.truth), TranslationError(hypotheses[0], f.truth));
}

// Rounds of Levenberg-Marquardt on the mask and depth terms bring one hypothesis, 3 degrees
// and 7 mm off, to within a third of its translation and rotation errors. (Not to the
// rendered pose itself: the contour points are the centres of the rendered edge pixels,
// half a pixel inside the outline, and the objective pulls them onto the observed
// boundary: here its minimum lies about 2 mm from the truth. Targeting the signed distance
// -0.5 instead removes that offset on this fixture but did not help on the dev sets,
// bench/RESULTS.md, "MHPO's Levenberg-Marquardt loop".)
TEST(RefineByMhpo, BringsAHypothesisCloserToTheRenderedPose) {
  Fixture f;
  const MhpoTarget target = MakeMhpoTarget(f.grid, f.z_m);
  Eigen::Isometry3d start = f.truth;
  start.linear() = ExpSO3(Eigen::Vector3d(0.03, -0.03, 0.03)) * start.linear();
  start.translation() += Eigen::Vector3d(0.004, -0.004, 0.004);
  MhpoOptions options;
  options.early_stop_score = 0.0;
  Eigen::Isometry3d best;
  MhpoReport report;
  InlineExecutor executor;
  RefineByMhpo(options, ScoreOptions(), target, f.mesh, {start}, &executor, &best, &report);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_LT(TranslationError(best, f.truth), TranslationError(start, f.truth) / 3.0);
  EXPECT_LT(RotationErrorDeg(best.linear(), f.truth.linear()), RotationErrorDeg(start.linear(), f.truth.linear()) / 3.0);
  EXPECT_LT(report.best_score.s, report.hypotheses[0].initial_s / 3.0);
}

TEST(RefineByMhpo, SameResultWithOneAndTwoThreads) {
  Fixture f;
  const MhpoTarget target = MakeMhpoTarget(f.grid, f.z_m);
  std::vector<Eigen::Isometry3d> hypotheses;
  for (int k = 0; k < 4; ++k) {
    Eigen::Isometry3d pose = f.truth;
    pose.translation() += Eigen::Vector3d(0.003 * k, -0.002, 0.004);
    hypotheses.push_back(pose);
  }
  InlineExecutor one;
  ThreadPool two(2);
  Eigen::Isometry3d best_one, best_two;
  MhpoReport report_one, report_two;
  RefineByMhpo(MhpoOptions(), ScoreOptions(), target, f.mesh, hypotheses, &one, &best_one, &report_one);
  RefineByMhpo(MhpoOptions(), ScoreOptions(), target, f.mesh, hypotheses, &two, &best_two, &report_two);
  EXPECT_EQ(report_one.best_hypothesis, report_two.best_hypothesis);
  EXPECT_EQ(report_one.best_score.s, report_two.best_score.s);
  EXPECT_TRUE(best_one.matrix() == best_two.matrix());
}

// Early stopping may end MHPO only after min_rounds: with a threshold every pose meets,
// min_rounds = 0 refines nothing, min_rounds = 1 refines every hypothesis once.
TEST(RefineByMhpo, EarlyStoppingWaitsForMinRounds) {
  Fixture f;
  const MhpoTarget target = MakeMhpoTarget(f.grid, f.z_m);
  std::vector<Eigen::Isometry3d> hypotheses;
  for (int k = 0; k < 3; ++k) {
    Eigen::Isometry3d pose = f.truth;
    pose.translation() += Eigen::Vector3d(0.002 * k, 0.003, -0.002);
    hypotheses.push_back(pose);
  }
  MhpoOptions options;
  options.early_stop_score = 10.0;  // any S
  InlineExecutor executor;
  Eigen::Isometry3d best;
  MhpoReport report;
  options.min_rounds = 0;
  RefineByMhpo(options, ScoreOptions(), target, f.mesh, hypotheses, &executor, &best, &report);
  ASSERT_TRUE(report.success);
  EXPECT_TRUE(report.early_stopped);
  for (const auto& h : report.hypotheses) EXPECT_EQ(h.rounds, 0);
  options.min_rounds = 1;
  RefineByMhpo(options, ScoreOptions(), target, f.mesh, hypotheses, &executor, &best, &report);
  ASSERT_TRUE(report.success);
  EXPECT_TRUE(report.early_stopped);
  for (const auto& h : report.hypotheses) EXPECT_EQ(h.rounds, 1);
}

// Scores the caller already has are used as they are (not recomputed).
TEST(RefineByMhpo, UsesTheGivenInitialScores) {
  Fixture f;
  const MhpoTarget target = MakeMhpoTarget(f.grid, f.z_m);
  const std::vector<Eigen::Isometry3d> hypotheses = {f.truth};
  MhpoOptions options;
  options.max_rounds = 0;
  InlineExecutor executor;
  Eigen::Isometry3d best;
  MhpoReport report;
  PoseScore given;
  given.s = 0.123;
  const std::vector<PoseScore> scores = {given};
  RefineByMhpo(options, ScoreOptions(), target, f.mesh, hypotheses, &executor, &best, &report, nullptr, &scores);
  ASSERT_TRUE(report.success);
  EXPECT_EQ(report.hypotheses[0].initial_s, 0.123);
  RefineByMhpo(options, ScoreOptions(), target, f.mesh, hypotheses, &executor, &best, &report);
  EXPECT_LT(report.hypotheses[0].initial_s, 0.01);  // computed: the truth fits
}

}  // namespace
}  // namespace g6d
