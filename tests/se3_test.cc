#include "core/se3.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace g6d {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Random unit vector, fixed by the engine's state.
Eigen::Vector3d RandomAxis(std::mt19937_64* engine) {
  std::normal_distribution<double> normal(0.0, 1.0);
  return Eigen::Vector3d(normal(*engine), normal(*engine), normal(*engine)).normalized();
}

// Rotation vectors covering the whole open ball |phi| < pi, with extra weight on the
// delicate places: zero, tiny angles, and angles just below pi.
std::vector<Eigen::Vector3d> TestRotationVectors(uint64_t seed) {
  std::mt19937_64 engine(seed);
  std::uniform_real_distribution<double> angle(0.0, kPi);
  std::vector<Eigen::Vector3d> vectors = {Eigen::Vector3d::Zero()};
  for (double tiny : {1e-15, 1e-12, 1e-9, 1e-7, 1e-6, 2e-6, 1e-5, 1e-3, 0.1}) {
    vectors.push_back(tiny * RandomAxis(&engine));
  }
  for (double gap : {1e-2, 1e-4, 1e-6}) vectors.push_back((kPi - gap) * RandomAxis(&engine));
  for (int i = 0; i < 200; ++i) vectors.push_back(angle(engine) * RandomAxis(&engine));
  return vectors;
}

// Exponential of a 4x4 matrix by scaling and squaring of its Taylor series: an independent
// reference for the closed forms.
Eigen::Matrix4d MatrixExponential(const Eigen::Matrix4d& a) {
  int squarings = 0;
  double norm = a.norm();
  while (norm > 0.5) {
    norm *= 0.5;
    ++squarings;
  }
  const Eigen::Matrix4d scaled = a / std::pow(2.0, squarings);
  Eigen::Matrix4d result = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d term = Eigen::Matrix4d::Identity();
  for (int k = 1; k < 30; ++k) {
    term = term * scaled / k;
    result += term;
  }
  for (int i = 0; i < squarings; ++i) result = result * result;
  return result;
}

// The 4x4 twist matrix of xi = (rho, phi).
Eigen::Matrix4d Twist(const Vector6d& xi) {
  Eigen::Matrix4d twist = Eigen::Matrix4d::Zero();
  twist.topLeftCorner<3, 3>() = Hat(xi.tail<3>());
  twist.topRightCorner<3, 1>() = xi.head<3>();
  return twist;
}

// Random poses with |phi| < pi and translations up to a metre.
std::vector<Eigen::Isometry3d> TestPoses(uint64_t seed) {
  std::mt19937_64 engine(seed);
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0);
  std::vector<Eigen::Isometry3d> poses;
  for (const Eigen::Vector3d& phi : TestRotationVectors(seed)) {
    const Eigen::Vector3d translation(coordinate(engine), coordinate(engine), coordinate(engine));
    poses.push_back(MakePose(ExpSO3(phi), translation));
  }
  return poses;
}

double Distance(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.matrix() - b.matrix()).norm();
}

TEST(Hat, IsCrossProductAndSkew) {
  std::mt19937_64 engine(1);
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d v = RandomAxis(&engine) * 3.0;
    const Eigen::Vector3d w = RandomAxis(&engine);
    EXPECT_LT((Hat(v) * w - v.cross(w)).norm(), 1e-14);
    EXPECT_LT((Hat(v) + Hat(v).transpose()).norm(), 1e-15);
  }
}

TEST(ExpSO3, IsRotationAndMatchesAngleAxis) {
  for (const Eigen::Vector3d& phi : TestRotationVectors(2)) {
    const Eigen::Matrix3d rotation = ExpSO3(phi);
    EXPECT_LT((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm(), 1e-14);
    EXPECT_NEAR(rotation.determinant(), 1.0, 1e-14);
    // Rotates about its own axis by |phi|: reference from the matrix exponential.
    Vector6d xi = Vector6d::Zero();
    xi.tail<3>() = phi;
    EXPECT_LT((rotation - MatrixExponential(Twist(xi)).topLeftCorner<3, 3>()).norm(), 1e-13)
        << "phi " << phi.transpose();
  }
}

TEST(LogSO3, InvertsExpSO3) {
  for (const Eigen::Vector3d& phi : TestRotationVectors(3)) {
    const Eigen::Vector3d log = LogSO3(ExpSO3(phi));
    // Relative accuracy, also for tiny angles (exactly zero for phi = 0).
    EXPECT_LE((log - phi).norm(), 1e-10 * phi.norm()) << "phi " << phi.transpose();
    EXPECT_LE(log.norm(), kPi + 1e-12);
  }
}

TEST(LogSO3, NearPiGivesAngleNearPi) {
  std::mt19937_64 engine(4);
  for (double gap : {1e-3, 1e-5, 1e-7, 0.0}) {
    const Eigen::Vector3d axis = RandomAxis(&engine);
    const Eigen::Matrix3d rotation = ExpSO3((kPi - gap) * axis);
    const Eigen::Vector3d log = LogSO3(rotation);
    EXPECT_NEAR(log.norm(), kPi - gap, 1e-9) << "gap " << gap;
    // At pi, phi and -phi are the same rotation; either is a correct logarithm.
    EXPECT_LT((ExpSO3(log) - rotation).norm(), 1e-9) << "gap " << gap;
  }
}

TEST(ExpSE3, MatchesMatrixExponential) {
  std::mt19937_64 engine(5);
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0);
  for (const Eigen::Vector3d& phi : TestRotationVectors(5)) {
    Vector6d xi;
    xi << coordinate(engine), coordinate(engine), coordinate(engine), phi;
    const Eigen::Isometry3d pose = ExpSE3(xi);
    EXPECT_LT((pose.matrix() - MatrixExponential(Twist(xi))).norm(), 1e-12)
        << "xi " << xi.transpose();
  }
}

