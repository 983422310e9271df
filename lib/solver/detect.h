#pragma once
/// @file detect.h
/// DetectObjects: the known objects found in an RGB-D frame with no mask and no box, and no
/// learned model (the BOP localization task: the ids of the objects present and how many of
/// each are given, nothing else).
///
/// Proposals come from the depth alone, once per frame:
///  1. the support surfaces (a table, the floor, a wall) are planes far larger than any of
///     the objects looked for: RANSAC planes whose connected inliers span more than every
///     object's diameter are removed;
///  2. the rest splits into depth-connected segments (SegmentByDepthAndCreases: the depth
///     jumps where one surface ends, and objects that touch meet in a concave crease), and
///     neighbouring segments (a surface broken by a hole in the depth
///     or by a self-occlusion edge) join into unions of up to `max_union_segments`;
///  3. every segment or union whose 3D extent fits inside an object (at most its diameter,
///     at least a fraction of it) is a candidate region for that object.
/// Per object the candidates are ranked cheaply (how much of the object's size they show,
/// how well their colours agree with the cache's appearance samples); the best ones are
/// solved as the region solve of a mask read as evidence (EstimatePose, MaskTrust::kDepth),
/// and the answers are kept by S_A with non-maximum suppression: a pixel belongs to at most
/// one answer, an object's count is respected, and a poor S_A is no answer.

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/executor.h"
#include "core/frame.h"
#include "solver/pipeline.h"
#include "solver/segments.h"
#include "templates/template_bank.h"

