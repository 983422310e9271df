#include "eval/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/error.h"
#include "core/se3.h"

namespace g6d {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

Eigen::Isometry3d Pose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  return pose;
}

Eigen::Matrix3d RotationZ(double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

// Points on the side of a cylinder of `radius_m` around the z axis through `centre_m`,
// every 10 degrees, at 5 heights in [-0.05, 0.05] m: symmetric under rotations about that
// axis by multiples of 10 degrees.
std::vector<Eigen::Vector3f> CylinderPoints(
    double radius_m, const Eigen::Vector3d& centre_m = Eigen::Vector3d::Zero()) {
  std::vector<Eigen::Vector3f> points;
  for (int h = 0; h < 5; ++h) {
    for (int a = 0; a < 36; ++a) {
      const double angle = a * 10.0 * kDegToRad;
      const Eigen::Vector3d p =
          centre_m + Eigen::Vector3d(radius_m * std::cos(angle), radius_m * std::sin(angle),
                                     -0.05 + 0.025 * h);
      points.push_back(p.cast<float>());
    }
  }
  return points;
}

// A non-symmetric set: random points in a 10 cm box, fixed seed.
std::vector<Eigen::Vector3f> RandomPoints(int count, uint32_t seed) {
  std::mt19937 generator(seed);
  std::uniform_real_distribution<float> uniform(-0.05f, 0.05f);
  std::vector<Eigen::Vector3f> points(count);
  for (auto& p : points)
    p = Eigen::Vector3f(uniform(generator), uniform(generator), uniform(generator));
  return points;
}

// 36 rotations about z by multiples of 10 degrees (object_from_object), identity first.
std::vector<Eigen::Isometry3d> TenDegreeSymmetries() {
  std::vector<Eigen::Isometry3d> symmetries;
  for (int a = 0; a < 36; ++a) {
    symmetries.push_back(Pose(RotationZ(a * 10.0 * kDegToRad), Eigen::Vector3d::Zero()));
  }
  return symmetries;
}

const Eigen::Isometry3d kGt =
    Pose(ExpSO3(Eigen::Vector3d(0.3, -0.2, 0.5)), Eigen::Vector3d(0.05, -0.02, 0.8));

TEST(ComputeAdd, IdentityPoseIsZero) {
  const auto points = RandomPoints(200, 1);
  EXPECT_EQ(ComputeAdd(kGt, kGt, points), 0.0);
}

TEST(ComputeAdd, FiveMillimetreOffsetIsFiveMillimetres) {
  const auto points = RandomPoints(200, 2);
  Eigen::Isometry3d estimate = kGt;
  estimate.translation() += Eigen::Vector3d(0.003, 0.0, 0.004);  // |(3, 0, 4)| = 5 mm
  EXPECT_NEAR(ComputeAdd(estimate, kGt, points), 0.005, 1e-12);
}

TEST(ComputeAdd, RotationMovesEachPointByChord) {
  // Points at radius r from the z axis rotated by theta move by 2 r sin(theta / 2).
  const double radius = 0.04;
  const auto points = CylinderPoints(radius);
  const Eigen::Isometry3d rotated =
      kGt * Pose(RotationZ(30.0 * kDegToRad), Eigen::Vector3d::Zero());
  EXPECT_NEAR(ComputeAdd(rotated, kGt, points), 2.0 * radius * std::sin(15.0 * kDegToRad), 1e-7);
}

TEST(ComputeAdd, EmptyPointsThrow) { EXPECT_THROW(ComputeAdd(kGt, kGt, {}), Error); }

TEST(ComputeAdds, SymmetricRotationIsZeroWhileAddIsLarge) {
  const double radius = 0.04;
  const auto points = CylinderPoints(radius);
  const Eigen::Isometry3d rotated =
      kGt * Pose(RotationZ(30.0 * kDegToRad), Eigen::Vector3d::Zero());
  EXPECT_NEAR(ComputeAdds(rotated, kGt, points), 0.0, 1e-7);
  EXPECT_GT(ComputeAdd(rotated, kGt, points), 0.02);
}

TEST(ComputeAdds, TranslationAlongAxisOfDenseLineIsSmall) {
  // Hand case: points every 1 mm on a line along x; shifting the estimate by 0.5 mm along
  // the line leaves every GT point 0.5 mm from its nearest estimated point.
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i <= 100; ++i) points.emplace_back(0.001f * i, 0.0f, 0.0f);
  Eigen::Isometry3d estimate = Eigen::Isometry3d::Identity();
  estimate.translation() = Eigen::Vector3d(0.0005, 0.0, 0.0);
  // Every GT point has a neighbour at 0.5 mm (the first one too: x = 0.5 mm).
  EXPECT_NEAR(ComputeAdds(estimate, Eigen::Isometry3d::Identity(), points), 0.0005, 1e-7);
  EXPECT_NEAR(ComputeAdd(estimate, Eigen::Isometry3d::Identity(), points), 0.0005, 1e-12);
}

