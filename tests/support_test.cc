// The support planes and the islands on them (proposals.h): a floor seen from 0.7 m with a
// structured-light sensor's noise (σ 0.7 mm), a 3 mm plate lying flat on it whose metal
// gives depth on only 60% of its pixels, and a 40 mm block.
#include "solver/proposals.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace g6d {
namespace {

const Camera kCamera{572.4, 573.6, 325.3, 242.0, 640, 480};
// The floor: the plane through (0, 0, 0.7) with normal kUp (towards the camera, tilted by
// about 17 degrees so that its depth changes over the image).
const Eigen::Vector3d kFloorPoint(0.0, 0.0, 0.7);
const Eigen::Vector3d kUp = Eigen::Vector3d(0.0, -0.3, -1.0).normalized();

struct FloorScene {
  Frame frame;
  cv::Mat plate;  // the plate's pixels (with depth or not), CV_8U 0/255
  cv::Mat block;  // the block's pixels
};

// Depth of the plane at height `height` above the floor along the ray through (u, v).
double DepthAt(int u, int v, double height) {
  const Eigen::Vector3d ray = kCamera.Ray(Eigen::Vector2d(u + 0.5, v + 0.5));
  const Eigen::Vector3d point = kFloorPoint + height * kUp;
  return kUp.dot(point) / kUp.dot(ray);
}

// A grey frame without depth, nothing marked.
FloorScene EmptyScene() {
  FloorScene scene;
  scene.frame.camera = kCamera;
  scene.frame.rgb = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 90, 90));
  scene.frame.depth = cv::Mat::zeros(480, 640, CV_32F);
  scene.plate = cv::Mat::zeros(480, 640, CV_8U);
  scene.block = cv::Mat::zeros(480, 640, CV_8U);
  return scene;
}

// Plates 3 mm thick lying on the floor, depth on 60% of their pixels; their union in
// scene.plate, the block none.
// The floor's depth with the sensor's noise (σ `sigma_m`); scene->plate stands `height_m`
// above it, with depth on `with_depth` of its pixels.
void FillDepth(double height_m, double with_depth, double sigma_m, unsigned seed, FloorScene* scene) {
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0.0, sigma_m);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const bool on_plate = scene->plate.at<uint8_t>(v, u) != 0;
      if (on_plate && uniform(random) >= with_depth) continue;
      scene->frame.depth.at<float>(v, u) = static_cast<float>(DepthAt(u, v, on_plate ? height_m : 0.0) + noise(random));
    }
  }
}

FloorScene MakePlates(const std::vector<cv::Rect>& plates) {
  FloorScene scene = EmptyScene();
  for (const cv::Rect& plate : plates) scene.plate(plate).setTo(255);
  FillDepth(0.003, 0.6, 0.0007, 11, &scene);
  return scene;
}

double Iou(const cv::Mat& a, const cv::Mat& b) {
  return static_cast<double>(cv::countNonZero(a & b)) / cv::countNonZero(a | b);
}

FloorScene MakeScene(double plate_thickness_m) {
  FloorScene scene = EmptyScene();
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, 0.0007);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const cv::Rect plate_box(200, 180, 70, 70), block_box(420, 250, 50, 50);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      double height = 0.0;
      bool has_depth = true;
      if (plate_box.contains(cv::Point(u, v))) {
        scene.plate.at<uint8_t>(v, u) = 255;
        height = plate_thickness_m;
        has_depth = uniform(random) < 0.6;  // bare metal: the pattern is reflected away
      } else if (block_box.contains(cv::Point(u, v))) {
        scene.block.at<uint8_t>(v, u) = 255;
        height = 0.04;
      }
      if (has_depth) scene.frame.depth.at<float>(v, u) = static_cast<float>(DepthAt(u, v, height) + noise(random));
    }
  }
  return scene;
}

double FractionWithDepthIn(const FloorScene& scene, const cv::Mat& part, const cv::Mat& mask) {
  const cv::Mat with_depth = part & (scene.frame.depth > 0.0f);
  return static_cast<double>(cv::countNonZero(with_depth & mask)) / cv::countNonZero(with_depth);
}

