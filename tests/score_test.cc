// S and E_obs against hand-computed cases; grid construction.
#include "solver/score.h"

#include "solver/segments.h"

#include <gtest/gtest.h>

namespace g6d {
namespace {

// A 10 x 10 grid with a 4 x 5 observed mask at depth 1 m.
EvaluationGrid MakeGrid() {
  EvaluationGrid grid;
  grid.camera = {100, 100, 5, 5, 10, 10};
  grid.mask = cv::Mat::zeros(10, 10, CV_8U);
  grid.depth = cv::Mat::zeros(10, 10, CV_32F);
  grid.mask(cv::Rect(2, 2, 4, 5)).setTo(255);
  grid.depth(cv::Rect(2, 2, 4, 5)).setTo(1.0f);
  grid.mask_pixels = 20;
  return grid;
}

TEST(ScoreRendering, PerfectOverlapIsZero) {
  const EvaluationGrid grid = MakeGrid();
  RasterImage rendered;
  rendered.depth = grid.depth.clone();
  const PoseScore score = ScoreRendering(grid, rendered, 1.0, ScoreOptions());
  EXPECT_DOUBLE_EQ(score.coverage, 1.0);
  EXPECT_DOUBLE_EQ(score.iou, 1.0);
  EXPECT_NEAR(score.s, 0.0, 1e-9);
  EXPECT_NEAR(score.e_obs, 0.0, 1e-12);
  EXPECT_EQ(score.overlap_pixels, 20);
}

TEST(ScoreRendering, HandComputedShiftAndDepthOffset) {
  const EvaluationGrid grid = MakeGrid();
  RasterImage rendered;
  rendered.depth = cv::Mat::zeros(10, 10, CV_32F);
  // Rendered 4 x 5 box shifted right by 2 columns, 2 cm behind the observation.
  rendered.depth(cv::Rect(4, 2, 4, 5)).setTo(1.02f);
  // Intersection: columns 4..5 -> 2 x 5 = 10 px; union 20 + 20 - 10 = 30 (the grid has no
  // depth outside the mask: the paper's count, every rendered pixel outside it against).
  ScoreOptions options;
  options.unseen_is_hidden = false;
  const PoseScore score = ScoreRendering(grid, rendered, 1.0, options);
  EXPECT_DOUBLE_EQ(score.coverage, 10.0 / 20.0);
  EXPECT_DOUBLE_EQ(score.iou, 10.0 / 30.0);
  // E_obs = 0.7 * (1 - 0.5) + 0.3 * (1 - 1/3) = 0.35 + 0.2 = 0.55
  EXPECT_NEAR(score.e_obs, 0.55, 1e-12);
  // depth term = mean |1.02 - 1.0| / z_M = 0.02 (float rounding); S = 1 - 1/3 + 10 * 0.02
  EXPECT_NEAR(score.depth_residual, 0.02, 1e-6);
  EXPECT_NEAR(score.s, 1.0 - 1.0 / 3.0 + 0.2, 1e-5);
}

TEST(ScoreRendering, MissingObservedDepthIsNotCounted) {
  EvaluationGrid grid = MakeGrid();
  grid.depth(cv::Rect(2, 2, 2, 5)).setTo(0.0f);  // half the mask has no depth
  RasterImage rendered;
  rendered.depth = cv::Mat::zeros(10, 10, CV_32F);
  rendered.depth(cv::Rect(2, 2, 4, 5)).setTo(1.01f);
  const PoseScore score = ScoreRendering(grid, rendered, 1.0, ScoreOptions());
  EXPECT_EQ(score.overlap_pixels, 10);
  EXPECT_NEAR(score.depth_residual, 0.01, 1e-6);
}

TEST(ScoreRendering, UnseenPixelsOutsideTheMaskCountForNothing) {
  // The object continues 2 columns left of the mask, under an occluder the sensor saw no
  // depth on (metal, a shadow); right of the mask the background has depth.
  EvaluationGrid grid = MakeGrid();
  grid.depth(cv::Rect(6, 0, 4, 10)).setTo(1.5f);
  RasterImage rendered;
  rendered.depth = cv::Mat::zeros(10, 10, CV_32F);
  rendered.depth(cv::Rect(0, 2, 6, 5)).setTo(1.0f);
  ScoreOptions options;
  EXPECT_FALSE(options.unseen_is_hidden);  // the paper's count by default
  options.unseen_is_hidden = true;
  const PoseScore hidden = ScoreRendering(grid, rendered, 1.0, options);
  EXPECT_EQ(hidden.occluded_pixels, 10);
  EXPECT_DOUBLE_EQ(hidden.iou, 1.0);
  options.unseen_is_hidden = false;
  const PoseScore counted = ScoreRendering(grid, rendered, 1.0, options);
  EXPECT_EQ(counted.occluded_pixels, 0);
  EXPECT_DOUBLE_EQ(counted.iou, 20.0 / 30.0);
  // Where the sensor sees no background at all (most of the grid outside the mask without
  // depth), a missing depth says nothing of occluders: counted again.
  options.unseen_is_hidden = true;
  grid.unseen_background = 0.8;
  EXPECT_DOUBLE_EQ(ScoreRendering(grid, rendered, 1.0, options).iou, 20.0 / 30.0);
  grid.unseen_background = 0.0;
  // Where the background has depth, a rendering beyond the mask still counts against.
  RasterImage right;
  right.depth = cv::Mat::zeros(10, 10, CV_32F);
  right.depth(cv::Rect(2, 2, 6, 5)).setTo(1.0f);
  EXPECT_DOUBLE_EQ(ScoreRendering(grid, right, 1.0, options).iou, 20.0 / 30.0);
}

TEST(MakeEvaluationGrid, DownscalesAroundTheMask) {
  const Camera camera{500, 500, 320, 240, 640, 480};
  cv::Mat mask = cv::Mat::zeros(480, 640, CV_8U);
  mask(cv::Rect(200, 100, 200, 100)).setTo(255);
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(0.8f));
  GridOptions options;
  options.margin = 0.5;
  options.max_side_px = 100;
  const EvaluationGrid grid = MakeEvaluationGrid(camera, mask, depth, options);
  // ROI: x 100..500, y 0..300 (clipped at the top) -> 400 x 300, scaled by 0.25.
  EXPECT_EQ(grid.camera.width, 100);
  EXPECT_EQ(grid.camera.height, 75);
  EXPECT_NEAR(grid.mask_pixels, 50 * 25, 60);
  EXPECT_DOUBLE_EQ(grid.camera.fx, 125.0);
  EXPECT_DOUBLE_EQ(grid.camera.cx, (320.0 - 100.0) * 0.25);
}

TEST(MakeEvaluationGrid, AThinDepthlessBandIsNoUnseenAreaAWideHoleIs) {
  // A sensor loses depth in a thin band along an edge (3 px, left of the mask); an occluder
  // it cannot see leaves a wide hole (40 x 40 px, right of the mask).
  const Camera camera{500, 500, 320, 240, 640, 480};
  cv::Mat mask = cv::Mat::zeros(480, 640, CV_8U);
  mask(cv::Rect(200, 200, 100, 100)).setTo(255);
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(0.8f));
  depth(cv::Rect(197, 200, 3, 100)).setTo(0.0f);
  depth(cv::Rect(300, 220, 40, 40)).setTo(0.0f);
  depth(cv::Rect(220, 220, 30, 30)).setTo(0.0f);  // the object's own depthless metal
  GridOptions options;
  options.max_side_px = 4096;  // no downscaling: grid pixel = image pixel
  ASSERT_EQ(options.unseen_area_min_px, 9);
  const EvaluationGrid grid = MakeEvaluationGrid(camera, mask, depth, options);
  ASSERT_EQ(grid.unseen_area.size(), grid.mask.size());
  const int x0 = 150, y0 = 150;  // the ROI's corner: the mask box less half its side
  ASSERT_DOUBLE_EQ(grid.camera.cx, 320.0 - x0);
  auto at = [&](int x, int y) { return grid.unseen_area.at<uint8_t>(y - y0, x - x0); };
  EXPECT_EQ(at(198, 250), 0);    // the band
  EXPECT_EQ(at(300, 220), 255);  // the hole, corner to corner
  EXPECT_EQ(at(339, 259), 255);
  EXPECT_EQ(at(320, 240), 255);
  EXPECT_EQ(at(235, 235), 0);    // inside the mask: never an occluder's
  EXPECT_EQ(at(330, 300), 0);    // background with depth
  EXPECT_EQ(cv::countNonZero(grid.unseen_area), 40 * 40);
  EXPECT_TRUE(grid.hole_near.empty());  // the thin holes are filled only when asked
  GridOptions fill = options;
  fill.fill_thin_holes = true;
  const EvaluationGrid filled = MakeEvaluationGrid(camera, mask, depth, fill);
  EXPECT_FLOAT_EQ(filled.hole_near.at<float>(250 - y0, 198 - x0), 0.8f);  // the band: its surroundings' depth
  EXPECT_FLOAT_EQ(filled.hole_far.at<float>(250 - y0, 198 - x0), 0.8f);
  EXPECT_EQ(filled.hole_near.at<float>(240 - y0, 320 - x0), 0.0f);  // the wide hole is no thin one
  // The band counts against a pose that spills into it; the hole hides what lies behind it.
  RasterImage rendered;
  rendered.depth = cv::Mat::zeros(grid.mask.size(), CV_32F);
  rendered.depth(cv::Rect(197 - x0, 200 - y0, 103, 100)).setTo(0.8f);  // 3 columns over the band
  ScoreOptions score;
  score.unseen_is_hidden = true;
  EXPECT_EQ(ScoreRendering(grid, rendered, 0.8, score).occluded_pixels, 0);
  rendered.depth.setTo(0.0f);
  rendered.depth(cv::Rect(200 - x0, 220 - y0, 110, 40)).setTo(0.8f);  // 10 columns into the hole
  EXPECT_EQ(ScoreRendering(grid, rendered, 0.8, score).occluded_pixels, 10 * 40);
  // 0: every depthless pixel outside the mask may be an occluder's (no area is made).
  options.unseen_area_min_px = 0;
  EXPECT_TRUE(MakeEvaluationGrid(camera, mask, depth, options).unseen_area.empty());
  options.unseen_area_min_px = -1;
  EXPECT_NE(options.Check().find("unseen_area_min_px"), std::string::npos);
}

