#pragma once
/// @file raster.h
/// Fast CPU rasterizer for the online stages: mask, metric depth and face id for a pose.
/// A region of interest at any scale is rendered by passing a cropped / scaled Camera
/// (Camera::Cropped, Camera::Scaled). Pixel (u, v) is sampled at its centre (u+0.5, v+0.5),
/// the BOP convention, so it agrees with OpenGL rendering of the same K.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/camera.h"
#include "mesh/mesh.h"

namespace g6d {

namespace internal {
/// Per-vertex working data of Rasterize() (camera-frame point, fixed-point projection).
struct RasterVertex {
  Eigen::Vector3d point_in_cam;  ///< metres
  double inverse_z = 0.0;        ///< 1 / point_in_cam.z(), 1/metres
  int32_t x_fixed = 0;           ///< image x in 1/256 pixel
  int32_t y_fixed = 0;           ///< image y in 1/256 pixel
  bool usable = false;           ///< beyond the near plane and inside the fixed-point range
};
}  // namespace internal

/// Output of one rasterization. All images have the camera's size.
/// Keep one per thread and pass it again: repeated calls of the same size do not allocate.
struct RasterImage {
  cv::Mat depth;        ///< CV_32F, z along the optical axis in metres; 0 where no surface
  cv::Mat face_id;      ///< CV_32S, index into the mesh faces; -1 where no surface; empty when
                        ///< RasterOptions::want_face_id is false
  int pixel_count = 0;  ///< number of covered pixels (the silhouette area)
  std::vector<internal::RasterVertex> scratch;  ///< working memory reused across calls

  /// Mask of covered pixels as CV_8U 0/255.
  cv::Mat Mask() const;
};

/// Options for Rasterize().
struct RasterOptions {
  double near_m = 0.01;         ///< near clipping plane, metres; triangles crossing it are skipped
  bool cull_backfaces = false;  ///< skip faces whose winding is clockwise on screen
  bool want_face_id = true;     ///< fill face_id (slightly slower when true)

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Rasterizes `mesh` (metres, object frame) seen from `camera` at `cam_from_object`.
/// Overwrites *out (reallocating only when the size changed). Nearest surface wins.
/// Coverage is decided at pixel centres with vertices snapped to 1/256 pixel and the
/// top-left fill rule, so triangles sharing an edge leave neither cracks nor double hits.
/// Depth is the exact z of the triangle's plane on the ray through the pixel centre.
/// Triangles with any vertex closer than options.near_m (or projecting beyond +-2^21 px)
/// are skipped, not clipped: callers keep objects in front of the near plane.
/// Throws g6d::Error for an invalid camera or options, or a face index out of range.
void Rasterize(const Mesh& mesh, const Camera& camera, const Eigen::Isometry3d& cam_from_object,
               const RasterOptions& options, RasterImage* out);

}  // namespace g6d
