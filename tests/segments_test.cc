// Depth segments: surfaces split where the depth jumps, a steep surface kept whole, speckle
// left out, a sensor's holes bridged, and the options' checks.
#include "solver/segments.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/error.h"

namespace g6d {
namespace {

constexpr int kWidth = 200, kHeight = 150;
const Camera kCamera{300.0, 300.0, 100.0, 75.0, kWidth, kHeight};

cv::Mat Filled(float depth_m) { return cv::Mat(kHeight, kWidth, CV_32F, cv::Scalar(depth_m)); }
cv::Mat Everything() { return cv::Mat(kHeight, kWidth, CV_8U, cv::Scalar(255)); }

TEST(SegmentByDepth, TwoObjectsSideBySideAtDifferentDepthsAreTwoSegments) {
  cv::Mat depth = Filled(0.80f);
  depth(cv::Rect(0, 0, 120, kHeight)).setTo(0.70f);  // the nearer object: 10 cm in front
  const DepthSegmentation segmentation = SegmentByDepth(kCamera, depth, Everything(), SegmentOptions());
  ASSERT_EQ(segmentation.segments.size(), 2u);
  EXPECT_EQ(segmentation.segments[0].pixels, 120 * kHeight);  // largest first
  EXPECT_EQ(segmentation.segments[1].pixels, 80 * kHeight);
  EXPECT_FLOAT_EQ(segmentation.segments[0].median_depth_m, 0.70f);
  EXPECT_EQ(segmentation.segments[1].box, cv::Rect(120, 0, 80, kHeight));
  EXPECT_EQ(segmentation.labels.at<int>(10, 10), 1);
  EXPECT_EQ(segmentation.labels.at<int>(10, 150), 2);
}

TEST(SegmentByDepth, ASteepPlaneIsOneSegmentAndASmallStepIsNoEdge) {
  // A plane seen at 60 degrees from its normal: depth grows by z tan(60°) / f per pixel.
  cv::Mat depth(kHeight, kWidth, CV_32F);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) depth.at<float>(v, u) = 0.6f * std::pow(1.0f + 1.732f / 300.0f, static_cast<float>(u));
  }
  // A 2 mm step (a seam, sensor quantization) does not split it.
  depth(cv::Rect(0, 70, kWidth, 10)) += 0.002f;
  const DepthSegmentation segmentation = SegmentByDepth(kCamera, depth, Everything(), SegmentOptions());
  ASSERT_EQ(segmentation.segments.size(), 1u);
  EXPECT_EQ(segmentation.segments[0].pixels, kWidth * kHeight);
}

// Depth of a fold along the column u = kWidth / 2: two planes tilted towards (valley) or
// away from (ridge) the camera by `slope` metres of depth per metre across, meeting there.
cv::Mat Fold(double slope, bool valley) {
  cv::Mat depth(kHeight, kWidth, CV_32F);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      // Metres across at 0.6 m: (u - centre) * z / f, depth change slope times that.
      const double across = std::abs(u + 0.5 - kWidth / 2.0) * 0.6 / kCamera.fx;
      depth.at<float>(v, u) = static_cast<float>(valley ? 0.6 - slope * across : 0.6 + slope * across);
    }
  }
  return depth;
}

TEST(MarkConcaveCreases, AValleyIsACreaseAndARidgeIsNot) {
  // Two faces at 45 degrees to the view meeting in a valley: two convex objects touching.
  const cv::Mat valley = MarkConcaveCreases(kCamera, Fold(1.0, true), Everything(), SegmentOptions());
  EXPECT_EQ(valley.at<uint8_t>(75, kWidth / 2), 255);
  EXPECT_EQ(valley.at<uint8_t>(75, kWidth / 2 - 1), 255);
  EXPECT_EQ(valley.at<uint8_t>(75, 20), 0);  // far from the fold: a plane
  // The same fold the other way (a box's edge seen from outside): no crease anywhere.
  const cv::Mat ridge = MarkConcaveCreases(kCamera, Fold(1.0, false), Everything(), SegmentOptions());
  EXPECT_EQ(cv::countNonZero(ridge), 0);
  // A flat plane with 1 mm noise-like ripples: no crease.
  cv::Mat ripples = Filled(0.6f);
  for (int u = 0; u < kWidth; u += 2) ripples.col(u) += 0.001f;
  EXPECT_EQ(cv::countNonZero(MarkConcaveCreases(kCamera, ripples, Everything(), SegmentOptions())), 0);
  // Off: nothing marked.
  SegmentOptions off;
  off.crease_half_span_m = 0.0;
  EXPECT_EQ(cv::countNonZero(MarkConcaveCreases(kCamera, Fold(1.0, true), Everything(), off)), 0);
}

