#include "templates/crop.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace g6d {
namespace {

cv::Mat RectangleMask(cv::Size size, cv::Rect rect) {
  cv::Mat mask = cv::Mat::zeros(size, CV_8UC1);
  mask(rect).setTo(255);
  return mask;
}

// A bright Gaussian blob centred at (x, y) in OpenCV pixel coordinates on a dark ground.
cv::Mat BlobImage(cv::Size size, double x, double y, double sigma) {
  cv::Mat image(size, CV_8UC1);
  for (int v = 0; v < size.height; ++v) {
    for (int u = 0; u < size.width; ++u) {
      const double r2 = (u - x) * (u - x) + (v - y) * (v - y);
      image.at<uint8_t>(v, u) =
          cv::saturate_cast<uint8_t>(20.0 + 180.0 * std::exp(-0.5 * r2 / (sigma * sigma)));
    }
  }
  return image;
}

// Intensity centroid of the crop inside its mask, above the mask's minimum grey.
Eigen::Vector2d CropCentroid(const NormalizedCrop& crop) {
  double min_gray = 0.0;
  cv::minMaxLoc(crop.gray, &min_gray, nullptr, nullptr, nullptr, crop.mask);
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double weight_sum = 0.0;
  for (int v = 0; v < crop.gray.rows; ++v) {
    for (int u = 0; u < crop.gray.cols; ++u) {
      if (crop.mask.at<uint8_t>(v, u) == 0) continue;
      const double w = crop.gray.at<uint8_t>(v, u) - min_gray;
      sum += w * Eigen::Vector2d(u, v);
      weight_sum += w;
    }
  }
  return sum / weight_sum;
}

TEST(NormalizeCrop, EmptyMaskIsInvalid) {
  const cv::Mat image(100, 120, CV_8UC3, cv::Scalar(10, 20, 30));
  const cv::Mat mask = cv::Mat::zeros(100, 120, CV_8UC1);
  const NormalizedCrop crop = NormalizeCrop(image, mask, CropOptions());
  EXPECT_FALSE(crop.valid);
}

TEST(NormalizeCrop, RectangleMaskGivesExpectedSideCentredAndSquare) {
  CropOptions options;  // p = 0.15, S = 256
  const cv::Size size(320, 240);
  const cv::Rect rect(100, 60, 40, 20);
  const cv::Mat image(size, CV_8UC3, cv::Scalar(90, 90, 90));
  const NormalizedCrop crop = NormalizeCrop(image, RectangleMask(size, rect), options);
  ASSERT_TRUE(crop.valid);
  EXPECT_EQ(crop.gray.rows, 256);
  EXPECT_EQ(crop.gray.cols, 256);
  EXPECT_EQ(crop.mask.size(), crop.gray.size());
  // s = (1 + 2p) max(w, h) = 1.3 * 40 = 52.
  EXPECT_DOUBLE_EQ(crop.scale, 52.0 / 256.0);
  // The long side of the box spans S / (1 + 2p) crop pixels, centred; the short side is
  // scaled by the same factor (shape preserved).
  // (Up to a pixel per side: the mask is resampled in 1/32 source pixel fixed point.)
  const cv::Rect box = cv::boundingRect(crop.mask);
  EXPECT_NEAR(box.width, 256.0 / 1.3, 2.0);
  EXPECT_NEAR(box.height, 256.0 / 1.3 / 2.0, 2.0);
  EXPECT_NEAR(box.x + 0.5 * box.width, 128.0, 0.5);
  EXPECT_NEAR(box.y + 0.5 * box.height, 128.0, 0.5);
  // The crop's centre maps to the box centre (OpenCV coordinates: 119.5, 69.5).
  const Eigen::Vector2d centre = crop.ToSource(Eigen::Vector2d(127.5, 127.5));
  EXPECT_NEAR(centre.x(), 119.5, 1e-12);
  EXPECT_NEAR(centre.y(), 69.5, 1e-12);
}

TEST(NormalizeCrop, AffineRoundTripIsExact) {
  const cv::Size size(200, 150);
  const cv::Mat image(size, CV_8UC1, cv::Scalar(50));
  const NormalizedCrop crop =
      NormalizeCrop(image, RectangleMask(size, cv::Rect(13, 21, 77, 45)), CropOptions());
  ASSERT_TRUE(crop.valid);
  for (double x : {-3.25, 0.0, 17.5, 255.0}) {
    for (double y : {-1.0, 64.125, 300.0}) {
      const Eigen::Vector2d p(x, y);
      EXPECT_LT((crop.ToCrop(crop.ToSource(p)) - p).norm(), 1e-12);
    }
  }
}

// The image content lands where ToSource() says, to a small fraction of a pixel, both when
// the crop enlarges (small mask) and when it shrinks (large mask, anti-aliased).
TEST(NormalizeCrop, ImageContentFollowsTheAffineExactly) {
  struct Case {
    cv::Size size;
    cv::Rect mask_rect;
    double x, y, sigma;
  };
  const Case cases[] = {
      {{160, 120}, {60, 40, 40, 36}, 78.3, 59.7, 4.0},       // scale 0.2: enlarged
      {{640, 480}, {90, 50, 420, 400}, 301.6, 248.2, 25.0},  // scale 2.1: shrunk
      {{300, 300}, {0, 0, 300, 300}, 150.25, 140.8, 30.0},   // crop reaches outside the image
  };
  for (const Case& c : cases) {
    const cv::Mat image = BlobImage(c.size, c.x, c.y, c.sigma);
    const NormalizedCrop crop =
        NormalizeCrop(image, RectangleMask(c.size, c.mask_rect), CropOptions());
    ASSERT_TRUE(crop.valid);
    const Eigen::Vector2d found = crop.ToSource(CropCentroid(crop));
    EXPECT_NEAR(found.x(), c.x, 0.03 * std::max(1.0, crop.scale)) << "scale " << crop.scale;
    EXPECT_NEAR(found.y(), c.y, 0.03 * std::max(1.0, crop.scale)) << "scale " << crop.scale;
  }
}

TEST(NormalizeCrop, PixelsOutsideTheSourceAreBackground) {
  CropOptions options;
  options.background_gray = 77;
  const cv::Size size(200, 100);
  const cv::Mat image(size, CV_8UC3, cv::Scalar(200, 100, 50));
  // Touches the left image border: the padded crop reaches x < 0.
  const NormalizedCrop crop =
      NormalizeCrop(image, RectangleMask(size, cv::Rect(0, 30, 40, 40)), options);
  ASSERT_TRUE(crop.valid);
  // Source pixel 0 covers x in [-0.5, 0.5) (OpenCV convention); left of that is outside
  // (less OpenCV's 1/32 pixel fixed-point resolution of the sample positions).
  int outside_columns = 0;
  while (crop.ToSource(Eigen::Vector2d(outside_columns, 0.0)).x() < -0.5 - 1.0 / 32)
    ++outside_columns;
  ASSERT_GT(outside_columns, 5);
  for (int v = 0; v < crop.gray.rows; ++v) {
    for (int u = 0; u < outside_columns; ++u) {
      ASSERT_EQ(crop.mask.at<uint8_t>(v, u), 0);
      ASSERT_EQ(crop.gray.at<uint8_t>(v, u), 77);
    }
  }
}

TEST(NormalizeCrop, ContrastIsNormalizedInsideTheMask) {
  CropOptions options;
  const cv::Size size(300, 300);
  cv::Mat image(size, CV_8UC1);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> gray(95, 135);  // dull, low-contrast texture
  for (int v = 0; v < size.height; v += 4)
    for (int u = 0; u < size.width; u += 4) image(cv::Rect(u, v, 4, 4)).setTo(gray(rng));
  cv::Mat mask = cv::Mat::zeros(size, CV_8UC1);
  cv::circle(mask, cv::Point(150, 150), 100, cv::Scalar(255), cv::FILLED);
  const NormalizedCrop crop = NormalizeCrop(image, mask, options);
  ASSERT_TRUE(crop.valid);
  cv::Scalar mean, stddev;
  cv::meanStdDev(crop.gray, mean, stddev, crop.mask);
  EXPECT_NEAR(mean[0], options.normalized_mean, 2.0);
  EXPECT_NEAR(stddev[0], options.normalized_std, 3.0);
  // Outside the mask: the background grey.
  EXPECT_EQ(crop.gray.at<uint8_t>(2, 2), options.background_gray);
}

TEST(NormalizeCrop, RejectsBadInputs) {
  const cv::Mat image(50, 60, CV_8UC3, cv::Scalar::all(0));
  EXPECT_THROW(NormalizeCrop(image, cv::Mat::zeros(50, 61, CV_8UC1), CropOptions()), Error);
  EXPECT_THROW(NormalizeCrop(image, cv::Mat::zeros(50, 60, CV_32F), CropOptions()), Error);
  EXPECT_THROW(
      NormalizeCrop(cv::Mat(50, 60, CV_32FC3), cv::Mat::zeros(50, 60, CV_8UC1), CropOptions()),
      Error);
  CropOptions bad;
  bad.padding = -0.1;
  EXPECT_NE(bad.Check().find("padding"), std::string::npos);
  EXPECT_THROW(NormalizeCrop(image, cv::Mat::zeros(50, 60, CV_8UC1), bad), Error);
}

}  // namespace
}  // namespace g6d