TEST(FindSupport, APlateLyingFlatOnTheFloorIsNotTakenAwayWithIt) {
  const FloorScene scene = MakeScene(0.003);
  const cv::Mat floor = ~(scene.plate | scene.block);
  DetectOptions options;
  cv::Mat support;
  EXPECT_EQ(FindSupport(scene.frame, options, 0.1, &support), 1);
  EXPECT_GT(FractionWithDepthIn(scene, floor, support), 0.97);
  EXPECT_LT(FractionWithDepthIn(scene, scene.plate, support), 0.1);
  EXPECT_EQ(FractionWithDepthIn(scene, scene.block, support), 0.0);
  // Asked for the raised pixels apart (as DetectObjects does: they join the islands, not
  // the segments), the plate stays support and is raised.
  cv::Mat raised;
  FindSupport(scene.frame, options, 0.1, &support, &raised);
  EXPECT_GT(FractionWithDepthIn(scene, scene.plate, support), 0.9);
  EXPECT_GT(FractionWithDepthIn(scene, scene.plate, raised), 0.9);
  EXPECT_LT(FractionWithDepthIn(scene, floor, raised), 0.01);
  // Without the test of the smoothed height the plate lies within the plane's tolerance and
  // goes with the floor: the cause.
  options.raised_sigmas = 0.0;
  FindSupport(scene.frame, options, 0.1, &support);
  EXPECT_GT(FractionWithDepthIn(scene, scene.plate, support), 0.9);
}

// The planes FindSupport removed face the camera; an answer's model is measured against the
// one holding most of the ring around its region: a cube standing on the floor reaches
// nothing behind it, one with its centre 2 cm below the floor reaches 4.5 cm (2 cm and half
// its side); a plane holding only a strip of the ring (a wall beside the region) is no
// support under it.
TEST(FindSupport, ItsPlanesFaceTheCameraAndTellHowFarAModelReachesBehindThem) {
  const FloorScene scene = MakeScene(0.003);
  cv::Mat support;
  std::vector<SupportPlane> planes;
  ASSERT_EQ(FindSupport(scene.frame, DetectOptions(), 0.1, &support, nullptr, &planes), 1);
  ASSERT_EQ(planes.size(), 1u);
  EXPECT_GT(planes[0].plane.normal.dot(kUp), 0.999);
  EXPECT_GT(planes[0].plane.offset, 0.0);
  EXPECT_EQ(cv::countNonZero(planes[0].pixels != support), 0);
  Mesh cube;  // 5 cm, centred on its origin
  for (int i = 0; i < 8; ++i) {
    cube.vertices.emplace_back(i & 1 ? 0.025f : -0.025f, i & 2 ? 0.025f : -0.025f, i & 4 ? 0.025f : -0.025f);
  }
  // Its z axis along the floor's normal, under the block's centre.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d x = kUp.cross(Eigen::Vector3d::UnitX()).normalized();
  pose.linear().col(0) = x;
  pose.linear().col(1) = kUp.cross(x);
  pose.linear().col(2) = kUp;
  const Eigen::Vector3d ray = kCamera.Ray(Eigen::Vector2d(445.5, 275.5));
  const Eigen::Vector3d on_floor = ray * (kUp.dot(kFloorPoint) / kUp.dot(ray));
  double tolerance = -1.0;
  pose.translation() = on_floor + 0.025 * kUp;  // standing on the floor
  EXPECT_LT(DepthBehindFrameSupport(planes, scene.frame.depth, scene.block, 0.5, cube, pose, &tolerance), 0.002);
  EXPECT_GT(tolerance, 0.0);
  pose.translation() = on_floor - 0.02 * kUp;  // its centre 2 cm below the floor
  EXPECT_NEAR(DepthBehindFrameSupport(planes, scene.frame.depth, scene.block, 0.5, cube, pose, &tolerance), 0.045, 0.002);
  // The plane's pixels only in a strip beside the region: no support under it.
  std::vector<SupportPlane> wall = planes;
  wall[0].pixels = cv::Mat::zeros(support.size(), CV_8U);
  wall[0].pixels(cv::Rect(470, 220, 10, 110)).setTo(255);
  EXPECT_EQ(DepthBehindFrameSupport(wall, scene.frame.depth, scene.block, 0.5, cube, pose, &tolerance), 0.0);
  EXPECT_EQ(tolerance, 0.0);
}

TEST(FindSupport, TheSensorsNoiseAloneRaisesNothing) {
  const FloorScene scene = MakeScene(0.0);  // the "plate" is floor with holes in its depth
  cv::Mat support;
  FindSupport(scene.frame, DetectOptions(), 0.1, &support);
  const cv::Mat with_depth = scene.frame.depth > 0.0f;
  EXPECT_GT(cv::countNonZero(support & ~scene.block), 0.99 * cv::countNonZero(with_depth & ~scene.block));
}