TEST(SegmentByDepthAndCreases, TouchingFacesComeApartAndKeepEveryPixel) {
  const cv::Mat depth = Fold(1.0, true);
  // SegmentByDepth alone: the fold is continuous in depth, one segment.
  EXPECT_EQ(SegmentByDepth(kCamera, depth, Everything(), SegmentOptions()).segments.size(), 1u);
  cv::Mat creases;
  const DepthSegmentation split = SegmentByDepthAndCreases(kCamera, depth, Everything(), SegmentOptions(), &creases);
  ASSERT_EQ(split.segments.size(), 2u);
  EXPECT_GT(cv::countNonZero(creases), 0);
  // Every pixel is back in a segment, each face in its own, largest first.
  EXPECT_EQ(split.segments[0].pixels + split.segments[1].pixels, kWidth * kHeight);
  EXPECT_GE(split.segments[0].pixels, split.segments[1].pixels);
  EXPECT_NE(split.labels.at<int>(75, 10), split.labels.at<int>(75, kWidth - 10));
  EXPECT_EQ(split.labels.at<int>(75, 10), split.labels.at<int>(140, 60));
  // A ridge stays whole.
  EXPECT_EQ(SegmentByDepthAndCreases(kCamera, Fold(1.0, false), Everything(), SegmentOptions(), nullptr).segments.size(),
            1u);
}

// A sensor's hole (a dark or shining blob, 6 px across) cuts a surface in two; bridged, it is
// one segment again. A depthless band between two objects at different depths stays a gap.
TEST(BridgeDepthHoles, AHoleInOneSurfaceIsBridgedAStepBetweenTwoIsNot) {
  cv::Mat depth = Filled(0.80f);
  for (int v = 0; v < kHeight; ++v) {  // a slanted surface: 1 mm per column
    for (int u = 0; u < kWidth; ++u) depth.at<float>(v, u) = 0.80f + 0.001f * u;
  }
  depth(cv::Rect(97, 0, 6, kHeight)).setTo(0.0f);  // a hole across the whole image
  ASSERT_EQ(SegmentByDepth(kCamera, depth, Everything(), SegmentOptions()).segments.size(), 2u);
  const cv::Mat bridged = BridgeDepthHoles(kCamera, depth, 8, SegmentOptions());
  EXPECT_EQ(SegmentByDepth(kCamera, bridged, Everything(), SegmentOptions()).segments.size(), 1u);
  EXPECT_NEAR(bridged.at<float>(40, 99), 0.80f + 0.001f * 99, 1e-5);  // interpolated along the row
  EXPECT_EQ(cv::countNonZero(bridged != depth), 6 * kHeight);             // only the hole changed
  // A hole wider than the bridge stays.
  EXPECT_EQ(cv::countNonZero(BridgeDepthHoles(kCamera, depth, 5, SegmentOptions()) != depth), 0);
  EXPECT_EQ(cv::countNonZero(BridgeDepthHoles(kCamera, depth, 0, SegmentOptions()) != depth), 0);

  // Two objects 10 cm apart in depth with a shadow between them: no bridge.
  cv::Mat step = Filled(0.80f);
  step(cv::Rect(0, 0, 100, kHeight)).setTo(0.70f);
  step(cv::Rect(100, 0, 4, kHeight)).setTo(0.0f);
  const cv::Mat kept = BridgeDepthHoles(kCamera, step, 8, SegmentOptions());
  EXPECT_EQ(cv::countNonZero(kept != step), 0);
  EXPECT_EQ(SegmentByDepth(kCamera, kept, Everything(), SegmentOptions()).segments.size(), 2u);
  // An island of holes inside a face is filled from its rows and its columns.
  cv::Mat face = Filled(0.90f);
  face(cv::Rect(50, 50, 5, 5)).setTo(0.0f);
  EXPECT_EQ(cv::countNonZero(BridgeDepthHoles(kCamera, face, 8, SegmentOptions()) != Filled(0.90f)), 0);
  EXPECT_THROW(BridgeDepthHoles(kCamera, cv::Mat::zeros(kHeight, kWidth, CV_16U), 8, SegmentOptions()), Error);
}

