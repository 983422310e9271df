#include "templates/features.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace g6d {
namespace {

// Random grey blocks (a texture ORB likes) inside a disc, black outside.
void TexturedDisc(cv::Size size, cv::Point centre, int radius, uint32_t seed, cv::Mat* image,
                  cv::Mat* mask) {
  *image = cv::Mat::zeros(size, CV_8UC3);
  *mask = cv::Mat::zeros(size, CV_8UC1);
  cv::circle(*mask, centre, radius, cv::Scalar(255), cv::FILLED);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> gray(0, 255);
  constexpr int kBlock = 9;
  cv::Mat texture(size, CV_8UC3);
  for (int v = 0; v < size.height; v += kBlock) {
    for (int u = 0; u < size.width; u += kBlock) {
      const int g = gray(rng);
      texture(cv::Rect(u, v, kBlock, kBlock) & cv::Rect(0, 0, size.width, size.height))
          .setTo(cv::Scalar(g, 255 - g, g / 2));
    }
  }
  texture.copyTo(*image, *mask);
}

TEST(DetectOrb, FindsFeaturesInsideTheSourceMask) {
  cv::Mat image, mask;
  TexturedDisc(cv::Size(640, 480), cv::Point(300, 250), 150, 1, &image, &mask);
  const NormalizedCrop crop = NormalizeCrop(image, mask, CropOptions());
  ASSERT_TRUE(crop.valid);
  const OrbOptions options;
  const std::vector<Feature> features = DetectOrb(crop, options);
  EXPECT_GE(features.size(), 200u);
  EXPECT_LE(features.size(), static_cast<size_t>(options.max_features));
  for (const Feature& f : features) {
    const int u = static_cast<int>(std::lround(f.xy.x()));
    const int v = static_cast<int>(std::lround(f.xy.y()));
    ASSERT_TRUE(u >= 0 && v >= 0 && u < mask.cols && v < mask.rows);
    EXPECT_EQ(mask.at<uint8_t>(v, u), 255) << "feature at " << f.xy.transpose();
  }
}

TEST(DetectOrb, MappingFollowsTheObject) {
  // Shifting image and mask by whole pixels gives the same crop, so the same keypoints
  // shifted by exactly that amount in source coordinates.
  cv::Mat image, mask;
  TexturedDisc(cv::Size(640, 480), cv::Point(250, 200), 120, 2, &image, &mask);
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 37, 0, 1, 21);
  cv::Mat image_shifted, mask_shifted;
  cv::warpAffine(image, image_shifted, shift, image.size(), cv::INTER_NEAREST);
  cv::warpAffine(mask, mask_shifted, shift, mask.size(), cv::INTER_NEAREST);
  const auto a = DetectOrb(NormalizeCrop(image, mask, CropOptions()), OrbOptions());
  const auto b = DetectOrb(NormalizeCrop(image_shifted, mask_shifted, CropOptions()), OrbOptions());
  ASSERT_EQ(a.size(), b.size());
  ASSERT_FALSE(a.empty());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(b[i].xy.x() - a[i].xy.x(), 37.0f, 1e-3f);
    EXPECT_NEAR(b[i].xy.y() - a[i].xy.y(), 21.0f, 1e-3f);
    EXPECT_EQ(a[i].descriptor, b[i].descriptor);
  }
}

TEST(DetectOrb, DeterministicAndEmptyForInvalidCrop) {
  cv::Mat image, mask;
  TexturedDisc(cv::Size(320, 240), cv::Point(160, 120), 90, 3, &image, &mask);
  const NormalizedCrop crop = NormalizeCrop(image, mask, CropOptions());
  const auto a = DetectOrb(crop, OrbOptions());
  const auto b = DetectOrb(crop, OrbOptions());
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].xy, b[i].xy);
    EXPECT_EQ(a[i].descriptor, b[i].descriptor);
  }
  EXPECT_TRUE(DetectOrb(NormalizedCrop(), OrbOptions()).empty());
}

TEST(DetectOrb, UniformObjectHasNoFeatures) {
  const cv::Mat image(240, 320, CV_8UC3, cv::Scalar(120, 120, 120));
  cv::Mat mask = cv::Mat::zeros(240, 320, CV_8UC1);
  cv::circle(mask, cv::Point(160, 120), 80, cv::Scalar(255), cv::FILLED);
  OrbOptions options;
  options.mask_erosion_px = 3;  // the disc's own rim is the only structure
  EXPECT_TRUE(DetectOrb(NormalizeCrop(image, mask, CropOptions()), options).empty());
}

TEST(DetectOrb, BadOptionsThrow) {
  OrbOptions options;
  options.scale_factor = 1.0f;
  EXPECT_NE(options.Check().find("scale_factor"), std::string::npos);
  cv::Mat image, mask;
  TexturedDisc(cv::Size(320, 240), cv::Point(160, 120), 90, 4, &image, &mask);
  EXPECT_THROW(DetectOrb(NormalizeCrop(image, mask, CropOptions()), options), Error);
}

}  // namespace
}  // namespace g6d
