#pragma once
/// @file synthetic_frame.h
/// A rendered synthetic view encoded as the g6d.rgbd_frame_t a camera driver would
/// publish, for the service tests and benchmarks.

#include <chrono>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <string>

#include "g6d/rgbd_frame_t.hpp"
#include "synthetic/service_scene.h"
#include "synthetic/synthetic_scene.h"
#include "wire/frame_codec.h"

namespace g6d::synthetic {

/// Encodes `view` as one frame with one instance (label 1) of `object_id`: colour RGB8
/// (`color_compression`), depth DEPTH_U16 in millimetres (zstd), labels LABEL_U8 (zstd).
inline rgbd_frame_t MakeRgbdFrame(const SyntheticView& view, int64_t seq,
                                  const std::string& object_id,
                                  const std::string& camera_id = "cam0",
                                  int8_t color_compression = image_t::COMPRESSION_NONE) {
  rgbd_frame_t frame;
  frame.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                    std::chrono::system_clock::now().time_since_epoch())
                    .count();
  frame.seq = seq;
  frame.camera_id = camera_id;
  frame.source = "service_test";
  frame.scene_id = 1;
  frame.image_id = static_cast<int32_t>(seq);
  frame.fx = kServiceCamera.fx;
  frame.fy = kServiceCamera.fy;
  frame.cx = kServiceCamera.cx;
  frame.cy = kServiceCamera.cy;
  frame.depth_scale_m = 0.001;
  frame.color = EncodeImage(view.rgb, image_t::FORMAT_RGB8, color_compression);
  cv::Mat depth_mm;
  view.depth.convertTo(depth_mm, CV_16U, 1000.0);
  frame.depth = EncodeImage(depth_mm, image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_ZSTD);
  cv::Mat labels;
  cv::threshold(view.mask, labels, 0, 1, cv::THRESH_BINARY);
  frame.labels = EncodeImage(labels, image_t::FORMAT_LABEL_U8, image_t::COMPRESSION_ZSTD);
  instance_t instance{};  // {}: no box, no candidates (lcm-gen leaves members uninitialized)
  instance.object_id = object_id;
  instance.label = 1;
  instance.score = 1.0f;
  instance.gt_index = 0;
  frame.instances = {instance};
  frame.num_instances = 1;
  return frame;
}

}  // namespace g6d::synthetic
