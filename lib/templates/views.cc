#include "templates/views.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/error.h"
#include "core/se3.h"

namespace g6d {

std::string ViewSamplingOptions::Check() const {
  std::ostringstream out;
  if (num_directions < 1 || num_directions > 100000) {
    out << "views.num_directions must be in 1..100000 (got " << num_directions << ")";
  } else if (num_inplane < 1 || num_inplane > 360) {
    out << "views.num_inplane must be in 1..360 (got " << num_inplane << ")";
  } else if (!std::isfinite(fill_fraction) || fill_fraction <= 0.0 || fill_fraction > 1.0) {
    out << "views.fill_fraction must be in (0, 1] (got " << fill_fraction << ")";
  }
  return out.str();
}

std::vector<Eigen::Isometry3d> SampleTemplateViews(const ViewSamplingOptions& options,
                                                   const Camera& camera, double diameter_m,
                                                   const Eigen::Vector3d& object_centre) {
  if (const std::string problem = options.Check(); !problem.empty()) {
    G6D_THROW("SampleTemplateViews: " << problem);
  }
  if (const std::string problem = camera.Check(); !problem.empty()) {
    G6D_THROW("SampleTemplateViews: camera " << problem);
  }
  if (!std::isfinite(diameter_m) || diameter_m <= 0.0) {
    G6D_THROW("SampleTemplateViews: diameter_m must be finite and > 0 (got " << diameter_m << ")");
  }

  // Distance at which a sphere of radius r around the centre projects to a disc whose
  // radius is half the wanted span: the silhouette cone has half-angle asin(r / d), so the
  // disc radius is f * r / sqrt(d^2 - r^2). Solve for d along the smaller image side.
  const double radius = 0.5 * diameter_m;
  const bool width_smaller = camera.width <= camera.height;
  const double side_px = width_smaller ? camera.width : camera.height;
  const double focal_px = width_smaller ? camera.fx : camera.fy;
  const double disc_radius_px = 0.5 * options.fill_fraction * side_px;
  const double distance = radius * std::sqrt(1.0 + std::pow(focal_px / disc_radius_px, 2));

  // Fibonacci lattice: z evenly spaced in (-1, 1), azimuth advancing by the golden angle.
  const double golden_angle = M_PI * (3.0 - std::sqrt(5.0));
  const int n = options.num_directions;
  std::vector<Eigen::Isometry3d> views;
  views.reserve(static_cast<size_t>(options.NumViews()));
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / n;
    const double ring = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double azimuth = golden_angle * k;
    const Eigen::Vector3d direction(ring * std::cos(azimuth), ring * std::sin(azimuth), z);
    // Object +z appears "up" in the image where possible; near the poles use +y instead.
    const Eigen::Vector3d up =
        std::abs(direction.z()) > 0.99 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ();
    const Eigen::Isometry3d cam_from_object_base =
        LookAt(object_centre + distance * direction, object_centre, up);
    for (int r = 0; r < options.num_inplane; ++r) {
      // In-plane rotation about the optical axis keeps the centre on the axis.
      const double angle = 2.0 * M_PI * r / options.num_inplane;
      Eigen::Isometry3d cam_from_cam = Eigen::Isometry3d::Identity();
      cam_from_cam.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      views.push_back(cam_from_cam * cam_from_object_base);
    }
  }
  return views;
}

}  // namespace g6d