TEST(MeanMaskedDepth, IgnoresInvalidPixels) {
  cv::Mat mask = cv::Mat::zeros(4, 4, CV_8U);
  mask(cv::Rect(0, 0, 2, 2)).setTo(255);
  cv::Mat depth = cv::Mat::zeros(4, 4, CV_32F);
  depth.at<float>(0, 0) = 1.0f;
  depth.at<float>(0, 1) = 2.0f;
  depth.at<float>(3, 3) = 9.0f;  // outside the mask
  int valid = 0;
  EXPECT_DOUBLE_EQ(MeanMaskedDepth(mask, depth, &valid), 1.5);
  EXPECT_EQ(valid, 2);
}

// Masks as evidence: a rendering larger than an eroded mask, whose extra pixels the depth
// puts on the rendered surface, is not penalized for them; on the support plane it is.
TEST(ScoreRendering, DepthEvidenceCountsWhatTheMaskMissed) {
  EvaluationGrid grid = MakeGrid();
  grid.depth(cv::Rect(1, 1, 6, 7)).setTo(1.0f);  // the object is larger than its (eroded) mask
  RasterImage rendered;
  rendered.depth = cv::Mat::zeros(10, 10, CV_32F);
  rendered.depth(cv::Rect(1, 1, 6, 7)).setTo(1.002f);  // the true pose: 42 px
  ScoreOptions exact;
  const PoseScore as_given = ScoreRendering(grid, rendered, 1.0, exact);
  EXPECT_DOUBLE_EQ(as_given.iou, 20.0 / 42.0);
  EXPECT_EQ(as_given.recovered_pixels, 0);
  ScoreOptions evidence;
  evidence.depth_evidence = true;
  evidence.surface_tolerance_m = 0.005;
  const PoseScore checked = ScoreRendering(grid, rendered, 1.0, evidence);
  EXPECT_EQ(checked.recovered_pixels, 22);
  EXPECT_DOUBLE_EQ(checked.iou, 1.0);
  EXPECT_EQ(checked.overlap_pixels, 42);
  // Off the surface by more than the tolerance: background, against the pose as before.
  evidence.surface_tolerance_m = 0.001;
  EXPECT_DOUBLE_EQ(ScoreRendering(grid, rendered, 1.0, evidence).iou, 20.0 / 42.0);
  // On the support plane: never object.
  evidence.surface_tolerance_m = 0.005;
  grid.support = cv::Mat::zeros(10, 10, CV_8U);
  grid.support(cv::Rect(1, 1, 6, 7)).setTo(255);
  grid.support(cv::Rect(2, 2, 4, 5)).setTo(0);
  EXPECT_DOUBLE_EQ(ScoreRendering(grid, rendered, 1.0, evidence).iou, 20.0 / 42.0);
}

