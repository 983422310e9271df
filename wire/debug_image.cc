#include "wire/debug_image.h"

#include <cstdio>

#include "core/error.h"
#include "wire/image_codec.h"
#include "wire/names.h"
#include "wire/foreign_images.h"

namespace g6d {
namespace {

constexpr size_t kMaxMessageChars = 60;  // a longer failure message is cut in the label
constexpr int kOutlinePx = 2;            // failed instance's mask outline, pixels
constexpr int kLabelGapPx = 4;           // between a label and the box it names, pixels

// cam_from_object of an estimate (position metres, quaternion w x y z).
Eigen::Isometry3d PoseOf(const pose_estimate_t& estimate) {
  const Eigen::Quaterniond rotation(estimate.orientation[0], estimate.orientation[1], estimate.orientation[2],
                                    estimate.orientation[3]);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation.normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d(estimate.position[0], estimate.position[1], estimate.position[2]);
  return pose;
}

// Where a label naming `box` goes: just above it, or at the top-left corner of the image
// when there is no box.
cv::Point LabelAnchor(const cv::Rect& box) {
  if (box.area() == 0) return {0, 0};
  return {box.x, box.y - kLabelGapPx};
}

// Draws an OK estimate; the label box.
cv::Rect DrawAnswered(const pose_estimate_t& estimate, const TemplateBank* bank, const Camera& camera,
                      const OverlayStyle& style, RasterImage* raster, cv::Mat* canvas) {
  cv::Rect silhouette_box;
  if (bank != nullptr) {
    const OverlayModel model{&bank->online_mesh, bank->bounding_box.center(), bank->diameter_m};
    silhouette_box = DrawPoseOverlay(model, camera, PoseOf(estimate), style, canvas, raster).silhouette_box;
  }
  return DrawLabel(DebugLabel(estimate), LabelAnchor(silhouette_box), style.contour_color, style.label_scale, canvas);
}

// Draws a failed estimate: its instance's mask outline; the label box.
cv::Rect DrawFailed(const pose_estimate_t& estimate, const DecodedInstance& instance, const OverlayStyle& style,
                    cv::Mat* canvas) {
  cv::Rect mask_box;
  if (!instance.mask.empty() && instance.mask.size() == canvas->size()) {
    mask_box = DrawMaskOutline(instance.mask, style.failure_color, kOutlinePx, canvas);
  }
  return DrawLabel(DebugLabel(estimate), LabelAnchor(mask_box), style.failure_color, style.label_scale, canvas);
}

}  // namespace

const char* DebugImageTypeName(DebugImageType type) {
  return type == DebugImageType::kG6d ? "g6d" : "bot_core";
}

DebugImageType ParseDebugImageType(const std::string& name) {
  if (name == "bot_core") return DebugImageType::kBotCore;
  if (name == "g6d") return DebugImageType::kG6d;
  G6D_THROW("debug image type must be bot_core or g6d (got '" << name << "')");
}

std::string DebugLabel(const pose_estimate_t& estimate) {
  const std::string object = estimate.object_id.empty() ? "(unknown)" : estimate.object_id;
  if (estimate.status == pose_estimate_t::STATUS_OK) {
    char numbers[64];
    std::snprintf(numbers, sizeof(numbers), " S %.3f c %.2f ", estimate.score, estimate.confidence);
    return object + numbers + EstimateModeName(estimate.mode);
  }
  std::string message = estimate.message;
  if (message.size() > kMaxMessageChars) message = message.substr(0, kMaxMessageChars - 3) + "...";
  return object + " " + EstimateStatusName(estimate.status) + ": " + message;
}

cv::Mat DrawDebugImage(const DebugImageInput& input, const OverlayStyle& style, DebugImageReport* report) {
  const Camera& camera = input.camera;
  if (input.rgb.type() != CV_8UC3 || input.rgb.cols != camera.width || input.rgb.rows != camera.height) {
    G6D_THROW("DrawDebugImage: the colour image must be CV_8UC3 of the camera's " << camera.width << " x "
                                                                                  << camera.height);
  }
  const std::vector<pose_estimate_t>& estimates = input.answer.estimates;
  if (estimates.size() != input.instances.size()) {
    G6D_THROW("DrawDebugImage: " << estimates.size() << " estimates for " << input.instances.size()
                                 << " instances (expected one per instance)");
  }
  DebugImageReport local;
  DebugImageReport& out = report != nullptr ? *report : local;
  out = DebugImageReport();
  cv::Mat canvas = input.rgb.clone();
  RasterImage raster;
  for (size_t i = 0; i < estimates.size(); ++i) {
    const pose_estimate_t& estimate = estimates[i];
    if (estimate.status == pose_estimate_t::STATUS_OK) {
      const auto bank = input.banks.find(estimate.object_id);
      const TemplateBank* model = bank == input.banks.end() ? nullptr : bank->second.get();
      out.label_boxes.push_back(DrawAnswered(estimate, model, camera, style, &raster, &canvas));
      if (model != nullptr) ++out.poses_drawn;
    } else {
      out.label_boxes.push_back(DrawFailed(estimate, input.instances[i], style, &canvas));
      ++out.failures_drawn;
    }
  }
  return canvas;
}

image_t MakeG6dJpeg(const cv::Mat& rgb, int quality) {
  EncodeOptions options;
  options.jpeg_quality = quality;
  return EncodeImage(rgb, image_t::FORMAT_RGB8, image_t::COMPRESSION_JPEG, options);
}

bot_core::image_t MakeBotCoreJpeg(const cv::Mat& rgb, int quality, int64_t utime) {
  // The same JPEG bytes as g6d's image codec makes (true colours from RGB8).
  return MakeBotCoreImage(rgb, bot_core::image_t::PIXEL_FORMAT_MJPEG, MakeG6dJpeg(rgb, quality).data, utime);
}

}  // namespace g6d
