// The mask as evidence: leaks removed by the depth (support plane, far and near), the
// caller's word kept where the depth cannot judge, and the options' checks; the support
// plane as a limit on the answer (no pose reaches behind it).
#include "solver/region.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "solver/finalists.h"
#include "solver/frame_check.h"
#include "solver/mask_stage.h"
#include "solver/solve_context.h"
#include "test_meshes.h"

namespace g6d {
namespace {

// A part lying flat shows no depth step at its outline; the colour image outlines it.
TEST(EdgeSupport, CountsTheOutlineThatTheColourImageOutlines) {
  cv::Mat rgb(100, 120, CV_8UC3, cv::Scalar(30, 30, 30));
  rgb(cv::Rect(40, 30, 40, 40)).setTo(cv::Scalar(200, 190, 180));
  cv::Mat rendered = cv::Mat::zeros(rgb.size(), CV_32F);
  rendered(cv::Rect(40, 30, 40, 40)).setTo(0.8f);
  EXPECT_GT(EdgeSupport(rendered, rgb, kOutlineEdgeReachPx, kOutlineEdgeThreshold), 0.95);
  // Shifted by 8 pixels, only the parts of its top and bottom sides over the square's lie on an edge.
  cv::Mat shifted = cv::Mat::zeros(rgb.size(), CV_32F);
  shifted(cv::Rect(48, 30, 40, 40)).setTo(0.8f);
  const double off = EdgeSupport(shifted, rgb, kOutlineEdgeReachPx, kOutlineEdgeThreshold);
  EXPECT_GT(off, 0.2);
  EXPECT_LT(off, 0.6);
  // A uniform image outlines nothing; no colour, no outline: 0.
  const cv::Mat grey(rgb.size(), CV_8UC3, cv::Scalar(90, 90, 90));
  EXPECT_EQ(EdgeSupport(rendered, grey, kOutlineEdgeReachPx, kOutlineEdgeThreshold), 0.0);
  EXPECT_EQ(EdgeSupport(rendered, cv::Mat(), kOutlineEdgeReachPx, kOutlineEdgeThreshold), 0.0);
  EXPECT_EQ(EdgeSupport(cv::Mat::zeros(rgb.size(), CV_32F), rgb, kOutlineEdgeReachPx, kOutlineEdgeThreshold), 0.0);
  // The image's border is no outline: a rendering cut by it is judged on its sides inside.
  cv::Mat at_border = cv::Mat::zeros(rgb.size(), CV_32F);
  at_border(cv::Rect(0, 30, 80, 40)).setTo(0.8f);
  cv::Mat cut = rgb.clone();
  cut(cv::Rect(0, 30, 80, 40)).setTo(cv::Scalar(200, 190, 180));
  EXPECT_GT(EdgeSupport(at_border, cut, kOutlineEdgeReachPx, kOutlineEdgeThreshold), 0.95);
}

// A light square on a dark plain image, and its rendering.
struct PlainSquare {
  cv::Mat rgb = cv::Mat(100, 120, CV_8UC3, cv::Scalar(30, 30, 30));
  cv::Mat rendered = cv::Mat::zeros(100, 120, CV_32F);
  PlainSquare() {
    rgb(cv::Rect(40, 30, 40, 40)).setTo(cv::Scalar(200, 190, 180));
    rendered(cv::Rect(40, 30, 40, 40)).setTo(0.8f);
  }
};

// A two-tone image of the plain square's size: light (220) where `light(u, v)`, dark (30)
// elsewhere.
template <typename Light>
cv::Mat TwoTone(Light light) {
  cv::Mat image(PlainSquare().rgb.size(), CV_8UC3);
  for (int v = 0; v < image.rows; ++v) {
    for (int u = 0; u < image.cols; ++u) {
      image.at<cv::Vec3b>(v, u) = light(u, v) ? cv::Vec3b(220, 220, 220) : cv::Vec3b(30, 30, 30);
    }
  }
  return image;
}

// Both edge measures on the plain square: its whole outline is on an edge, and its uniform
// face inside meets none by chance. `measure` is EdgeSupport or OrientedEdgeSupport.
template <typename Measure>
void ExpectThePlainSquaresOutlineSupported(Measure measure) {
  const PlainSquare square;
  double chance = -1.0;
  EXPECT_GT(measure(square.rendered, square.rgb, kOutlineEdgeReachPx, kOutlineEdgeThreshold, &chance), 0.95);
  EXPECT_EQ(chance, 0.0);
}

// On a plain surface the outline's edges are evidence; on a surface full of edges (a
// keyboard's keys) the outline meets one wherever it lies: the chance says how often.
TEST(EdgeSupport, MeasuresHowOftenTheInteriorMeetsAnEdgeByChance) {
  ExpectThePlainSquaresOutlineSupported(EdgeSupport);
  const PlainSquare square;
  const cv::Mat& rendered = square.rendered;
  double chance = -1.0;
  const cv::Mat keys = TwoTone([](int u, int v) { return (u / 6 + v / 6) % 2 == 0; });  // 6 px keys
  const double on_keys = EdgeSupport(rendered, keys, kOutlineEdgeReachPx, kOutlineEdgeThreshold, &chance);
  EXPECT_GT(on_keys, 0.9);
  EXPECT_GT(chance, 0.9);
  // No interior (a rendering thinner than twice the reach): nothing to compare, 0.
  cv::Mat thin = cv::Mat::zeros(rendered.size(), CV_32F);
  thin(cv::Rect(40, 30, 40, 4)).setTo(0.8f);
  EdgeSupport(thin, keys, kOutlineEdgeReachPx, kOutlineEdgeThreshold, &chance);
  EXPECT_EQ(chance, 0.0);
}

// An edge only counts when it runs along the outline: on keys turned 45 degrees to the
// outline, or on noise, the outline meets edges everywhere but few along it (about a third
// of random directions lie within kOutlineEdgeAngleDeg), and the line inside says so too.
TEST(OrientedEdgeSupport, CountsEdgesAlongTheOutlineOnly) {
  ExpectThePlainSquaresOutlineSupported(OrientedEdgeSupport);
  const PlainSquare square;
  const cv::Mat& rendered = square.rendered;
  double chance = -1.0;
  const cv::Mat turned = TwoTone([](int u, int v) { return ((u + v) / 8 + (u - v + 400) / 8) % 2 == 0; });
  EXPECT_GT(EdgeSupport(rendered, turned, kOutlineEdgeReachPx, kOutlineEdgeThreshold), 0.8);
  // (where the turned keys' corners meet the outline, some gradients do run along it)
  EXPECT_LT(OrientedEdgeSupport(rendered, turned, kOutlineEdgeReachPx, kOutlineEdgeThreshold, &chance), 0.5);
  EXPECT_LT(chance, 0.5);
  cv::Mat noise(rendered.size(), CV_8UC3);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  const double on_noise = OrientedEdgeSupport(rendered, noise, kOutlineEdgeReachPx, kOutlineEdgeThreshold, &chance);
  EXPECT_GT(on_noise, 0.15);
  EXPECT_LT(on_noise, 0.55);
  EXPECT_GT(chance, 0.15);
  EXPECT_LT(chance, 0.55);
  const cv::Mat grey(rendered.size(), CV_8UC3, cv::Scalar(90, 90, 90));
  EXPECT_EQ(OrientedEdgeSupport(rendered, grey, kOutlineEdgeReachPx, kOutlineEdgeThreshold), 0.0);
  EXPECT_EQ(OrientedEdgeSupport(rendered, cv::Mat(), kOutlineEdgeReachPx, kOutlineEdgeThreshold), 0.0);
  EXPECT_EQ(OrientedEdgeSupport(cv::Mat::zeros(rendered.size(), CV_32F), square.rgb, kOutlineEdgeReachPx, kOutlineEdgeThreshold), 0.0);
}

// A right pose a few pixels off sees past its own rim by a band that wide, whatever its size;
// a model laid onto a smaller box hangs over it by a wide band. The rendering: a 60 x 40 px
// face at 0.8 m (196 outline pixels); behind it a wall at 1.2 m.
TEST(FreeSpaceBand, IsTheMeanWidthOfWhatTheCameraSeesThrough) {
  const cv::Size size(200, 150);
  cv::Mat rendered(size, CV_32F, cv::Scalar(0.0f));
  rendered(cv::Rect(70, 50, 60, 40)).setTo(0.8f);
  const double outline = 2 * 60 + 2 * 40 - 4;
  const auto scene = [&](const cv::Rect& face) {
    cv::Mat observed(size, CV_32F, cv::Scalar(1.2f));
    observed(face).setTo(0.8f);
    return observed;
  };
  const float tolerance = 0.01f;
  EXPECT_EQ(FreeSpaceBand(rendered, scene(cv::Rect(70, 50, 60, 40)), tolerance), 0.0);
  // The observed face 3 px to the right: 3 columns of 40 px see the wall.
  EXPECT_NEAR(FreeSpaceBand(rendered, scene(cv::Rect(73, 50, 60, 40)), tolerance), 3 * 40 / outline, 1e-9);
  // The same 3 px on a face twice as large: the same width, half the share of its pixels.
  cv::Mat large(size, CV_32F, cv::Scalar(0.0f));
  large(cv::Rect(40, 30, 120, 80)).setTo(0.8f);
  const double large_outline = 2 * 120 + 2 * 80 - 4;
  EXPECT_NEAR(FreeSpaceBand(large, scene(cv::Rect(43, 30, 120, 80)), tolerance), 3 * 80 / large_outline, 1e-9);
  // Laid onto a box half its width: 30 columns hang over.
  EXPECT_NEAR(FreeSpaceBand(rendered, scene(cv::Rect(70, 50, 30, 40)), tolerance), 30 * 40 / outline, 1e-9);
  // An occluder in front is no free space, nor are pixels without depth.
  cv::Mat occluded = scene(cv::Rect(70, 50, 60, 40));
  occluded(cv::Rect(100, 50, 30, 40)).setTo(0.5f);
  EXPECT_EQ(FreeSpaceBand(rendered, occluded, tolerance), 0.0);
  cv::Mat holes = scene(cv::Rect(70, 50, 30, 40));
  holes(cv::Rect(100, 0, 100, 150)).setTo(0.0f);
  EXPECT_EQ(FreeSpaceBand(rendered, holes, tolerance), 0.0);
  EXPECT_EQ(FreeSpaceBand(cv::Mat::zeros(size, CV_32F), scene(cv::Rect(0, 0, 10, 10)), tolerance), 0.0);
}

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

// A part in a pile: the ring around its mask is the pile (6 px tiles at five heights 3 cm
// apart, beyond the plane tolerance of one another, in a scrambled order: none a quarter
// of the ring), the table shows only farther out. No support for the mask's leaks, but the
// wider ring finds the table as the limit no pose may reach behind.
TEST(ComputeObservedRegion, FindsTheLimitPlaneInAWiderRingAroundAPile) {
  cv::Mat depth = SceneDepth();
  const cv::Rect box = ObjectBox();
  const cv::Rect pile(box.x - 30, box.y - 30, box.width + 60, box.height + 60);
  for (int v = pile.y; v < pile.y + pile.height; ++v) {
    for (int u = pile.x; u < pile.x + pile.width; ++u) {
      if (box.contains(cv::Point(u, v))) continue;
      const int tu = u / 6, tv = v / 6;
      const int level = ((tu * 7 + tv * 13) ^ (tu * tv)) % 5;
      depth.at<float>(v, u) = depth.at<float>(v, u) - 0.02f - 0.03f * static_cast<float>(level);
    }
  }
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  mask(box).setTo(255);
  const ObservedRegion region = ComputeObservedRegion(kCamera, mask, depth, 0.12, RegionOptions());
  EXPECT_FALSE(region.has_plane);
  EXPECT_TRUE(region.support.empty());
  ASSERT_TRUE(region.has_limit_plane);
  // The table: the object's face 5 cm in front of it, a table point on it.
  const Eigen::Vector3d face = kCamera.Backproject(PixelCentre(160, 115), depth.at<float>(115, 160));
  const Eigen::Vector3d table = kCamera.Backproject(PixelCentre(10, 230), depth.at<float>(230, 10));
  EXPECT_GT(region.limit_plane_normal.dot(face) + region.limit_plane_offset_m, 0.03);
  EXPECT_NEAR(region.limit_plane_normal.dot(table) + region.limit_plane_offset_m, 0.0, 0.002);
  // Without the wider search: no limit.
  RegionOptions narrow;
  narrow.limit_ring_fraction = 0.0;
  EXPECT_FALSE(ComputeObservedRegion(kCamera, mask, depth, 0.12, narrow).has_limit_plane);
}

// A mask whose surroundings have no depth (a lit floor, a pile the sensor missed): the ring
// shows no plane, and the support the caller knows (detection: the frame's support plane
// around the region) becomes the limit; where the ring shows one, the ring's stays.
TEST(PrepareObservation, TheCallersSupportIsTheLimitWhereTheRingShowsNone) {
  Frame frame;
  frame.camera = kCamera;
  frame.rgb = cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(90, 90, 90));
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  mask(ObjectBox()).setTo(255);
  frame.depth = cv::Mat::zeros(kHeight, kWidth, CV_32F);
  SceneDepth()(ObjectBox()).copyTo(frame.depth(ObjectBox()));  // depth on the object only
  Instance instance{"part", mask};
  instance.has_support_limit = true;
  instance.support_limit_normal = Eigen::Vector3d(0.0, 0.0, -1.0);
  instance.support_limit_offset_m = 1.0;  // the plane z = 1 m, facing the camera
  const SolverOptions options;
  Observation without;
  ASSERT_EQ(PrepareObservation(frame, Instance{"part", mask}, options, 0.12, &without), "");
  EXPECT_FALSE(without.region.has_limit_plane);
  Observation with;
  ASSERT_EQ(PrepareObservation(frame, instance, options, 0.12, &with), "");
  ASSERT_TRUE(with.region.has_limit_plane);
  EXPECT_EQ(with.region.limit_plane_normal, instance.support_limit_normal);
  EXPECT_EQ(with.region.limit_plane_offset_m, 1.0);
  // The support check off: no limit at all.
  SolverOptions off;
  off.support_penetration_fraction = 0.0;
  Observation unchecked;
  ASSERT_EQ(PrepareObservation(frame, instance, off, 0.12, &unchecked), "");
  EXPECT_FALSE(unchecked.region.has_limit_plane);
  // The whole scene's depth: the ring's own plane (the table), not the caller's.
  frame.depth = SceneDepth();
  Observation ring;
  ASSERT_EQ(PrepareObservation(frame, instance, options, 0.12, &ring), "");
  ASSERT_TRUE(ring.region.has_limit_plane);
  EXPECT_NE(ring.region.limit_plane_offset_m, 1.0);
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

// A support plane facing the camera at z = 1 m (normal -z: towards the camera).
ObservedRegion PlaneAtOneMetre() {
  ObservedRegion region;
  region.has_plane = region.has_limit_plane = true;
  region.plane_normal = region.limit_plane_normal = Eigen::Vector3d(0.0, 0.0, -1.0);
  region.plane_offset_m = region.limit_plane_offset_m = 1.0;  // -z + 1 = 0
  region.surface_tolerance_m = 0.002;
  return region;
}

Eigen::Isometry3d At(const Eigen::Vector3d& t, const Eigen::Matrix3d& rotation = Eigen::Matrix3d::Identity()) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = t;
  return pose;
}

TEST(DepthBehindSupport, IsHowFarTheModelReachesPastThePlane) {
  const Mesh cube = test::MakeCube(0.05);
  const ObservedRegion region = PlaneAtOneMetre();
  // Resting on it: the far face on the plane; pushed 3 cm into it; in front by 1 cm.
  EXPECT_NEAR(DepthBehindSupport(region, cube, At({0.1, -0.2, 0.95})), 0.0, 1e-9);
  EXPECT_NEAR(DepthBehindSupport(region, cube, At({0.1, -0.2, 0.98})), 0.03, 1e-6);
  EXPECT_NEAR(DepthBehindSupport(region, cube, At({0.0, 0.0, 0.94})), 0.0, 1e-9);
  // Turned 45 degrees about x: the deepest corner reaches h·sqrt(2) past the centre.
  const Eigen::Matrix3d turned = Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_NEAR(DepthBehindSupport(region, cube, At({0.0, 0.0, 0.95}, turned)), 0.05 * std::sqrt(2.0) - 0.05, 1e-6);
  // No plane: no limit.
  ObservedRegion none = region;
  none.has_plane = none.has_limit_plane = false;
  EXPECT_EQ(DepthBehindSupport(none, cube, At({0.0, 0.0, 1.2})), 0.0);
}

// Two finalists of a 10 x 6 x 2 cm plate: the lower S reaches 4 cm into the support, the
// other rests on it.
struct SupportCase {
  TemplateBank bank;
  Frame frame;
  std::vector<Finalist> finalists;
  PoseResult result;

