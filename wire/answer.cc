#include "wire/answer.h"

#include <Eigen/Geometry>

#include <algorithm>

namespace g6d {

FrameHeader HeaderOf(const rgbd_frame_t& message) {
  FrameHeader header;
  header.utime = message.utime;
  header.seq = message.seq;
  header.camera_id = message.camera_id;
  header.source = message.source;
  header.scene_id = message.scene_id;
  header.image_id = message.image_id;
  return header;
}

namespace {

pose_estimate_t EstimateFor(const DecodedInstance& instance) {
  pose_estimate_t estimate{};
  estimate.object_id = instance.object_id;
  estimate.label = instance.label;
  estimate.gt_index = instance.gt_index;
  estimate.orientation[0] = 1.0;  // identity (w, x, y, z) until a pose is set
  estimate.score = 2.0;           // the worst S (1 - J with J = 0, plus a residual)
  // No runner-up, not truncated, not ambiguous, no appearance until a result says so; the
  // quaternion is the identity rather than all zeros so that no message ever carries a
  // quaternion a subscriber cannot normalize.
  estimate.runner_up_orientation[0] = 1.0;
  // Not an answer of a track until a tracked answer says so.
  estimate.mode = pose_estimate_t::MODE_DETECTED;
  estimate.track_id = -1;
  estimate.frames_since_detection = 0;
  // Nothing solved yet: no mask IoU, no candidate tried.
  estimate.mask_iou = 0.0;
  estimate.identity_searched = instance.identity_unknown();
  estimate.runner_up_object_score = 0.0;
  estimate.candidates_tried = 0;
  // Which request it answers; found in the service's own proposals only when it says so.
  estimate.request_index = instance.index;
  estimate.found_without_mask = false;
  std::fill(estimate.region_box, estimate.region_box + 4, 0);
  estimate.region_pixels = 0;
  return estimate;
}

// Position (metres) and unit quaternion (w, x, y, z) of `cam_from_object`.
void SetPose(const Eigen::Isometry3d& cam_from_object, double position[3], double orientation[4]) {
  const Eigen::Vector3d translation = cam_from_object.translation();
  const Eigen::Quaterniond rotation(cam_from_object.rotation());
  for (int i = 0; i < 3; ++i) position[i] = translation[i];
  orientation[0] = rotation.w();
  orientation[1] = rotation.x();
  orientation[2] = rotation.y();
  orientation[3] = rotation.z();
}

}  // namespace

Eigen::Isometry3d CamFromObjectOf(const pose_estimate_t& estimate) {
  const Eigen::Quaterniond rotation(estimate.orientation[0], estimate.orientation[1], estimate.orientation[2],
                                    estimate.orientation[3]);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation.normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d(estimate.position[0], estimate.position[1], estimate.position[2]);
  return pose;
}

pose_estimate_t MakePoseEstimate(const DecodedInstance& instance, const PoseResult& result) {
  pose_estimate_t estimate = EstimateFor(instance);
  if (result.success) {
    estimate.status = pose_estimate_t::STATUS_OK;
    estimate.message = "ok";
  } else {
    switch (result.termination) {
      case Termination::kBadInput:
        estimate.status = pose_estimate_t::STATUS_BAD_INPUT;
        break;
      case Termination::kNotRun:
        estimate.status = pose_estimate_t::STATUS_INTERNAL_ERROR;
        break;
      default:
        estimate.status = pose_estimate_t::STATUS_NO_SOLUTION;
        break;
    }
    estimate.message =
        result.message.empty() ? TerminationName(result.termination) : result.message;
  }
  estimate.hypotheses = result.stages.kept_hypotheses;
  estimate.solve_time_s = result.stages.total_ms * 1e-3;
  estimate.identity_searched = false;
  estimate.candidates_tried = 1;
  if (!result.success) return estimate;

  SetPose(result.cam_from_object, estimate.position, estimate.orientation);
  estimate.score = result.score;
  estimate.confidence = result.confidence;
  estimate.iou = result.details.iou;
  estimate.depth_residual = result.details.depth_residual;
  estimate.truncated = result.truncated;
  estimate.cut_short = result.cut_short;
  estimate.ambiguous = result.ambiguous;
  estimate.has_runner_up = result.has_runner_up;
  if (result.has_runner_up) {
    SetPose(result.runner_up_cam_from_object, estimate.runner_up_position,
            estimate.runner_up_orientation);
    estimate.runner_up_score = result.runner_up_score;
  }
  estimate.appearance_valid = result.appearance_valid;
  if (result.appearance_valid) estimate.appearance_agreement = result.appearance_agreement;
  estimate.mask_iou = result.mask_iou;
  return estimate;
}

pose_estimate_t MakeIdentifiedEstimate(const DecodedInstance& instance,
                                       const IdentifiedPose& identified) {
  DecodedInstance chosen = instance;
  chosen.object_id = identified.object_id;
  pose_estimate_t estimate = MakePoseEstimate(chosen, identified.result);
  estimate.identity_searched = true;
  estimate.candidates_tried = static_cast<int32_t>(identified.candidates.size());
  // The search solved every candidate: its time is the instance's solver time.
  estimate.solve_time_s = identified.total_ms * 1e-3;
  if (estimate.status == pose_estimate_t::STATUS_OK && !identified.runner_up_id.empty()) {
    estimate.runner_up_object_id = identified.runner_up_id;
    estimate.runner_up_object_score = identified.runner_up_score;
  }
  return estimate;
}

int8_t ModeOnWire(AnswerMode mode) {
  switch (mode) {
    case AnswerMode::kDetected:
      return pose_estimate_t::MODE_DETECTED;
    case AnswerMode::kTracked:
      return pose_estimate_t::MODE_TRACKED;
    case AnswerMode::kRedetected:
      return pose_estimate_t::MODE_REDETECTED;
  }
  return pose_estimate_t::MODE_DETECTED;
}

pose_estimate_t MakeTrackedEstimate(const DecodedInstance& instance, const TrackedAnswer& answer) {
  pose_estimate_t estimate = MakePoseEstimate(instance, answer.result);
  // An answer of a track ran TrackPose and maybe the full solver too: its solver time is
  // both (answer.result.stages times only the one whose pose was kept).
  if (answer.mode != AnswerMode::kDetected)
    estimate.solve_time_s = (answer.track_ms + answer.detect_ms) * 1e-3;
  if (estimate.status != pose_estimate_t::STATUS_OK) return estimate;
  estimate.mode = ModeOnWire(answer.mode);
  estimate.track_id = answer.track_id;
  estimate.frames_since_detection = answer.frames_since_detection;
  return estimate;
}

pose_estimate_t MakeFoundEstimate(const DecodedInstance& instance, const std::string& object_id,
                                  const TrackedAnswer& answer, const cv::Rect& region_box,
                                  int region_pixels, int candidates) {
  DecodedInstance found = instance;
  found.object_id = object_id;
  pose_estimate_t estimate = MakeTrackedEstimate(found, answer);
  if (instance.identity_unknown()) {
    estimate.identity_searched = true;
    estimate.candidates_tried = candidates;
  }
  if (estimate.status != pose_estimate_t::STATUS_OK) return estimate;
  estimate.found_without_mask = true;
  const int32_t box[4] = {region_box.x, region_box.y, region_box.width, region_box.height};
  std::copy(box, box + 4, estimate.region_box);
  estimate.region_pixels = region_pixels;
  return estimate;
}

pose_estimate_t MakeFailedEstimate(const DecodedInstance& instance, int8_t status,
                                   const std::string& message) {
  pose_estimate_t estimate = EstimateFor(instance);
  estimate.status = status;
  estimate.message = message;
  return estimate;
}

pose_array_t MakePoseArray(const FrameHeader& header, int8_t status, const std::string& message,
                           std::vector<pose_estimate_t> estimates, const Timings& timings,
                           double total_s, int64_t utime) {
  pose_array_t answer;
  answer.utime = utime;
  answer.source_utime = header.utime;
  answer.seq = header.seq;
  answer.camera_id = header.camera_id;
  answer.source = header.source;
  answer.scene_id = header.scene_id;
  answer.image_id = header.image_id;
  answer.status = status;
  answer.message = message;
  answer.num_estimates = static_cast<int32_t>(estimates.size());
  answer.estimates = std::move(estimates);
  answer.num_timings = static_cast<int32_t>(timings.size());
  for (const auto& [name, seconds] : timings) {
    answer.timing_names.push_back(name);
    answer.timing_s.push_back(seconds);
  }
  answer.total_s = total_s;
  return answer;
}

}  // namespace g6d