TEST(ExpSE3, PureTranslation) {
  Vector6d xi;
  xi << 0.1, -0.2, 0.3, 0.0, 0.0, 0.0;
  const Eigen::Isometry3d pose = ExpSE3(xi);
  EXPECT_TRUE(pose.linear().isIdentity(0.0));
  EXPECT_TRUE(pose.translation().isApprox(Eigen::Vector3d(0.1, -0.2, 0.3)));
}

TEST(ExpSE3, ActsByLeftMultiplication) {
  // d/dt Exp(t xi) * p at t = 0 is phi x p + rho: the perturbation acts in the target frame.
  Vector6d xi;
  xi << 0.3, -0.1, 0.2, 0.5, -0.4, 0.7;
  const Eigen::Vector3d point(0.2, 0.4, -0.6);
  const double step = 1e-6;
  const Eigen::Vector3d numeric =
      ((ExpSE3(step * xi) * point) - (ExpSE3(-step * xi) * point)) / (2 * step);
  const Eigen::Vector3d analytic = xi.tail<3>().cross(point) + xi.head<3>();
  EXPECT_LT((numeric - analytic).norm(), 1e-8);
}

TEST(LogSE3, InvertsExpSE3) {
  std::mt19937_64 engine(6);
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0);
  for (const Eigen::Vector3d& phi : TestRotationVectors(6)) {
    Vector6d xi;
    xi << coordinate(engine), coordinate(engine), coordinate(engine), phi;
    const Vector6d log = LogSE3(ExpSE3(xi));
    EXPECT_LT((log - xi).norm(), 1e-10) << "xi " << xi.transpose();
  }
}

TEST(LogSE3, TinyMotionKeepsRelativeAccuracy) {
  std::mt19937_64 engine(7);
  for (double size : {1e-12, 1e-9, 1e-6, 2e-6, 1e-5, 1e-4}) {
    Vector6d xi;
    xi << size * RandomAxis(&engine), size * RandomAxis(&engine);
    const Vector6d log = LogSE3(ExpSE3(xi));
    EXPECT_LT((log - xi).norm(), 1e-9 * xi.norm()) << "size " << size;
  }
}

TEST(ExpSE3, InvertsLogSE3) {
  for (const Eigen::Isometry3d& pose : TestPoses(8)) {
    EXPECT_LT(Distance(ExpSE3(LogSE3(pose)), pose), 1e-10);
  }
}

