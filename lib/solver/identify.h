#pragma once
/// @file identify.h
/// EstimatePoseOfUnknownObject: the pose of a masked object whose identity is not known (a
/// class-agnostic segmenter, or a short list of candidate objects): EstimatePose for every
/// candidate, the answer with the lowest S_A wins, the runner-up identity is reported.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/executor.h"
#include "core/frame.h"
#include "solver/pipeline.h"
#include "templates/template_bank.h"

namespace g6d {

/// Options of the identity search beyond the solver's own (SolverOptions).
struct IdentifyOptions {
  /// Pre-screen: a candidate whose diameter is shorter than the extent of the mask's depth
  /// points (MaskDepthExtent), less the sensor's noise at both ends, cannot be the object
  /// and is not solved. Never applied to a single candidate, nor when it would rule out
  /// every candidate (the mask then holds more than one object: all are solved), nor when
  /// the candidate's region holds two large depth segments or more (a box, a merged mask:
  /// its extent is not one object's).
  bool prescreen = true;
  /// Fraction of the points left out at each end of every direction's span (flying pixels
  /// and label bleed at the mask boundary), in [0, 0.25).
  double extent_trim_fraction = 0.02;
  /// Mask pixels beyond the sensor noise an extent may exceed the diameter by, at each end
  /// (a mask boundary is uncertain by about a pixel).
  double extent_margin_px = 1.0;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// One candidate object as tried.
struct IdentityCandidate {
  std::string object_id;
  bool success = false;       ///< solved with a pose (EstimatePose's success)
  bool screened_out = false;  ///< the pre-screen ruled it out: not solved
  double score = 2.0;         ///< its S_A (2 when not solved or failed); lower is better
  double diameter_m = 0.0;    ///< the candidate's diameter (TemplateBank::diameter_m)
  /// The extent of the mask's depth points in the region this candidate's solve would read
  /// (MaskDepthExtent), metres; 0 when the pre-screen did not run.
  double extent_m = 0.0;
  /// How much longer than the diameter the extent may be: the sensor noise at both ends
  /// plus IdentifyOptions::extent_margin_px at the mask's farthest depth, metres.
  double extent_allowance_m = 0.0;
  double ms = 0.0;            ///< time spent on this candidate: pre-screen + solve, ms
  std::string message = "not run";  ///< EstimatePose's message, or why it was screened out
};

/// The answer for a mask of unknown identity.
struct IdentifiedPose {
  /// The chosen object's EstimatePose answer, unchanged. When no candidate succeeded:
  /// success false, the first solved candidate's termination and a message naming every
  /// candidate's reason.
  PoseResult result;
  std::string object_id;      ///< the chosen object ("" when none succeeded)
  std::string runner_up_id;   ///< the successful candidate with the next lowest S ("" if none)
  double runner_up_score = 2.0;  ///< its S_A (2 when there is none)
  /// The runner-up object explains the mask nearly as well: its S_A is within
  /// SolverOptions::ambiguity_margin of the chosen one's (as for two poses of one object).
  /// A larger object cut by the image border or hidden behind an occluder can cover the
  /// same visible pixels and depths as a smaller one; S cannot tell them apart then.
  bool ambiguous = false;
  /// Every candidate, in the order given, with its S, extent and time.
  std::vector<IdentityCandidate> candidates;
  int screened_out = 0;       ///< candidates the pre-screen ruled out
  double total_ms = 0.0;      ///< wall time of the whole search, ms
};

/// A lower bound on the distance between two of the object's visible points that the mask
/// shows (metres): the largest span, over SpanDirections() (segments.h: the camera axes and
/// the face and body diagonals), of the back-projected valid-depth pixels of `mask`,
/// each span between the `trim_fraction` and 1 - `trim_fraction` quantiles. Two points at
/// least a span apart exist among the kept points, so an object whose diameter is shorter
/// (less the depth noise) cannot have made them. `depth`: CV_32F metres, 0 or NaN = invalid;
/// `mask`: CV_8U of the same size. Also returns the largest valid depth in the mask
/// (`max_depth_m`, may be null). 0 when fewer than two pixels have depth.
double MaskDepthExtent(const Camera& camera, const cv::Mat& mask, const cv::Mat& depth,
                       double trim_fraction, double* max_depth_m);

/// Estimates the pose of the object seen in `mask` among `candidates` (their banks; each a
/// different object): EstimatePose(frame, {bank->object_id, mask}, *bank, options, executor)
/// for each candidate in the order given (after the pre-screen, IdentifyOptions), and the
/// successful answer with the lowest S_A wins (ties: the earlier candidate). S_A compares
/// across objects as it does across poses: 1 - J is a fraction of the silhouette and the
/// depth term is normalized by the mask's depth, not by the object's size.
/// SolverOptions::budget_ms and stop_requested apply to each candidate's solve. With one
/// candidate the result is exactly EstimatePose's. Throws g6d::Error for bad arguments: no
/// candidates, a null bank, two candidates with one object id, bad IdentifyOptions. Bad
/// frames and masks are EstimatePose's to report (result.success false, kBadInput).
IdentifiedPose EstimatePoseOfUnknownObject(const Frame& frame, const cv::Mat& mask,
                                           const std::vector<const TemplateBank*>& candidates,
                                           const SolverOptions& options,
                                           const IdentifyOptions& identify_options,
                                           Executor* executor);

/// The same with default IdentifyOptions.
IdentifiedPose EstimatePoseOfUnknownObject(const Frame& frame, const cv::Mat& mask,
                                           const std::vector<const TemplateBank*>& candidates,
                                           const SolverOptions& options, Executor* executor);

}  // namespace g6d