TEST(ComputeAdds, NeverAboveAddOnRandomPoses) {
  const auto points = RandomPoints(300, 3);
  std::mt19937 generator(4);
  std::normal_distribution<double> normal(0.0, 0.2);
  for (int trial = 0; trial < 20; ++trial) {
    Vector6d xi;
    for (int k = 0; k < 6; ++k) xi[k] = normal(generator);
    const Eigen::Isometry3d estimate = ExpSE3(xi) * kGt;
    EXPECT_LE(ComputeAdds(estimate, kGt, points), ComputeAdd(estimate, kGt, points) + 1e-12);
  }
}

TEST(ComputeAdds, EmptyPointsThrow) { EXPECT_THROW(ComputeAdds(kGt, kGt, {}), Error); }

TEST(IsAddCorrect, ThresholdIsStrictFractionOfDiameter) {
  EXPECT_TRUE(IsAddCorrect(0.0099, 0.1));
  EXPECT_FALSE(IsAddCorrect(0.0101, 0.1));
  EXPECT_TRUE(IsAddCorrect(0.019, 0.1, 0.2));
  EXPECT_FALSE(IsAddCorrect(0.021, 0.1, 0.2));
}

TEST(SymmetryTransforms, NoSymmetryGivesIdentityOnly) {
  const auto all = SymmetryTransforms({}, {});
  ASSERT_EQ(all.size(), 1u);
  EXPECT_TRUE(all[0].isApprox(Eigen::Isometry3d::Identity()));
}

TEST(SymmetryTransforms, DiscreteListFollowsIdentity) {
  const Eigen::Isometry3d flip = Pose(RotationZ(M_PI), Eigen::Vector3d(0.01, 0.0, 0.0));
  const auto all = SymmetryTransforms({flip}, {});
  ASSERT_EQ(all.size(), 2u);
  EXPECT_TRUE(all[0].isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_TRUE(all[1].isApprox(flip));
}

TEST(SymmetryTransforms, ContinuousUsesBopStepAndKeepsAxisFixed) {
  ContinuousSymmetry symmetry;
  symmetry.axis = Eigen::Vector3d(0.0, 0.0, 2.0);  // not unit on purpose
  symmetry.offset_m = Eigen::Vector3d(0.1, -0.05, 0.0);
  const auto all = SymmetryTransforms({}, {symmetry});
  // ceil(pi / 0.01) = 315 rotations, the first one the identity.
  ASSERT_EQ(all.size(), 315u);
  EXPECT_TRUE(all[0].isApprox(Eigen::Isometry3d::Identity()));
  for (const auto& s : all) {
    // Points on the axis stay put; rotation is about z.
    const Eigen::Vector3d on_axis = symmetry.offset_m + Eigen::Vector3d(0.0, 0.0, 0.3);
    EXPECT_NEAR((s * on_axis - on_axis).norm(), 0.0, 1e-12);
    EXPECT_NEAR((s.linear() * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ()).norm(), 0.0,
                1e-12);
  }
  EXPECT_NEAR(RotationErrorDeg(all[1].linear(), Eigen::Matrix3d::Identity()), 360.0 / 315.0, 1e-9);
}

TEST(SymmetryTransforms, DiscreteTimesContinuousCount) {
  const Eigen::Isometry3d flip =
      Pose(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix(),
           Eigen::Vector3d::Zero());
  const auto all = SymmetryTransforms({flip}, {ContinuousSymmetry{}}, 0.1);
  EXPECT_EQ(all.size(), 2u * 32u);  // (1 + 1) * ceil(pi / 0.1)
}

TEST(SymmetryTransforms, BadArgumentsThrow) {
  EXPECT_THROW(SymmetryTransforms({}, {}, 0.0), Error);
  ContinuousSymmetry zero_axis;
  zero_axis.axis = Eigen::Vector3d::Zero();
  EXPECT_THROW(SymmetryTransforms({}, {zero_axis}), Error);
}

TEST(ComputeMssd, IdentitySymmetryOnlyIsMaxDistance) {
  const double radius = 0.04;
  const auto points = CylinderPoints(radius);
  Eigen::Isometry3d estimate = kGt;
  estimate.translation() += Eigen::Vector3d(0.0, 0.005, 0.0);
  const std::vector<Eigen::Isometry3d> identity = {Eigen::Isometry3d::Identity()};
  EXPECT_NEAR(ComputeMssd(estimate, kGt, points, identity), 0.005, 1e-12);

  const Eigen::Isometry3d rotated =
      kGt * Pose(RotationZ(30.0 * kDegToRad), Eigen::Vector3d::Zero());
  EXPECT_NEAR(ComputeMssd(rotated, kGt, points, identity),
              2.0 * radius * std::sin(15.0 * kDegToRad), 1e-7);
}

TEST(ComputeMssd, SymmetricRotationIsZeroWithSymmetryList) {
  const auto points = CylinderPoints(0.04);
  const Eigen::Isometry3d rotated =
      kGt * Pose(RotationZ(30.0 * kDegToRad), Eigen::Vector3d::Zero());
  EXPECT_NEAR(ComputeMssd(rotated, kGt, points, TenDegreeSymmetries()), 0.0, 1e-7);
}

TEST(ComputeMssd, ContinuousSymmetryWithOffsetAxis) {
  // A cylinder around a z axis through (0.1, 0, 0) in the object frame; rotated about that
  // axis by an angle between two discretization steps.
  const double radius = 0.04;
  const Eigen::Vector3d centre(0.1, 0.0, 0.0);
  const auto points = CylinderPoints(radius, centre);
  Eigen::Isometry3d about_axis = Pose(RotationZ(37.3 * kDegToRad), Eigen::Vector3d::Zero());
  about_axis.translation() = centre - about_axis.linear() * centre;
  const Eigen::Isometry3d estimate = kGt * about_axis;

  ContinuousSymmetry symmetry;
  symmetry.offset_m = centre;
  const auto symmetries = SymmetryTransforms({}, {symmetry});
  const double mssd = ComputeMssd(estimate, kGt, points, symmetries);
  // Nearest discretized angle is at most half a step (180/315 deg) away.
  EXPECT_LE(mssd, 2.0 * radius * std::sin(0.5 * (180.0 / 315.0) * kDegToRad) + 1e-7);
  EXPECT_GT(ComputeMssd(estimate, kGt, points, {Eigen::Isometry3d::Identity()}), 0.02);
}

TEST(ComputeMssd, EmptyInputsThrow) {
  EXPECT_THROW(ComputeMssd(kGt, kGt, {}, {Eigen::Isometry3d::Identity()}), Error);
  EXPECT_THROW(ComputeMssd(kGt, kGt, RandomPoints(3, 5), {}), Error);
}

Camera TestCamera() { return Camera{500.0, 500.0, 320.0, 240.0, 640, 480}; }

TEST(ComputeMspd, LateralShiftOfPlanarObjectIsKnownPixels) {
  // Object points in the plane z = 1 m; a 1 cm shift along x moves all of them by
  // fx * 0.01 / 1 = 5 px.
  std::vector<Eigen::Vector3f> points;
  for (int i = -2; i <= 2; ++i) {
    for (int j = -2; j <= 2; ++j) points.emplace_back(0.01f * i, 0.01f * j, 0.0f);
  }
  const Eigen::Isometry3d gt = Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, 1.0));
  Eigen::Isometry3d estimate = gt;
  estimate.translation().x() += 0.01;
  const std::vector<Eigen::Isometry3d> identity = {Eigen::Isometry3d::Identity()};
  EXPECT_NEAR(ComputeMspd(estimate, gt, TestCamera(), points, identity), 5.0, 1e-9);
}

