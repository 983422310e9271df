#pragma once
/// @file silhouette.h
/// Silhouette codes: a mask resampled onto a small grid in a frame normalized by its own
/// centroid, area and a rotation, as bits. Two outlines of one view of an object at
/// different distances, image positions and in-plane rotations give the same code, so a
/// template's code compared with an observed mask's (rotated in steps) says which views and
/// in-plane angles could have cast it; with the areas and centroids that gives a pose
/// (solver/silhouette_poses.h). Needs neither texture nor depth: bare metal that reflects the
/// sensor's pattern away still has an outline.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace g6d {

/// Side of the code's square grid, cells.
constexpr int kSilhouetteSide = 40;
/// The square root of the mask's area spans this many cells: an outline four times as long
/// as it is wide (2 sqrt(area) long) spans 24 of the 40 cells.
constexpr double kSilhouetteUnitCells = 12.0;
constexpr int kSilhouetteWords = (kSilhouetteSide * kSilhouetteSide + 63) / 64;

/// Bits of a normalized outline: cell (x, y) is bit y * kSilhouetteSide + x.
using SilhouetteBits = std::array<uint64_t, kSilhouetteWords>;

/// Centroid and area of a mask's non-zero pixels (OpenCV pixel coordinates, pixel centres
/// at integers); area 0 for an empty mask.
struct MaskMoments {
  Eigen::Vector2d centroid_px = Eigen::Vector2d::Zero();
  double area_px = 0.0;
};

/// The moments of `mask` (CV_8U, non-zero = inside).
MaskMoments MomentsOfMask(const cv::Mat& mask);

/// The code of `mask` (CV_8U, non-zero = inside) seen from its centroid `moments`, turned by
/// `angle_rad`: cell c (centre offset d from the grid's centre, in cells) reads the mask
/// pixel nearest to centroid + R(angle) d sqrt(area) / kSilhouetteUnitCells, where R turns
/// image x towards image y. A mask turned by +angle in the image has the same code at
/// `angle_rad` as the unturned one at 0. Pixels outside the mask image read as outside.
SilhouetteBits EncodeSilhouette(const cv::Mat& mask, const MaskMoments& moments, double angle_rad);

/// Intersection over union of two codes; 0 when both are empty.
double SilhouetteIou(const SilhouetteBits& a, const SilhouetteBits& b);

/// A template's code, with the moments of its mask in template image pixels.
struct TemplateSilhouette {
  SilhouetteBits bits{};
  MaskMoments moments;  ///< template image px (the crop mapped back by A_j)
};

}  // namespace g6d