// DetectOptions::measure_plane_flatness: a bin's floor 6 mm above the ground, walled off by
// a band without depth, lies within the fixed tolerance (3 sigma of the noise + 6 mm) and
// goes with the ground; a plane that reads its flatness off its own largest part (the
// ground: flat to the noise) leaves it to a plane of its own. A floor bent by 5 mm across the
// image stays one support either way.
TEST(FindSupport, APlaneThatMeasuresItsFlatnessLeavesABinsFloorToAPlaneOfItsOwn) {
  FloorScene scene = EmptyScene();
  const cv::Rect bin(200, 150, 240, 180);
  scene.plate(bin).setTo(255);
  FillDepth(0.006, 1.0, 0.0007, 5, &scene);
  cv::Mat wall = cv::Mat::zeros(480, 640, CV_8U);
  cv::rectangle(wall, bin, cv::Scalar(255), 8);
  scene.frame.depth.setTo(0.0f, wall);
  scene.plate.setTo(0, wall);
  const cv::Mat ground = ~(scene.plate | wall);
  DetectOptions options;
  options.raised_sigmas = 0.0;  // the planes alone
  cv::Mat support;
  std::vector<SupportPlane> planes;
  EXPECT_EQ(FindSupport(scene.frame, options, 0.1, &support, nullptr, &planes), 1);
  EXPECT_GT(FractionWithDepthIn(scene, scene.plate, planes[0].pixels), 0.95);
  options.measure_plane_flatness = true;
  ASSERT_EQ(FindSupport(scene.frame, options, 0.1, &support, nullptr, &planes), 2);
  EXPECT_GT(FractionWithDepthIn(scene, ground, planes[0].pixels), 0.97);
  EXPECT_LT(FractionWithDepthIn(scene, scene.plate, planes[0].pixels), 0.05);
  EXPECT_GT(FractionWithDepthIn(scene, scene.plate, planes[1].pixels), 0.95);

  FloorScene bent = EmptyScene();
  std::mt19937 random(3);
  std::normal_distribution<double> noise(0.0, 0.0007);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const double x = (u - 320.0) / 320.0;
      bent.frame.depth.at<float>(v, u) = static_cast<float>(DepthAt(u, v, 0.005 * x * x) + noise(random));
    }
  }
  EXPECT_EQ(FindSupport(bent.frame, options, 0.1, &support, nullptr, &planes), 1);
  EXPECT_GT(cv::countNonZero(support), 0.97 * 480 * 640);
}

TEST(FormIslands, AnObjectLyingApartIsOneRegionWithItsPixelsWithoutDepth) {
  const FloorScene scene = MakeScene(0.003);
  cv::Mat support;
  FindSupport(scene.frame, DetectOptions(), 0.1, &support);  // the plate taken out of the support
  const std::vector<Proposal> islands = FormIslands(scene.frame, support == 0, 0.12, DetectOptions());
  ASSERT_EQ(islands.size(), 2u);
  for (const Proposal& island : islands) {
    ASSERT_FALSE(island.mask.empty());
    EXPECT_TRUE(island.segments.empty());
    const bool is_plate = island.box.contains(cv::Point(230, 210));
    const cv::Mat& truth = is_plate ? scene.plate : scene.block;
    const double iou = static_cast<double>(cv::countNonZero(island.mask & truth)) / cv::countNonZero(island.mask | truth);
    EXPECT_GT(iou, 0.9) << "island at " << island.box;
    const double centre_depth = is_plate ? DepthAt(235, 215, 0.003) : DepthAt(445, 275, 0.04);
    EXPECT_NEAR(island.depth_m, centre_depth, 0.005);
    EXPECT_GT(island.extent_m, 0.04);
    EXPECT_LT(island.extent_m, 0.12);
  }
  // The plate's island holds its pixels without depth too: the mask a segmenter would draw.
  const Proposal& plate = islands[0].box.contains(cv::Point(230, 210)) ? islands[0] : islands[1];
  EXPECT_GT(cv::countNonZero(plate.mask & scene.plate & (scene.frame.depth == 0.0f)), 0.3 * cv::countNonZero(scene.plate));
  // Nothing wider than the largest object is an island; -1 turns them off.
  EXPECT_TRUE(FormIslands(scene.frame, support == 0, 0.03, DetectOptions()).empty());
  DetectOptions off;
  off.island_open_px = -1;
  EXPECT_TRUE(FormIslands(scene.frame, support == 0, 0.12, off).empty());
}

