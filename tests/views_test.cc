#include "templates/views.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/se3.h"

namespace g6d {
namespace {

Camera TemplateCamera() {
  Camera camera;
  camera.fx = camera.fy = 400.0;
  camera.cx = camera.cy = 160.0;
  camera.width = camera.height = 320;
  return camera;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

// Unit direction from the object centre to the camera centre, object frame.
Eigen::Vector3d ViewDirection(const Eigen::Isometry3d& cam_from_object,
                              const Eigen::Vector3d& centre) {
  const Eigen::Vector3d eye = cam_from_object.inverse().translation();
  return (eye - centre).normalized();
}

TEST(SampleTemplateViews, CountAndDeterminism) {
  const ViewSamplingOptions options;  // 108 x 3
  const Eigen::Vector3d centre(0.01, -0.02, 0.03);
  const auto a = SampleTemplateViews(options, TemplateCamera(), 0.1, centre);
  const auto b = SampleTemplateViews(options, TemplateCamera(), 0.1, centre);
  ASSERT_EQ(a.size(), 324u);
  ASSERT_EQ(options.NumViews(), 324);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].matrix(), b[i].matrix()) << "view " << i;
    // Proper rotations.
    EXPECT_NEAR(a[i].linear().determinant(), 1.0, 1e-12);
    EXPECT_LT((a[i].linear().transpose() * a[i].linear() - Eigen::Matrix3d::Identity()).norm(),
              1e-12);
  }
}

TEST(SampleTemplateViews, DirectionsRoughlyUniform) {
  ViewSamplingOptions options;
  options.num_inplane = 1;
  const Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  const auto views = SampleTemplateViews(options, TemplateCamera(), 0.1, centre);
  std::vector<Eigen::Vector3d> directions;
  for (const auto& view : views) directions.push_back(ViewDirection(view, centre));

  // 108 points on the sphere: the mean spacing is about sqrt(4 pi / 108) = 19.5 deg.
  double min_pair_deg = 180.0;
  double max_nearest_deg = 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < directions.size(); ++i) {
    double nearest = 180.0;
    for (size_t j = 0; j < directions.size(); ++j) {
      if (i != j) nearest = std::min(nearest, AngleDeg(directions[i], directions[j]));
    }
    min_pair_deg = std::min(min_pair_deg, nearest);
    max_nearest_deg = std::max(max_nearest_deg, nearest);
    mean += directions[i];
  }
  EXPECT_GT(min_pair_deg, 12.0);
  EXPECT_LT(max_nearest_deg, 26.0);
  EXPECT_LT((mean / directions.size()).norm(), 0.02);  // balanced over the sphere
}

TEST(SampleTemplateViews, InPlaneRotationsShareTheViewpoint) {
  const ViewSamplingOptions options;  // 3 in-plane
  const Eigen::Vector3d centre(0.0, 0.0, 0.02);
  const auto views = SampleTemplateViews(options, TemplateCamera(), 0.1, centre);
  for (int d = 0; d < options.num_directions; ++d) {
    const Eigen::Isometry3d& first = views[3 * d];
    for (int r = 1; r < 3; ++r) {
      const Eigen::Isometry3d& other = views[3 * d + r];
      EXPECT_LT((first.inverse().translation() - other.inverse().translation()).norm(), 1e-12);
      EXPECT_NEAR(RotationErrorDeg(first.linear(), other.linear()), 120.0, 1e-9);
    }
  }
}

TEST(SampleTemplateViews, CentreOnAxisAndSphereFillsFraction) {
  ViewSamplingOptions options;
  options.num_directions = 20;
  options.fill_fraction = 0.8;
  const Camera camera = TemplateCamera();
  const double diameter = 0.15;
  const Eigen::Vector3d centre(0.02, 0.01, -0.03);
  const auto views = SampleTemplateViews(options, camera, diameter, centre);

  // Dense points on the sphere of the diameter around the centre.
  std::vector<Eigen::Vector3d> sphere;
  const int n = 4000;
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / n;
    const double ring = std::sqrt(1.0 - z * z);
    const double azimuth = k * M_PI * (3.0 - std::sqrt(5.0));
    sphere.push_back(centre +
                     0.5 * diameter *
                         Eigen::Vector3d(ring * std::cos(azimuth), ring * std::sin(azimuth), z));
  }
  for (const auto& view : views) {
    const Eigen::Vector3d centre_in_cam = view * centre;
    EXPECT_NEAR(centre_in_cam.x(), 0.0, 1e-12);
    EXPECT_NEAR(centre_in_cam.y(), 0.0, 1e-12);
    EXPECT_GT(centre_in_cam.z(), diameter);
    double max_radius_px = 0.0;
    for (const auto& point : sphere) {
      const Eigen::Vector2d uv = camera.Project(view * point);
      max_radius_px = std::max(max_radius_px, (uv - Eigen::Vector2d(camera.cx, camera.cy)).norm());
    }
    // The silhouette of the sphere spans fill_fraction of the side (sampling error < 1 px).
    EXPECT_NEAR(2.0 * max_radius_px, options.fill_fraction * camera.width, 1.5);
    EXPECT_LE(2.0 * max_radius_px, options.fill_fraction * camera.width + 1e-9);
  }
}

TEST(SampleTemplateViews, BadArgumentsThrow) {
  ViewSamplingOptions options;
  options.num_directions = 0;
  EXPECT_NE(options.Check().find("num_directions"), std::string::npos);
  EXPECT_THROW(SampleTemplateViews(options, TemplateCamera(), 0.1, Eigen::Vector3d::Zero()), Error);
  options = ViewSamplingOptions();
  options.fill_fraction = 1.5;
  EXPECT_NE(options.Check().find("fill_fraction"), std::string::npos);
  EXPECT_THROW(
      SampleTemplateViews(ViewSamplingOptions(), TemplateCamera(), 0.0, Eigen::Vector3d::Zero()),
      Error);
  EXPECT_THROW(SampleTemplateViews(ViewSamplingOptions(), Camera(), 0.1, Eigen::Vector3d::Zero()),
               Error);
}

}  // namespace
}  // namespace g6d
