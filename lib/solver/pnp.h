#pragma once
/// @file pnp.h
/// MSAC-PnP (paper eq. 5): a robust metric pose per correspondence set, with the inlier
/// threshold τ_P scaled by the projected object size and clipped, then refined on the
/// MSAC inliers.

#include <string>

#include <Eigen/Geometry>

#include "core/camera.h"
#include "solver/match.h"

namespace g6d {

/// Options of EstimatePnp().
struct PnpOptions {
  double tau_fraction = 0.03;   ///< τ_P as a fraction of the projected object size (px / px)
  double tau_min_px = 3.0;      ///< lower clip of τ_P, pixels
  double tau_max_px = 12.0;     ///< upper clip of τ_P, pixels
  int max_iterations = 300;     ///< RANSAC iterations at most
  double confidence = 0.99;     ///< RANSAC stopping confidence
  int min_inliers = 6;          ///< fewer MSAC inliers = invalid hypothesis
  uint64_t seed = 7;            ///< base RNG seed; set j uses seed + template index

  std::string Check() const;
};

/// One PnP hypothesis.
struct PnpResult {
  bool success = false;
  std::string message = "not run";
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();
  int inliers = 0;
  double tau_px = 0.0;      ///< the threshold used
  double msac_cost = 0.0;   ///< Σ min(r², τ_P²) over the set at the final pose (eq. 5), px²
};

/// τ_P for an object whose projection spans `projected_size_px` pixels.
double PnpThreshold(const PnpOptions& options, double projected_size_px);

/// Robust PnP on one correspondence set (image points under `camera`'s K).
void EstimatePnp(const PnpOptions& options, const CorrespondenceSet& set, const Camera& camera,
                 double projected_size_px, PnpResult* result);

}  // namespace g6d
