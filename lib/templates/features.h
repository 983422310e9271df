#pragma once
/// @file features.h
/// ORB on normalized crops, and the back-projection of template keypoints to object-frame
/// 3D points (paper eq. 2).

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "templates/crop.h"

namespace g6d {

/// Options of DetectOrb().
struct OrbOptions {
  /// ORB features kept per crop. 200 keeps a 324-template cache under ~3 MB (the 32-byte
  /// descriptors dominate) and the online matching cost proportional.
  int max_features = 200;
  float scale_factor = 1.2f;  ///< pyramid decimation ratio
  int num_levels = 6;         ///< pyramid levels
  int edge_threshold = 15;    ///< border in pixels where no features are detected
  /// FAST corner threshold, grey levels of the contrast-normalized crop (std 48). Low,
  /// because rendered CAD models (LM-O) are weakly textured: at 12 the ape and the duck
  /// keep a median of ~100 / ~75 keypoints per template, at 8 ~160 / ~140.
  int fast_threshold = 8;
  /// The crop mask is eroded by this many crop pixels before detection, so keypoints sit
  /// on the object (corners right at the silhouette stay detectable, none lie outside).
  int mask_erosion_px = 1;

  std::string Check() const;
};

/// One ORB feature: location in source image pixel coordinates (OpenCV convention,
/// centre of pixel (u, v) at (u, v)) and its 256-bit descriptor.
struct Feature {
  Eigen::Vector2f xy = Eigen::Vector2f::Zero();
  std::array<uint8_t, 32> descriptor{};
};

/// Detects ORB inside crop.mask (eroded by options.mask_erosion_px) on crop.gray and maps
/// each keypoint back to the source image through the crop's affine. Deterministic; the
/// order is ORB's (strongest retained response per pyramid level). Returns an empty
/// vector for an invalid crop; throws g6d::Error on bad options.
std::vector<Feature> DetectOrb(const NormalizedCrop& crop, const OrbOptions& options);

}  // namespace g6d
