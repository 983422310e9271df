// render/overlay.h: the pose drawing of g6d-solve --overlay and the service's debug images,
// checked pixel by pixel on a canvas of one colour (no compression in between).
#include "render/overlay.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "test_meshes.h"

namespace g6d {
namespace {

const Camera kCamera{500.0, 500.0, 320.0, 240.0, 640, 480};
const cv::Scalar kBackground(90, 90, 90);

// A cube of 10 cm seen face-on, 0.5 m in front of the camera (its front face at 0.45 m).
Eigen::Isometry3d FaceOn() {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(0.0, 0.0, 0.5);
  return pose;
}

cv::Mat Canvas() { return cv::Mat(kCamera.height, kCamera.width, CV_8UC3, kBackground); }

cv::Mat PixelsOf(const cv::Mat& rgb, const cv::Scalar& color) {
  cv::Mat same;
  cv::inRange(rgb, color, color, same);
  return same;
}

TEST(DrawPoseOverlay, ContourLiesOnTheSilhouetteBoundaryAndNothingElseFarAway) {
  const Mesh cube = test::MakeCube(0.05);
  const OverlayModel model{&cube, Eigen::Vector3d::Zero(), 0.1 * std::sqrt(3.0)};
  const OverlayStyle style;
  cv::Mat canvas = Canvas();
  const PoseOverlayReport report = DrawPoseOverlay(model, kCamera, FaceOn(), style, &canvas);

  RasterImage raster;
  Rasterize(cube, kCamera, FaceOn(), RasterOptions(), &raster);
  const cv::Mat mask = raster.Mask();
  EXPECT_EQ(report.silhouette_pixels, cv::countNonZero(mask));
  EXPECT_EQ(report.silhouette_box, cv::boundingRect(mask));
  cv::Mat eroded;
  cv::erode(mask, eroded, cv::Mat::ones(3, 3, CV_8U));
  const cv::Mat boundary = mask - eroded;
  // Anti-aliased lines: the exact colour on the line's core, next to the boundary.
  cv::Mat near_contour;
  cv::dilate(PixelsOf(canvas, style.contour_color), near_contour, cv::Mat::ones(3, 3, CV_8U));
  EXPECT_GT(cv::countNonZero(boundary & near_contour), 0.95 * cv::countNonZero(boundary));

  // Far from the silhouette and from the axes (x to the right, y down through the
  // centre; z points away and projects to the centre), the canvas is untouched.
  cv::Mat far;
  cv::dilate(mask, far, cv::Mat::ones(9, 9, CV_8U));
  far = far == 0;
  far(cv::Rect(0, 240 - 12, 640, 24)).setTo(0);  // arrow heads included
  far(cv::Rect(320 - 12, 0, 24, 480)).setTo(0);
  EXPECT_EQ(cv::countNonZero(far & PixelsOf(canvas, kBackground)), cv::countNonZero(far));
  // The x axis reaches beyond the silhouette: 0.5 diameters = 87 mm at 0.5 m = 87 px.
  EXPECT_GT(cv::countNonZero(PixelsOf(canvas, style.axis_colors[0])(cv::Rect(395, 234, 10, 12))),
            0);
}

TEST(DrawPoseOverlay, RefusesACanvasOfTheWrongSizeAndABadStyle) {
  const Mesh cube = test::MakeCube(0.05);
  const OverlayModel model{&cube, Eigen::Vector3d::Zero(), 0.1};
  cv::Mat small(100, 100, CV_8UC3);
  EXPECT_THROW(DrawPoseOverlay(model, kCamera, FaceOn(), OverlayStyle(), &small), Error);
  OverlayStyle style;
  style.contour_thickness_px = 0;
  EXPECT_NE(style.Check().find("contour_thickness_px"), std::string::npos);
  cv::Mat canvas = Canvas();
  EXPECT_THROW(DrawPoseOverlay(model, kCamera, FaceOn(), style, &canvas), Error);
  EXPECT_THROW(DrawPoseOverlay(OverlayModel(), kCamera, FaceOn(), OverlayStyle(), &canvas), Error);
}

TEST(DrawMaskOutline, OutlinesTheMaskAndLeavesItsInside) {
  cv::Mat mask = cv::Mat::zeros(kCamera.height, kCamera.width, CV_8U);
  const cv::Rect box(100, 120, 80, 60);
  mask(box).setTo(255);
  cv::Mat canvas = Canvas();
  const cv::Scalar red(255, 50, 50);
  EXPECT_EQ(DrawMaskOutline(mask, red, 2, &canvas), box);
  EXPECT_EQ(canvas.at<cv::Vec3b>(box.y, box.x + 40), cv::Vec3b(255, 50, 50));
  EXPECT_EQ(canvas.at<cv::Vec3b>(box.y + 30, box.x + 40), cv::Vec3b(90, 90, 90));
  EXPECT_EQ(DrawMaskOutline(cv::Mat::zeros(kCamera.height, kCamera.width, CV_8U), red, 2, &canvas),
            cv::Rect());
  EXPECT_THROW(DrawMaskOutline(cv::Mat::zeros(10, 10, CV_8U), red, 2, &canvas), Error);
}

TEST(DrawLabel, StaysInsideTheImage) {
  cv::Mat canvas = Canvas();
  const cv::Rect inside(0, 0, canvas.cols, canvas.rows);
  for (const cv::Point anchor : {cv::Point(630, 2), cv::Point(-50, 900), cv::Point(300, 200)}) {
    const cv::Rect box = DrawLabel("obj_000001 S 0.050 c 0.90 tracked", anchor,
                                   cv::Scalar(60, 255, 60), 0.5, &canvas);
    EXPECT_GT(box.area(), 0);
    EXPECT_EQ(box & inside, box) << "anchor " << anchor;
  }
}

}  // namespace
}  // namespace g6d
