#include "templates/features.h"

#include <cmath>
#include <cstring>
#include <sstream>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace g6d {

std::string OrbOptions::Check() const {
  std::ostringstream out;
  if (max_features < 1 || max_features > 100000) {
    out << "orb.max_features must be in 1..100000 (got " << max_features << ")";
  } else if (!std::isfinite(scale_factor) || scale_factor <= 1.0f || scale_factor > 4.0f) {
    out << "orb.scale_factor must be in (1, 4] (got " << scale_factor << ")";
  } else if (num_levels < 1 || num_levels > 16) {
    out << "orb.num_levels must be in 1..16 (got " << num_levels << ")";
  } else if (edge_threshold < 1 || edge_threshold > 256) {
    out << "orb.edge_threshold must be in 1..256 (got " << edge_threshold << ")";
  } else if (fast_threshold < 1 || fast_threshold > 255) {
    out << "orb.fast_threshold must be in 1..255 (got " << fast_threshold << ")";
  } else if (mask_erosion_px < 0 || mask_erosion_px > 64) {
    out << "orb.mask_erosion_px must be in 0..64 (got " << mask_erosion_px << ")";
  }
  return out.str();
}

std::vector<Feature> DetectOrb(const NormalizedCrop& crop, const OrbOptions& options) {
  if (const std::string problem = options.Check(); !problem.empty()) {
    G6D_THROW("DetectOrb: " << problem);
  }
  std::vector<Feature> features;
  if (!crop.valid) return features;
  if (crop.gray.type() != CV_8UC1 || crop.mask.type() != CV_8UC1 ||
      crop.gray.size() != crop.mask.size()) {
    G6D_THROW("DetectOrb: crop.gray and crop.mask must be CV_8UC1 of the same size");
  }

  // A fresh Mat: eroding into a header that shares crop.mask's buffer would modify the
  // caller's (const) crop in place.
  cv::Mat detect_mask;
  if (options.mask_erosion_px > 0) {
    const int k = 2 * options.mask_erosion_px + 1;
    cv::erode(crop.mask, detect_mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k)));
  } else {
    detect_mask = crop.mask;
  }

  // Patch size 31 (ORB's learned test pattern) at first level 0, Harris ranking.
  constexpr int kPatchSize = 31;
  cv::Ptr<cv::ORB> orb = cv::ORB::create(
      options.max_features, options.scale_factor, options.num_levels, options.edge_threshold,
      /*firstLevel=*/0, /*WTA_K=*/2, cv::ORB::HARRIS_SCORE, kPatchSize, options.fast_threshold);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  orb->detectAndCompute(crop.gray, detect_mask, keypoints, descriptors);
  if (keypoints.empty()) return features;
  G6D_CHECK(descriptors.type() == CV_8UC1 && descriptors.cols == 32 &&
            descriptors.rows == static_cast<int>(keypoints.size()));

  features.resize(keypoints.size());
  for (size_t i = 0; i < keypoints.size(); ++i) {
    const Eigen::Vector2d source =
        crop.ToSource(Eigen::Vector2d(keypoints[i].pt.x, keypoints[i].pt.y));
    features[i].xy = source.cast<float>();
    std::memcpy(features[i].descriptor.data(), descriptors.ptr<uint8_t>(static_cast<int>(i)), 32);
  }
  return features;
}

}  // namespace g6d