TEST(SegmentByDepth, OnlyTheRegionWithDepthIsSegmentedAndFragmentsAreLeftOut) {
  cv::Mat depth = Filled(0.9f);
  depth(cv::Rect(50, 50, 20, 20)).setTo(0.0f);        // a hole
  depth(cv::Rect(100, 100, 3, 3)).setTo(0.5f);        // speckle: 9 pixels far in front
  cv::Mat region = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  region(cv::Rect(40, 40, 100, 80)).setTo(255);
  const DepthSegmentation segmentation = SegmentByDepth(kCamera, depth, region, SegmentOptions());
  ASSERT_EQ(segmentation.segments.size(), 1u);
  EXPECT_EQ(segmentation.segments[0].pixels, 100 * 80 - 20 * 20 - 9);
  EXPECT_EQ(segmentation.labels.at<int>(60, 60), 0);    // no depth
  EXPECT_EQ(segmentation.labels.at<int>(101, 101), 0);  // fragment
  EXPECT_EQ(segmentation.labels.at<int>(10, 10), 0);    // outside the region
  EXPECT_EQ(segmentation.labels.at<int>(45, 45), 1);
}

TEST(SegmentByDepth, SameLabelsWhateverTheSplitOrder) {
  // Three strips, the middle one nearest: labels by size, so the result is fixed.
  cv::Mat depth = Filled(1.0f);
  depth(cv::Rect(60, 0, 70, kHeight)).setTo(0.8f);
  depth(cv::Rect(130, 0, 70, kHeight)).setTo(1.2f);
  const DepthSegmentation a = SegmentByDepth(kCamera, depth, Everything(), SegmentOptions());
  const DepthSegmentation b = SegmentByDepth(kCamera, depth, Everything(), SegmentOptions());
  ASSERT_EQ(a.segments.size(), 3u);
  EXPECT_EQ(cv::countNonZero(a.labels != b.labels), 0);
  // Two strips of 70 columns tie: the one met first in raster order is labelled first.
  EXPECT_EQ(a.labels.at<int>(0, 60), 1);
  EXPECT_EQ(a.labels.at<int>(0, 130), 2);
  EXPECT_EQ(a.labels.at<int>(0, 0), 3);
}

TEST(SegmentByDepth, SpansBoundTheSegmentsExtent) {
  // A fronto-parallel 100 x 150 px patch at 0.9 m: 30 cm x 45 cm (f = 300 px); its spans
  // along x and y are those sizes less the 2% trimmed at each end, along z about 0.
  cv::Mat depth = Filled(0.9f);
  cv::Mat region = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  region(cv::Rect(50, 0, 100, kHeight)).setTo(255);
  const DepthSegmentation segmentation = SegmentByDepth(kCamera, depth, region, SegmentOptions());
  ASSERT_EQ(segmentation.segments.size(), 1u);
  const Spans& spans = segmentation.segments[0].spans;
  EXPECT_NEAR(spans.high[0] - spans.low[0], 0.30 * 0.96, 0.01);
  EXPECT_NEAR(spans.high[1] - spans.low[1], 0.45 * 0.96, 0.01);
  EXPECT_NEAR(spans.high[2] - spans.low[2], 0.0, 1e-6);
  // The largest span is the diagonal's projection, at most the diagonal.
  EXPECT_GE(spans.Extent(), 0.45 * 0.96 - 0.01);
  EXPECT_LE(spans.Extent(), std::hypot(0.30, 0.45));
  // A union spans both.
  Spans other = spans;
  for (double& high : other.high) high += 0.1;
  EXPECT_NEAR(spans.Union(other).Extent(), other.Extent(), 1e-12);
  EXPECT_GE(spans.Union(other).high[0], other.high[0]);
  EXPECT_LE(spans.Union(other).low[0], spans.low[0]);
}

