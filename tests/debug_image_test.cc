// wire/debug_image.h without a bus: labels, what DrawDebugImage draws for answered,
// failed and bank-less estimates, its refusals, and the JPEG messages' true colours.
#include "wire/debug_image.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "test_meshes.h"
#include "wire/image_codec.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;

const Camera kCamera{500.0, 500.0, 320.0, 240.0, 640, 480};

pose_estimate_t Estimate(const std::string& object_id, int8_t status, const std::string& message) {
  pose_estimate_t estimate{};
  estimate.object_id = object_id;
  estimate.status = status;
  estimate.message = message;
  estimate.orientation[0] = 1.0;
  estimate.mode = pose_estimate_t::MODE_DETECTED;
  return estimate;
}

// A frame of one grey colour with two requested instances: a cube answered 0.5 m ahead,
// and an instance (the box 40..120 x 40..100) that failed.
DebugImageInput TwoInstances() {
  DebugImageInput input;
  input.camera = kCamera;
  input.rgb = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 90, 90));
  DecodedInstance answered, failed;
  answered.object_id = "cube";
  failed.object_id = "other";
  failed.mask = cv::Mat::zeros(480, 640, CV_8U);
  failed.mask(cv::Rect(40, 40, 80, 60)).setTo(255);
  input.instances = {answered, failed};
  pose_estimate_t ok = Estimate("cube", pose_estimate_t::STATUS_OK, "ok");
  ok.position[2] = 0.5;
  ok.score = 0.0841;
  ok.confidence = 0.93;
  ok.mode = pose_estimate_t::MODE_TRACKED;
  input.answer.estimates = {
      ok, Estimate("other", pose_estimate_t::STATUS_NO_SOLUTION, "too few matches")};
  input.answer.estimates[1].request_index = 1;  // each answers its own instance
  input.answer.num_estimates = 2;
  auto bank = std::make_shared<TemplateBank>();
  bank->object_id = "cube";
  bank->online_mesh = test::MakeCube(0.05);
  bank->diameter_m = 0.1 * std::sqrt(3.0);
  bank->bounding_box =
      Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-0.05), Eigen::Vector3d::Constant(0.05));
  input.banks["cube"] = bank;
  return input;
}

TEST(DebugLabel, SaysObjectScoreConfidenceAndModeOrTheFailure) {
  const DebugImageInput input = TwoInstances();
  EXPECT_EQ(DebugLabel(input.answer.estimates[0]), "cube S 0.084 c 0.93 tracked");
  EXPECT_EQ(DebugLabel(input.answer.estimates[1]), "other no_solution: too few matches");
  const pose_estimate_t long_failure =
      Estimate("", pose_estimate_t::STATUS_BAD_INPUT, std::string(200, 'x'));
  const std::string label = DebugLabel(long_failure);
  EXPECT_THAT(label, HasSubstr("(unknown) bad_input: "));
  EXPECT_LT(label.size(), 90u) << "a long message is cut";
}

TEST(DrawDebugImage, DrawsPosesFailuresAndLabels) {
  const DebugImageInput input = TwoInstances();
  DebugImageReport report;
  const cv::Mat picture = DrawDebugImage(input, OverlayStyle(), &report);
  EXPECT_EQ(report.poses_drawn, 1);
  EXPECT_EQ(report.failures_drawn, 1);
  ASSERT_EQ(report.label_boxes.size(), 2u);
  const OverlayStyle style;
  cv::Mat contour, failure;
  cv::inRange(picture, style.contour_color, style.contour_color, contour);
  cv::inRange(picture, style.failure_color, style.failure_color, failure);
  EXPECT_GT(cv::countNonZero(contour), 300) << "the cube's contour (about 4 x 111 px)";
  // The failed instance's box outline: on its top edge, not inside it.
  EXPECT_GT(cv::countNonZero(failure(cv::Rect(40, 40, 80, 2))), 60);
  EXPECT_EQ(cv::countNonZero(failure(cv::Rect(50, 50, 60, 40))), 0);
  EXPECT_EQ(input.rgb.at<cv::Vec3b>(40, 60), cv::Vec3b(90, 90, 90))
      << "the input image is not drawn on";
}

TEST(DrawDebugImage, LabelsOfObjectsSideBySideDoNotCoverEachOther) {
  DebugImageInput input = TwoInstances();
  // Three answers of the cube 1 cm apart: their silhouette boxes start at the same height.
  input.instances = {input.instances[0], input.instances[0], input.instances[0]};
  pose_estimate_t ok = input.answer.estimates[0];
  input.answer.estimates = {ok, ok, ok};
  input.answer.estimates[1].position[0] = 0.01;
  input.answer.estimates[2].position[0] = 0.02;
  DebugImageReport report;
  DrawDebugImage(input, OverlayStyle(), &report);
  ASSERT_EQ(report.label_boxes.size(), 3u);
  for (size_t a = 0; a < 3; ++a) {
    for (size_t b = a + 1; b < 3; ++b) {
      EXPECT_EQ((report.label_boxes[a] & report.label_boxes[b]).area(), 0)
          << "labels " << a << " and " << b;
    }
  }
}

TEST(DrawDebugImage, AnswerWithoutABankGetsItsLabelOnly) {
  DebugImageInput input = TwoInstances();
  input.banks.clear();
  DebugImageReport report;
  DrawDebugImage(input, OverlayStyle(), &report);
  EXPECT_EQ(report.poses_drawn, 0);
  EXPECT_EQ(report.label_boxes.size(), 2u);
}

TEST(DrawDebugImage, RefusesMismatchedInput) {
  DebugImageInput input = TwoInstances();
  input.instances.pop_back();
  EXPECT_THROW(DrawDebugImage(input, OverlayStyle()), Error);
  input = TwoInstances();
  input.rgb = cv::Mat(10, 10, CV_8UC3);
  EXPECT_THROW(DrawDebugImage(input, OverlayStyle()), Error);
}

TEST(MakeBotCoreJpeg, IsAnMjpegImageInTrueColours) {
  const cv::Mat red_rgb(48, 64, CV_8UC3, cv::Scalar(220, 30, 30));
  const bot_core::image_t message = MakeBotCoreJpeg(red_rgb, 90, 1234);
  EXPECT_EQ(message.pixelformat, +bot_core::image_t::PIXEL_FORMAT_MJPEG);
  EXPECT_EQ(message.utime, 1234);
  EXPECT_EQ(message.width, 64);
  EXPECT_EQ(message.height, 48);
  EXPECT_EQ(message.size, static_cast<int32_t>(message.data.size()));
  const cv::Mat bgr = cv::imdecode(message.data, cv::IMREAD_COLOR);
  ASSERT_FALSE(bgr.empty());
  const cv::Vec3b pixel = bgr.at<cv::Vec3b>(24, 32);
  EXPECT_GT(pixel[2], 180) << "red stays red for a viewer";
  EXPECT_LT(pixel[0], 70);

  const image_t g6d = MakeG6dJpeg(red_rgb, 90);
  EXPECT_EQ(g6d.compression, +image_t::COMPRESSION_JPEG);
  EXPECT_GT(DecodeImage(g6d, "debug").at<cv::Vec3b>(24, 32)[0], 180);
  EXPECT_THROW(ParseDebugImageType("png"), Error);
  EXPECT_EQ(ParseDebugImageType(DebugImageTypeName(DebugImageType::kG6d)), DebugImageType::kG6d);
}

}  // namespace
}  // namespace g6d
