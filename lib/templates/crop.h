#pragma once
/// @file crop.h
/// Shape-preserving crop normalization shared by templates and queries (paper Sec. III-B):
/// square side s = (1 + 2p) max(w, h) around the mask box, resized to S x S, with the
/// affine that maps crop pixels back to the original image; contrast normalization
/// inside the mask.

#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace g6d {

/// Options of NormalizeCrop().
///
/// Contrast normalization is a global affine grey map inside the mask (mean/std to
/// `normalized_mean` / `normalized_std`, clipped to 0..255), not CLAHE: ORB's BRIEF tests
/// compare pairs of intensities, so they are exactly invariant to an increasing affine map
/// (up to clipping), and the FAST threshold becomes relative to the object's own contrast.
/// CLAHE's tile-wise curves depend on what else falls into each tile (background, occluders),
/// which differs between the rendered template and the real query, and would change the
/// descriptors of the same surface point.
struct CropOptions {
  double padding = 0.15;  ///< p: padding ratio on each side of the mask box
  int size_px = 256;      ///< S: side of the normalized square crop, pixels
  /// Grey value written outside the mask after contrast normalization (0..255).
  int background_gray = 0;
  double normalized_mean = 128.0;  ///< grey mean inside the mask after normalization
  double normalized_std = 48.0;    ///< grey standard deviation inside the mask after normalization
  /// Floor on the measured standard deviation (grey levels), so a nearly uniform object
  /// does not have its noise amplified without bound (gain <= normalized_std / min_std).
  double min_std = 4.0;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// A normalized crop and the map back to the source image.
struct NormalizedCrop {
  cv::Mat gray;  ///< CV_8U S x S, contrast-normalized inside the mask, background elsewhere
  cv::Mat mask;  ///< CV_8U S x S, 0/255
  /// Maps crop pixel coordinates (OpenCV convention) to source image pixel coordinates
  /// (OpenCV convention): source = scale * crop + offset.
  double scale = 1.0;
  Eigen::Vector2d offset = Eigen::Vector2d::Zero();
  bool valid = false;  ///< false when the mask is empty

  /// Source image pixel coordinates (OpenCV convention) of a crop pixel coordinate.
  Eigen::Vector2d ToSource(const Eigen::Vector2d& crop_xy) const {
    return scale * crop_xy + offset;
  }
  /// Crop pixel coordinates (OpenCV convention) of a source pixel coordinate.
  Eigen::Vector2d ToCrop(const Eigen::Vector2d& source_xy) const {
    return (source_xy - offset) / scale;
  }
};

/// Crops `image` (CV_8UC3 RGB or CV_8U gray) around the non-zero pixels of `mask` (CV_8U).
/// Pixels outside the image are treated as background. When the crop shrinks the image
/// (s > S) the source is low-pass filtered first (Gaussian, sigma = (s/S - 1) / 2 source
/// pixels) so the result does not alias. Returns valid = false for an empty mask; throws
/// g6d::Error when the sizes or types disagree or the options are bad.
NormalizedCrop NormalizeCrop(const cv::Mat& image, const cv::Mat& mask, const CropOptions& options);

}  // namespace g6d