TEST(ComputeMspd, MaximumIsAtNearestPoint) {
  // Points at depths 0.9, 1.0, 1.1 m; the shift is largest for the nearest one:
  // 500 * 0.01 / 0.9 px.
  const std::vector<Eigen::Vector3f> points = {
      {0.0f, 0.0f, -0.1f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.1f}};
  const Eigen::Isometry3d gt = Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, 1.0));
  Eigen::Isometry3d estimate = gt;
  estimate.translation().y() += 0.01;
  EXPECT_NEAR(ComputeMspd(estimate, gt, TestCamera(), points, {Eigen::Isometry3d::Identity()}),
              500.0 * 0.01 / 0.9, 1e-6);
}

TEST(ComputeMspd, SymmetricRotationIsZeroWithSymmetryList) {
  const auto points = CylinderPoints(0.04);
  const Eigen::Isometry3d rotated =
      kGt * Pose(RotationZ(50.0 * kDegToRad), Eigen::Vector3d::Zero());
  EXPECT_NEAR(ComputeMspd(rotated, kGt, TestCamera(), points, TenDegreeSymmetries()), 0.0, 1e-4);
  EXPECT_GT(ComputeMspd(rotated, kGt, TestCamera(), points, {Eigen::Isometry3d::Identity()}), 5.0);
}

TEST(ComputeMspd, EmptyInputsThrow) {
  EXPECT_THROW(ComputeMspd(kGt, kGt, TestCamera(), {}, {Eigen::Isometry3d::Identity()}), Error);
  EXPECT_THROW(ComputeMspd(kGt, kGt, TestCamera(), RandomPoints(3, 6), {}), Error);
}

}  // namespace
}  // namespace g6d