// An L-shaped bracket of sheet metal, arms 10 px wide, 1.5 mm thick, lying flat at (200, 150)
// (depth on 70% of its pixels, σ 1 mm: a structured-light sensor at 0.8 m); and the same L
// painted on the floor at (400, 250), no higher than the floor. Both bright on the grey floor.
FloorScene MakeBracketAndPaint(cv::Mat* paint) {
  FloorScene scene = EmptyScene();
  *paint = cv::Mat::zeros(480, 640, CV_8U);
  auto draw_l = [](cv::Mat* mask, cv::Point at) {
    (*mask)(cv::Rect(at.x, at.y, 10, 60)).setTo(255);
    (*mask)(cv::Rect(at.x, at.y + 50, 50, 10)).setTo(255);
  };
  draw_l(&scene.plate, cv::Point(200, 150));
  draw_l(paint, cv::Point(400, 250));
  scene.frame.rgb.setTo(cv::Scalar(200, 200, 205), scene.plate | *paint);
  FillDepth(0.0015, 0.7, 0.001, 5, &scene);
  return scene;
}

TEST(FindSupport, AThinBracketTheColourImageOutlinesIsRaisedAndPaintIsNot) {
  cv::Mat paint;
  const FloorScene scene = MakeBracketAndPaint(&paint);
  const cv::Mat floor = ~(scene.plate | paint);
  DetectOptions options;
  cv::Mat support, raised;
  EXPECT_EQ(FindSupport(scene.frame, options, 0.1, &support, &raised), 1);
  EXPECT_GT(FractionWithDepthIn(scene, scene.plate, raised), 0.8);
  EXPECT_LT(FractionWithDepthIn(scene, paint, raised), 0.05);
  EXPECT_LT(FractionWithDepthIn(scene, floor, raised), 0.01);
  // The cause: averaged over 13 x 13 squares that reach the floor on both sides of a 10 px
  // arm, 1.5 mm of height stays below the depth-only test.
  options.raised_outline_edge = 0.0;
  FindSupport(scene.frame, options, 0.1, &support, &raised);
  EXPECT_LT(FractionWithDepthIn(scene, scene.plate, raised), 0.3);
  // A bracket lying in the colour image's shadow (no edges) is not outlined: still depth-only.
  FloorScene unseen = scene;
  unseen.frame.rgb = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 90, 90));
  FindSupport(unseen.frame, DetectOptions(), 0.1, &support, &raised);
  EXPECT_LT(FractionWithDepthIn(unseen, unseen.plate, raised), 0.3);
}

TEST(SplitAtNecks, TwoBlobsJoinedByANeckSplitAndAnLOfOneWidthDoesNot) {
  cv::Mat two = cv::Mat::zeros(120, 200, CV_8U);
  cv::circle(two, cv::Point(50, 60), 35, cv::Scalar(255), cv::FILLED);
  cv::circle(two, cv::Point(128, 60), 30, cv::Scalar(255), cv::FILLED);
  two(cv::Rect(80, 56, 25, 8)).setTo(255);  // the neck: 8 px where the blobs are 60-70 px wide
  cv::Mat pieces;
  std::set<std::pair<int, int>> touching;
  ASSERT_EQ(SplitAtNecks(two, 0.6, 20, 4, &pieces, &touching), 2);
  EXPECT_EQ(touching, (std::set<std::pair<int, int>>{{1, 2}}));
  EXPECT_EQ(cv::countNonZero((pieces > 0) != (two > 0)), 0);  // every pixel of the island in a piece
  cv::Mat left = cv::Mat::zeros(two.size(), CV_8U), right = left.clone();
  cv::circle(left, cv::Point(50, 60), 35, cv::Scalar(255), cv::FILLED);
  cv::circle(right, cv::Point(128, 60), 30, cv::Scalar(255), cv::FILLED);
  const int left_label = pieces.at<int>(60, 50), right_label = pieces.at<int>(60, 128);
  EXPECT_NE(left_label, right_label);
  EXPECT_GT(Iou(pieces == left_label, left), 0.85);
  EXPECT_GT(Iou(pieces == right_label, right), 0.85);
  // An L of one width (a bracket) has no neck: one piece.
  cv::Mat bracket = cv::Mat::zeros(120, 120, CV_8U);
  bracket(cv::Rect(10, 10, 20, 100)).setTo(255);
  bracket(cv::Rect(10, 90, 100, 20)).setTo(255);
  EXPECT_EQ(SplitAtNecks(bracket, 0.6, 20, 4, &pieces, &touching), 1);
  EXPECT_TRUE(touching.empty());
  EXPECT_THROW(SplitAtNecks(bracket, 0.0, 20, 4, &pieces, &touching), Error);
  EXPECT_THROW(SplitAtNecks(bracket, 0.6, 0, 4, &pieces, &touching), Error);
}

