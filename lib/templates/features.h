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
  int max_features = 300;      ///< ORB features kept per crop
  float scale_factor = 1.2f;   ///< pyramid decimation ratio
  int num_levels = 6;          ///< pyramid levels
  int edge_threshold = 15;     ///< border in pixels where no features are detected
  int fast_threshold = 12;     ///< FAST corner threshold (grey levels)

  std::string Check() const;
};

/// One ORB feature: location in source image pixel coordinates (OpenCV convention,
/// centre of pixel (u, v) at (u, v)) and its 256-bit descriptor.
struct Feature {
  Eigen::Vector2f xy = Eigen::Vector2f::Zero();
  std::array<uint8_t, 32> descriptor{};
};

/// Detects ORB inside crop.mask on crop.gray and maps each keypoint back to the source
/// image through the crop's affine. Returns an empty vector for an invalid crop.
std::vector<Feature> DetectOrb(const NormalizedCrop& crop, const OrbOptions& options);

}  // namespace g6d