TEST(Orthonormalize, KeepsRotationsAndFixesNoise) {
  std::mt19937_64 engine(9);
  std::normal_distribution<double> noise(0.0, 1e-3);
  for (const Eigen::Vector3d& phi : TestRotationVectors(9)) {
    const Eigen::Matrix3d rotation = ExpSO3(phi);
    EXPECT_LT((Orthonormalize(rotation) - rotation).norm(), 1e-12);
    Eigen::Matrix3d noisy = rotation;
    for (int i = 0; i < 9; ++i) noisy.data()[i] += noise(engine);
    const Eigen::Matrix3d fixed = Orthonormalize(noisy);
    EXPECT_LT((fixed.transpose() * fixed - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_NEAR(fixed.determinant(), 1.0, 1e-12);
    EXPECT_LT(RotationErrorDeg(fixed, rotation), 0.5);
  }
}

TEST(Orthonormalize, ReflectionBecomesRotation) {
  Eigen::Matrix3d reflection = Eigen::Matrix3d::Identity();
  reflection(2, 2) = -1.0;
  const Eigen::Matrix3d fixed = Orthonormalize(reflection * ExpSO3(Eigen::Vector3d(0.1, 0.2, 0.3)));
  EXPECT_NEAR(fixed.determinant(), 1.0, 1e-12);
  EXPECT_LT((fixed.transpose() * fixed - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(RotationErrorDeg, EqualsRotationAngle) {
  std::mt19937_64 engine(10);
  const Eigen::Matrix3d base = ExpSO3(Eigen::Vector3d(0.4, -1.1, 0.3));
  for (double angle_rad : {0.0, 1e-8, 1e-6, 1e-3, 0.5, 2.0, kPi - 1e-4}) {
    const Eigen::Matrix3d other = base * ExpSO3(angle_rad * RandomAxis(&engine));
    const double expected_deg = angle_rad * 180.0 / kPi;
    EXPECT_NEAR(RotationErrorDeg(base, other), expected_deg, 1e-6 * expected_deg + 1e-12)
        << "angle " << angle_rad;
    EXPECT_NEAR(RotationErrorDeg(other, base), expected_deg, 1e-6 * expected_deg + 1e-12);
  }
  EXPECT_NEAR(RotationErrorDeg(base, base * ExpSO3(Eigen::Vector3d(0, 0, kPi))), 180.0, 1e-9);
}

TEST(TranslationError, IsEuclideanDistance) {
  const Eigen::Isometry3d a = MakePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 2, 3));
  const Eigen::Isometry3d b =
      MakePose(ExpSO3(Eigen::Vector3d(0.3, 0, 0)), Eigen::Vector3d(1, 6, 0));
  EXPECT_DOUBLE_EQ(TranslationError(a, b), 5.0);
}

TEST(MakePose, HoldsRotationAndTranslation) {
  const Eigen::Matrix3d rotation = ExpSO3(Eigen::Vector3d(0.1, 0.2, -0.3));
  const Eigen::Vector3d translation(0.5, -0.25, 2.0);
  const Eigen::Isometry3d pose = MakePose(rotation, translation);
  EXPECT_EQ(pose.linear(), rotation);
  EXPECT_EQ(pose.translation(), translation);
  const Eigen::Vector3d point(1.0, 2.0, 3.0);
  EXPECT_LT((pose * point - (rotation * point + translation)).norm(), 1e-15);
}

TEST(LookAt, CanonicalCameraIsIdentity) {
  // Camera at z = -1 looking at the origin with up = -y: the OpenCV camera frame itself.
  const Eigen::Isometry3d cam_from_object =
      LookAt(Eigen::Vector3d(0, 0, -1), Eigen::Vector3d::Zero(), Eigen::Vector3d(0, -1, 0));
  EXPECT_LT((cam_from_object.linear() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_LT((cam_from_object.translation() - Eigen::Vector3d(0, 0, 1)).norm(), 1e-12);
}

TEST(LookAt, TargetOnOpticalAxisInFrontAndUpIsImageUp) {
  std::mt19937_64 engine(11);
  std::uniform_real_distribution<double> coordinate(-2.0, 2.0);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d eye(coordinate(engine), coordinate(engine), coordinate(engine));
    const Eigen::Vector3d target(coordinate(engine), coordinate(engine), coordinate(engine));
    const Eigen::Vector3d up = RandomAxis(&engine);
    const Eigen::Isometry3d cam_from_object = LookAt(eye, target, up);
    const Eigen::Matrix3d rotation = cam_from_object.linear();
    EXPECT_LT((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_NEAR(rotation.determinant(), 1.0, 1e-12);
    // The eye is the camera centre; the target lies on +z at its distance.
    EXPECT_LT((cam_from_object * eye).norm(), 1e-12);
    const Eigen::Vector3d target_in_cam = cam_from_object * target;
    EXPECT_LT(target_in_cam.head<2>().norm(), 1e-12);
    EXPECT_NEAR(target_in_cam.z(), (target - eye).norm(), 1e-12);
    // `up` in the camera frame: no x component, negative y (image y points down).
    const Eigen::Vector3d up_in_cam = rotation * up;
    EXPECT_NEAR(up_in_cam.x(), 0.0, 1e-12) << "case " << i;
    EXPECT_LT(up_in_cam.y(), 0.0) << "case " << i;
  }
}

TEST(LookAt, LookingAlongUpStillValid) {
  const Eigen::Vector3d eye(0, 0, 2);
  const Eigen::Isometry3d cam_from_object =
      LookAt(eye, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 1));
  const Eigen::Matrix3d rotation = cam_from_object.linear();
  EXPECT_LT((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(rotation.determinant(), 1.0, 1e-12);
  EXPECT_LT((cam_from_object * Eigen::Vector3d::Zero() - Eigen::Vector3d(0, 0, 2)).norm(), 1e-12);
}

}  // namespace
}  // namespace g6d
