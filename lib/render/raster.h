#pragma once
/// @file raster.h
/// Fast CPU rasterizer for the online stages: mask, metric depth and face id for a pose.
/// A region of interest at any scale is rendered by passing a cropped / scaled Camera
/// (Camera::Cropped, Camera::Scaled). Pixel (u, v) is sampled at its centre (u+0.5, v+0.5),
/// the BOP convention, so it agrees with OpenGL rendering of the same K.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "mesh/mesh.h"

namespace g6d {

/// Output of one rasterization. All images have the camera's size.
struct RasterImage {
  cv::Mat depth;    ///< CV_32F, z along the optical axis in metres; 0 where no surface
  cv::Mat face_id;  ///< CV_32S, index into the mesh faces; -1 where no surface
  int pixel_count = 0;  ///< number of covered pixels (the silhouette area)

  /// Mask of covered pixels as CV_8U 0/255.
  cv::Mat Mask() const;
};

/// Options for Rasterize().
struct RasterOptions {
  double near_m = 0.01;      ///< near clipping plane, metres; triangles crossing it are skipped
  bool cull_backfaces = false;  ///< skip faces whose winding is clockwise on screen
  bool want_face_id = true;  ///< fill face_id (slightly slower when true)

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Rasterizes `mesh` (metres, object frame) seen from `camera` at `cam_from_object`.
/// Overwrites *out (reallocating only when the size changed). Nearest surface wins.
void Rasterize(const Mesh& mesh, const Camera& camera, const Eigen::Isometry3d& cam_from_object,
               const RasterOptions& options, RasterImage* out);

}  // namespace g6d
