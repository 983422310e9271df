// The mask as evidence: leaks removed by the depth (support plane, far and near), the
// caller's word kept where the depth cannot judge, and the options' checks.
#include "solver/region.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "solver/mask_stage.h"

namespace g6d {
namespace {

constexpr int kWidth = 320, kHeight = 240;
const Camera kCamera{300.0, 300.0, 160.0, 120.0, kWidth, kHeight};

// Depth of a table: the plane y = 0.10 m below the optical centre, tilted so that it
// recedes upwards in the image (a camera looking down at about 30 degrees).
cv::Mat TableDepth() {
  const Eigen::Vector3d normal = Eigen::Vector3d(0.0, -std::cos(0.5), -std::sin(0.5)).normalized();
  const double offset = 0.55;  // n · p + offset = 0
  cv::Mat depth(kHeight, kWidth, CV_32F, cv::Scalar(0.0f));
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const Eigen::Vector3d ray = kCamera.Ray(PixelCentre(u, v));
      const double t = -offset / normal.dot(ray);
      if (t > 0.0 && t < 3.0) depth.at<float>(v, u) = static_cast<float>(t * ray.z());
    }
  }
  return depth;
}

// An object: a box face facing the camera, 5 cm in front of the nearest table point it
// covers.
cv::Rect ObjectBox() { return cv::Rect(130, 90, 60, 50); }

cv::Mat SceneDepth() {
  cv::Mat depth = TableDepth();
  double nearest = 0.0;
  cv::minMaxLoc(depth(ObjectBox()), &nearest);
  depth(ObjectBox()).setTo(nearest - 0.05);
  return depth;
}

int Count(const cv::Mat& mask) { return cv::countNonZero(mask); }

TEST(ComputeObservedRegion, RemovesALeakOntoTheTable) {
  const cv::Mat depth = SceneDepth();
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  const cv::Rect leaky(ObjectBox().x - 6, ObjectBox().y - 6, ObjectBox().width + 12, ObjectBox().height + 12);
  mask(leaky).setTo(255);
  const ObservedRegion region = ComputeObservedRegion(kCamera, mask, depth, 0.12, RegionOptions());
  ASSERT_TRUE(region.has_plane);
  EXPECT_EQ(region.given_pixels, leaky.area());
  // Every leaked pixel lies on the table; the face lies 8 cm above it.
  EXPECT_EQ(region.support_leak, leaky.area() - ObjectBox().area());
  EXPECT_EQ(Count(region.mask), ObjectBox().area());
  EXPECT_EQ(Count(region.mask(ObjectBox())), ObjectBox().area());
  // The plane normal points to the camera and the object is on the camera side.
  EXPECT_GT(region.plane_offset_m, 0.0);
  EXPECT_GT(region.plane_normal.dot(kCamera.Backproject(PixelCentre(160, 115), depth.at<float>(115, 160))) +
                region.plane_offset_m,
            0.02);
  // Tolerance: 3 sigma of 1.5 mm z^2 at the face's depth plus 3 % of the diameter.
  EXPECT_GT(region.surface_tolerance_m, 0.03 * 0.12);
  EXPECT_LT(region.surface_tolerance_m, 0.03 * 0.12 + 0.02);
}

TEST(ComputeObservedRegion, RemovesBackgroundFarBehindAndAnOccluderInFront) {
  // No table: a wall 1 m behind the object, and an occluder 0.4 m in front of it.
  cv::Mat depth(kHeight, kWidth, CV_32F, cv::Scalar(2.0f));
  depth(ObjectBox()).setTo(1.0f);
  const cv::Rect occluder(ObjectBox().x, ObjectBox().y, 10, ObjectBox().height);
  depth(occluder).setTo(0.6f);
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  const cv::Rect leaky(ObjectBox().x - 5, ObjectBox().y, ObjectBox().width + 5, ObjectBox().height);
  mask(leaky).setTo(255);
  const ObservedRegion region = ComputeObservedRegion(kCamera, mask, depth, 0.15, RegionOptions());
  // The wall is a plane the object stands in front of: background, as a table would be.
  EXPECT_TRUE(region.has_plane);
  EXPECT_EQ(region.support_leak, 5 * ObjectBox().height);
  EXPECT_EQ(region.far_leak, occluder.area());
  EXPECT_EQ(Count(region.mask), ObjectBox().area() - occluder.area());
}

TEST(ComputeObservedRegion, KeepsTheMaskWhereTheDepthCannotJudge) {
  // Depth only on the object (as in LM-O's rendered depth): nothing to fit, nothing far.
  cv::Mat depth = cv::Mat::zeros(kHeight, kWidth, CV_32F);
  depth(ObjectBox()).setTo(0.9f);
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  mask(cv::Rect(120, 80, 80, 70)).setTo(255);  // leaks onto pixels without depth
  const ObservedRegion region = ComputeObservedRegion(kCamera, mask, depth, 0.12, RegionOptions());
  EXPECT_FALSE(region.has_plane);
  EXPECT_TRUE(region.support.empty());
  EXPECT_EQ(region.support_leak + region.far_leak, 0);
  EXPECT_EQ(Count(region.mask), Count(mask));
}

