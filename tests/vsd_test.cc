#include "eval/vsd.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/error.h"
#include "render/raster.h"
#include "test_meshes.h"

namespace g6d {
namespace {

// A 10x10 camera with f = 100 px and the principal point on pixel (5, 5).
Camera TinyCamera() { return Camera{100.0, 100.0, 5.0, 5.0, 10, 10}; }

// A CV_32F depth image of the tiny camera with `depth_m` in columns [first, last].
cv::Mat Columns(int first, int last, float depth_m) {
  cv::Mat depth(10, 10, CV_32F, cv::Scalar(0));
  depth.colRange(first, last + 1).setTo(depth_m);
  return depth;
}

Eigen::Isometry3d Translation(double x, double y, double z) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(x, y, z);
  return pose;
}

TEST(BopVsdTaus, AreNumpyArange) {
  const std::vector<double> taus = BopVsdTaus();
  ASSERT_EQ(taus.size(), 10u);
  EXPECT_EQ(taus.front(), 0.05);
  for (size_t i = 0; i < taus.size(); ++i) EXPECT_NEAR(taus[i], 0.05 * (i + 1), 1e-15);
  // np.arange(0.05, 0.51, 0.05)[2] is 0.15000000000000002, not 0.15.
  EXPECT_EQ(taus[2], 0.05 + 2 * 0.05);
}

TEST(VsdOptions, CheckNamesTheBadField) {
  VsdOptions options;
  EXPECT_EQ(options.Check(), "");
  options.delta_m = -1.0;
  EXPECT_NE(options.Check().find("delta_m"), std::string::npos);
  options = VsdOptions();
  options.taus = {0.1, 0.0};
  EXPECT_NE(options.Check().find("taus[1]"), std::string::npos);
}

TEST(DepthToDistance, ScalesByTheRayLengthAtIntegerPixels) {
  const Camera camera = TinyCamera();
  const cv::Mat depth(10, 10, CV_32F, cv::Scalar(2.0f));
  const cv::Mat distance = DepthToDistance(depth, camera);
  // On the principal point the ray is the optical axis.
  EXPECT_FLOAT_EQ(distance.at<float>(5, 5), 2.0f);
  // bop_toolkit uses (u - cx) / fx with the integer index u: (9 - 5) / 100 = 0.04.
  EXPECT_FLOAT_EQ(distance.at<float>(5, 9), static_cast<float>(2.0 * std::sqrt(1.0 + 0.04 * 0.04)));
  EXPECT_FLOAT_EQ(distance.at<float>(0, 0),
                  static_cast<float>(2.0 * std::sqrt(1.0 + 0.05 * 0.05 + 0.05 * 0.05)));
  EXPECT_THROW(DepthToDistance(cv::Mat(3, 3, CV_64F), camera), Error);
}

// Occluder, missing depth and a shifted estimate on the tiny camera (delta = 15 mm):
//   GT at 1 m in columns 0..5, estimate at 1 m in columns 2..7;
//   test depth 1 m, except column 0 (an occluder at 0.5 m) and column 7 (no measurement).
// V_gt = columns 1..5 (column 0 is occluded): 50 px.
// V_est = columns 2..7 (column 7 counts as visible, BOP'19 rule for missing depth): 60 px.
// Intersection columns 2..5 (40 px, distance 0), union columns 1..7 (70 px):
// e = (0 + 70 - 40) / 70 = 3/7 for every tau.
TEST(ComputeVsdFromDepth, OcclusionAndMissingDepthByHand) {
  const Camera camera = TinyCamera();
  const cv::Mat gt = Columns(0, 5, 1.0f);
  const cv::Mat estimate = Columns(2, 7, 1.0f);
  cv::Mat test(10, 10, CV_32F, cv::Scalar(1.0f));
  test.col(0).setTo(0.5f);
  test.col(7).setTo(0.0f);
  const std::vector<double> errors =
      ComputeVsdFromDepth(estimate, gt, test, camera, 0.25, VsdOptions());
  ASSERT_EQ(errors.size(), 10u);
  for (double e : errors) EXPECT_NEAR(e, 3.0 / 7.0, 1e-12);

  // The same masks from the separate visibility functions.
  const cv::Mat test_distance = DepthToDistance(test, camera);
  const cv::Mat visib_gt =
      EstimateVisibilityMaskGt(test_distance, DepthToDistance(gt, camera), 0.015);
  const cv::Mat visib_estimate = EstimateVisibilityMaskEstimate(
      test_distance, DepthToDistance(estimate, camera), visib_gt, 0.015);
  EXPECT_EQ(cv::countNonZero(visib_gt), 50);
  EXPECT_EQ(cv::countNonZero(visib_gt.col(0)), 0);
  EXPECT_EQ(cv::countNonZero(visib_estimate), 60);
  EXPECT_EQ(cv::countNonZero(visib_estimate.col(7)), 10);
}

// As above but the estimate is 2 cm behind the GT (1.02 m): in columns 2..5 it is more
// than delta behind the measured surface, yet visible because the GT is visible there
// (visib_est includes visib_gt ∩ est > 0); column 6 becomes invisible, column 7 (no
// depth) stays visible. V_est = columns 2..5 and 7 (50 px), union = columns 1..5 and 7
// (60 px), intersection 40 px with distance 0.02 m = 0.08 d (d = 0.25 m; the ray factor is
// below 1.002 here). tau = 0.05: every intersection pixel costs 1, e = (40 + 20) / 60 = 1;
// tau >= 0.1: e = 20 / 60 = 1/3.
TEST(ComputeVsdFromDepth, EstimateBehindTheGtByHand) {
  const Camera camera = TinyCamera();
  const cv::Mat gt = Columns(0, 5, 1.0f);
  const cv::Mat estimate = Columns(2, 7, 1.02f);
  cv::Mat test(10, 10, CV_32F, cv::Scalar(1.0f));
  test.col(0).setTo(0.5f);
  test.col(7).setTo(0.0f);
  const std::vector<double> errors =
      ComputeVsdFromDepth(estimate, gt, test, camera, 0.25, VsdOptions());
  ASSERT_EQ(errors.size(), 10u);
  EXPECT_NEAR(errors[0], 1.0, 1e-12);
  for (size_t k = 1; k < errors.size(); ++k) EXPECT_NEAR(errors[k], 1.0 / 3.0, 1e-12) << k;
}

TEST(ComputeVsdFromDepth, NothingVisibleIsErrorOne) {
  const Camera camera = TinyCamera();
  const cv::Mat empty(10, 10, CV_32F, cv::Scalar(0));
  for (double e : ComputeVsdFromDepth(empty, empty, empty, camera, 0.1, VsdOptions())) {
    EXPECT_EQ(e, 1.0);
  }
}

TEST(ComputeVsdFromDepth, RejectsBadInput) {
  const Camera camera = TinyCamera();
  const cv::Mat depth(10, 10, CV_32F, cv::Scalar(1.0f));
  EXPECT_THROW(ComputeVsdFromDepth(depth, depth, cv::Mat(5, 5, CV_32F), camera, 0.1, VsdOptions()),
               Error);
  EXPECT_THROW(ComputeVsdFromDepth(depth, depth, depth, camera, 0.0, VsdOptions()), Error);
  VsdOptions bad;
  bad.taus.clear();
  EXPECT_THROW(ComputeVsdFromDepth(depth, depth, depth, camera, 0.1, bad), Error);
}

// A 10 cm cube on the optical axis, front face at 0.5 m, seen by a camera with f = 500 px
// and the principal point on a pixel corner (320, 240): the front face covers pixel
// centres in [270, 370) x [190, 290), 100 x 100 px; the sides hide behind it. The test
// depth is the GT rendering (perfect sensor). The estimate is pushed back by 5.5 cm along
// the optical axis: its front face (at 0.555 m) covers [274.955, 365.045)^2 around the
// centre, 90 x 90 px, all inside the GT silhouette. It is 5.5 cm behind the measured
// surface (> delta) but counts as visible because the GT is visible there.
// V_gt = 10000 px, V_est = 8100 px = intersection, union = 10000 px; pixel distances
// 0.055 m * ray factor (1 .. 1.00995) / diameter 0.2 m = 0.275 .. 0.2778.
// tau <= 0.25: e = (8100 + 1900) / 10000 = 1; tau >= 0.3: e = 1900 / 10000 = 0.19.
TEST(ComputeVsd, CubePushedBackByHand) {
  const Camera camera{500.0, 500.0, 320.0, 240.0, 640, 480};
  const Mesh cube = test::MakeCube(0.05);
  const Eigen::Isometry3d gt = Translation(0.0, 0.0, 0.55);
  const Eigen::Isometry3d estimate = Translation(0.0, 0.0, 0.605);
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  RasterImage gt_render;
  Rasterize(cube, camera, gt, raster_options, &gt_render);
  ASSERT_EQ(gt_render.pixel_count, 10000);
  const std::vector<double> errors =
      ComputeVsd(estimate, gt, gt_render.depth, camera, cube, 0.2, VsdOptions());
  ASSERT_EQ(errors.size(), 10u);
  for (size_t k = 0; k < 5; ++k) EXPECT_NEAR(errors[k], 1.0, 1e-12) << "tau " << k;
  for (size_t k = 5; k < 10; ++k) EXPECT_NEAR(errors[k], 0.19, 1e-12) << "tau " << k;

  // The GT against itself is perfect for every tau, also with the background measured
  // 1 m away.
  cv::Mat test = gt_render.depth.clone();
  test.setTo(1.0f, test == 0.0f);
  for (double e : ComputeVsd(gt, gt, test, camera, cube, 0.2, VsdOptions())) EXPECT_EQ(e, 0.0);
}

// A cube fully hidden behind a wall at 0.3 m (measured everywhere): neither pose has a
// visible pixel, the union is empty and pose_error.vsd returns 1 for every tau, even for
// the GT pose itself.
TEST(ComputeVsd, FullyOccludedIsErrorOne) {
  const Camera camera{500.0, 500.0, 320.0, 240.0, 640, 480};
  const Mesh cube = test::MakeCube(0.05);
  const cv::Mat wall(480, 640, CV_32F, cv::Scalar(0.3f));
  const Eigen::Isometry3d gt = Translation(0.0, 0.0, 0.55);
  for (double e : ComputeVsd(gt, gt, wall, camera, cube, 0.2, VsdOptions())) EXPECT_EQ(e, 1.0);
}

TEST(SphereProjectionsOverlap, NormalizedImageDistance) {
  // Centres 0.1 m apart sideways at 1 m, radius 0.06: 0.1 < 0.06 * 2.
  EXPECT_TRUE(SphereProjectionsOverlap(0.06, {0.0, 0.0, 1.0}, {0.1, 0.0, 1.0}));
  // Radius 0.04: 0.1 >= 0.08.
  EXPECT_FALSE(SphereProjectionsOverlap(0.04, {0.0, 0.0, 1.0}, {0.1, 0.0, 1.0}));
  // Same line of sight at different depths always overlaps.
  EXPECT_TRUE(SphereProjectionsOverlap(0.01, {0.1, 0.0, 1.0}, {0.2, 0.0, 2.0}));
  EXPECT_FALSE(SphereProjectionsOverlap(1.0, {0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}));
}

}  // namespace
}  // namespace g6d