// Masks as evidence: a mask pixel that the depth puts in front of the rendered surface is
// an occluder the mask leaked onto: not rendered (a miss for every pose alike), and no
// depth residual.
TEST(ScoreRendering, DepthEvidenceCountsAnOccluderInTheMaskAsAMissWithoutResidual) {
  EvaluationGrid grid = MakeGrid();
  grid.depth(cv::Rect(2, 2, 1, 5)).setTo(0.8f);  // a 5 px occluder inside the mask
  RasterImage rendered;
  rendered.depth = cv::Mat::zeros(10, 10, CV_32F);
  rendered.depth(cv::Rect(2, 2, 4, 5)).setTo(1.0f);
  const PoseScore as_given = ScoreRendering(grid, rendered, 1.0, ScoreOptions());
  EXPECT_NEAR(as_given.depth_residual, 5 * 0.2 / 20.0, 1e-6);
  ScoreOptions evidence;
  evidence.depth_evidence = true;
  evidence.surface_tolerance_m = 0.005;
  const PoseScore checked = ScoreRendering(grid, rendered, 1.0, evidence);
  EXPECT_EQ(checked.occluded_pixels, 5);
  EXPECT_NEAR(checked.depth_residual, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(checked.iou, 15.0 / 20.0);
  EXPECT_LT(checked.s, as_given.s);
}

// MakeGrid's object (4 x 5 at 1 m, depth segment 1) merged with a neighbour beside it
// (3 x 5 at 0.9 m, segment 2), as a segmenter that merged touching objects gives it.
EvaluationGrid MergedGrid() {
  EvaluationGrid grid = MakeGrid();
  grid.mask(cv::Rect(6, 2, 3, 5)).setTo(255);
  grid.depth(cv::Rect(6, 2, 3, 5)).setTo(0.9f);
  grid.mask_pixels = 35;
  grid.segment = cv::Mat::zeros(10, 10, CV_32S);
  grid.segment(cv::Rect(2, 2, 4, 5)).setTo(1);
  grid.segment(cv::Rect(6, 2, 3, 5)).setTo(2);
  grid.segment_pixels = {0, 20, 15};
  return grid;
}

// The object rendered at its true pose on MergedGrid.
RasterImage TruePoseRendering() {
  RasterImage rendered;
  rendered.depth = cv::Mat::zeros(10, 10, CV_32F);
  rendered.depth(cv::Rect(2, 2, 4, 5)).setTo(1.0f);
  return rendered;
}

// Segment ownership: a mask merged with a neighbour (another depth segment) is explained by
// the pose of the object alone; a pose that covers part of the neighbour must explain it all.
TEST(ScoreRendering, DepthEvidenceLeavesOutTheSegmentsAPoseDoesNotCover) {
  EvaluationGrid grid = MergedGrid();
  RasterImage rendered = TruePoseRendering();
  ScoreOptions evidence;
  evidence.depth_evidence = true;
  evidence.surface_tolerance_m = 0.005;
  const PoseScore owned = ScoreRendering(grid, rendered, 1.0, evidence);
  EXPECT_EQ(owned.foreign_pixels, 15);
  EXPECT_DOUBLE_EQ(owned.iou, 1.0);
  EXPECT_NEAR(owned.s, 0.0, 1e-9);
  // Without ownership the neighbour is a miss of the true pose.
  ScoreOptions every_pixel = evidence;
  every_pixel.segment_own_fraction = 0.0;
  const PoseScore merged = ScoreRendering(grid, rendered, 1.0, every_pixel);
  EXPECT_EQ(merged.foreign_pixels, 0);
  EXPECT_DOUBLE_EQ(merged.iou, 20.0 / 35.0);
  // A pose reaching a third of the way into the neighbour owns it: its 10 px left count.
  rendered.depth(cv::Rect(6, 2, 1, 5)).setTo(0.9f);
  const PoseScore reaching = ScoreRendering(grid, rendered, 1.0, evidence);
  EXPECT_EQ(reaching.foreign_pixels, 0);
  EXPECT_DOUBLE_EQ(reaching.iou, 25.0 / 35.0);
}

// ... but a segment the object could reach from what the pose covers is the pose's to
// explain (a part behind a depth step): only beyond the object's extent is it another's.
TEST(ScoreRendering, DepthEvidenceLeavesOutOnlySegmentsBeyondTheObjectsReach) {
  EvaluationGrid grid = MergedGrid();
  // Segment 1 spans 0..4 cm along every direction, segment 2 6..9 cm: together 9 cm.
  Spans first, second;
  first.low.fill(0.0);
  first.high.fill(0.04);
  second.low.fill(0.06);
  second.high.fill(0.09);
  grid.segment_spans = {Spans(), first, second};
  const RasterImage rendered = TruePoseRendering();
  ScoreOptions evidence;
  evidence.depth_evidence = true;
  evidence.surface_tolerance_m = 0.005;
  evidence.max_object_extent_m = 0.10;  // the object could span both: segment 2 counts
  EXPECT_EQ(ScoreRendering(grid, rendered, 1.0, evidence).foreign_pixels, 0);
  EXPECT_DOUBLE_EQ(ScoreRendering(grid, rendered, 1.0, evidence).iou, 20.0 / 35.0);
  evidence.max_object_extent_m = 0.08;  // it could not: segment 2 is another object's
  EXPECT_EQ(ScoreRendering(grid, rendered, 1.0, evidence).foreign_pixels, 15);
  EXPECT_DOUBLE_EQ(ScoreRendering(grid, rendered, 1.0, evidence).iou, 1.0);
}

}  // namespace
}  // namespace g6d
