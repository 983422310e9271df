#include "render/overlay.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "core/error.h"

namespace g6d {
namespace {

void CheckCanvas(const cv::Mat* rgb, int width, int height, const char* what) {
  if (rgb == nullptr || rgb->type() != CV_8UC3 || rgb->cols != width || rgb->rows != height) {
    G6D_THROW(
        what << ": the canvas must be a CV_8UC3 image of " << width << " x " << height << " (got "
             << (rgb == nullptr ? std::string("none")
                                : std::to_string(rgb->cols) + " x " + std::to_string(rgb->rows) +
                                      " of type " + std::to_string(rgb->type()))
             << ")");
  }
}

// Continuous image coordinates (pixel centres at +0.5) to OpenCV drawing coordinates.
cv::Point2d ToDrawing(const Eigen::Vector2d& image_point) {
  return {image_point.x() - kOpenCvToImage, image_point.y() - kOpenCvToImage};
}

void DrawAxes(const OverlayModel& model, const Camera& camera,
              const Eigen::Isometry3d& cam_from_object, const OverlayStyle& style, cv::Mat* rgb) {
  const Eigen::Vector3d origin = cam_from_object * model.axes_origin_in_object;
  if (origin.z() <= 0.0) return;
  const double length_m = style.axis_length_fraction * model.diameter_m;
  const cv::Point2d from = ToDrawing(camera.Project(origin));
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Vector3d tip = origin + cam_from_object.linear().col(axis) * length_m;
    if (tip.z() <= 0.0) continue;
    cv::arrowedLine(*rgb, from, ToDrawing(camera.Project(tip)), style.axis_colors[axis],
                    style.axis_thickness_px, cv::LINE_AA, 0, 0.1);
  }
}

}  // namespace

std::string OverlayStyle::Check() const {
  std::ostringstream out;
  if (contour_thickness_px < 1 || contour_thickness_px > 20)
    out << "contour_thickness_px must be in 1..20 (got " << contour_thickness_px << ")";
  else if (axis_thickness_px < 1 || axis_thickness_px > 20)
    out << "axis_thickness_px must be in 1..20 (got " << axis_thickness_px << ")";
  else if (!std::isfinite(axis_length_fraction) || axis_length_fraction < 0.0)
    out << "axis_length_fraction must be >= 0 (got " << axis_length_fraction << ")";
  else if (!std::isfinite(label_scale) || label_scale <= 0.0 || label_scale > 10.0)
    out << "label_scale must be in (0, 10] (got " << label_scale << ")";
  return out.str();
}

PoseOverlayReport DrawPoseOverlay(const OverlayModel& model, const Camera& camera,
                                  const Eigen::Isometry3d& cam_from_object,
                                  const OverlayStyle& style, cv::Mat* rgb, RasterImage* raster) {
  if (const std::string error = style.Check(); !error.empty())
    G6D_THROW("DrawPoseOverlay: style." << error);
  if (model.mesh == nullptr) G6D_THROW("DrawPoseOverlay: the model has no mesh");
  if (!std::isfinite(model.diameter_m) || model.diameter_m < 0.0)
    G6D_THROW("DrawPoseOverlay: model diameter_m must be >= 0 (got " << model.diameter_m << ")");
  if (const std::string error = camera.Check(); !error.empty())
    G6D_THROW("DrawPoseOverlay: camera: " << error);
  CheckCanvas(rgb, camera.width, camera.height, "DrawPoseOverlay");
  RasterImage local;
  RasterImage& silhouette = raster != nullptr ? *raster : local;
  // Face ids are not needed for a silhouette: the cheaper rasterization.
  RasterOptions options;
  options.want_face_id = false;
  Rasterize(*model.mesh, camera, cam_from_object, options, &silhouette);
  PoseOverlayReport report;
  report.silhouette_pixels = silhouette.pixel_count;
  if (silhouette.pixel_count > 0) {
    const cv::Mat mask = silhouette.Mask();
    report.silhouette_box = cv::boundingRect(mask);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    cv::drawContours(*rgb, contours, -1, style.contour_color, style.contour_thickness_px,
                     cv::LINE_AA);
  }
  DrawAxes(model, camera, cam_from_object, style, rgb);
  return report;
}

cv::Rect DrawMaskOutline(const cv::Mat& mask, const cv::Scalar& color, int thickness_px,
                         cv::Mat* rgb) {
  if (mask.type() != CV_8UC1)
    G6D_THROW("DrawMaskOutline: the mask must be CV_8UC1 (got type " << mask.type() << ")");
  CheckCanvas(rgb, mask.cols, mask.rows, "DrawMaskOutline");
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  if (contours.empty()) return cv::Rect();
  cv::drawContours(*rgb, contours, -1, color, std::max(1, thickness_px), cv::LINE_8);
  return cv::boundingRect(mask);
}

namespace {
constexpr int kLabelFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kLabelPadding = 3;  // pixels around the text
}  // namespace

cv::Rect LabelBox(const std::string& text, cv::Point anchor, double scale, cv::Size image_size) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kLabelFont, scale, 1, &baseline);
  cv::Rect box(anchor.x, anchor.y - size.height - baseline - 2 * kLabelPadding,
               size.width + 2 * kLabelPadding, size.height + baseline + 2 * kLabelPadding);
  // Keep the box inside the image (shifted, not clipped, so the text stays readable).
  box.x = std::clamp(box.x, 0, std::max(0, image_size.width - box.width));
  box.y = std::clamp(box.y, 0, std::max(0, image_size.height - box.height));
  return box & cv::Rect(0, 0, image_size.width, image_size.height);
}

cv::Rect DrawLabel(const std::string& text, cv::Point anchor, const cv::Scalar& color, double scale,
                   cv::Mat* rgb) {
  if (rgb == nullptr || rgb->empty()) G6D_THROW("DrawLabel: no canvas");
  const cv::Rect box = LabelBox(text, anchor, scale, rgb->size());
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kLabelFont, scale, 1, &baseline);
  cv::rectangle(*rgb, box, cv::Scalar(20, 20, 20), cv::FILLED);
  cv::putText(*rgb, text, cv::Point(box.x + kLabelPadding, box.y + kLabelPadding + size.height),
              kLabelFont, scale, color, 1, cv::LINE_AA);
  return box;
}

}  // namespace g6d
