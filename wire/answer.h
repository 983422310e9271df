#pragma once
/// @file answer.h
/// Building the service's answers: solver results -> g6d.pose_estimate_t, and the
/// g6d.pose_array_t of one frame (or of a frame that was refused).

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "g6d/pose_array_t.hpp"
#include "g6d/pose_estimate_t.hpp"
#include "g6d/rgbd_frame_t.hpp"
#include "solver/identify.h"
#include "solver/pipeline.h"
#include "track/tracker.h"
#include "wire/frame_codec.h"

namespace g6d {

/// The identity of a request frame, echoed in its answer. seq = -1 when the message did
/// not decode far enough to know it.
struct FrameHeader {
  int64_t utime = 0;
  int64_t seq = -1;
  std::string camera_id;
  std::string source;
  int32_t scene_id = -1;
  int32_t image_id = -1;
};

/// The header fields of a decoded request.
FrameHeader HeaderOf(const rgbd_frame_t& message);

/// Named durations of one frame, seconds, in publication order.
using Timings = std::vector<std::pair<std::string, double>>;

/// pose_estimate_t for one solver result. Success -> STATUS_OK with message "ok";
/// termination kBadInput -> STATUS_BAD_INPUT, kNoHypothesis (or any other failure) ->
/// STATUS_NO_SOLUTION, kNotRun -> STATUS_INTERNAL_ERROR; the solver's message otherwise.
/// Position in metres and quaternion (w, x, y, z) of cam_from_object; score S_A,
/// confidence, IoU, depth residual, hypotheses kept (N_H used) and solver time; the
/// truncated and ambiguous flags, the runner-up (pose and S, when has_runner_up) and the
/// appearance agreement (when appearance_valid). A failure carries only the status,
/// message, hypotheses and solver time: flags false, numbers 0, identity quaternions.
/// Mode MODE_DETECTED, track_id -1, frames_since_detection 0 (an answer without tracking).
/// mask_iou is PoseResult::mask_iou (0 on failure); identity_searched false, no runner-up
/// identity ("", 0), candidates_tried 1. request_index is instance.index; not found
/// without a mask (found_without_mask false, region_box and region_pixels 0).
pose_estimate_t MakePoseEstimate(const DecodedInstance& instance, const PoseResult& result);

/// The estimate's cam_from_object (position in metres, the quaternion w x y z normalized).
Eigen::Isometry3d CamFromObjectOf(const pose_estimate_t& estimate);

/// The estimate of an instance of unknown identity: MakePoseEstimate of the chosen
/// object's result with object_id the chosen object ("" when no candidate succeeded), the
/// whole search's time as solve_time_s, identity_searched true, candidates_tried the
/// candidates considered and, on success, the runner-up identity and its S_A (when one
/// succeeded).
pose_estimate_t MakeIdentifiedEstimate(const DecodedInstance& instance,
                                       const IdentifiedPose& identified);

/// MakePoseEstimate of `answer.result`, with the answer's mode, track_id and
/// frames_since_detection (Tracker::Update sets them); the solver time of an answer of a
/// track is TrackPose's plus the full solver's (when it ran). A failed estimate keeps
/// MODE_DETECTED, track_id -1 and frames_since_detection 0 whatever the answer says.
pose_estimate_t MakeTrackedEstimate(const DecodedInstance& instance, const TrackedAnswer& answer);

/// The estimate of one instance that a detection request (DecodedInstance::detect) found:
/// MakeTrackedEstimate of `answer` for `object_id` (the request's, or the candidate found
/// when the request named none: then identity_searched, and candidates_tried is
/// `candidates`), found_without_mask true and the region it was solved on (`region_box`,
/// pixels; `region_pixels`). A failed answer gives MakeTrackedEstimate's failure, without
/// the region.
pose_estimate_t MakeFoundEstimate(const DecodedInstance& instance, const std::string& object_id,
                                  const TrackedAnswer& answer, const cv::Rect& region_box,
                                  int region_pixels, int candidates);

/// pose_estimate_t::MODE_* of a mode.
int8_t ModeOnWire(AnswerMode mode);

/// An estimate that carries only a failure: identity pose, score 2, confidence 0, no
/// runner-up (identity quaternion, S 0), flags false, appearance agreement 0, mode
/// MODE_DETECTED, track_id -1, frames_since_detection 0, mask_iou 0, identity_searched
/// true exactly when the request had no object id, no runner-up identity, candidates_tried 0,
/// request_index instance.index, found_without_mask false, no region.
pose_estimate_t MakeFailedEstimate(const DecodedInstance& instance, int8_t status,
                                   const std::string& message);

/// The answer to one frame. `utime` is the publication time (microseconds since the
/// epoch), `total_s` the time from receipt to publication.
pose_array_t MakePoseArray(const FrameHeader& header, int8_t status, const std::string& message,
                           std::vector<pose_estimate_t> estimates, const Timings& timings,
                           double total_s, int64_t utime);

}  // namespace g6d
