#pragma once
/// @file overlay.h
/// Drawing a pose over an image, for people: the model's silhouette contour at the pose
/// (from the CPU rasterizer's exact silhouette), its axes, a text label, and the outline
/// of a mask. One drawing for g6d-solve --overlay and the service's debug images.
///
/// Canvas. Every function draws on a CV_8UC3 image in RGB order (the order of the
/// decoded frames); colours are RGB. A tool holding a BGR image converts around the call.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>

#include "core/camera.h"
#include "mesh/mesh.h"
#include "render/raster.h"

namespace g6d {

/// Colours (RGB) and sizes of the overlay.
struct OverlayStyle {
  cv::Scalar contour_color{60, 255, 60};  ///< silhouette contour of a pose, RGB
  int contour_thickness_px = 2;           ///< line width of the contour, pixels
  /// Axis colours x, y, z (red, green, blue), RGB.
  cv::Scalar axis_colors[3] = {cv::Scalar(255, 40, 40), cv::Scalar(0, 200, 0),
                               cv::Scalar(40, 80, 255)};
  int axis_thickness_px = 2;              ///< line width of the axes, pixels
  double axis_length_fraction = 0.5;      ///< axis length, fraction of the object diameter
  cv::Scalar failure_color{255, 50, 50};  ///< outline and label of a failed instance, RGB
  double label_scale = 0.5;               ///< OpenCV font scale of labels

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Where to draw a model and how large its axes are.
struct OverlayModel {
  const Mesh* mesh = nullptr;  ///< metres, object frame (a bank's online mesh)
  Eigen::Vector3d axes_origin_in_object = Eigen::Vector3d::Zero();  ///< metres (e.g. box centre)
  double diameter_m = 0.0;                                          ///< sets the axis length
};

/// What one DrawPoseOverlay drew, for the caller to place a label.
struct PoseOverlayReport {
  int silhouette_pixels = 0;  ///< area of the rendered silhouette (0 = off screen)
  cv::Rect silhouette_box;    ///< its bounding box, pixels (empty when 0 pixels)
};

/// Draws `model` seen from `camera` at `cam_from_object` on *rgb (camera-sized, CV_8UC3):
/// the outer contour of its rasterized silhouette in style.contour_color, and its x, y, z
/// axes from axes_origin_in_object, axis_length_fraction diameters long (an axis whose
/// tip is behind the camera is left out). `raster` is working memory (pass one per thread
/// to avoid allocations; may be null). Throws g6d::Error when the canvas does not match
/// the camera, the style or model is invalid, or the mesh has a face index out of range.
PoseOverlayReport DrawPoseOverlay(const OverlayModel& model, const Camera& camera,
                                  const Eigen::Isometry3d& cam_from_object,
                                  const OverlayStyle& style, cv::Mat* rgb,
                                  RasterImage* raster = nullptr);

/// Draws the outer outline of the non-zero pixels of `mask` (CV_8U, canvas-sized) in
/// `color`, `thickness_px` wide. Returns the mask's bounding box (empty when it has no
/// pixels). Throws g6d::Error when the mask does not match the canvas.
cv::Rect DrawMaskOutline(const cv::Mat& mask, const cv::Scalar& color, int thickness_px,
                         cv::Mat* rgb);

/// The box DrawLabel fills for `text` at `anchor` on an image of `image_size`: its
/// bottom-left corner at `anchor`, moved so the box stays inside the image; pixels.
cv::Rect LabelBox(const std::string& text, cv::Point anchor, double scale, cv::Size image_size);

/// Writes `text` in `color` on a dark box (LabelBox of `anchor`). Returns the box drawn.
cv::Rect DrawLabel(const std::string& text, cv::Point anchor, const cv::Scalar& color, double scale,
                   cv::Mat* rgb);

}  // namespace g6d
