#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "render/overlay.h"
#include "solver/detect.h"

namespace g6d {

cv::Mat DrawDetectionPicture(const Frame& frame, const std::vector<DetectRequest>& requests,
                             const DetectionReport& report, const std::vector<Detection>& detections) {
  cv::Mat picture = frame.rgb.clone();
  if (!report.support.empty()) {
    cv::Mat dark = picture * 0.35;
    dark.copyTo(picture, report.support);
  }
  // Thin parts raised above the support (they join the islands), outlined in cyan.
  if (!report.raised.empty() && cv::countNonZero(report.raised) > 0) DrawMaskOutline(report.raised, cv::Scalar(0, 255, 255), 1, &picture);
  // Concave creases the segments were split at, in magenta.
  if (!report.creases.empty()) picture.setTo(cv::Scalar(255, 0, 255), report.creases);
  // Segment outlines: a colour per label from a fixed hue walk.
  const cv::Mat& labels = report.segmentation.labels;
  for (size_t k = 0; k < report.segmentation.segments.size(); ++k) {
    const cv::Mat mask = labels == static_cast<int>(k) + 1;
    const double hue = std::fmod(static_cast<double>(k) * 0.618, 1.0) * 180.0;
    cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(hue, 200, 255)), rgb;
    cv::cvtColor(hsv, rgb, cv::COLOR_HSV2RGB);
    const cv::Vec3b c = rgb.at<cv::Vec3b>(0, 0);
    DrawMaskOutline(mask, cv::Scalar(c[0], c[1], c[2]), 1, &picture);
  }
  // Solved regions in white.
  for (const CandidateTrial& trial : report.trials) {
    if (!trial.solved) continue;
    const Proposal& proposal = report.proposals[static_cast<size_t>(trial.proposal)];
    const cv::Mat& pass_labels = static_cast<size_t>(proposal.pass) < report.passes.size()
                                     ? report.passes[static_cast<size_t>(proposal.pass)].segmentation.labels
                                     : labels;
    cv::Mat mask = cv::Mat::zeros(labels.size(), CV_8U);
    for (int label : proposal.segments) mask |= pass_labels == label;
    if (!proposal.mask.empty()) mask = proposal.mask;  // a region of the point-pair-feature vote
    DrawMaskOutline(mask, cv::Scalar(255, 255, 255), 1, &picture);
  }
  OverlayStyle style;
  for (const Detection& detection : detections) {
    const TemplateBank& bank = *requests[static_cast<size_t>(detection.request)].bank;
    OverlayModel model;
    model.mesh = &bank.online_mesh;
    model.axes_origin_in_object = bank.bounding_box.center();
    model.diameter_m = bank.diameter_m;
    const PoseOverlayReport drawn =
        DrawPoseOverlay(model, frame.camera, detection.result.cam_from_object, style, &picture);
    char text[96];
    std::snprintf(text, sizeof(text), "%s S %.3f", detection.object_id.c_str(), detection.result.score);
    const cv::Point anchor = drawn.silhouette_box.empty() ? cv::Point(4, 16) : drawn.silhouette_box.tl();
    DrawLabel(text, anchor, style.contour_color, style.label_scale, &picture);
  }
  return picture;
}

}  // namespace g6d