TEST(FormIslands, PlatesThatTouchGetARegionEach) {
  // Two plates of about 70 mm that touch along 10 px: one island of 150 mm, too wide for the
  // largest object (0.1 m), so without the split neither plate is a region.
  const std::vector<cv::Rect> plates{{200, 200, 60, 60}, {270, 190, 60, 60}, {259, 220, 12, 10}};
  const FloorScene scene = MakePlates(plates);
  cv::Mat support;
  FindSupport(scene.frame, DetectOptions(), 0.1, &support);
  DetectOptions unsplit;
  unsplit.island_split_core = 0.0;
  EXPECT_TRUE(FormIslands(scene.frame, support == 0, 0.1, unsplit).empty());
  const std::vector<Proposal> islands = FormIslands(scene.frame, support == 0, 0.1, DetectOptions());
  for (int k = 0; k < 2; ++k) {
    cv::Mat plate = cv::Mat::zeros(480, 640, CV_8U);
    plate(plates[static_cast<size_t>(k)]).setTo(255);
    double best = 0.0;
    for (const Proposal& island : islands) {
      EXPECT_TRUE(island.island_piece);
      best = std::max(best, Iou(island.mask, plate));
    }
    EXPECT_GT(best, 0.85) << "plate " << k;
  }
  for (const Proposal& island : islands) EXPECT_LE(island.extent_m, 0.1);
}

// A box's face (0.9 m) behind a marker-thin occluder (0.75 m, 12 px wide) whose projector
// shadow (10 px without depth) lies left of it, a second face below it across a band without
// depth, and a third to its right across a band of the table (support, 1.2 m).
struct GapScene {
  cv::Mat depth, region;
  DepthSegmentation segmentation;
  int left = 0, right = 0, below = 0, beyond_table = 0, occluder = 0;
};

GapScene MakeGapScene() {
  GapScene scene;
  scene.depth = cv::Mat(480, 640, CV_32F, cv::Scalar(1.2f));  // the table
  scene.region = cv::Mat::zeros(480, 640, CV_8U);
  auto put = [&](cv::Rect rect, float z) {
    scene.depth(rect).setTo(z);
    scene.region(rect).setTo(255);
  };
  put(cv::Rect(100, 150, 200, 100), 0.9f);   // the face behind, u 100..299
  put(cv::Rect(190, 150, 10, 100), 0.0f);    // the shadow, u 190..199
  put(cv::Rect(200, 120, 12, 160), 0.75f);   // the occluder, u 200..211
  put(cv::Rect(212, 250, 88, 12), 0.0f);     // a band without depth, v 250..261
  put(cv::Rect(212, 262, 88, 60), 0.9f);     // the face below it
  put(cv::Rect(320, 150, 80, 100), 0.9f);    // beyond 20 px of table, u 320..399
  SegmentOptions options;
  options.min_segment_pixels = 40;
  scene.segmentation = SegmentByDepth(kCamera, scene.depth, scene.region, options);
  const cv::Mat& labels = scene.segmentation.labels;
  scene.left = labels.at<int>(200, 150);
  scene.right = labels.at<int>(200, 250);
  scene.below = labels.at<int>(290, 250);
  scene.beyond_table = labels.at<int>(200, 350);
  scene.occluder = labels.at<int>(200, 205);
  return scene;
}

