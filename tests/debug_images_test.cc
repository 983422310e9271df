// The service's debug pictures (--debug-images) over a real LCM bus (memq) with real
// rendering: the published JPEG, decoded with OpenCV, shows the model's contour along the
// silhouette of the answered pose and the original image away from it; a failed instance's
// mask outline in the failure colour; the rate limit, counted over frames.
#include "service/debug_images.h"

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "bot_core/image_t.hpp"
#include "render/raster.h"
#include "service/service.h"
#include "service_fixture.h"
#include "service_test_util.h"
#include "test_bank.h"
#include "wire/image_codec.h"

namespace g6d {
namespace {

using std::chrono::seconds;

constexpr int kNumViews = 3;

// Pixels of `rgb` (CV_8UC3 RGB) close to `color`: every channel within `tolerance`.
cv::Mat PixelsOfColor(const cv::Mat& rgb, const cv::Scalar& color, int tolerance) {
  cv::Mat near;
  cv::inRange(rgb, color - cv::Scalar::all(tolerance), color + cv::Scalar::all(tolerance), near);
  return near;
}

// The one-pixel inner boundary of a 0/255 mask.
cv::Mat Boundary(const cv::Mat& mask) {
  cv::Mat eroded;
  cv::erode(mask, eroded, cv::Mat::ones(3, 3, CV_8U));
  return mask - eroded;
}

// Fraction of `boundary` pixels within 2 px of a pixel of `drawn`.
double CoveredFraction(const cv::Mat& boundary, const cv::Mat& drawn) {
  cv::Mat near;
  cv::dilate(drawn, near, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
  const int total = cv::countNonZero(boundary);
  return total == 0 ? 0.0 : static_cast<double>(cv::countNonZero(boundary & near)) / total;
}

// Fraction of the pixels of `region` where `a` and `b` differ by at most `tolerance` in
// every channel.
double UnchangedFraction(const cv::Mat& a, const cv::Mat& b, const cv::Mat& region, int tolerance) {
  cv::Mat difference, max_channel;
  cv::absdiff(a, b, difference);
  std::vector<cv::Mat> channels;
  cv::split(difference, channels);
  max_channel = cv::max(channels[0], cv::max(channels[1], channels[2]));
  const cv::Mat unchanged = (max_channel <= tolerance) & region;
  return static_cast<double>(cv::countNonZero(unchanged)) / cv::countNonZero(region);
}

// Pixels farther than `distance_px` from every pixel of `boundary`.
cv::Mat FarFrom(const cv::Mat& boundary, int distance_px) {
  cv::Mat near;
  cv::dilate(boundary, near,
             cv::getStructuringElement(cv::MORPH_ELLIPSE,
                                       cv::Size(2 * distance_px + 1, 2 * distance_px + 1)));
  return near == 0;
}

/// Collects the pictures of one debug channel, of either type, as RGB images.
class PictureListener {
 public:
  PictureListener(lcm::LCM* lcm, const std::string& channel, DebugImageType type) : lcm_(lcm) {
    subscription_ = type == DebugImageType::kBotCore
                        ? lcm->subscribe(channel, &PictureListener::OnBotCore, this)
                        : lcm->subscribe(channel, &PictureListener::OnG6d, this);
    subscription_->setQueueCapacity(1000);
  }
  ~PictureListener() { lcm_->unsubscribe(subscription_); }

  struct Picture {
    cv::Mat rgb;
    int64_t utime = -1;       ///< bot_core only
    int32_t pixelformat = 0;  ///< bot_core only
    int32_t declared_width = 0, declared_height = 0;
  };
  test::Inbox<Picture> pictures;

 private:
  void OnBotCore(const lcm::ReceiveBuffer*, const std::string&, const bot_core::image_t* image) {
    Picture picture;
    const cv::Mat bgr = cv::imdecode(image->data, cv::IMREAD_COLOR);
    if (!bgr.empty()) cv::cvtColor(bgr, picture.rgb, cv::COLOR_BGR2RGB);
    picture.utime = image->utime;
    picture.pixelformat = image->pixelformat;
    picture.declared_width = image->width;
    picture.declared_height = image->height;
    pictures.Push(picture);
  }
  void OnG6d(const lcm::ReceiveBuffer*, const std::string&, const image_t* image) {
    Picture picture;
    picture.rgb = DecodeImage(*image, "debug image");
    picture.declared_width = image->width;
    picture.declared_height = image->height;
    pictures.Push(picture);
  }
  lcm::LCM* lcm_;
  lcm::Subscription* subscription_ = nullptr;
};

class DebugImagesTest : public test::InProcessServiceTest {
 protected:
  static void SetUpTestSuite() {
    scene_ = new test::ServiceScene(
        test::MakeServiceScene(kNumViews, 11, test::SharedBankBuilder("service-scene")));
  }
  static void TearDownTestSuite() { delete scene_; }

  static ServiceOptions Options(const std::string& suffix) {
    ServiceOptions options = test::InProcessServiceOptions(suffix);
    options.debug_images.channel = "G6D_DEBUG_" + suffix;
    // Every view is a detection: the picture is about one answer at a time.
    options.tracking.enabled = false;
    return options;
  }

  void StartService(const ServiceOptions& options) {
    pictures_ = std::make_unique<PictureListener>(&lcm_, options.debug_images.channel,
                                                  options.debug_images.type);
    InProcessServiceTest::StartService(options, test::StoreOf(scene_->bank));
  }

  pose_array_t Answer(const rgbd_frame_t& frame) {
    Publish(frame);
    return NextAnswer();
  }

  PictureListener::Picture NextPicture() {
    std::optional<PictureListener::Picture> picture = pictures_->pictures.Pop(seconds(60));
    if (!picture) ADD_FAILURE() << "no debug image within 60 s";
    return picture.value_or(PictureListener::Picture{});
  }

  void TearDown() override {
    InProcessServiceTest::TearDown();
    pictures_.reset();
  }

  static test::ServiceScene* scene_;
  std::unique_ptr<PictureListener> pictures_;
};
test::ServiceScene* DebugImagesTest::scene_ = nullptr;

TEST_F(DebugImagesTest, ContourFollowsTheAnsweredSilhouetteAndTheRestIsTheImage) {
  ServiceOptions options = Options("contour");
  options.debug_images.max_rate_hz = 1000.0;  // every frame sent one at a time gets its picture
  StartService(options);
  const OverlayStyle style;
  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE("view " + std::to_string(i));
    const test::SyntheticView& view = scene_->views[i];
    const rgbd_frame_t frame = test::MakeRgbdFrame(view, 10 + i, test::kBoxId);
    const pose_array_t answer = Answer(frame);
    ASSERT_EQ(answer.num_estimates, 1);
    const pose_estimate_t& estimate = answer.estimates[0];
    ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK) << estimate.message;

    const PictureListener::Picture picture = NextPicture();
    ASSERT_FALSE(picture.rgb.empty()) << "the JPEG did not decode";
    EXPECT_EQ(picture.pixelformat, +bot_core::image_t::PIXEL_FORMAT_MJPEG);
    EXPECT_EQ(picture.utime, frame.utime) << "the picture carries the frame's capture time";
    EXPECT_EQ(picture.declared_width, 640);
    EXPECT_EQ(picture.declared_height, 480);
    ASSERT_EQ(picture.rgb.size(), view.rgb.size());

    // The silhouette of the mesh at the answered pose, rendered here independently.
    RasterImage raster;
    Rasterize(scene_->bank.online_mesh, test::kServiceCamera, test::PoseOf(estimate),
              RasterOptions(), &raster);
    const cv::Mat boundary = Boundary(raster.Mask());
    ASSERT_GT(cv::countNonZero(boundary), 100);
    // JPEG shifts colours, most near sharp lines: a generous tolerance, still far from
    // the grey background and the box's texture (the control below).
    constexpr int kTolerance = 70;
    const double covered =
        CoveredFraction(boundary, PixelsOfColor(picture.rgb, style.contour_color, kTolerance));
    EXPECT_GT(covered, 0.85) << "the contour colour along the answered silhouette";
    const double covered_before =
        CoveredFraction(boundary, PixelsOfColor(view.rgb, style.contour_color, kTolerance));
    EXPECT_LT(covered_before, 0.2)
        << "the frame itself has the contour colour there: the check proves nothing";

    // Away from the silhouette the picture is the frame (up to JPEG), except the label
    // and the axis tips: a few per cent of the pixels at most.
    const cv::Mat far = FarFrom(boundary, 10);
    EXPECT_GT(UnchangedFraction(picture.rgb, view.rgb, far, 24), 0.95);
  }
  service_->Stop();
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.debug_images_published, 2);
  EXPECT_EQ(counters.debug_images_skipped, 0);
}

