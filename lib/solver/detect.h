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
/// solved as the region solve of a mask read as evidence (EstimatePoseOnMask, mask_solve.h,
/// MaskTrust::kDepth),
/// and the answers are kept by S_A with non-maximum suppression: a pixel belongs to at most
/// one answer, an object's count is respected, and a poor S_A is no answer.

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/executor.h"
#include "core/frame.h"
#include "solver/detect_options.h"
#include "solver/frame_check.h"
#include "solver/proposals.h"
#include "solver/result.h"
#include "solver/segments.h"
#include "solver/solver_options.h"
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

/// One (object, candidate) pair that was ranked, and solved when it ranked high enough.
struct CandidateTrial {
  int request = -1;          ///< index into the requests
  int proposal = -1;         ///< index into DetectionReport::proposals
  int pass = 0;              ///< the pass it was ranked in
  double size_term = 0.0;    ///< extent / diameter, in [0, 1]
  double colour_term = 0.5;  ///< chromaticity agreement in [0, 1] (0.5 = no colour model)
  /// The region's mean lightness over the frame's white point (its 95th percentile), over the
  /// model's mean albedo (its appearance samples); 0 for a model without colour. Measured
  /// (the detection records), not used: right answers lie at 0.5-2.2, and asking the colour
  /// term to agree within a factor 2 too answered more absent objects on the real frames, not
  /// fewer (bench/RESULTS.md, "Edges along the outline").
  double lightness_ratio = 0.0;
  double shape_term = 0.5;   ///< PPF support over the best region's, in [0, 1] (0.5 = no PPF model)
  /// The region's area (pixels with depth; an island's whole mask) over the object's median
  /// silhouette area at the region's depth, and its agreement with the silhouettes' range in
  /// [0, 1] (DetectOptions::area_weight).
  double area_ratio = 0.0;
  double area_term = 1.0;
  double rank = 0.0;         ///< the ranking score (higher first)
  bool solved = false;
  bool success = false;
  double score = 2.0;        ///< S_A when solved
  double region_iou = 0.0;   ///< IoU of the answer's corrected mask with the region solved
  double confidence = 0.0;   ///< DetectionConfidence of the answer when solved with success
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();  ///< the answer when solved with success
  double ms = 0.0;           ///< solve time
};

/// How far the answer's own solve had a rival: the S of its best distinct finalist (the
/// answer's flips included, PoseResult::runner_up_score) less S_A, at most 0.25 (a rival
/// worse by more is none: right answers' median is 0.22); 0.25 when the solve had none. A
/// wrong answer is mostly one of two poses that explain the frame almost equally (a
/// near-symmetric part turned over): small or negative.
double RunnerUpGap(const PoseResult& result);

/// The confidence of an answer with `result` (S_A, ambiguous, RunnerUpGap), `check` (the frame at the
/// pose), `region_iou` and the region's
/// `colour_term` (CandidateTrial; 0.5 for a model without colour) (DetectOptions::
/// confidence_*), in [0, 1].
double DetectionConfidence(const DetectOptions& options, const PoseResult& result, const FrameCheck& check,
                           double region_iou, double colour_term);

/// One answer.
struct Detection {
  int request = -1;           ///< index into the requests
  std::string object_id;
  int proposal = -1;          ///< the candidate region it was solved on
  cv::Mat region;             ///< CV_8U 0/255, frame size: that region (the mask it was solved with)
  PoseResult result;          ///< EstimatePoseOnMask's answer on the region (corrected_mask, S_A, ...)
  FrameCheck check;           ///< the answer against the whole frame
  /// What its confidence read besides `result` and `check` (DetectionConfidence): the IoU of
  /// its corrected mask with `region`, and the region's colour agreement with the model.
  double region_iou = 0.0;
  double colour_term = 0.5;
  double lightness_ratio = 0.0;  ///< CandidateTrial::lightness_ratio of its region
};

/// The answers DetectObjects keeps among `solved` (every pass's solves of `requests`): each
/// at most `max_score` in S_A and at least `min_confidence`, taken in order (those at least
/// `sure_first_confidence` sure first, then the others, each group by S_A) while
/// its object still wants an instance (DetectRequest::count), it claims pixels (its corrected
/// mask, or its region without one) of which at most `max_overlap` are claimed already, and it
/// explains the frame around it (`max_free_space`, `min_contour_support`). `*suppressed`
/// counts the others.
std::vector<Detection> SelectAnswers(const Frame& frame, const std::vector<DetectRequest>& requests,
                                     const DetectOptions& options, const std::vector<Detection>& solved,
                                     int* suppressed);

/// What DetectObjects() saw and did.
struct DetectionReport {
  bool success = false;
  std::string message = "not run";
  int support_planes = 0;
  cv::Mat support;                  ///< CV_8U 0/255, frame size: the removed support pixels
  /// CV_8U 0/255: the support's pixels that stand above its level (thin parts lying on it:
  /// DetectOptions::raised_*); they join the islands, not the depth segments.
  cv::Mat raised;
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
  int solves = 0;                   ///< EstimatePoseOnMask calls
  int answers = 0;                  ///< detections returned
  int suppressed = 0;               ///< solved answers dropped by S_A, the overlap or the count
  /// Unsure answers re-solved as the other objects asked for (DetectOptions::
  /// identity_check_below), the solves that took, and the answers another object explained
  /// better (dropped), and the better explanations answered in their place (their object
  /// still wanted instances).
  int identity_checked = 0, identity_solves = 0, identity_dropped = 0, identity_replaced = 0;
  double identity_ms = 0.0;
  int ppf_regions = 0;              ///< regions from the point-pair-feature vote
  double shape_ms = 0.0;            ///< the shape term's vote (part of rank_ms)
  /// Inside solve_ms: the solves' stage times (StageTimes names: prepare ... mask_refine,
  /// total) summed over every solve, and the frame checks' time. Solves run side by side on
  /// the executor, so these sums exceed solve_ms on more than one thread.
  std::vector<StageTime> solve_stages;
  double check_ms = 0.0;
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
