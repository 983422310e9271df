#include "templates/crop.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace g6d {

std::string CropOptions::Check() const {
  std::ostringstream out;
  if (!std::isfinite(padding) || padding < 0.0 || padding > 4.0) {
    out << "crop.padding must be in [0, 4] (got " << padding << ")";
  } else if (size_px < 16 || size_px > 4096) {
    out << "crop.size_px must be in 16..4096 (got " << size_px << ")";
  } else if (background_gray < 0 || background_gray > 255) {
    out << "crop.background_gray must be in 0..255 (got " << background_gray << ")";
  } else if (!std::isfinite(normalized_mean) || normalized_mean < 0.0 || normalized_mean > 255.0) {
    out << "crop.normalized_mean must be in [0, 255] (got " << normalized_mean << ")";
  } else if (!std::isfinite(normalized_std) || normalized_std <= 0.0 || normalized_std > 255.0) {
    out << "crop.normalized_std must be in (0, 255] (got " << normalized_std << ")";
  } else if (!std::isfinite(min_std) || min_std <= 0.0 || min_std > 255.0) {
    out << "crop.min_std must be in (0, 255] (got " << min_std << ")";
  }
  return out.str();
}

NormalizedCrop NormalizeCrop(const cv::Mat& image, const cv::Mat& mask,
                             const CropOptions& options) {
  if (const std::string problem = options.Check(); !problem.empty()) {
    G6D_THROW("NormalizeCrop: " << problem);
  }
  if (image.empty() || (image.type() != CV_8UC3 && image.type() != CV_8UC1)) {
    G6D_THROW("NormalizeCrop: image must be a non-empty CV_8UC3 or CV_8UC1 (got type "
              << image.type() << ", " << image.cols << "x" << image.rows << ")");
  }
  if (mask.type() != CV_8UC1 || mask.size() != image.size()) {
    G6D_THROW("NormalizeCrop: mask must be CV_8UC1 of the image size "
              << image.cols << "x" << image.rows << " (got type " << mask.type() << ", "
              << mask.cols << "x" << mask.rows << ")");
  }

  NormalizedCrop crop;
  const cv::Rect box = cv::boundingRect(mask);
  if (box.area() <= 0) return crop;  // empty mask: valid = false

  // The box covers the continuous square [x, x + w) x [y, y + h) (corner origin). The crop
  // square of side s shares its centre and maps onto [0, S)^2. In corner coordinates
  // source = scale * crop + corner; OpenCV coordinates are corner - 0.5 on both sides, so
  // source_cv = scale * crop_cv + corner + 0.5 * (scale - 1).
  const int size = options.size_px;
  const double side = (1.0 + 2.0 * options.padding) * std::max(box.width, box.height);
  crop.scale = side / size;
  const Eigen::Vector2d corner(box.x + 0.5 * box.width - 0.5 * side,
                               box.y + 0.5 * box.height - 0.5 * side);
  crop.offset = corner + Eigen::Vector2d::Constant(0.5 * (crop.scale - 1.0));

  // Only the source pixels the crop can touch (plus the filter support) are processed.
  const double sigma = crop.scale > 1.0 ? 0.5 * (crop.scale - 1.0) : 0.0;
  const int margin = 2 + static_cast<int>(std::ceil(3.0 * sigma));
  const cv::Rect reach(static_cast<int>(std::floor(corner.x())) - margin,
                       static_cast<int>(std::floor(corner.y())) - margin,
                       static_cast<int>(std::ceil(side)) + 2 * margin + 1,
                       static_cast<int>(std::ceil(side)) + 2 * margin + 1);
  const cv::Rect roi = reach & cv::Rect(0, 0, image.cols, image.rows);

  cv::Mat gray_source;
  if (image.channels() == 3) {
    cv::cvtColor(image(roi), gray_source, cv::COLOR_RGB2GRAY);
  } else {
    gray_source = image(roi).clone();
  }
  if (sigma > 0.05) {
    // Edges of the ROI that are image edges continue as background (0) beyond the image;
    // other ROI edges lie outside the crop's reach by `margin`, so any border mode works.
    cv::GaussianBlur(gray_source, gray_source, cv::Size(0, 0), sigma, sigma, cv::BORDER_CONSTANT);
  }

  // With WARP_INVERSE_MAP the matrix maps destination pixel centres to source pixel centres
  // (both with OpenCV's integer-centre convention), which is exactly ToSource() shifted by
  // the ROI origin.
  const cv::Matx23d crop_to_roi(crop.scale, 0.0, crop.offset.x() - roi.x,  //
                                0.0, crop.scale, crop.offset.y() - roi.y);
  const cv::Size crop_size(size, size);
  cv::Mat gray;
  cv::warpAffine(gray_source, gray, crop_to_roi, crop_size, cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                 cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat mask_linear;
  cv::warpAffine(mask(roi), mask_linear, crop_to_roi, crop_size,
                 cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::threshold(mask_linear, crop.mask, 127, 255, cv::THRESH_BINARY);

  if (cv::countNonZero(crop.mask) == 0) return NormalizedCrop{};  // sub-pixel mask vanished

  // Contrast normalization inside the mask: an increasing affine grey map (see CropOptions).
  cv::Scalar mean, stddev;
  cv::meanStdDev(gray, mean, stddev, crop.mask);
  const double gain = options.normalized_std / std::max(stddev[0], options.min_std);
  const double bias = options.normalized_mean - gain * mean[0];
  gray.convertTo(crop.gray, CV_8U, gain, bias);  // saturating: clips to 0..255
  crop.gray.setTo(cv::Scalar(options.background_gray), crop.mask == 0);
  crop.valid = true;
  return crop;
}

}  // namespace g6d
