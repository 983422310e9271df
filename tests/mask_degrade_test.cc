// Degradations for the benchmark: masks as a segmenter gives them (mask_degrade.h) and depth
// as a structured-light sensor gives it (depth_sensor.h).
#include "eval/mask_degrade.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/error.h"
#include "eval/depth_sensor.h"

namespace g6d {
namespace {

constexpr int kSize = 200;  // test images are kSize x kSize

// A disc of `radius_px` around (centre_x, centre_y): the pixels whose centre lies inside.
cv::Mat DiscMask(double centre_x, double centre_y, double radius_px) {
  cv::Mat mask = cv::Mat::zeros(kSize, kSize, CV_8U);
  for (int v = 0; v < kSize; ++v) {
    for (int u = 0; u < kSize; ++u) {
      if (std::hypot(u - centre_x, v - centre_y) <= radius_px) mask.at<uint8_t>(v, u) = 255;
    }
  }
  return mask;
}

cv::Mat RectMask(const cv::Rect& rect) {
  cv::Mat mask = cv::Mat::zeros(kSize, kSize, CV_8U);
  mask(rect).setTo(255);
  return mask;
}

MaskDegradeOptions Options(MaskDegradation mode, int size_px = 6) {
  MaskDegradeOptions options;
  options.mode = mode;
  options.size_px = size_px;
  return options;
}

int Area(const cv::Mat& mask) { return cv::countNonZero(mask); }

// Whether every non-zero pixel of `inner` is non-zero in `outer`.
bool IsSubset(const cv::Mat& inner, const cv::Mat& outer) {
  for (int v = 0; v < inner.rows; ++v) {
    for (int u = 0; u < inner.cols; ++u) {
      if (inner.at<uint8_t>(v, u) && !outer.at<uint8_t>(v, u)) return false;
    }
  }
  return true;
}

bool IsZeroOr255(const cv::Mat& mask) {
  for (int v = 0; v < mask.rows; ++v) {
    for (int u = 0; u < mask.cols; ++u) {
      const uint8_t value = mask.at<uint8_t>(v, u);
      if (value != 0 && value != 255) return false;
    }
  }
  return true;
}

std::vector<cv::Point> Pixels(const cv::Mat& mask) {
  std::vector<cv::Point> pixels;
  cv::findNonZero(mask, pixels);
  return pixels;
}

// The smallest rectangle holding every non-zero pixel (empty for an empty mask).
cv::Rect BoundingBox(const cv::Mat& mask) {
  cv::Rect box;
  for (const cv::Point& p : Pixels(mask)) box |= cv::Rect(p.x, p.y, 1, 1);
  return box;
}

// The convex hull (counter-clockwise, monotone chain) of a point set.
std::vector<cv::Point> ConvexHull(std::vector<cv::Point> points) {
  std::sort(points.begin(), points.end(), [](const cv::Point& a, const cv::Point& b) {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
  });
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  auto cross = [](const cv::Point& o, const cv::Point& a, const cv::Point& b) {
    return static_cast<long>(a.x - o.x) * (b.y - o.y) - static_cast<long>(a.y - o.y) * (b.x - o.x);
  };
  std::vector<cv::Point> hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

// Whether a straight line has all of `kept` strictly on one side and all of `removed` on
// the other. Two convex polygons are disjoint exactly when one of their edge normals
// separates them (separating axis theorem), so the edge normals of both hulls are the only
// directions to try. Integer coordinates: the projections are exact.
bool SeparableByALine(const std::vector<cv::Point>& kept, const std::vector<cv::Point>& removed) {
  std::vector<cv::Point> normals;
  for (const std::vector<cv::Point>& hull : {ConvexHull(kept), ConvexHull(removed)}) {
    for (size_t i = 0; i < hull.size(); ++i) {
      const cv::Point edge = hull[(i + 1) % hull.size()] - hull[i];
      normals.emplace_back(-edge.y, edge.x);
      normals.emplace_back(edge.y, -edge.x);
    }
  }
  for (const cv::Point& normal : normals) {
    long kept_max = std::numeric_limits<long>::min(),
         removed_min = std::numeric_limits<long>::max();
    for (const cv::Point& p : kept) kept_max = std::max(kept_max, static_cast<long>(normal.dot(p)));
    for (const cv::Point& p : removed)
      removed_min = std::min(removed_min, static_cast<long>(normal.dot(p)));
    if (removed_min > kept_max) return true;
  }
  return false;
}

TEST(DegradeMask, NoneReturnsTheSameMaskAsZeroOr255) {
  cv::Mat mask = cv::Mat::zeros(kSize, kSize, CV_8U);
  mask(cv::Rect(10, 20, 30, 40)).setTo(1);
  const cv::Mat result = DegradeMask(mask, {}, Options(MaskDegradation::kNone), 7);
  EXPECT_TRUE(IsZeroOr255(result));
  EXPECT_EQ(cv::countNonZero(result != (mask > 0)), 0);
}

TEST(DegradeMask, ErodeShrinksADiscByTheRadius) {
  const cv::Mat disc = DiscMask(100, 100, 40);
  for (const int size_px : {2, 6, 12}) {
    const cv::Mat eroded = DegradeMask(disc, {}, Options(MaskDegradation::kErode, size_px), 1);
    EXPECT_TRUE(IsZeroOr255(eroded));
    EXPECT_TRUE(IsSubset(eroded, disc)) << size_px << " px";
    const double expected = M_PI * (40 - size_px) * (40 - size_px);
    EXPECT_NEAR(Area(eroded), expected, 0.02 * expected) << size_px << " px";
  }
}

TEST(DegradeMask, DilateGrowsADiscByTheRadius) {
  const cv::Mat disc = DiscMask(100, 100, 40);
  for (const int size_px : {2, 6, 12}) {
    const cv::Mat dilated = DegradeMask(disc, {}, Options(MaskDegradation::kDilate, size_px), 1);
    EXPECT_TRUE(IsZeroOr255(dilated));
    EXPECT_TRUE(IsSubset(disc, dilated)) << size_px << " px";
    const double expected = M_PI * (40 + size_px) * (40 + size_px);
    EXPECT_NEAR(Area(dilated), expected, 0.02 * expected) << size_px << " px";
  }
}

TEST(DegradeMask, ErodeByZeroAndDilateByZeroKeepTheMask) {
  const cv::Mat disc = DiscMask(100, 100, 40);
  for (const MaskDegradation mode : {MaskDegradation::kErode, MaskDegradation::kDilate}) {
    EXPECT_EQ(cv::countNonZero(DegradeMask(disc, {}, Options(mode, 0), 1) != disc), 0);
  }
}

TEST(DegradeMask, ErodeRemovesATinyMaskEntirely) {
  const cv::Mat tiny = RectMask(cv::Rect(50, 50, 5, 5));
  const cv::Mat eroded = DegradeMask(tiny, {}, Options(MaskDegradation::kErode), 1);
  EXPECT_EQ(eroded.size(), tiny.size());
  EXPECT_EQ(eroded.type(), CV_8U);
  EXPECT_EQ(Area(eroded), 0);
}

TEST(DegradeMask, ErodeDoesNotShrinkAwayFromTheImageBorder) {
  // A mask cut by the image border: the border is not the object's boundary.
  const cv::Mat square = RectMask(cv::Rect(0, 0, 50, 50));
  const cv::Mat eroded = DegradeMask(square, {}, Options(MaskDegradation::kErode, 6), 1);
  EXPECT_EQ(BoundingBox(eroded), cv::Rect(0, 0, 44, 44));
}

TEST(DegradeMask, JitterMovesTheBoundaryByAtMostSizePx) {
  const double radius_px = 40;
  const cv::Mat disc = DiscMask(100, 100, radius_px);
  for (const int size_px : {3, 6, 10}) {
    for (const uint64_t seed : {1, 2, 3}) {
      MaskDegradeOptions options = Options(MaskDegradation::kJitter, size_px);
      options.seed = seed;
      const cv::Mat jittered = DegradeMask(disc, {}, options, 11);
      ASSERT_TRUE(IsZeroOr255(jittered));
      int added = 0, removed = 0;
      for (int v = 0; v < kSize; ++v) {
        for (int u = 0; u < kSize; ++u) {
          if (jittered.at<uint8_t>(v, u) == disc.at<uint8_t>(v, u)) continue;
          // The disc's boundary is the circle, so this is the distance to it.
          const double to_boundary_px = std::abs(std::hypot(u - 100.0, v - 100.0) - radius_px);
          ASSERT_LE(to_boundary_px, size_px + 1.0)
              << "(" << u << ", " << v << "), " << size_px << " px, seed " << seed;
          (jittered.at<uint8_t>(v, u) ? added : removed) += 1;
        }
      }
      // It moves both ways, by a visible amount.
      EXPECT_GT(added, 0);
      EXPECT_GT(removed, 0);
      EXPECT_GT(added + removed, 0.1 * size_px * 2 * M_PI * radius_px);
    }
  }
}

TEST(DegradeMask, JitterIsDeterministicForASeedAndKey) {
  const cv::Mat disc = DiscMask(100, 100, 40);
  MaskDegradeOptions options = Options(MaskDegradation::kJitter);
  const cv::Mat first = DegradeMask(disc, {}, options, 5);
  EXPECT_EQ(cv::countNonZero(DegradeMask(disc, {}, options, 5) != first), 0);
  EXPECT_GT(cv::countNonZero(DegradeMask(disc, {}, options, 6) != first), 0);
  options.seed = 2;
  EXPECT_GT(cv::countNonZero(DegradeMask(disc, {}, options, 5) != first), 0);
}

TEST(DegradeMask, CutRemovesTheFractionOnOneSideOfALine) {
  // The checker itself: a stripe out of the middle of a square is not one side of a line.
  const cv::Mat square = RectMask(cv::Rect(40, 40, 60, 60));
  const cv::Mat stripe = RectMask(cv::Rect(60, 40, 20, 60));
  ASSERT_FALSE(SeparableByALine(Pixels(square & ~stripe), Pixels(stripe)));
  ASSERT_TRUE(SeparableByALine(Pixels(square & ~stripe & RectMask(cv::Rect(0, 0, 60, kSize))),
                               Pixels(stripe)));

  const std::vector<cv::Mat> shapes = {DiscMask(100, 100, 40), RectMask(cv::Rect(40, 60, 90, 50))};
  for (const cv::Mat& shape : shapes) {
    for (const double fraction : {0.1, 0.3, 0.5}) {
      for (uint64_t seed = 1; seed <= 8; ++seed) {
        MaskDegradeOptions options = Options(MaskDegradation::kCut);
        options.cut_fraction = fraction;
        options.seed = seed;
        const cv::Mat cut = DegradeMask(shape, {}, options, 3);
        ASSERT_TRUE(IsZeroOr255(cut));
        ASSERT_TRUE(IsSubset(cut, shape));
        const double removed_fraction = 1.0 - static_cast<double>(Area(cut)) / Area(shape);
        EXPECT_NEAR(removed_fraction, fraction, 0.05) << "seed " << seed;
        cv::Mat removed;
        cv::bitwise_and(shape, ~cut, removed);
        EXPECT_TRUE(SeparableByALine(Pixels(cut), Pixels(removed)))
            << "fraction " << fraction << ", seed " << seed;
      }
    }
  }
}

TEST(DegradeMask, CutDirectionDependsOnTheSeedAndKey) {
  const cv::Mat disc = DiscMask(100, 100, 40);
  MaskDegradeOptions options = Options(MaskDegradation::kCut);
  const cv::Mat first = DegradeMask(disc, {}, options, 1);
  EXPECT_EQ(cv::countNonZero(DegradeMask(disc, {}, options, 1) != first), 0);
  EXPECT_GT(cv::countNonZero(DegradeMask(disc, {}, options, 2) != first), 0);
  options.seed = 9;
  EXPECT_GT(cv::countNonZero(DegradeMask(disc, {}, options, 1) != first), 0);
}

TEST(DegradeMask, CutOfZeroKeepsTheMask) {
  const cv::Mat disc = DiscMask(100, 100, 40);
  MaskDegradeOptions options = Options(MaskDegradation::kCut);
  options.cut_fraction = 0.0;
  EXPECT_EQ(cv::countNonZero(DegradeMask(disc, {}, options, 1) != disc), 0);
}

TEST(DegradeMask, MergeTakesInTouchingNeighboursOnly) {
  const cv::Mat square = RectMask(cv::Rect(20, 20, 40, 40));
  const cv::Mat touching = RectMask(cv::Rect(60, 20, 40, 40));  // shares the edge x = 60
  const cv::Mat near = RectMask(cv::Rect(20, 64, 40, 20));      // 4 px gap below
  const cv::Mat far = RectMask(cv::Rect(140, 140, 40, 40));
  bool merged = false;
  const cv::Mat result =
      DegradeMask(square, {touching, near, far}, Options(MaskDegradation::kMerge, 6), 1, &merged);
  EXPECT_TRUE(merged);
  EXPECT_TRUE(IsZeroOr255(result));
  cv::Mat expected = square | touching | near;
  EXPECT_EQ(cv::countNonZero(result != expected), 0);

  // Within 2 px the 4 px gap is not touching.
  const cv::Mat tight =
      DegradeMask(square, {touching, near, far}, Options(MaskDegradation::kMerge, 2), 1, &merged);
  EXPECT_TRUE(merged);
  expected = square | touching;
  EXPECT_EQ(cv::countNonZero(tight != expected), 0);
}

TEST(DegradeMask, MergeWithoutANeighbourKeepsTheMaskAndSaysSo) {
  const cv::Mat square = RectMask(cv::Rect(20, 20, 40, 40));
  const cv::Mat far = RectMask(cv::Rect(140, 140, 40, 40));
  bool merged = true;
  const cv::Mat result = DegradeMask(square, {far}, Options(MaskDegradation::kMerge), 1, &merged);
  EXPECT_FALSE(merged);
  EXPECT_EQ(cv::countNonZero(result != square), 0);
  merged = true;
  DegradeMask(square, {}, Options(MaskDegradation::kMerge), 1, &merged);
  EXPECT_FALSE(merged);
}

TEST(DegradeMask, OtherModesNeverReportAMerge) {
  const cv::Mat square = RectMask(cv::Rect(20, 20, 40, 40));
  const cv::Mat touching = RectMask(cv::Rect(60, 20, 40, 40));
  bool merged = true;
  const cv::Mat result =
      DegradeMask(square, {touching}, Options(MaskDegradation::kDilate), 1, &merged);
  EXPECT_FALSE(merged);
  EXPECT_EQ(cv::countNonZero(result & touching), 6 * 40);  // dilation only, no union
}

TEST(DegradeMask, BoxIsTheGrownBoundingRectangle) {
  const cv::Mat disc = DiscMask(100, 80, 30);
  const cv::Mat box = DegradeMask(disc, {}, Options(MaskDegradation::kBox, 6), 1);
  EXPECT_TRUE(IsZeroOr255(box));
  // The disc spans columns 70..130 and rows 50..110.
  EXPECT_EQ(cv::countNonZero(box != RectMask(cv::Rect(64, 44, 73, 73))), 0);
}

TEST(DegradeMask, BoxIsClippedToTheImage) {
  cv::Mat corner = cv::Mat::zeros(kSize, kSize, CV_8U);
  corner.at<uint8_t>(2, 3) = 255;
  corner.at<uint8_t>(9, 195) = 255;
  const cv::Mat box = DegradeMask(corner, {}, Options(MaskDegradation::kBox, 6), 1);
  EXPECT_EQ(cv::countNonZero(box != RectMask(cv::Rect(0, 0, kSize, 16))), 0);
}

TEST(DegradeMask, EmptyMaskStaysEmptyInEveryMode) {
  const cv::Mat empty = cv::Mat::zeros(kSize, kSize, CV_8U);
  const cv::Mat other = RectMask(cv::Rect(20, 20, 40, 40));
  for (const char* name : {"none", "erode", "dilate", "jitter", "cut", "merge", "box"}) {
    const cv::Mat result = DegradeMask(empty, {other}, Options(ParseMaskDegradation(name)), 1);
    EXPECT_EQ(result.size(), empty.size()) << name;
    EXPECT_EQ(Area(result), 0) << name;
  }
}

TEST(DegradeMask, BadInputsThrowSayingWhat) {
  const cv::Mat square = RectMask(cv::Rect(20, 20, 40, 40));
  MaskDegradeOptions bad = Options(MaskDegradation::kErode, -1);
  EXPECT_THAT([&] { DegradeMask(square, {}, bad, 1); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("size_px")));
  EXPECT_THAT([&] { DegradeMask(cv::Mat(), {}, Options(MaskDegradation::kErode), 1); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("CV_8UC1")));
  const cv::Mat small = cv::Mat::zeros(10, 10, CV_8U);
  EXPECT_THAT([&] { DegradeMask(square, {small}, Options(MaskDegradation::kMerge), 1); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("other mask 0")));
}

TEST(MaskDegradeOptions, CheckNamesTheBadField) {
  EXPECT_EQ(MaskDegradeOptions().Check(), "");
  MaskDegradeOptions options;
  options.size_px = -2;
  EXPECT_THAT(options.Check(), testing::HasSubstr("size_px"));
  options = MaskDegradeOptions();
  options.cut_fraction = 1.0;
  EXPECT_THAT(options.Check(), testing::HasSubstr("cut_fraction"));
  options.cut_fraction = -0.1;
  EXPECT_THAT(options.Check(), testing::HasSubstr("cut_fraction"));
}

TEST(ParseMaskDegradation, NamesRoundTrip) {
  for (const MaskDegradation mode :
       {MaskDegradation::kNone, MaskDegradation::kErode, MaskDegradation::kDilate,
        MaskDegradation::kJitter, MaskDegradation::kCut, MaskDegradation::kMerge,
        MaskDegradation::kBox}) {
    EXPECT_EQ(ParseMaskDegradation(MaskDegradationName(mode)), mode);
  }
  EXPECT_EQ(MaskDegradationName(MaskDegradation::kJitter), "jitter");
  EXPECT_EQ(MaskDegradationNames(), "none, erode, dilate, jitter, cut, merge, box");
}

TEST(ParseMaskDegradation, BadNameIsNamedWithTheValidOnes) {
  EXPECT_THAT([] { ParseMaskDegradation("eroded"); },
              testing::ThrowsMessage<Error>(testing::AllOf(
                  testing::HasSubstr("'eroded'"),
                  testing::HasSubstr("none, erode, dilate, jitter, cut, merge, box"))));
  EXPECT_THROW(ParseMaskDegradation(""), Error);
  EXPECT_THROW(ParseMaskDegradation("Erode"), Error);
}

TEST(MaskInstanceKey, IsStableAndDistinguishesTheIds) {
  // A golden value: the key must not change between versions, or degraded runs would not
  // be comparable.
  EXPECT_EQ(MaskInstanceKey(48, 1, 0), 0xe134afcb653d8f64ULL);
  EXPECT_NE(MaskInstanceKey(48, 1, 0), MaskInstanceKey(48, 1, 1));
  EXPECT_NE(MaskInstanceKey(48, 1, 0), MaskInstanceKey(48, 0, 1));
  EXPECT_NE(MaskInstanceKey(1, 48, 0), MaskInstanceKey(48, 1, 0));
}

TEST(MaskIou, OfKnownOverlaps) {
  const cv::Mat a = RectMask(cv::Rect(0, 0, 20, 10));
  const cv::Mat b = RectMask(cv::Rect(10, 0, 20, 10));
  EXPECT_DOUBLE_EQ(MaskIou(a, b), 100.0 / 300.0);
  EXPECT_DOUBLE_EQ(MaskIou(a, a), 1.0);
  const cv::Mat empty = cv::Mat::zeros(kSize, kSize, CV_8U);
  EXPECT_DOUBLE_EQ(MaskIou(empty, empty), 1.0);
  EXPECT_DOUBLE_EQ(MaskIou(a, empty), 0.0);
  EXPECT_THROW(MaskIou(a, cv::Mat::zeros(5, 5, CV_8U)), Error);
}

// The simulated sensor's scenes: 640 x 480, fx = fy = 572.4.
const Camera kSensorCamera{572.4, 572.4, 320.0, 240.0, 640, 480};

// A model with one effect on: `keep` names it (the others off).
DepthSensorModel OnlySensorEffect(const std::string& keep) {
  DepthSensorModel model;
  if (keep != "noise") model.noise_at_1m_m = 0.0;
  if (keep != "grazing") model.max_incidence_deg = 90.0;
  if (keep != "edges") model.edge_drop = 0.0;
  if (keep != "dropout") model.dropout = 0.0;
  return model;
}

// A plane at `z_m` facing the camera, with a box `box_z_m` closer in `box` (0 = none).
cv::Mat PlaneDepth(float z_m, const cv::Rect& box = cv::Rect(), float box_z_m = 0.0f) {
  cv::Mat depth(kSensorCamera.height, kSensorCamera.width, CV_32F, cv::Scalar(z_m));
  if (box.area() > 0) depth(box).setTo(box_z_m);
  return depth;
}

TEST(SimulateDepthSensor, TheProjectorShadowsABandLeftOfACloserBox) {
  const cv::Rect box(300, 200, 60, 80);
  const cv::Mat depth = PlaneDepth(1.0f, box, 0.8f);
  const DepthSensorModel model = OnlySensorEffect("shadows");
  const cv::Mat out = SimulateDepthSensor(depth, cv::Mat(), kSensorCamera, model, 1);
  // The band: fx * baseline * (1/0.8 - 1/1.0) = 10.7 px of the plane left of the box.
  const double band_px = kSensorCamera.fx * model.baseline_m * (1.0 / 0.8 - 1.0 / 1.0);
  for (int v : {210, 240, 270}) {
    int left = 0, right = 0;
    for (int u = 270; u < box.x; ++u) left += out.at<float>(v, u) == 0.0f;
    for (int u = box.x + box.width; u < box.x + box.width + 30; ++u) right += out.at<float>(v, u) == 0.0f;
    EXPECT_NEAR(left, band_px, 1.0) << "row " << v;
    EXPECT_EQ(right, 0) << "row " << v;
    EXPECT_GT(out.at<float>(v, box.x + 30), 0.0f);  // the box itself is lit
  }
  // Above and below the box nothing is shadowed.
  EXPECT_EQ(cv::countNonZero(out(cv::Rect(0, 0, 640, 190)) == 0.0f), 0);
}

TEST(SimulateDepthSensor, NoiseGrowsWithTheSquareOfDepthOnDisparitySteps) {
  const DepthSensorModel model = OnlySensorEffect("noise");
  for (const float z : {1.0f, 2.0f}) {
    const cv::Mat out = SimulateDepthSensor(PlaneDepth(z), cv::Mat(), kSensorCamera, model, 3);
    double sum = 0.0, sum2 = 0.0;
    int n = 0;
    bool on_steps = true;
    const double focal_baseline = kSensorCamera.fx * model.baseline_m;
    for (int v = 10; v < 470; v += 3) {
      for (int u = 10; u < 630; u += 3) {
        const double measured = out.at<float>(v, u);
        ASSERT_GT(measured, 0.0);
        sum += measured - z;
        sum2 += (measured - z) * (measured - z);
        ++n;
        const double steps = focal_baseline / measured / model.disparity_step_px;
        on_steps = on_steps && std::abs(steps - std::round(steps)) < 0.02;
      }
    }
    const double sigma = std::sqrt(sum2 / n - (sum / n) * (sum / n));
    // sigma_z = 1.5 mm * z^2, widened a little by the disparity steps (2.6 mm at 1 m).
    EXPECT_NEAR(sigma, model.noise_at_1m_m * z * z, 0.25 * model.noise_at_1m_m * z * z) << "z " << z;
    EXPECT_NEAR(sum / n, 0.0, 0.2 * model.noise_at_1m_m * z * z) << "z " << z;
    EXPECT_TRUE(on_steps) << "z " << z;
  }
}

TEST(SimulateDepthSensor, AGrazingSurfaceHasNoDepth) {
  const DepthSensorModel model = OnlySensorEffect("grazing");
  for (const double tilt_deg : {45.0, 82.0}) {
    // A plane through (0, 0, 1 m) turned about the y axis: n . X = n_z.
    const double t = tilt_deg * M_PI / 180.0;
    cv::Mat depth(kSensorCamera.height, kSensorCamera.width, CV_32F);
    for (int v = 0; v < depth.rows; ++v) {
      for (int u = 0; u < depth.cols; ++u) {
        const double x = (u - kSensorCamera.cx) / kSensorCamera.fx;
        const double along = std::sin(t) * x + std::cos(t);
        depth.at<float>(v, u) = along > 0.05 ? static_cast<float>(std::cos(t) / along) : 0.0f;
      }
    }
    const cv::Mat out = SimulateDepthSensor(depth, cv::Mat(), kSensorCamera, model, 1);
    const cv::Mat centre = out(cv::Rect(300, 200, 40, 80));
    const double kept = static_cast<double>(cv::countNonZero(centre > 0.0f)) / centre.total();
    if (tilt_deg < 60.0) EXPECT_EQ(kept, 1.0);
    else EXPECT_EQ(kept, 0.0);
  }
}

TEST(SimulateDepthSensor, DarkAndShiningSurfacesLoseDepthInBlobs) {
  const DepthSensorModel model = OnlySensorEffect("none");
  for (const int grey : {20, 128, 240}) {
    const cv::Mat rgb(kSensorCamera.height, kSensorCamera.width, CV_8UC3, cv::Scalar(grey, grey, grey));
    const cv::Mat out = SimulateDepthSensor(PlaneDepth(1.0f), rgb, kSensorCamera, model, 5);
    const cv::Mat lost = out == 0.0f;
    const double rate = static_cast<double>(cv::countNonZero(lost)) / lost.total();
    const double expected = grey < model.dark_grey ? model.dark_drop : grey >= model.bright_grey ? model.bright_drop : 0.0;
    EXPECT_NEAR(rate, expected, 0.02) << "grey " << grey;
    if (expected == 0.0) continue;
    // Blobs, not speckle: a lost pixel's right neighbour is lost far more often than the rate.
    int pairs = 0, both = 0;
    for (int v = 0; v < lost.rows; ++v) {
      for (int u = 0; u + 1 < lost.cols; ++u) {
        if (!lost.at<uint8_t>(v, u)) continue;
        ++pairs;
        both += lost.at<uint8_t>(v, u + 1) != 0;
      }
    }
    EXPECT_GT(static_cast<double>(both) / pairs, expected + 0.3) << "grey " << grey;
  }
}

TEST(SimulateDepthSensor, IsRepeatableAndDiffersByFrame) {
  const cv::Mat depth = PlaneDepth(1.2f, cv::Rect(200, 150, 100, 100), 0.9f);
  const cv::Mat rgb(kSensorCamera.height, kSensorCamera.width, CV_8UC3, cv::Scalar(30, 30, 30));
  const DepthSensorModel model;
  const cv::Mat a = SimulateDepthSensor(depth, rgb, kSensorCamera, model, MaskInstanceKey(2, 8, -1));
  const cv::Mat b = SimulateDepthSensor(depth, rgb, kSensorCamera, model, MaskInstanceKey(2, 8, -1));
  const cv::Mat c = SimulateDepthSensor(depth, rgb, kSensorCamera, model, MaskInstanceKey(2, 9, -1));
  EXPECT_EQ(cv::countNonZero(a != b), 0);
  EXPECT_GT(cv::countNonZero(a != c), 1000);
  // Every default effect together leaves most of the plane and the box measured.
  const double kept = static_cast<double>(cv::countNonZero(a > 0.0f)) / a.total();
  EXPECT_GT(kept, 0.6);
  EXPECT_LT(kept, 0.8);  // the dark surface loses 30%
}

TEST(SimulateDepthSensor, BadInputIsRefusedByName) {
  const DepthSensorModel model;
  EXPECT_THAT([&] { SimulateDepthSensor(cv::Mat::zeros(480, 640, CV_16U), cv::Mat(), kSensorCamera, model, 1); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("CV_32F")));
  EXPECT_THAT([&] { SimulateDepthSensor(cv::Mat::zeros(240, 320, CV_32F), cv::Mat(), kSensorCamera, model, 1); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("640x480")));
  EXPECT_THAT([&] { SimulateDepthSensor(PlaneDepth(1.0f), cv::Mat::zeros(480, 640, CV_8U), kSensorCamera, model, 1); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("colour image")));
  DepthSensorModel bad;
  bad.edge_drop = 1.5;
  EXPECT_THAT([&] { SimulateDepthSensor(PlaneDepth(1.0f), cv::Mat(), kSensorCamera, bad, 1); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("edge_drop")));
  bad = DepthSensorModel();
  bad.baseline_m = 0.0;
  EXPECT_NE(bad.Check().find("baseline_m"), std::string::npos);
  EXPECT_EQ(DepthSensorModel().Check(), "");
  const DepthSensorModel quiet = WithoutSensorEffects(model, "shadows,grazing,edges,noise,dark,bright,speckle");
  EXPECT_FALSE(quiet.shadows);
  EXPECT_FALSE(quiet.edges);
  EXPECT_EQ(quiet.noise_at_1m_m, 0.0);
  EXPECT_EQ(quiet.dark_drop + quiet.bright_drop + quiet.dropout, 0.0);
  const cv::Mat box = PlaneDepth(1.0f, cv::Rect(300, 200, 60, 80), 0.8f);
  // All off: every pixel measured, moved by at most half a disparity step (1.5 mm at 1 m).
  const cv::Mat quiet_box = SimulateDepthSensor(box, cv::Mat(), kSensorCamera, quiet, 1);
  EXPECT_EQ(cv::countNonZero(quiet_box > 0.0f), static_cast<int>(box.total()));
  double largest = 0.0;
  for (int v = 0; v < box.rows; ++v) {
    for (int u = 0; u < box.cols; ++u) largest = std::max(largest, std::abs(double(quiet_box.at<float>(v, u)) - box.at<float>(v, u)));
  }
  EXPECT_LT(largest, 0.5 * model.disparity_step_px / (kSensorCamera.fx * model.baseline_m) + 1e-6);
  EXPECT_THAT([&] { WithoutSensorEffects(model, "noise,blur"); },
              testing::ThrowsMessage<Error>(testing::HasSubstr("'blur'")));
  EXPECT_FALSE(ParseDepthSensorName("none"));
  EXPECT_TRUE(ParseDepthSensorName("structured-light"));
  EXPECT_THAT([] { ParseDepthSensorName("kinect"); },
              testing::ThrowsMessage<Error>(testing::AllOf(testing::HasSubstr("'kinect'"),
                                                           testing::HasSubstr("none, structured-light"))));
}

}  // namespace
}  // namespace g6d
