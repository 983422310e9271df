#include "templates/silhouette.h"

#include <cmath>

namespace g6d {

MaskMoments MomentsOfMask(const cv::Mat& mask) {
  MaskMoments moments;
  if (mask.empty()) return moments;
  double sum_x = 0.0, sum_y = 0.0;
  int64_t count = 0;
  for (int y = 0; y < mask.rows; ++y) {
    const uint8_t* row = mask.ptr<uint8_t>(y);
    for (int x = 0; x < mask.cols; ++x) {
      if (row[x] == 0) continue;
      sum_x += x;
      sum_y += y;
      ++count;
    }
  }
  if (count == 0) return moments;
  moments.area_px = static_cast<double>(count);
  moments.centroid_px = Eigen::Vector2d(sum_x, sum_y) / static_cast<double>(count);
  return moments;
}

SilhouetteBits EncodeSilhouette(const cv::Mat& mask, const MaskMoments& moments, double angle_rad) {
  SilhouetteBits bits{};
  if (mask.empty() || moments.area_px <= 0.0) return bits;
  const double px_per_cell = std::sqrt(moments.area_px) / kSilhouetteUnitCells;
  // Grid cell (x, y) -> mask pixel: centroid + R(angle) (cell centre - grid centre) px_per_cell.
  const double c = std::cos(angle_rad) * px_per_cell, s = std::sin(angle_rad) * px_per_cell;
  const double half = 0.5 * kSilhouetteSide;
  for (int y = 0; y < kSilhouetteSide; ++y) {
    const double dy = y + 0.5 - half;
    for (int x = 0; x < kSilhouetteSide; ++x) {
      const double dx = x + 0.5 - half;
      const int u = static_cast<int>(std::lround(moments.centroid_px.x() + c * dx - s * dy));
      const int v = static_cast<int>(std::lround(moments.centroid_px.y() + s * dx + c * dy));
      if (u < 0 || v < 0 || u >= mask.cols || v >= mask.rows || mask.at<uint8_t>(v, u) == 0) continue;
      const int bit = y * kSilhouetteSide + x;
      bits[static_cast<size_t>(bit / 64)] |= uint64_t{1} << (bit % 64);
    }
  }
  return bits;
}

double SilhouetteIou(const SilhouetteBits& a, const SilhouetteBits& b) {
  int intersection = 0, union_count = 0;
  for (size_t w = 0; w < a.size(); ++w) {
    intersection += __builtin_popcountll(a[w] & b[w]);
    union_count += __builtin_popcountll(a[w] | b[w]);
  }
  return union_count > 0 ? static_cast<double>(intersection) / union_count : 0.0;
}

}  // namespace g6d
