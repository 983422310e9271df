#pragma once
/// @file debug_image.h
/// The service's debug picture of one answered frame: the frame's colour image with each
/// answer drawn on it (render/overlay.h: the model's silhouette contour at the answered
/// pose, its axes, a label "object S_A c confidence mode"; a failed instance's mask
/// outline and status in the failure colour), JPEG-compressed as bot_core.image_t (what
/// bot viewers and Director show) or g6d.image_t.

#include <cstdint>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "bot_core/image_t.hpp"
#include "core/camera.h"
#include "g6d/image_t.hpp"
#include "g6d/pose_array_t.hpp"
#include "render/overlay.h"
#include "templates/template_bank.h"
#include "wire/frame_codec.h"

namespace g6d {

/// The message type debug images go out as.
enum class DebugImageType {
  kBotCore,  ///< bot_core.image_t, pixelformat MJPEG, utime = the frame's capture time
  kG6d,      ///< g6d.image_t, RGB8 with COMPRESSION_JPEG
};

/// "bot_core" or "g6d".
const char* DebugImageTypeName(DebugImageType type);

/// The type named "bot_core" or "g6d"; throws g6d::Error naming the value otherwise.
DebugImageType ParseDebugImageType(const std::string& name);

/// What one debug picture is drawn from. The images are only read.
struct DebugImageInput {
  Camera camera;  ///< the frame's intrinsics and size
  cv::Mat rgb;    ///< the frame's colour image, CV_8UC3 RGB, camera-sized
  /// The request's instances, in request order (their masks outline failed answers).
  std::vector<DecodedInstance> instances;
  pose_array_t answer;  ///< the published answer; estimates in request order
  /// The banks of the answered objects (online mesh, diameter, bounding box), by object id.
  std::map<std::string, std::shared_ptr<const TemplateBank>> banks;
};

/// What DrawDebugImage drew.
struct DebugImageReport {
  int poses_drawn = 0;     ///< OK estimates drawn with contour and axes
  int failures_drawn = 0;  ///< failed estimates drawn as a mask outline (or a label only)
  std::vector<cv::Rect> label_boxes;  ///< every label's box, pixels, in estimate order
};

/// The label of an estimate: "obj_000005 S 0.084 c 0.93 tracked" for an OK one,
/// "obj_000005 no_solution: <message>" (the message cut to 60 characters) otherwise.
std::string DebugLabel(const pose_estimate_t& estimate);

/// input.rgb (copied) with every estimate of input.answer drawn on it, CV_8UC3 RGB: an
/// OK estimate whose bank is in input.banks gets its contour, axes and label (above its
/// silhouette box); a failed one the outline of its instance's mask and its label in
/// style.failure_color. An OK estimate without a bank gets its label only. Throws
/// g6d::Error when the image does not match the camera or the estimates are not one per
/// instance.
cv::Mat DrawDebugImage(const DebugImageInput& input, const OverlayStyle& style,
                       DebugImageReport* report = nullptr);

/// bot_core.image_t of `rgb` (CV_8UC3 RGB) as JPEG of `quality` (1..100), pixelformat
/// MJPEG, row_stride 3 x width, utime as given.
bot_core::image_t MakeBotCoreJpeg(const cv::Mat& rgb, int quality, int64_t utime);

/// g6d.image_t of `rgb` (CV_8UC3 RGB): FORMAT_RGB8, COMPRESSION_JPEG of `quality`.
image_t MakeG6dJpeg(const cv::Mat& rgb, int quality);

}  // namespace g6d