TEST_F(DebugImagesTest, FailedInstanceIsOutlinedInTheFailureColourAsG6dImage) {
  ServiceOptions options = Options("failed");
  options.debug_images.type = DebugImageType::kG6d;
  StartService(options);
  const test::SyntheticView& view = scene_->views[2];
  // No template cache for this object: STATUS_UNKNOWN_OBJECT, the mask outlined.
  const pose_array_t answer = Answer(test::MakeRgbdFrame(view, 20, "obj_not_loaded"));
  ASSERT_EQ(answer.num_estimates, 1);
  ASSERT_EQ(answer.estimates[0].status, +pose_estimate_t::STATUS_UNKNOWN_OBJECT);
  const PictureListener::Picture picture = NextPicture();
  ASSERT_EQ(picture.rgb.size(), view.rgb.size());
  EXPECT_EQ(picture.declared_width, 640);
  const cv::Mat boundary = Boundary(view.mask);
  const OverlayStyle style;
  EXPECT_GT(CoveredFraction(boundary, PixelsOfColor(picture.rgb, style.failure_color, 70)), 0.85);
  EXPECT_LT(CoveredFraction(boundary, PixelsOfColor(picture.rgb, style.contour_color, 70)), 0.2)
      << "a failure is not drawn as a pose";
}