TEST(NeighboursAcrossGaps, TheTwoSidesOfAnOccluderAndItsShadowAreNeighboursAndTheTableStopsThePath) {
  const GapScene scene = MakeGapScene();
  const std::set<int> labels{scene.left, scene.right, scene.below, scene.beyond_table, scene.occluder};
  ASSERT_EQ(labels.size(), 5u);
  ASSERT_EQ(labels.count(0), 0u);
  const DepthSegmentation& segmentation = scene.segmentation;
  auto has = [](const std::set<std::pair<int, int>>& pairs, int a, int b) {
    return pairs.count({std::min(a, b), std::max(a, b)}) > 0;
  };
  // The gap between the face's two sides is 22 px: 0.035 m at 0.9 m is 22.3 px.
  const auto across = NeighboursAcrossGaps(kCamera, scene.depth, scene.region, segmentation, 0.035, 0.01);
  EXPECT_TRUE(has(across, scene.left, scene.right));
  EXPECT_TRUE(has(across, scene.right, scene.below));       // 12 px without depth
  EXPECT_FALSE(has(across, scene.right, scene.beyond_table));  // 20 px of table: support is no gap
  // The box-distance neighbours see neither gap.
  const auto near = NeighbourSegments(segmentation.labels, 6);
  EXPECT_FALSE(has(near, scene.left, scene.right));
  EXPECT_FALSE(has(near, scene.right, scene.below));
  // A reach shorter than the gap, or an occluder that is not in front by the margin.
  const auto short_reach = NeighboursAcrossGaps(kCamera, scene.depth, scene.region, segmentation, 0.025, 0.01);
  EXPECT_FALSE(has(short_reach, scene.left, scene.right));
  EXPECT_TRUE(has(short_reach, scene.right, scene.below));
  const auto wide_margin = NeighboursAcrossGaps(kCamera, scene.depth, scene.region, segmentation, 0.035, 0.2);
  EXPECT_FALSE(has(wide_margin, scene.left, scene.right));
  EXPECT_TRUE(NeighboursAcrossGaps(kCamera, scene.depth, scene.region, segmentation, 0.0, 0.01).empty());
  EXPECT_THROW(NeighboursAcrossGaps(kCamera, scene.depth, cv::Mat::zeros(10, 10, CV_8U), segmentation, 0.035, 0.01),
               Error);
}

TEST(FormRegions, AFaceSplitByAnOccluderIsOneRegionWithoutIt) {
  const GapScene scene = MakeGapScene();
  const DepthSegmentation& segmentation = scene.segmentation;
  DetectOptions options;
  std::set<std::pair<int, int>> neighbours = NeighbourSegments(segmentation.labels, options.neighbour_gap_px);
  const auto across = NeighboursAcrossGaps(kCamera, scene.depth, scene.region, segmentation, 0.035, 0.01);
  auto holds = [&](const std::vector<Proposal>& proposals) {
    for (const Proposal& proposal : proposals) {
      if (proposal.segments == std::vector<int>{std::min(scene.left, scene.right), std::max(scene.left, scene.right)}) return true;
    }
    return false;
  };
  // The face is 200 px = 0.31 m wide: a largest extent of 0.5 m lets the union fit.
  EXPECT_FALSE(holds(FormRegions(segmentation, neighbours, 0.5, options)));
  neighbours.insert(across.begin(), across.end());
  EXPECT_TRUE(holds(FormRegions(segmentation, neighbours, 0.5, options)));
}

TEST(DetectOptions, TheSupportAndIslandFieldsAreChecked) {
  DetectOptions options;
  options.raised_window_px = 4;
  EXPECT_NE(options.Check().find("raised_window_px"), std::string::npos);
  options = DetectOptions();
  options.raised_level_px = 5;
  EXPECT_NE(options.Check().find("raised_level_px"), std::string::npos);
  options = DetectOptions();
  options.raised_sigmas = -1.0;
  EXPECT_NE(options.Check().find("raised_sigmas"), std::string::npos);
  options = DetectOptions();
  options.raised_outline_edge = -1.0;
  EXPECT_NE(options.Check().find("raised_outline_edge"), std::string::npos);
  options = DetectOptions();
  options.raised_outline_ring_px = 0;
  EXPECT_NE(options.Check().find("raised_outline_ring_px"), std::string::npos);
  options = DetectOptions();
  options.island_open_px = -2;
  EXPECT_NE(options.Check().find("island_open_px"), std::string::npos);
  options = DetectOptions();
  options.island_split_core = 1.5;
  EXPECT_NE(options.Check().find("island_split_core"), std::string::npos);
  options = DetectOptions();
  options.island_split_window = 0.0;
  EXPECT_NE(options.Check().find("island_split_window"), std::string::npos);
  options = DetectOptions();
  options.island_split_max_pieces = 1;
  EXPECT_NE(options.Check().find("island_split_max_pieces"), std::string::npos);
  options = DetectOptions();
  options.gap_neighbour_reach_m = -0.01;
  EXPECT_NE(options.Check().find("gap_neighbour_reach_m"), std::string::npos);
  options = DetectOptions();
  options.gap_occluder_margin_m = 0.0;
  EXPECT_NE(options.Check().find("gap_occluder_margin_m"), std::string::npos);
}

}  // namespace
}  // namespace g6d