  SupportCase(double s_behind, double s_front) {
    Mesh plate = test::MakeCube(1.0);
    for (Eigen::Vector3f& v : plate.vertices) v = v.cwiseProduct(Eigen::Vector3f(0.05f, 0.03f, 0.01f));
    bank.object_id = "plate";
    bank.online_mesh = plate;
    bank.diameter_m = ComputeDiameter(plate);
    frame.camera = kCamera;
    frame.rgb = cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(0, 0, 0));
    frame.depth = cv::Mat(kHeight, kWidth, CV_32F, cv::Scalar(0.0f));
    PoseScore behind, front;
    behind.s = s_behind;
    front.s = s_front;
    const Eigen::Matrix3d on_edge = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
    finalists.push_back(Finalist{At({0.0, 0.0, 0.99}, on_edge), behind, 0});  // reaches 1 + 0.04 m
    finalists.push_back(Finalist{At({0.0, 0.0, 0.99}), front, 1});           // far face on the plane
  }

  void Resolve(const SolverOptions& options) {
    ResolveFinalists(options, bank, frame, cv::Mat(), PlaneAtOneMetre(), AnswerSymmetries(bank),
                     DistancePoints(bank.online_mesh, 64), finalists, &result);
  }
};

TEST(ResolveFinalists, PassesOverAPoseBehindTheSupport) {
  SupportCase c(0.05, 0.07);
  SolverOptions options;
  c.Resolve(options);
  EXPECT_EQ(c.result.stages.answer_hypothesis, 1);
  EXPECT_TRUE(c.result.stages.support_changed);
  EXPECT_EQ(c.result.stages.finalists_behind_support, 1);
  EXPECT_NEAR(c.result.stages.support_penetration_m, 0.0, 1e-6);
  EXPECT_FALSE(c.result.stages.answer_behind_support);
  // The pose behind the support is no rival: the answer is not ambiguous for it.
  EXPECT_FALSE(c.result.has_runner_up);
  EXPECT_FALSE(c.result.ambiguous);
}

TEST(ResolveFinalists, KeepsTheLowestSWhenTheSupportCheckIsOffOrNoPoseIsCloseInS) {
  SupportCase off(0.05, 0.07);
  SolverOptions options;
  options.support_penetration_fraction = 0.0;
  off.Resolve(options);
  EXPECT_EQ(off.result.stages.answer_hypothesis, 0);
  EXPECT_TRUE(off.result.ambiguous);  // the other within ambiguity_margin
  SupportCase far(0.05, 0.05 + SolverOptions().support_margin + 0.01);
  far.Resolve(SolverOptions());
  EXPECT_EQ(far.result.stages.answer_hypothesis, 0);
  EXPECT_FALSE(far.result.stages.support_changed);
  EXPECT_NEAR(far.result.stages.support_penetration_m, 0.04, 1e-6);
  EXPECT_TRUE(far.result.stages.answer_behind_support);  // nothing in front was close in S
  EXPECT_FALSE(off.result.stages.answer_behind_support);  // not checked
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
