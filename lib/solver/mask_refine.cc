#include "solver/mask_refine.h"

#include <algorithm>

#include <opencv2/imgproc.hpp>

#include "render/raster.h"
#include "solver/region.h"
#include "solver/track_pose.h"

namespace g6d {

namespace {

// The area the corrected mask is rendered in: the caller's mask box grown by its longer
// side on each side (an eroded or cut mask can be much smaller than the object).
cv::Rect CorrectionArea(const cv::Rect& box) {
  const int grow = std::max(box.width, box.height);
  return cv::Rect(box.x - grow, box.y - grow, box.width + 2 * grow, box.height + 2 * grow);
}

}  // namespace

void RefineWithCorrectedMask(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                             const SolverOptions& options, const Observation& observation,
                             const ScoreOptions& online_score, const std::function<bool()>& out_of_time,
                             Executor* executor, PoseResult* result) {
  const cv::Mat given = instance.mask > 0;
  const cv::Rect area = CorrectionArea(cv::boundingRect(given));
  auto corrected_at = [&](const Eigen::Isometry3d& pose) {
    return CorrectedMask(frame.camera, bank.online_mesh, pose, observation.depth,
                         online_score.occlusion_margin_m, online_score.cull_backfaces, area);
  };
  cv::Mat corrected = corrected_at(result->cam_from_object);
  if (options.mask_trust == MaskTrust::kDepth) {
    for (int round = 0; round < options.mask_refine_rounds && !out_of_time(); ++round) {
      if (cv::countNonZero(corrected) < options.min_valid_depth_pixels) break;
      SolverOptions track_options = options;
      track_options.mask_refine_rounds = 0;
      const PoseResult again = TrackPose(frame, Instance{instance.object_id, corrected}, bank, track_options,
                                         TrackSolveOptions(), {result->cam_from_object}, executor);
      if (!again.success) break;
      RasterImage scratch;
      const PoseScore score = ScorePose(observation.refine_grid, bank.online_mesh, again.cam_from_object,
                                        observation.z_m, online_score, &scratch);
      if (!(score.s < result->details.s)) break;
      result->cam_from_object = again.cam_from_object;
      result->details = score;
      ++result->mask_refined_rounds;
      corrected = corrected_at(result->cam_from_object);
    }
  }
  result->mask_iou = MaskIntersectionOverUnion(corrected, given);
  result->corrected_mask = corrected;
}

}  // namespace g6d