TEST_F(DebugImagesTest, RateLimitCountsFramesNotTime) {
  // One picture per 1000 s: of a run of frames (each answered) exactly the first gets one,
  // whatever the speed of the machine; every other offer is counted as skipped.
  constexpr int kFrames = 6;
  ServiceOptions options = Options("rate");
  options.debug_images.max_rate_hz = 0.001;
  StartService(options);
  for (int i = 0; i < kFrames; ++i) {
    const pose_array_t answer =
        Answer(test::MakeRgbdFrame(scene_->views[i % kNumViews], 30 + i, test::kBoxId));
    ASSERT_EQ(answer.status, +pose_array_t::STATUS_OK);
  }
  ASSERT_FALSE(NextPicture().rgb.empty());
  service_->Stop();
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.frames_processed, kFrames);
  EXPECT_EQ(counters.debug_images_published, 1);
  EXPECT_EQ(counters.debug_images_skipped, kFrames - 1);
  EXPECT_EQ(pictures_->pictures.Size(), 0u) << "more pictures than the rate allows";
}

TEST_F(DebugImagesTest, BurstIsAnsweredInFullWhilePicturesAreSkipped) {
  // Frames as fast as they come, pictures as fast as allowed: every answered frame is
  // either pictured or counted as skipped, never waited for.
  ServiceOptions options = Options("burst");
  options.debug_images.max_rate_hz = 1000.0;
  StartService(options);
  constexpr int kFrames = 8;
  for (int i = 0; i < kFrames; ++i) {
    const rgbd_frame_t frame =
        test::MakeRgbdFrame(scene_->views[i % kNumViews], 40 + i, test::kBoxId);
    ASSERT_EQ(lcm_.publish(options_.input_channel, &frame), 0);
  }
  ASSERT_FALSE(NextPicture().rgb.empty());
  service_->Stop();
  const ServiceCounters counters = service_->Counters();
  // Frames the LCM thread had not taken when it stopped are not received.
  EXPECT_EQ(counters.frames_processed + counters.frames_dropped, counters.frames_received);
  EXPECT_GE(counters.debug_images_published, 1);
  EXPECT_EQ(counters.debug_images_published + counters.debug_images_skipped,
            counters.frames_processed);
}

TEST(DebugImageOptions, CheckNamesTheBadField) {
  DebugImageOptions options;
  EXPECT_EQ(options.Check(), "");
  EXPECT_FALSE(options.enabled()) << "off by default";
  options.max_rate_hz = 0.0;
  EXPECT_NE(options.Check().find("debug_images_hz"), std::string::npos);
  options = DebugImageOptions();
  options.jpeg_quality = 101;
  EXPECT_NE(options.Check().find("debug_images_jpeg_quality"), std::string::npos);
}

}  // namespace
}  // namespace g6d
