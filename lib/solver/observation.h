#pragma once
/// @file observation.h
/// The observed data of one instance, prepared once and shared (read-only) by every
/// hypothesis: the instance mask, depth, the region of interest used for scoring, and
/// z_M, the mean observed depth inside the mask (paper eq. 9).

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/frame.h"
#include "solver/segments.h"

namespace g6d {

/// A mask and depth resampled onto a (cropped, scaled) region of interest of the image.
/// Grid pixel (u, v) samples the source pixel containing the grid pixel's centre.
struct EvaluationGrid {
  Camera camera;  ///< camera of the grid (Camera::Cropped then Scaled)
  cv::Mat mask;   ///< CV_8U 0/255 observed mask on the grid
  cv::Mat depth;  ///< CV_32F metres on the grid, 0 = invalid
  cv::Mat support;  ///< CV_8U 0/255 on the grid: pixels on the support plane; empty = none known
  /// CV_32S on the grid: the depth segment (segments.h) of each mask pixel, 0 = none; empty
  /// when the mask is one segment (nothing for a pose to own or leave).
  cv::Mat segment;
  /// Mask pixels on the grid per segment label (index 0: mask pixels in no segment).
  std::vector<int> segment_pixels;
  /// The spans of each segment (DepthSegment::spans) by label (index 0 unused).
  std::vector<Spans> segment_spans;
  /// CV_8U 0/255 on the grid: mask pixels the depth cannot judge (ObservedRegion::unsure);
  /// empty when none.
  cv::Mat unsure;
  int mask_pixels = 0;
  /// Share of the grid's pixels outside the mask without observed depth: small where the
  /// sensor sees a background with holes, near 1 where it sees none (a far wall, depth of
  /// the objects alone).
  double unseen_background = 0.0;
  /// CV_8U 0/255 on the grid: pixels outside the mask without depth that lie in a depthless
  /// area at least GridOptions::unseen_area_min_px wide (an occluder the sensor could not
  /// see, ScoreOptions::unseen_is_hidden); empty when that option is 0.
  cv::Mat unseen_area;
  /// CV_32F metres on the grid, for a depthless pixel outside the mask in no unseen_area
  /// (a hole narrower than GridOptions::unseen_area_min_px: speckle on bare metal, a band
  /// along an edge): the nearest and the farthest valid depth within that square around it;
  /// 0 elsewhere and where no depth is near. Empty unless GridOptions::fill_thin_holes (and
  /// unseen_area_min_px > 0).
  cv::Mat hole_near, hole_far;
};

/// Options of MakeEvaluationGrid().
struct GridOptions {
  /// Margin added on each side of the mask box, as a fraction of the box's longer side.
  double margin = 0.5;
  /// The grid's longer side in pixels (the ROI is downscaled, never upscaled, to it).
  int max_side_px = 128;
  /// Width in image pixels a depthless area outside the mask must have to enter
  /// EvaluationGrid::unseen_area (a morphological opening with a square of this side).
  /// Sensors lose depth in thin bands along every depth step (edges, a projector's shadow);
  /// a band is no occluder. 0 = every depthless pixel outside the mask is in the area.
  int unseen_area_min_px = 9;
  /// Fill EvaluationGrid::hole_near and hole_far (the depth around a thin hole outside the
  /// mask), so that a rendered pixel in a hole whose surroundings lie on its surface counts
  /// as object the mask missed (HoleOnSurface, with depth evidence). Off: measured
  /// (bench/RESULTS.md, "A confidence that reads the frame") it helps the simulated sensor
  /// (synth_dev cut masks 72.1% -> 72.8%, without masks AR 0.548 -> 0.557) and the real foam
  /// brick (AR 0.530 -> 0.643) but costs real YCB-V clutter's precision (without masks AR
  /// 0.824 -> 0.795): the Xtion's holes along edges let a pose spill over its outline.
  bool fill_thin_holes = false;

  std::string Check() const;
};

/// Resamples `mask` (CV_8U, non-zero = object) and `depth` (CV_32F metres) of the full
/// image onto the ROI around the mask box, clipped to the image.
/// `support` (optional, CV_8U frame size, non-zero = on the support plane) is resampled too,
/// and so are the depth `segments` of the mask (optional) when it holds two or more, and
/// `unsure` (optional, CV_8U frame size, ObservedRegion::unsure).
EvaluationGrid MakeEvaluationGrid(const Camera& camera, const cv::Mat& mask, const cv::Mat& depth,
                                  const GridOptions& options, const cv::Mat& support = cv::Mat(),
                                  const DepthSegmentation* segments = nullptr, const cv::Mat& unsure = cv::Mat());

/// The depthless pixels outside `mask` (CV_8U, non-zero = mask) within `roi`, less the
/// areas narrower than `min_px` (an opening with a square of that side; 1 = every one):
/// where the sensor saw nothing, not where it lost the depth in a thin band along an edge.
/// CV_8U 0/255 of roi's size. `depth` is CV_32F of the mask's size.
cv::Mat UnseenAreaOutside(const cv::Mat& mask, const cv::Mat& depth, const cv::Rect& roi, int min_px);

/// z_M of eq. (9): mean observed depth over mask pixels with valid depth, metres;
/// 0 when there is none. *valid_pixels (optional) receives their count.
double MeanMaskedDepth(const cv::Mat& mask, const cv::Mat& depth, int* valid_pixels = nullptr);

/// Robust z_M: the median observed depth over mask pixels with valid depth, metres; 0 when
/// there is none. Used instead of eq. (9)'s mean because real masks leak onto the
/// background and the table and real depth has flying pixels at edges: a few such pixels
/// move a mean by centimetres, the median not at all. *valid_pixels (optional) receives
/// their count.
double MedianMaskedDepth(const cv::Mat& mask, const cv::Mat& depth, int* valid_pixels = nullptr);

}  // namespace g6d
