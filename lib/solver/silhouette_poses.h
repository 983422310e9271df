#pragma once
/// @file silhouette_poses.h
/// Pose hypotheses from the mask's outline alone: each template's silhouette code
/// (templates/silhouette.h) is compared with the mask's at evenly spaced in-plane angles;
/// a template and angle whose outlines agree give a pose: the template's rotation turned by
/// the angle about the viewing ray, at the distance where the template's area becomes the
/// mask's. Needs neither texture (ORB-PnP) nor much depth (point-pair features): a bare
/// metal part whose surface reflects the sensor's pattern away has few depth pixels but a
/// whole outline.

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "templates/template_bank.h"

namespace g6d {

/// Options of SilhouettePoses().
struct SilhouetteOptions {
  int rotations = 36;      ///< in-plane angles compared per template, evenly over 360 degrees
  int candidates = 12;     ///< distinct poses returned at most, best outline agreement first
  double min_iou = 0.5;    ///< codes agreeing less than this (intersection over union) give no pose
  int min_mask_pixels = 64;  ///< a smaller mask's outline says too little: no pose

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// One pose from the outline.
struct SilhouettePose {
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();
  double iou = 0.0;        ///< agreement of the two codes
  int template_index = -1;  ///< into bank.templates
  double angle_rad = 0.0;  ///< in-plane turn of the template's outline onto the mask's
};

/// Decides whether two poses are the same hypothesis (e.g. within a distance modulo the
/// object's symmetries).
using SamePose = std::function<bool(const Eigen::Isometry3d&, const Eigen::Isometry3d&)>;

/// Poses whose template outline matches `mask` (CV_8U, non-zero = object, camera's image
/// size), best agreement first, at most options.candidates of them, none the same as a
/// better one by `same`. Empty when the bank has no silhouette codes, the mask is smaller
/// than options.min_mask_pixels or no code agrees options.min_iou.
std::vector<SilhouettePose> SilhouettePoses(const TemplateBank& bank, const Camera& camera, const cv::Mat& mask,
                                            const SilhouetteOptions& options, const SamePose& same);

/// The pose that casts the template `view` turned by `angle_rad` in the image (silhouette.h's
/// convention) with its silhouette centroid at `centroid_px` (OpenCV pixel coordinates of
/// `camera`) and area `area_px`: the template's rotation turned about the viewing ray, the
/// bounding-box centre on the ray through where the template's centre falls, at the distance
/// that scales the template's area to area_px.
Eigen::Isometry3d PoseFromSilhouette(const TemplateBank& bank, int view, double angle_rad,
                                     const Eigen::Vector2d& centroid_px, double area_px, const Camera& camera);

}  // namespace g6d
