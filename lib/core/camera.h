#pragma once
/// @file camera.h
/// Pinhole camera: intrinsics K and image size.
///
/// Pixel convention (the BOP one): the pixel with integer index (u, v) covers the
/// continuous image square [u, u+1) x [v, v+1), so its centre is (u + 0.5, v + 0.5) in the
/// coordinates that K maps to. OpenCV keypoints use centre = (u, v); convert with
/// `PixelCentre()` / `kOpenCvToImage`. With this convention cropping and scaling a camera
/// are exact: crop shifts (cx, cy), scale multiplies all four intrinsics.

#include <string>

#include <Eigen/Core>

namespace g6d {

/// Offset to add to an OpenCV pixel coordinate (centre at integer) to get image
/// coordinates under K (centre at +0.5).
inline constexpr double kOpenCvToImage = 0.5;

/// Pinhole intrinsics in pixels plus the image size.
struct Camera {
  double fx = 0.0;  ///< focal length along x, pixels
  double fy = 0.0;  ///< focal length along y, pixels
  double cx = 0.0;  ///< principal point x, pixels (continuous, corner origin)
  double cy = 0.0;  ///< principal point y, pixels (continuous, corner origin)
  int width = 0;    ///< image width, pixels
  int height = 0;   ///< image height, pixels

  /// Empty string when valid, else names the bad field (finite positive focal lengths,
  /// finite principal point, positive size up to 1<<15).
  std::string Check() const;

  /// Projects a point in the camera frame (z > 0 expected) to continuous image coordinates.
  Eigen::Vector2d Project(const Eigen::Vector3d& point_in_cam) const {
    return {fx * point_in_cam.x() / point_in_cam.z() + cx,
            fy * point_in_cam.y() / point_in_cam.z() + cy};
  }
  /// Back-projects continuous image coordinates at metric depth z (along the optical axis).
  Eigen::Vector3d Backproject(const Eigen::Vector2d& uv, double depth_m) const {
    return {(uv.x() - cx) / fx * depth_m, (uv.y() - cy) / fy * depth_m, depth_m};
  }
  /// The ray direction (z = 1) through continuous image coordinates uv.
  Eigen::Vector3d Ray(const Eigen::Vector2d& uv) const { return Backproject(uv, 1.0); }

  /// Camera seeing the sub-image [x0, x0+w) x [y0, y0+h) of this one (pixels).
  Camera Cropped(int x0, int y0, int w, int h) const;
  /// Camera whose image is this one resized by `scale` (new size rounded to nearest).
  Camera Scaled(double scale) const;
  /// The 3x3 matrix K.
  Eigen::Matrix3d K() const;
};

/// Continuous image coordinates of the centre of integer pixel (u, v).
inline Eigen::Vector2d PixelCentre(int u, int v) { return {u + 0.5, v + 0.5}; }

}  // namespace g6d
