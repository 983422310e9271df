#include "service/answer.h"

#include <Eigen/Geometry>

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
  return estimate;
}

}  // namespace

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
  if (!result.success) return estimate;

  const Eigen::Vector3d position = result.cam_from_object.translation();
  const Eigen::Quaterniond rotation(result.cam_from_object.rotation());
  for (int i = 0; i < 3; ++i) estimate.position[i] = position[i];
  estimate.orientation[0] = rotation.w();
  estimate.orientation[1] = rotation.x();
  estimate.orientation[2] = rotation.y();
  estimate.orientation[3] = rotation.z();
  estimate.score = result.score;
  estimate.confidence = result.confidence;
  estimate.iou = result.details.iou;
  estimate.depth_residual = result.details.depth_residual;
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
