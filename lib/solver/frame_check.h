#pragma once
/// @file frame_check.h
/// An answer checked against the whole frame (not only its mask or region), at its pose:
/// how much of the rendered model the observed depth confirms, how much of it the camera
/// sees through, and where its outline meets a depth step or a colour edge. Detection's
/// confidence reads it (detect.h), and so does the confidence of an answer to a mask
/// (SolverOptions::confidence).

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace g6d {

struct Frame;
struct TemplateBank;

/// An answer against the whole frame at its pose.
struct FrameCheck {
  int rendered_pixels = 0;       ///< rendered pixels (in the image) with observed depth
  double on_surface = 0.0;       ///< fraction of them whose depth lies on the rendered surface
  double free_space = 0.0;       ///< ... whose depth lies behind it: the camera sees through the object
  /// The pixels the camera sees through (free_space's) per outline pixel (FreeSpaceBand): the
  /// mean width in pixels of the band along the outline that lies in front of what the camera
  /// sees. A right pose misses by a pixel or two at its outline, whatever its size; a model
  /// laid onto a smaller object hangs over it by a wide band.
  double free_space_band_px = 0.0;
  double contour_support = 0.0;  ///< fraction of the outline where the depth steps
  /// Fraction of the outline that the colour image outlines too (an edge within
  /// kOutlineEdgeReachPx: EdgeSupport). A part lying flat on a table or a bin's floor shows
  /// no depth step at its outline; its colour edge is still there.
  double edge_support = 0.0;
  /// How often an edge lies that near by chance: the share of the rendered interior (more than
  /// kOutlineEdgeReachPx + 2 px inside the outline) with an edge within the same reach (0
  /// when there is no such interior). On a keyboard's keys every outline meets an edge.
  double edge_chance = 0.0;
  /// Fraction of the outline whose strongest image gradient within kOutlineEdgeReachPx across
  /// it is an edge along it (OrientedEdgeSupport), and the same test's rate on a line
  /// kOutlineEdgeReachPx + 3 px inside the outline: what texture gives by chance (a third for
  /// gradients of any direction). On a carpet or a keyboard every outline meets some edge,
  /// few of them along it.
  double oriented_edge = 0.0;
  double oriented_edge_chance = 0.0;
  /// The share of the object's surface (the PPF model's evenly spaced samples; the online
  /// mesh's vertices without one) that projects into the image: a pose mostly beyond the
  /// image's border is checked on the little of it that is inside.
  double in_image = 0.0;
};

/// The colour edges an outline is checked against: Canny on the grey image with thresholds
/// kOutlineEdgeThreshold and twice it (DetectOptions::raised_outline_edge's default, which
/// outlines thin parts on a support), an edge within kOutlineEdgeReachPx of an outline pixel
/// counts for it (the rendering of a right pose is a pixel or two off the image's edge).
constexpr double kOutlineEdgeThreshold = 40.0;
constexpr int kOutlineEdgeReachPx = 2;

/// Renders `bank`'s online mesh at `cam_from_object` into the frame and reads the depth
/// (surface tolerance `surface_m`, outline step `step_m`) and, at the outline, the colour
/// image's edges (EdgeSupport).
FrameCheck CheckAgainstFrame(const Frame& frame, const TemplateBank& bank, const Eigen::Isometry3d& cam_from_object,
                             double surface_m, double step_m);

/// The rendered pixels (`rendered`, CV_32F metres, 0 = empty) whose `observed` depth (CV_32F
/// metres, same size) lies more than `tolerance_m` behind the rendering, per pixel of the
/// rendering's outline (rendered pixels with an unrendered 4-neighbour; the image's border is
/// no outline): the mean width of the band the camera sees through. 0 without an outline.
double FreeSpaceBand(const cv::Mat& rendered, const cv::Mat& observed, float tolerance_m);

/// The fraction of a rendering's outline (`rendered`, CV_32F metres, 0 = empty) where the
/// `observed` depth steps: for each rendered pixel with an unrendered 4-neighbour `gap` pixels
/// away, the observed depth there is farther or nearer than the rendered depth by more than
/// `step_m` (where it has depth; without depth it says nothing either way).
double ContourSupport(const cv::Mat& rendered, const cv::Mat& observed, int gap, float step_m);

/// The fraction of a rendering's outline (`rendered`, CV_32F, > 0 = rendered; its pixels with
/// an unrendered 4-neighbour inside the image) that has a colour edge of `rgb` (CV_8UC3, same
/// size) within `reach_px`: Canny on the grey image around the rendering, thresholds
/// `threshold` and twice it. 0 without an outline or without colour.
double EdgeSupport(const cv::Mat& rendered, const cv::Mat& rgb, int reach_px, double threshold,
                   double* interior_share = nullptr);

/// The fraction of a rendering's outline (as EdgeSupport's) where the strongest gradient of
/// the grey image within `reach_px` across the outline (along its normal, from the distance
/// to the outline) is at least `threshold` (3x3 Sobel, L2) and within kOutlineEdgeAngleDeg
/// of the normal: an edge along the outline. `*chance`, when given: the same test on the
/// pixels `reach_px` + 3 px inside the outline, with the normals there (0 without such
/// pixels). 0 without an outline or without colour.
constexpr double kOutlineEdgeAngleDeg = 30.0;
double OrientedEdgeSupport(const cv::Mat& rendered, const cv::Mat& rgb, int reach_px, double threshold,
                           double* chance = nullptr);

}  // namespace g6d
