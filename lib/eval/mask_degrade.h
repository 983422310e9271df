#pragma once
/// @file mask_degrade.h
/// Deterministic degradations of an instance mask, to measure how the solver copes with
/// the masks of a real segmenter instead of BOP's exact GT visible masks: eroded, dilated
/// (leaking onto the background), a jittered boundary, a part cut off, merged with touching
/// neighbours, or the filled bounding box. Every random choice comes from a seeded
/// std::mt19937_64 (options.seed mixed with a per-instance key), so a run is repeatable.
/// Masks are CV_8U images, a pixel is in the mask when non-zero; results are 0 / 255.

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace g6d {

/// How DegradeMask() changes a mask.
enum class MaskDegradation {
  kNone,    ///< unchanged
  kErode,   ///< eroded by a disc of radius size_px
  kDilate,  ///< dilated by a disc of radius size_px (leaks onto the background)
  kJitter,  ///< boundary moved in and out by up to size_px by a smooth random field
            ///< (independent every 4 size_px or so along the boundary)
  kCut,     ///< cut_fraction of the pixels removed on one side of a random straight line
  kMerge,   ///< united with every other instance mask within size_px of it
  kBox,     ///< the filled bounding box, grown by size_px on each side
};

/// The mode named `name`: none, erode, dilate, jitter, cut, merge or box. Throws g6d::Error
/// naming `name` and the valid names otherwise.
MaskDegradation ParseMaskDegradation(const std::string& name);

/// The name ParseMaskDegradation() accepts for `mode` ("erode" for kErode).
std::string MaskDegradationName(MaskDegradation mode);

/// The valid names, comma separated ("none, erode, dilate, jitter, cut, merge, box").
std::string MaskDegradationNames();

/// What DegradeMask() does.
struct MaskDegradeOptions {
  /// Which degradation; kNone returns the mask as it is (as 0 / 255).
  MaskDegradation mode = MaskDegradation::kNone;
  /// Strength in pixels, >= 0: the disc radius of erode and dilate, the largest boundary
  /// shift of jitter, the touching distance of merge, the margin of box. Unused by cut.
  int size_px = 6;
  /// Cut: the fraction of the mask's pixels removed, in [0, 1).
  double cut_fraction = 0.3;
  /// Seed of the random choices (jitter field, cut direction); mixed with the instance key.
  uint64_t seed = 1;

  /// Empty when valid, else a message naming the bad field and its value.
  std::string Check() const;
};

/// `mask` degraded as `options` says: a CV_8U 0 / 255 image of mask's size. May be empty
/// (all zero), e.g. a small mask eroded away; callers treat that as a failed segmentation.
/// `other_masks_in_image` are the other instances' masks of the same image (same size,
/// CV_8U), used only by kMerge: each one that comes within options.size_px of `mask` (the
/// mask dilated by a disc of that radius intersects it) is united with it. `instance_key`
/// identifies the instance (e.g. MaskInstanceKey()), so different instances get different
/// but repeatable random choices. `merged`, when given, is set to whether kMerge united
/// the mask with at least one neighbour (false for every other mode).
/// Throws g6d::Error when options.Check() fails, `mask` is not a non-empty single-channel
/// CV_8U image, or an other mask differs from it in size or type.
cv::Mat DegradeMask(const cv::Mat& mask, const std::vector<cv::Mat>& other_masks_in_image,
                    const MaskDegradeOptions& options, uint64_t instance_key,
                    bool* merged = nullptr);

/// A stable key of one BOP GT instance (FNV-1a over the three ids), for DegradeMask().
uint64_t MaskInstanceKey(int scene_id, int im_id, int gt_idx);

/// Intersection over union of the non-zero pixels of two masks of equal size; 1 when both
/// are empty. Throws g6d::Error when their sizes differ.
double MaskIou(const cv::Mat& a, const cv::Mat& b);

}  // namespace g6d
