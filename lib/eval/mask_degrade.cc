#include "eval/mask_degrade.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <utility>

#include "core/error.h"
#include "core/hash.h"

namespace g6d {
namespace {

constexpr std::pair<MaskDegradation, const char*> kModeNames[] = {
    {MaskDegradation::kNone, "none"},     {MaskDegradation::kErode, "erode"},
    {MaskDegradation::kDilate, "dilate"}, {MaskDegradation::kJitter, "jitter"},
    {MaskDegradation::kCut, "cut"},       {MaskDegradation::kMerge, "merge"},
    {MaskDegradation::kBox, "box"},
};

// Jitter's random field has one independent value per square cell of this many times
// size_px (at least kMinJitterCellPx): the boundary wanders in and out over a few
// size_px along its length, as a segmenter's boundary does, rather than pixel by pixel.
constexpr int kJitterCellFactor = 4;
constexpr int kMinJitterCellPx = 4;

// Spreads the bits of seed and key (SplitMix64, core/hash.h) so that neighbouring keys
// (consecutive gt_idx) start unrelated generator streams.
uint64_t Mix(uint64_t value) { return SplitMix64(value); }

// Uniform in [0, 1) from the generator's raw 64 bits. std::uniform_real_distribution is
// implementation-defined; this is the same with every standard library.
double Uniform01(std::mt19937_64* rng) { return static_cast<double>((*rng)() >> 11) * 0x1.0p-53; }

cv::Mat Disc(int radius_px) {
  return cv::getStructuringElement(cv::MORPH_ELLIPSE,
                                   cv::Size(2 * radius_px + 1, 2 * radius_px + 1));
}

// A smooth field in [-1, 1] of `size`: uniform values on a coarse grid of `cell_px`
// cells, upsampled bicubically (clamped, since bicubic overshoots).
cv::Mat SmoothNoise(cv::Size size, int cell_px, std::mt19937_64* rng) {
  const int grid_cols = size.width / cell_px + 3, grid_rows = size.height / cell_px + 3;
  cv::Mat grid(grid_rows, grid_cols, CV_32F);
  for (int v = 0; v < grid_rows; ++v) {
    for (int u = 0; u < grid_cols; ++u) {
      grid.at<float>(v, u) = static_cast<float>(2.0 * Uniform01(rng) - 1.0);
    }
  }
  cv::Mat upsampled;
  cv::resize(grid, upsampled, cv::Size(grid_cols * cell_px, grid_rows * cell_px), 0, 0,
             cv::INTER_CUBIC);
  // One cell in from the corner, where the interpolation has neighbours on every side.
  cv::Mat noise = upsampled(cv::Rect(cell_px, cell_px, size.width, size.height)).clone();
  cv::min(noise, 1.0, noise);
  cv::max(noise, -1.0, noise);
  return noise;
}

// A pixel stays or becomes part of the mask when its signed distance to the boundary
// (positive inside, the boundary half-way between an inside and an outside pixel) plus
// noise * size_px is positive: only pixels within size_px + 0.5 of the boundary change.
cv::Mat Jitter(const cv::Mat& binary, int size_px, std::mt19937_64* rng) {
  if (size_px == 0 || cv::countNonZero(binary) == 0) return binary.clone();
  cv::Mat inside_distance, outside_distance, outside;
  cv::distanceTransform(binary, inside_distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::bitwise_not(binary, outside);
  cv::distanceTransform(outside, outside_distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const cv::Mat noise =
      SmoothNoise(binary.size(), std::max(kMinJitterCellPx, kJitterCellFactor * size_px), rng);
  cv::Mat result = cv::Mat::zeros(binary.size(), CV_8U);
  for (int v = 0; v < binary.rows; ++v) {
    const uint8_t* in = binary.ptr<uint8_t>(v);
    const float* d_in = inside_distance.ptr<float>(v);
    const float* d_out = outside_distance.ptr<float>(v);
    const float* n = noise.ptr<float>(v);
    uint8_t* out = result.ptr<uint8_t>(v);
    for (int u = 0; u < binary.cols; ++u) {
      const double signed_distance = in[u] ? d_in[u] - 0.5 : -(d_out[u] - 0.5);
      out[u] = signed_distance + n[u] * size_px > 0.0 ? 255 : 0;
    }
  }
  return result;
}

// Removes the round(cut_fraction * N) pixels (fewer on ties) that lie farthest along a
// random direction: everything beyond a straight line across the mask.
cv::Mat Cut(const cv::Mat& binary, double cut_fraction, std::mt19937_64* rng) {
  std::vector<cv::Point> pixels;
  cv::findNonZero(binary, pixels);
  const int count = static_cast<int>(pixels.size());
  const int removed = std::min(count - 1, static_cast<int>(std::lround(cut_fraction * count)));
  if (count == 0 || removed <= 0) return binary.clone();
  const double angle_rad = 2.0 * M_PI * Uniform01(rng);
  const double normal_x = std::cos(angle_rad), normal_y = std::sin(angle_rad);
  std::vector<double> projections(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) {
    projections[i] = normal_x * pixels[i].x + normal_y * pixels[i].y;
  }
  std::vector<double> sorted = projections;
  const auto largest_kept = sorted.begin() + (count - removed - 1);
  std::nth_element(sorted.begin(), largest_kept, sorted.end());
  const double offset = *largest_kept;  // the line: normal . x = offset
  cv::Mat result = binary.clone();
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (projections[i] > offset) result.at<uint8_t>(pixels[i]) = 0;
  }
  return result;
}

cv::Mat Merge(const cv::Mat& binary, const std::vector<cv::Mat>& others, int size_px,
              bool* merged) {
  cv::Mat grown;
  cv::dilate(binary, grown, Disc(size_px));
  cv::Mat result = binary.clone();
  for (const cv::Mat& other : others) {
    const cv::Mat other_binary = other > 0;
    cv::Mat touching;
    cv::bitwise_and(grown, other_binary, touching);
    if (cv::countNonZero(touching) == 0) continue;
    cv::bitwise_or(result, other_binary, result);
    *merged = true;
  }
  return result;
}

cv::Mat Box(const cv::Mat& binary, int size_px) {
  cv::Mat result = cv::Mat::zeros(binary.size(), CV_8U);
  const cv::Rect box = cv::boundingRect(binary);
  if (box.area() == 0) return result;
  const cv::Rect grown(box.x - size_px, box.y - size_px, box.width + 2 * size_px,
                       box.height + 2 * size_px);
  result(grown & cv::Rect(0, 0, binary.cols, binary.rows)).setTo(255);
  return result;
}

}  // namespace

MaskDegradation ParseMaskDegradation(const std::string& name) {
  for (const auto& [mode, mode_name] : kModeNames) {
    if (name == mode_name) return mode;
  }
  G6D_THROW("unknown mask degradation '" << name << "' (valid: " << MaskDegradationNames() << ")");
}

std::string MaskDegradationName(MaskDegradation mode) {
  for (const auto& [known, name] : kModeNames) {
    if (known == mode) return name;
  }
  G6D_CHECK(false);
  return "";
}

std::string MaskDegradationNames() {
  std::string names;
  for (const auto& [mode, name] : kModeNames)
    names += (names.empty() ? "" : ", ") + std::string(name);
  return names;
}

std::string MaskDegradeOptions::Check() const {
  std::ostringstream out;
  if (size_px < 0) {
    out << "MaskDegradeOptions.size_px must be >= 0 (got " << size_px << ")";
  } else if (!(cut_fraction >= 0.0 && cut_fraction < 1.0)) {
    out << "MaskDegradeOptions.cut_fraction must be in [0, 1) (got " << cut_fraction << ")";
  }
  return out.str();
}

cv::Mat DegradeMask(const cv::Mat& mask, const std::vector<cv::Mat>& other_masks_in_image,
                    const MaskDegradeOptions& options, uint64_t instance_key, bool* merged) {
  if (const std::string problem = options.Check(); !problem.empty()) G6D_THROW(problem);
  if (mask.empty() || mask.type() != CV_8UC1) {
    G6D_THROW("DegradeMask: the mask must be a non-empty CV_8UC1 image (got type "
              << mask.type() << ", " << mask.cols << "x" << mask.rows << ")");
  }
  for (size_t i = 0; i < other_masks_in_image.size(); ++i) {
    const cv::Mat& other = other_masks_in_image[i];
    if (other.type() != CV_8UC1 || other.size() != mask.size()) {
      G6D_THROW("DegradeMask: other mask " << i << " must be CV_8UC1 of " << mask.cols << "x"
                                           << mask.rows << " (got type " << other.type() << ", "
                                           << other.cols << "x" << other.rows << ")");
    }
  }
  bool merged_any = false;
  const cv::Mat binary = mask > 0;
  std::mt19937_64 rng(Mix(Mix(options.seed) ^ instance_key));
  cv::Mat result;
  switch (options.mode) {
    case MaskDegradation::kNone:
      result = binary;
      break;
    case MaskDegradation::kErode:
      // Outside the image counts as inside (OpenCV's default border for erosion): a mask
      // cut by the image border does not also shrink away from it.
      cv::erode(binary, result, Disc(options.size_px));
      break;
    case MaskDegradation::kDilate:
      cv::dilate(binary, result, Disc(options.size_px));
      break;
    case MaskDegradation::kJitter:
      result = Jitter(binary, options.size_px, &rng);
      break;
    case MaskDegradation::kCut:
      result = Cut(binary, options.cut_fraction, &rng);
      break;
    case MaskDegradation::kMerge:
      result = Merge(binary, other_masks_in_image, options.size_px, &merged_any);
      break;
    case MaskDegradation::kBox:
      result = Box(binary, options.size_px);
      break;
  }
  if (merged) *merged = merged_any;
  return result;
}

uint64_t MaskInstanceKey(int scene_id, int im_id, int gt_idx) {
  uint64_t hash = kFnvOffsetBasis;
  for (const int id : {scene_id, im_id, gt_idx}) {
    // Little-endian bytes of the id, whatever the machine's byte order.
    unsigned char bytes[4];
    for (int b = 0; b < 4; ++b)
      bytes[b] = static_cast<unsigned char>(static_cast<uint32_t>(id) >> (8 * b));
    hash = Fnv1a64(bytes, sizeof(bytes), hash);
  }
  return hash;
}

double MaskIou(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size()) {
    G6D_THROW("MaskIou: masks of different sizes (" << a.cols << "x" << a.rows << " and " << b.cols
                                                    << "x" << b.rows << ")");
  }
  const cv::Mat a_in = a > 0, b_in = b > 0;
  cv::Mat both, either;
  cv::bitwise_and(a_in, b_in, both);
  cv::bitwise_or(a_in, b_in, either);
  const int union_px = cv::countNonZero(either);
  return union_px == 0 ? 1.0 : static_cast<double>(cv::countNonZero(both)) / union_px;
}

}  // namespace g6d