namespace g6d {

/// One object to find.
struct DetectRequest {
  const TemplateBank* bank = nullptr;  ///< the object's templates (not owned)
  int count = 1;                       ///< at most this many instances are answered (>= 1)
  /// Where the object was last seen (camera frame, metres), e.g. a lost track's last pose:
  /// candidates within the object's diameter of it are solved first. Unset = NaN.
  Eigen::Vector3d near_point_m = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Where the object is known to be, e.g. a segmenter's mask or a detector's box that may
  /// hold more than the object (CV_8U, frame size, non-zero = inside; empty = anywhere):
  /// only regions formed from the depth inside it that share at least half of the smaller
  /// of the two (the region, the pixels with depth inside it) are its candidates. Frames
  /// whose every request has one are segmented inside their union only.
  cv::Mat within = cv::Mat();
};

/// Options of DetectObjects().
struct DetectOptions {
  /// Depth segmentation (sensor noise, step between neighbours of one surface, fragments).
  SegmentOptions segments = [] {
    SegmentOptions segments;
    segments.min_segment_pixels = 40;
    return segments;
  }();
  /// Support planes: at most this many, found one after the other by RANSAC on a sample of
  /// the frame's depth points.
  int max_planes = 3;
  int plane_iterations = 300;
  int plane_samples = 4000;
  /// A point lies on a plane within noise_sigmas · σ(z) (segments.sensor_noise_at_1m, σ
  /// growing with z²) plus this: real tables and floors are not flat to the millimetre, and
  /// the depth of a real sensor bends by a few millimetres across the image.
  double plane_flatness_m = 0.006;
  /// A plane is a support when its inliers hold at least this fraction of the sampled points
  /// and a connected part of them spans more than `support_extent_factor` times the largest
  /// diameter of the objects looked for (so that no face of an object is taken away); only
  /// such large connected parts are removed.
  double min_plane_fraction = 0.03;
  double support_extent_factor = 1.5;
  /// Segments whose pixel boxes lie within this many pixels of each other are neighbours.
  int neighbour_gap_px = 6;
  /// Unions of at most this many neighbouring segments are candidates too.
  int max_union_segments = 3;
  /// At most this many distinct regions (segments and unions) are formed.
  int max_regions = 400;
  /// A region is a candidate for an object when its extent (Spans::Extent, a lower bound on
  /// its diameter) is at most the object's diameter plus the sensor noise and this many
  /// pixels at its depth at each end, and at least `min_extent_fraction` of the diameter.
  double extent_margin_px = 2.0;
  double min_extent_fraction = 0.3;
  /// ... and holds at least this fraction of the pixels the whole object would cover at the
  /// region's depth (about (f · diameter / z)² · π / 8 for a compact object).
  double min_area_fraction = 0.05;
  /// Candidates solved per object: its count plus this many, best ranked first (a candidate
  /// mostly inside one already chosen for solving is skipped). 1: on the real YCB-V sets the
  /// object's region always ranked first or second; 2 costs half as much again and on the
  /// sample let one wrong region beat the right one by S (97.2% against 100%,
  /// bench/RESULTS.md, issue 23). The explaining-away pass gives an object without an
  /// answer a second chance.
  int extra_candidates = 1;
  /// Ranking: weight of the colour agreement against the size agreement (0 = size only).
  /// The colour term is the Bhattacharyya coefficient of chromaticity histograms of the
  /// region's pixels and the cache's appearance samples (neutral 0.5 for an uncoloured
  /// model).
  double colour_weight = 0.5;
  /// An object's candidates are solved in rank order until it has `count` answers (not
  /// overlapping) whose confidence (SolverOptions' calibration of S_A) is at least
  /// `accept_confidence` and that explain their region: the mask the answer implies
  /// (PoseResult::corrected_mask) has an IoU of at least `accept_region_iou` with it. (A
  /// region of two objects can hold a good pose of one; it does not end the search.) The
  /// rest are not solved. 1 (the default) = always solve every chosen candidate: on the
  /// real YCB-V clutter a region of the sugar box and the bottle's top held a mustard-bottle
  /// pose with confidence 0.95 and region IoU 0.85, ranked above the bottle's own region
  /// (bench/RESULTS.md, issue 23); the search must compare the candidates.
  double accept_confidence = 1.0;
  double accept_region_iou = 0.7;
  /// The region solved is the candidate's segments plus the pixels without depth (or in
  /// depth fragments) within this many pixels of them that no other segment or support
  /// holds: a segmenter's mask covers the dark rims and holes of the object's depth too.
  int fill_gap_px = 3;
  /// Explaining away: when an object still lacks answers after a pass, the pixels of the
  /// answers kept so far are taken out and the rest is proposed, ranked and solved again for
  /// the objects still wanted, at most this many times (0 = one pass). Two objects that
  /// touch without a crease between them form one region too large for either; once the one
  /// found elsewhere (or in a region of its own) is taken out, the other stands alone.
  int explain_away_passes = 1;
  /// An answer whose S_A is above this is no answer (confidence about 1% at the defaults).
  double max_score = 0.35;
  /// Non-maximum suppression: an answer whose corrected mask shares more than this fraction
  /// of its pixels with the mask of a better answer (lower S_A) is dropped.
  double max_overlap = 0.3;
  /// Regions from the point-pair-feature vote over the frame (less its support; ppf.h), for
  /// objects whose bank has a PPF model (and SolverOptions::use_ppf): the pose clusters with
  /// the most votes, each rendered into the frame, and the pixels whose depth lies on its
  /// rendered surface are a candidate region of that object, besides the depth segments'.
  /// Parts that touch in a bin, or an object leaning on another, form no segment of their
  /// own; the vote finds them anyway. Per object, its count plus `ppf_extra` such regions
  /// are solved (0 = off, the default: on synth_dev without masks they cost 1.1 s per image
  /// and took recall from 39.1% to 37.1%: a pose laid onto a surface that runs on past it
  /// explains its own region, and S cannot tell; bench/RESULTS.md).
  int ppf_extra = 0;
  /// The vote over the frame: every n-th scene point is a reference, at most this many scene points.
  int ppf_reference_stride = 4;
  int ppf_max_scene_points = 5000;
  /// A pose's region: its rendered pixels whose observed depth lies within this fraction of
  /// the diameter of the rendered surface; a pose whose rendered pixels see past its surface
  /// (observed depth farther than that: free space the object would fill) for more than
  /// `ppf_max_free_space` of them is no candidate.
  double ppf_surface_fraction = 0.1;
  double ppf_max_free_space = 0.5;
  /// ... and an object ends where the depth steps: at this fraction of its rendered outline
  /// at least, the depth just outside it must lie behind it (or in front: an occluder, or
  /// be missing) by more than `ppf_contour_step_m`. A pose laid onto a larger surface (a
  /// flat part onto a wall, a plate onto another part) explains the depth under it as well
  /// as the true one, but the surface runs on past its outline.
  double ppf_min_contour_support = 0.3;
  double ppf_contour_step_m = 0.005;
  /// Every answer is checked against the whole frame at its final pose (FrameCheck, in
  /// Detection::check): it is no answer when more than `max_free_space` of its rendered
  /// pixels with depth see past its surface (by more than `free_space_fraction` of the
  /// diameter), or when less than `min_contour_support` of its outline shows a depth step
  /// (ppf_contour_step_m). Off by default (1 and 0): as hard limits (0.15, 0.5) they took
  /// synth_dev's recall without masks from 39.1% to 33.3%, refusing right answers of parts
  /// whose outline meets a touching part at the same depth (bench/RESULTS.md).
  double max_free_space = 1.0;
  double free_space_fraction = 0.05;
  double min_contour_support = 0.0;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// One candidate region.
struct Proposal {
  std::vector<int> segments;  ///< labels (1-based) of DetectionReport::segmentation
  cv::Rect box;               ///< pixel box
  int pixels = 0;             ///< pixels with depth
  double extent_m = 0.0;      ///< Spans::Extent of its points
  double depth_m = 0.0;       ///< median depth (pixel-weighted over its segments)
  Eigen::Vector3d centre_m = Eigen::Vector3d::Zero();  ///< centre of its spans' box, camera frame
  int pass = 0;               ///< the pass whose segmentation its labels refer to (DetectionReport::passes)
  /// A region of the point-pair-feature vote (DetectOptions::ppf_extra): CV_8U 0/255, frame
  /// size, the pixels on the surface of a voted pose of object `ppf_request`; `segments` is
  /// then empty. Empty for a region of the depth segments.
  cv::Mat mask;
  int ppf_request = -1;
  double ppf_votes = 0.0;
};

/// One (object, candidate) pair that was ranked, and solved when it ranked high enough.
struct CandidateTrial {
  int request = -1;          ///< index into the requests
  int proposal = -1;         ///< index into DetectionReport::proposals
  int pass = 0;              ///< the pass it was ranked in
  double size_term = 0.0;    ///< extent / diameter, in [0, 1]
  double colour_term = 0.5;  ///< chromaticity agreement in [0, 1] (0.5 = no colour model)
  double rank = 0.0;         ///< the ranking score (higher first)
  bool solved = false;
  bool success = false;
  double score = 2.0;        ///< S_A when solved
  double region_iou = 0.0;   ///< IoU of the answer's corrected mask with the region solved
  double ms = 0.0;           ///< solve time
};

/// An answer checked against the whole frame (not only its region), at its pose.
struct FrameCheck {
  int rendered_pixels = 0;       ///< rendered pixels (in the image) with observed depth
  double on_surface = 0.0;       ///< fraction of them whose depth lies on the rendered surface
  double free_space = 0.0;       ///< ... whose depth lies behind it: the camera sees through the object
  double contour_support = 0.0;  ///< fraction of the outline where the depth steps
};

/// Renders `bank`'s online mesh at `cam_from_object` into the frame and reads the depth:
/// surface tolerance `surface_m`, outline step `step_m`.
FrameCheck CheckAgainstFrame(const Frame& frame, const TemplateBank& bank, const Eigen::Isometry3d& cam_from_object,
                             double surface_m, double step_m);

/// One answer.
struct Detection {
  int request = -1;           ///< index into the requests
  std::string object_id;
  int proposal = -1;          ///< the candidate region it was solved on
  cv::Mat region;             ///< CV_8U 0/255, frame size: that region (the mask it was solved with)
  PoseResult result;          ///< EstimatePose's answer on the region (corrected_mask, S_A, ...)
  FrameCheck check;           ///< the answer against the whole frame
};

/// What DetectObjects() saw and did.
struct DetectionReport {
  bool success = false;
  std::string message = "not run";
  int support_planes = 0;
  cv::Mat support;                  ///< CV_8U 0/255, frame size: the removed support pixels
  cv::Mat creases;                  ///< CV_8U 0/255: concave creases the segments were split at
  DepthSegmentation segmentation;   ///< the first pass's segments of the rest (SegmentByDepthAndCreases)
  /// One pass of proposals and solves: the first over everything but the support, each
  /// further one (explaining away) over what the answers kept so far left.
  struct Pass {
    DepthSegmentation segmentation;
    int proposals = 0;  ///< regions formed in this pass
    int solves = 0;
  };
  std::vector<Pass> passes;
  int explain_away_passes = 0;      ///< passes after the first that ran
  std::vector<Proposal> proposals;  ///< every region formed, all passes
  std::vector<CandidateTrial> trials;  ///< every ranked pair, by request then rank
  int solves = 0;                   ///< EstimatePose calls
  int answers = 0;                  ///< detections returned
  int suppressed = 0;               ///< solved answers dropped by S_A, the overlap or the count
  int ppf_regions = 0;              ///< regions from the point-pair-feature vote
  double support_ms = 0.0, segment_ms = 0.0, propose_ms = 0.0, ppf_ms = 0.0, rank_ms = 0.0, solve_ms = 0.0,
         select_ms = 0.0, total_ms = 0.0;
};

/// Finds up to `count` instances of each requested object in `frame` (no mask): proposals
/// by the depth, ranked per object, the best solved with `solver_options` (as a mask read as
/// evidence: mask_trust is forced to kDepth), answers kept by S_A with non-maximum
/// suppression (this file's comment). Answers are ordered by S_A, best first. Never throws
/// for bad data (report->success false, no answers, the message says why); throws g6d::Error
/// for bad arguments (no requests, a null bank, a count < 1, bad options). `report` may be
/// null. Solves fan out over `executor` as EstimatePose's do.
std::vector<Detection> DetectObjects(const Frame& frame, const std::vector<DetectRequest>& requests,
                                     const SolverOptions& solver_options, const DetectOptions& options,
                                     Executor* executor, DetectionReport* report);

/// A picture of what DetectObjects() saw, for a person (g6d-solve --overlay, the benchmark's
/// --detect-pictures): `frame.rgb` with the support pixels darkened, the concave creases in
/// magenta, every segment outlined
/// thinly in a colour of its own, the regions that were solved outlined in white, and each
/// answer's model contour and axes in green with its object id and S_A. `requests` are
/// DetectObjects'. CV_8UC3, RGB, frame size.
cv::Mat DrawDetectionPicture(const Frame& frame, const std::vector<DetectRequest>& requests,
                             const DetectionReport& report, const std::vector<Detection>& detections);

}  // namespace g6d