TEST(ComputeObservedRegion, DepthlessPixelsAreUnsureOnlyWhereTheyContinueIntoAWideUnseenArea) {
  // The object's face has a hole without depth (bare metal reflecting the pattern away)
  // that reaches its edge; around the face the sensor loses a 2 px band, and beyond it sees
  // the table.
  cv::Mat depth = SceneDepth();
  const cv::Rect face = ObjectBox();
  const cv::Rect hole(face.x, face.y + 10, 25, 20);  // touches the face's left edge
  depth(hole).setTo(0.0f);
  cv::Mat band = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  const cv::Rect around(face.x - 2, face.y - 2, face.width + 4, face.height + 4);
  band(around).setTo(255);
  band(face).setTo(0);
  depth.setTo(0.0f, band);
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  mask(face).setTo(255);
  const ObservedRegion region = ComputeObservedRegion(kCamera, mask, depth, 0.12, RegionOptions());
  // The hole is the object's: its pixels count against a pose that leaves them out.
  EXPECT_EQ(region.unsure_pixels, 0);
  EXPECT_EQ(Count(region.mask), face.area());
  // With every depthless pixel outside the mask read as unseen (the rule before), the
  // band makes the hole unsure.
  RegionOptions any;
  any.unsure_area_min_px = 1;
  EXPECT_EQ(ComputeObservedRegion(kCamera, mask, depth, 0.12, any).unsure_pixels, hole.area());
  // A mask that leaked onto a wide area the sensor did not see: that part is unsure.
  cv::Mat far_depth = SceneDepth();
  const cv::Rect unseen(face.x - 20, face.y, 20, face.height);  // left of the face, no depth
  far_depth(unseen).setTo(0.0f);
  cv::Mat leaky = mask.clone();
  leaky(cv::Rect(face.x - 8, face.y, 8, face.height)).setTo(255);
  const ObservedRegion leaked = ComputeObservedRegion(kCamera, leaky, far_depth, 0.12, RegionOptions());
  EXPECT_EQ(leaked.unsure_pixels, 8 * face.height);
  ASSERT_FALSE(leaked.unsure.empty());
  EXPECT_EQ(Count(leaked.unsure(face)), 0);
}

// A bent sheet-metal part seen from above: an upright flange (the box face, 5 cm up) and a
// base lying flat on the table, thinner than the plane's tolerance. The base is a leak to
// the depth; where the mask decides, the scores do not read it as the support.
TEST(PrepareObservation, TheCallersMaskOnTheSupportIsNotTheScoresSupport) {
  Frame frame;
  frame.camera = kCamera;
  frame.depth = SceneDepth();
  frame.rgb = cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(90, 90, 90));
  const cv::Rect base(ObjectBox().x + ObjectBox().width, ObjectBox().y, 30, ObjectBox().height);
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  mask(ObjectBox()).setTo(255);
  mask(base).setTo(255);
  auto support_pixels = [&](bool mask_decides) {
    SolverOptions options;
    options.region.mask_decides_on_support = mask_decides;
    Observation observation;
    EXPECT_EQ(PrepareObservation(frame, Instance{"part", mask}, options, 0.12, &observation), "");
    EXPECT_EQ(observation.region.support_leak, base.area());  // the base left the mask either way
    return Count(observation.selection_grid.support);
  };
  const int nobodys = support_pixels(false);
  const int decided = support_pixels(true);
  EXPECT_GT(nobodys, 0);
  EXPECT_LT(decided, nobodys);
}

TEST(ComputeObservedRegion, IsDeterministic) {
  const cv::Mat depth = SceneDepth();
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  mask(cv::Rect(120, 80, 80, 70)).setTo(255);
  const ObservedRegion a = ComputeObservedRegion(kCamera, mask, depth, 0.12, RegionOptions());
  const ObservedRegion b = ComputeObservedRegion(kCamera, mask, depth, 0.12, RegionOptions());
  EXPECT_EQ(cv::norm(a.mask, b.mask, cv::NORM_L1), 0.0);
  EXPECT_DOUBLE_EQ(a.plane_offset_m, b.plane_offset_m);
}

TEST(RegionOptions, CheckNamesTheBadField) {
  RegionOptions options;
  EXPECT_EQ(options.Check(), "");
  options.noise_sigmas = 0.0;
  EXPECT_NE(options.Check().find("noise_sigmas"), std::string::npos);
  options = RegionOptions();
  options.min_plane_fraction = 1.5;
  EXPECT_NE(options.Check().find("min_plane_fraction"), std::string::npos);
  options = RegionOptions();
  options.unsure_area_min_px = 0;
  EXPECT_NE(options.Check().find("unsure_area_min_px"), std::string::npos);
}

TEST(ParseMaskTrust, NamesAndErrors) {
  EXPECT_EQ(ParseMaskTrust("exact"), MaskTrust::kExact);
  EXPECT_EQ(ParseMaskTrust("depth"), MaskTrust::kDepth);
  EXPECT_STREQ(MaskTrustName(MaskTrust::kDepth), "depth");
  try {
    ParseMaskTrust("trusting");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("trusting"), std::string::npos);
  }
}

}  // namespace
}  // namespace g6d
