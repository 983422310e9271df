#pragma once
/// @file gl_renderer.h
/// Offscreen OpenGL renderer (OSMesa, llvmpipe) for templates: RGB with vertex colours or
/// texture and simple Lambertian shading, metric depth and mask, for any K and image size.
/// One instance owns one OSMesa context and must be used from one thread at a time;
/// instances on different threads take turns (one process-wide lock: Mesa 22.3 crashed when
/// two contexts drew at once).
/// This header includes no GL headers (they collide with Open3D's).

#include <memory>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "mesh/mesh.h"

namespace g6d {

/// Images rendered by GlRenderer; all of the camera's size.
struct GlImage {
  cv::Mat rgb;    ///< CV_8UC3, RGB order; background black
  cv::Mat depth;  ///< CV_32F, z along the optical axis in metres; 0 where no surface
  cv::Mat mask;   ///< CV_8U, 255 on the object, 0 elsewhere
};

/// Options of GlRenderer.
struct GlRendererOptions {
  double near_m = 0.01;        ///< near plane, metres
  double far_m = 20.0;         ///< far plane, metres
  double ambient = 0.45;       ///< ambient light weight in [0, 1]
  double diffuse = 0.55;       ///< diffuse (headlight) weight in [0, 1]
  float default_gray = 0.7f;   ///< albedo when the mesh has neither colours nor texture

  std::string Check() const;
};

/// Offscreen renderer for one mesh.
class GlRenderer {
 public:
  /// Uploads the mesh. Throws g6d::Error if OSMesa cannot create a context.
  GlRenderer(const Mesh& mesh, const GlRendererOptions& options = {});
  ~GlRenderer();
  GlRenderer(const GlRenderer&) = delete;
  GlRenderer& operator=(const GlRenderer&) = delete;

  /// Renders the mesh at cam_from_object with the given camera.
  GlImage Render(const Camera& camera, const Eigen::Isometry3d& cam_from_object);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace g6d