TEST(GrowRegionByDepth, AnErodedMaskGrowsOverItsSurfaceButNotOntoTheBackgroundOrTheSupport) {
  // An object face at 0.7 m (60 x 50 px) in front of a wall at 1.0 m; the mask is the face
  // eroded by 6 px. The left 10 columns of the face are marked as support.
  cv::Mat depth = Filled(1.0f);
  const cv::Rect face(60, 40, 60, 50);
  depth(face).setTo(0.7f);
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  mask(cv::Rect(face.x + 6, face.y + 6, face.width - 12, face.height - 12)).setTo(255);
  cv::Mat support = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  support(cv::Rect(face.x, face.y, 4, face.height)).setTo(255);
  const cv::Mat grown = GrowRegionByDepth(kCamera, depth, mask, support, 0.5, 30, 0.25, SegmentOptions());
  EXPECT_EQ(cv::countNonZero(grown), face.area() - 4 * face.height);
  EXPECT_EQ(cv::countNonZero(grown(face)), face.area() - 4 * face.height);
  // Within 3 steps only the first 3 rings (4-neighbour growth: a diamond at the corners).
  const cv::Mat near = GrowRegionByDepth(kCamera, depth, mask, cv::Mat(), 0.5, 3, 0.25, SegmentOptions());
  EXPECT_GT(cv::countNonZero(near), cv::countNonZero(mask));
  EXPECT_LT(cv::countNonZero(near), face.area());
  EXPECT_EQ(cv::countNonZero(near(cv::Rect(face.x, face.y, 3, face.height))), 0);
  // Within a 1 cm reach of the mask's median point nothing new is close enough.
  const cv::Mat short_reach = GrowRegionByDepth(kCamera, depth, mask, cv::Mat(), 0.01, 30, 0.25, SegmentOptions());
  EXPECT_LT(cv::countNonZero(short_reach), cv::countNonZero(mask) + 10);
}

TEST(GrowRegionByDepth, AMaskThatLeakedOntoANeighbourDoesNotGrowOverIt) {
  // The object's face at 0.70 m (40 x 40 px) beside a neighbour's face at 0.76 m (a depth
  // step far above the noise) that it touches in the image; the mask is the object's face
  // dilated by 6 px to the right, over a 6 px rim of the neighbour.
  cv::Mat depth = Filled(1.0f);
  const cv::Rect object(60, 40, 40, 40), neighbour(100, 40, 60, 40);
  depth(object).setTo(0.70f);
  depth(neighbour).setTo(0.76f);
  cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  mask(cv::Rect(object.x, object.y, object.width + 6, object.height)).setTo(255);
  const cv::Mat grown = GrowRegionByDepth(kCamera, depth, mask, cv::Mat(), 0.5, 30, 0.25, SegmentOptions());
  // The rim leaves the region and nothing more of the neighbour joins.
  EXPECT_EQ(cv::countNonZero(grown(neighbour)), 0);
  EXPECT_EQ(cv::countNonZero(grown(object)), object.area());
  // Without the ownership rule the growth runs over the neighbour.
  const cv::Mat all = GrowRegionByDepth(kCamera, depth, mask, cv::Mat(), 0.5, 30, 0.0, SegmentOptions());
  EXPECT_GT(cv::countNonZero(all(neighbour)), 20 * neighbour.height);
}

TEST(SegmentByDepth, BadOptionsAndInputsAreRefusedByName) {
  SegmentOptions options;
  options.max_incidence_deg = 90.0;
  try {
    SegmentByDepth(kCamera, Filled(1.0f), Everything(), options);
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("max_incidence_deg"), std::string::npos) << e.what();
  }
  EXPECT_THROW(SegmentByDepth(kCamera, cv::Mat(kHeight, kWidth, CV_16U), Everything(), SegmentOptions()), Error);
  EXPECT_THROW(SegmentByDepth(kCamera, Filled(1.0f), cv::Mat(10, 10, CV_8U), SegmentOptions()), Error);
}

}  // namespace
}  // namespace g6d
