#include "wire/debug_image.h"

#include <cstdio>
#include <vector>

#include "core/error.h"
#include "wire/answer.h"
#include "wire/foreign_images.h"
#include "wire/image_codec.h"
#include "wire/names.h"

namespace g6d {
namespace {

constexpr size_t kMaxMessageChars = 60;  // a longer failure message is cut in the label
constexpr int kOutlinePx = 2;            // failed instance's mask outline, pixels
constexpr int kLabelGapPx = 4;           // between a label and the box it names, pixels


constexpr int kLabelTries = 6;  // places tried above (then below) a box for a free spot

bool Overlaps(const cv::Rect& box, const std::vector<cv::Rect>& taken) {
  for (const cv::Rect& other : taken)
    if ((box & other).area() > 0) return true;
  return false;
}

// Where a label naming `box` goes: just above it, else higher, else below it, at the first
// place where it covers no label drawn before (`taken`); the top-left corner of the image
// when there is no box. Objects side by side would otherwise get labels on top of each other.
cv::Point LabelAnchor(const std::string& text, const cv::Rect& box,
                      const std::vector<cv::Rect>& taken, double scale, cv::Size image_size) {
  const cv::Point above(box.x, box.area() == 0 ? 0 : box.y - kLabelGapPx);
  const int step = LabelBox(text, above, scale, image_size).height + 2;
  const cv::Point below(box.x, box.y + box.height + kLabelGapPx + step);
  for (const cv::Point start : {above, below}) {
    const int direction = start == above ? -1 : 1;
    for (int k = 0; k < kLabelTries; ++k) {
      const cv::Point anchor(start.x, start.y + direction * k * step);
      if (!Overlaps(LabelBox(text, anchor, scale, image_size), taken)) return anchor;
    }
  }
  return above;
}

// Draws an OK estimate's contour and axes when its bank is known; the silhouette's box.
cv::Rect DrawAnswered(const pose_estimate_t& estimate, const TemplateBank* bank,
                      const Camera& camera, const OverlayStyle& style, RasterImage* raster,
                      cv::Mat* canvas) {
  if (bank == nullptr) return cv::Rect();
  const OverlayModel model{&bank->online_mesh, bank->bounding_box.center(), bank->diameter_m};
  return DrawPoseOverlay(model, camera, CamFromObjectOf(estimate), style, canvas, raster).silhouette_box;
}

// Draws a failed estimate's instance mask outline (when it has one); the mask's box.
cv::Rect DrawFailed(const DecodedInstance& instance, const OverlayStyle& style, cv::Mat* canvas) {
  if (instance.mask.empty() || instance.mask.size() != canvas->size()) return cv::Rect();
  return DrawMaskOutline(instance.mask, style.failure_color, kOutlinePx, canvas);
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

cv::Mat DrawDebugImage(const DebugImageInput& input, const OverlayStyle& style,
                       DebugImageReport* report) {
  const Camera& camera = input.camera;
  if (input.rgb.type() != CV_8UC3 || input.rgb.cols != camera.width ||
      input.rgb.rows != camera.height) {
    G6D_THROW("DrawDebugImage: the colour image must be CV_8UC3 of the camera's "
              << camera.width << " x " << camera.height);
  }
  const std::vector<pose_estimate_t>& estimates = input.answer.estimates;
  // One estimate per instance, or, for a detection request, one per instance found:
  // request_index names the instance each answers.
  for (size_t i = 0; i < estimates.size(); ++i) {
    const int32_t request = estimates[i].request_index;
    if (request < 0 || static_cast<size_t>(request) >= input.instances.size()) {
      G6D_THROW("DrawDebugImage: estimate " << i << " answers instance " << request << " of "
                                            << input.instances.size() << " instances");
    }
  }
  DebugImageReport local;
  DebugImageReport& out = report != nullptr ? *report : local;
  out = DebugImageReport();
  cv::Mat canvas = input.rgb.clone();
  RasterImage raster;
  // Shapes first, labels last, so that no contour crosses a label.
  std::vector<cv::Rect> named_boxes(estimates.size());
  for (size_t i = 0; i < estimates.size(); ++i) {
    const pose_estimate_t& estimate = estimates[i];
    if (estimate.status == pose_estimate_t::STATUS_OK) {
      const auto bank = input.banks.find(estimate.object_id);
      const TemplateBank* model = bank == input.banks.end() ? nullptr : bank->second.get();
      named_boxes[i] = DrawAnswered(estimate, model, camera, style, &raster, &canvas);
      if (model != nullptr) ++out.poses_drawn;
    } else {
      named_boxes[i] = DrawFailed(input.instances[estimates[i].request_index], style, &canvas);
      ++out.failures_drawn;
    }
  }
  for (size_t i = 0; i < estimates.size(); ++i) {
    const std::string label = DebugLabel(estimates[i]);
    const cv::Point anchor =
        LabelAnchor(label, named_boxes[i], out.label_boxes, style.label_scale, canvas.size());
    const bool ok = estimates[i].status == pose_estimate_t::STATUS_OK;
    out.label_boxes.push_back(DrawLabel(
        label, anchor, ok ? style.contour_color : style.failure_color, style.label_scale, &canvas));
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
  return MakeBotCoreImage(rgb, bot_core::image_t::PIXEL_FORMAT_MJPEG,
                          MakeG6dJpeg(rgb, quality).data, utime);
}

}  // namespace g6d
