#pragma once
/// @file views.h
/// Template view sampling: roughly uniform viewing directions (Fibonacci sphere) times
/// evenly spaced in-plane rotations, at a distance where the object fills the crop.

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/camera.h"

namespace g6d {

/// Options of SampleTemplateViews().
struct ViewSamplingOptions {
  int num_directions = 108;  ///< viewing directions on the full sphere (Fibonacci lattice)
  int num_inplane = 3;       ///< in-plane rotations per direction, evenly spaced over 360 deg
  /// Fraction of the template image side that the object's diameter spans at the
  /// sampled distance (the crop padding is applied later, on the mask box).
  double fill_fraction = 0.8;

  int NumViews() const { return num_directions * num_inplane; }
  std::string Check() const;
};

/// cam_from_object for every template view. The object's bounding-box centre
/// (`object_centre`, metres, object frame) is placed on the optical axis at the distance
/// where a sphere of `diameter_m` spans `fill_fraction` of the smaller image side.
std::vector<Eigen::Isometry3d> SampleTemplateViews(const ViewSamplingOptions& options,
                                                   const Camera& camera, double diameter_m,
                                                   const Eigen::Vector3d& object_centre);

}  // namespace g6d
