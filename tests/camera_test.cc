#include "core/camera.h"

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_meshes.h"


namespace g6d {
namespace {

using ::testing::HasSubstr;
using ::testing::IsEmpty;

// A VGA camera like the LM-O Kinect.
Camera MakeCamera() { return test::LmoCamera(); }

// Random points in front of the camera, roughly inside its view, fixed seed.
std::vector<Eigen::Vector3d> RandomPointsInCam(int count, uint64_t seed) {
  std::mt19937_64 engine(seed);
  std::uniform_real_distribution<double> lateral(-0.3, 0.3);
  std::uniform_real_distribution<double> depth(0.3, 2.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i)
    points.emplace_back(lateral(engine), lateral(engine), depth(engine));
  return points;
}

TEST(CameraCheck, ValidCameraIsEmpty) { EXPECT_THAT(MakeCamera().Check(), IsEmpty()); }

TEST(CameraCheck, NamesTheBadField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const char* field;
    std::function<void(Camera*)> spoil;
  };
  const std::vector<Case> cases = {
      {"fx", [](Camera* c) { c->fx = 0.0; }},
      {"fx", [&](Camera* c) { c->fx = nan; }},
      {"fx", [](Camera* c) { c->fx = -500.0; }},
      {"fy", [&](Camera* c) { c->fy = inf; }},
      {"fy", [](Camera* c) { c->fy = 0.0; }},
      {"cx", [&](Camera* c) { c->cx = nan; }},
      {"cy", [&](Camera* c) { c->cy = -inf; }},
      {"width", [](Camera* c) { c->width = 0; }},
      {"width", [](Camera* c) { c->width = (1 << 15) + 1; }},
      {"height", [](Camera* c) { c->height = -3; }},
  };
  for (const Case& test_case : cases) {
    Camera camera = MakeCamera();
    test_case.spoil(&camera);
    const std::string message = camera.Check();
    EXPECT_THAT(message, HasSubstr(test_case.field)) << "message: " << message;
  }
}

TEST(CameraCheck, AcceptsLargestSize) {
  Camera camera = MakeCamera();
  camera.width = 1 << 15;
  camera.height = 1 << 15;
  EXPECT_THAT(camera.Check(), IsEmpty());
}

TEST(CameraK, HoldsIntrinsics) {
  const Camera camera = MakeCamera();
  const Eigen::Matrix3d k = camera.K();
  EXPECT_EQ(k(0, 0), camera.fx);
  EXPECT_EQ(k(1, 1), camera.fy);
  EXPECT_EQ(k(0, 2), camera.cx);
  EXPECT_EQ(k(1, 2), camera.cy);
  EXPECT_EQ(k(2, 2), 1.0);
  EXPECT_EQ(k(0, 1), 0.0);
  EXPECT_EQ(k(1, 0), 0.0);
  // Project is K applied to the point, then divided by z.
  const Eigen::Vector3d point_in_cam(0.1, -0.05, 0.8);
  const Eigen::Vector3d homogeneous = k * point_in_cam;
  EXPECT_TRUE(camera.Project(point_in_cam).isApprox(homogeneous.hnormalized(), 1e-12));
}

TEST(CameraProject, PrincipalPointOnOpticalAxis) {
  const Camera camera = MakeCamera();
  const Eigen::Vector2d uv = camera.Project(Eigen::Vector3d(0.0, 0.0, 1.5));
  EXPECT_DOUBLE_EQ(uv.x(), camera.cx);
  EXPECT_DOUBLE_EQ(uv.y(), camera.cy);
}

TEST(CameraBackproject, InvertsProject) {
  const Camera camera = MakeCamera();
  for (const Eigen::Vector3d& point_in_cam : RandomPointsInCam(200, 1)) {
    const Eigen::Vector2d uv = camera.Project(point_in_cam);
    const Eigen::Vector3d back = camera.Backproject(uv, point_in_cam.z());
    EXPECT_LT((back - point_in_cam).norm(), 1e-12);
    // Project after Backproject gives the pixel back.
    EXPECT_LT((camera.Project(camera.Backproject(uv, 0.7)) - uv).norm(), 1e-9);
    // The ray through uv holds the point.
    EXPECT_LT((camera.Ray(uv) * point_in_cam.z() - point_in_cam).norm(), 1e-12);
    EXPECT_DOUBLE_EQ(camera.Ray(uv).z(), 1.0);
  }
}

TEST(CameraCropped, ProjectEqualsShiftedProjection) {
  const Camera camera = MakeCamera();
  const int x0 = 100, y0 = 37, w = 211, h = 150;
  const Camera cropped = camera.Cropped(x0, y0, w, h);
  EXPECT_EQ(cropped.width, w);
  EXPECT_EQ(cropped.height, h);
  EXPECT_THAT(cropped.Check(), IsEmpty());
  for (const Eigen::Vector3d& point_in_cam : RandomPointsInCam(200, 2)) {
    const Eigen::Vector2d expected = camera.Project(point_in_cam) - Eigen::Vector2d(x0, y0);
    EXPECT_LT((cropped.Project(point_in_cam) - expected).norm(), 1e-9);
  }
  // Pixel (x0, y0) of the full image is pixel (0, 0) of the crop: same ray.
  EXPECT_LT((cropped.Ray(PixelCentre(0, 0)) - camera.Ray(PixelCentre(x0, y0))).norm(), 1e-12);
}

TEST(CameraScaled, ProjectEqualsScaledProjection) {
  const Camera camera = MakeCamera();
  for (double scale : {0.5, 0.25, 2.0, 1.0 / 3.0}) {
    const Camera scaled = camera.Scaled(scale);
    EXPECT_EQ(scaled.width, static_cast<int>(std::lround(camera.width * scale)));
    EXPECT_EQ(scaled.height, static_cast<int>(std::lround(camera.height * scale)));
    for (const Eigen::Vector3d& point_in_cam : RandomPointsInCam(100, 3)) {
      const Eigen::Vector2d expected = camera.Project(point_in_cam) * scale;
      EXPECT_LT((scaled.Project(point_in_cam) - expected).norm(), 1e-9) << "scale " << scale;
    }
  }
  // The image corners stay the image corners (the pixel-corner convention).
  const Camera half = camera.Scaled(0.5);
  const Eigen::Vector3d corner_ray = camera.Ray(Eigen::Vector2d(640.0, 480.0));
  EXPECT_LT((half.Project(corner_ray) - Eigen::Vector2d(320.0, 240.0)).norm(), 1e-9);
}

TEST(CameraScaled, CropThenScaleComposes) {
  // Cropping a box and resizing it to S x S, as the template crops do.
  const Camera camera = MakeCamera();
  const int x0 = 200, y0 = 120, side = 180, target = 128;
  const double scale = double(target) / side;
  const Camera crop = camera.Cropped(x0, y0, side, side).Scaled(scale);
  EXPECT_EQ(crop.width, target);
  EXPECT_EQ(crop.height, target);
  for (const Eigen::Vector3d& point_in_cam : RandomPointsInCam(100, 4)) {
    const Eigen::Vector2d expected =
        (camera.Project(point_in_cam) - Eigen::Vector2d(x0, y0)) * scale;
    EXPECT_LT((crop.Project(point_in_cam) - expected).norm(), 1e-9);
  }
}

TEST(PixelCentre, IsHalfPixelOffset) {
  EXPECT_EQ(PixelCentre(0, 0), Eigen::Vector2d(0.5, 0.5));
  EXPECT_EQ(PixelCentre(3, 7), Eigen::Vector2d(3.5, 7.5));
  EXPECT_EQ(kOpenCvToImage, 0.5);
}

}  // namespace
}  // namespace g6d
