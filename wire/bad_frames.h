#pragma once
/// @file bad_frames.h
/// Every kind of bad input g6d-service must answer with an error instead of a pose (or a
/// crash), built from one good g6d_rgbd_frame_t, with the answer each must get. Shared by
/// the service test (tests/service_test.cc) and the soak benchmark (bench/soak_runner.cc),
/// so it lives in the wire layer, not in tests/.
///
/// Two families:
///  - frame errors: the message does not decode or validate; the LCM thread answers it at
///    once with STATUS_BAD_FRAME and it never reaches the latest-frame mailbox;
///  - instance errors: the frame validates but no instance can be solved (unknown object
///    id, a label without pixels, ...); it goes through the mailbox like a good frame (so
///    under load it can be replaced there, a counted drop) and is answered STATUS_OK with
///    every estimate failed.

#include <algorithm>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "g6d/pose_array_t.hpp"
#include "g6d/pose_estimate_t.hpp"
#include "g6d/rgbd_frame_t.hpp"
#include "wire/frame_codec.h"

namespace g6d::synthetic {

/// One kind of bad message and what its answer must say.
struct BadCase {
  std::string name;
  int8_t frame_status = pose_array_t::STATUS_BAD_FRAME;  ///< expected pose_array_t status
  /// Expected status of every estimate when frame_status is STATUS_OK.
  int8_t estimate_status = pose_estimate_t::STATUS_OK;
  std::string words;           ///< must appear in the frame message (or each estimate's)
  bool seq_known = true;       ///< false: the answer carries seq -1 (not our message type)
  std::vector<uint8_t> bytes;  ///< the LCM message as published

  /// True when the frame validates and only its instances fail (it uses the mailbox).
  bool InstanceError() const { return frame_status == pose_array_t::STATUS_OK; }
};

/// The LCM encoding of `frame`.
inline std::vector<uint8_t> EncodeMessage(const rgbd_frame_t& frame) {
  std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
  frame.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

/// Writes big-endian `value` into an encoded message at `offset` (no bounds check beyond
/// the vector's: callers patch fields they know are there).
inline void PatchInt64(std::vector<uint8_t>* bytes, size_t offset, int64_t value) {
  for (int i = 0; i < 8; ++i)
    bytes->at(offset + i) = static_cast<uint8_t>(static_cast<uint64_t>(value) >> (56 - 8 * i));
}

/// Writes `seq` into an encoded rgbd_frame_t (int64 after the fingerprint and utime).
inline void PatchSeq(std::vector<uint8_t>* bytes, int64_t seq) { PatchInt64(bytes, 16, seq); }

/// Writes `utime` (microseconds) into an encoded rgbd_frame_t (int64 after the fingerprint).
inline void PatchUtime(std::vector<uint8_t>* bytes, int64_t utime) { PatchInt64(bytes, 8, utime); }

/// Every kind of bad input, built from `good` (any valid frame with at least one instance,
/// each instance with a label of its own that has pixels). Its seq and utime are kept;
/// patch them per send with PatchSeq() / PatchUtime(). `max_instances` is the service's
/// DecodeLimits::max_instances (one more is sent as "too many instances").
inline std::vector<BadCase> MakeBadCases(const rgbd_frame_t& good,
                                         int max_instances = DecodeLimits().max_instances) {
  constexpr int8_t kOk = pose_array_t::STATUS_OK, kBad = pose_array_t::STATUS_BAD_FRAME;
  const cv::Mat color = DecodeImage(good.color, "color");
  const cv::Mat depth = DecodeImage(good.depth, "depth");
  const cv::Mat labels = DecodeImage(good.labels, "labels");
  const int8_t color_format = good.color.pixel_format;
  std::vector<BadCase> cases;
  auto add = [&](const std::string& name, const rgbd_frame_t& frame, const std::string& words,
                 int8_t frame_status = pose_array_t::STATUS_BAD_FRAME,
                 int8_t estimate_status = pose_estimate_t::STATUS_OK) {
    cases.push_back({name, frame_status, estimate_status, words, true, EncodeMessage(frame)});
  };

  // ---- Image planes ----
  rgbd_frame_t f = good;
  f.color = EncodeImage(color, color_format, image_t::COMPRESSION_NONE);
  f.color.data.resize(f.color.data.size() - 7);
  f.color.size = static_cast<int32_t>(f.color.data.size());
  add("payload size mismatch", f, "color: payload");
  f = good;
  f.color.pixel_format = 42;
  add("unknown pixel format", f, "color: pixel format unknown(42)");
  f = good;
  f.depth.compression = 9;
  add("unknown compression", f, "depth: unknown compression 9");
  f = good;
  f.depth = EncodeImage(depth, good.depth.pixel_format, image_t::COMPRESSION_ZSTD);
  for (size_t i = f.depth.data.size() / 3; i < f.depth.data.size(); i += 11)
    f.depth.data[i] ^= 0xA5;
  add("corrupted zstd", f, "depth: corrupted zstd");
  f = good;
  f.color = EncodeImage(color, color_format, image_t::COMPRESSION_PNG);
  for (size_t i = f.color.data.size() / 2; i < f.color.data.size(); i += 97)
    f.color.data[i] ^= 0x3C;
  add("corrupted PNG", f, "color: corrupted PNG");
  f = good;
  f.color = EncodeImage(color, color_format, image_t::COMPRESSION_JPEG);
  f.color.data.resize(f.color.data.size() / 2);
  f.color.size = static_cast<int32_t>(f.color.data.size());
  add("corrupted JPEG", f, "color: corrupted JPEG");
  f = good;
  {
    cv::Mat half(depth.rows / 2, depth.cols / 2, depth.type(), cv::Scalar(700));
    f.depth = EncodeImage(half, good.depth.pixel_format, image_t::COMPRESSION_ZSTD);
  }
  add("depth and colour sizes differ", f,
      "depth: size " + std::to_string(depth.cols / 2) + "x" + std::to_string(depth.rows / 2) +
          " differs from color " + std::to_string(good.color.width) + "x" +
          std::to_string(good.color.height));
  f = good;
  f.color.width = 100000;
  f.color.row_stride = 300000;
  f.depth.width = f.labels.width = 100000;
  add("huge declared image size", f, "too large");

  // ---- Intrinsics ----
  f = good;
  f.fx = 0.0;
  add("zero focal length", f, "intrinsics: fx");
  f = good;
  f.fy = -500.0;
  add("negative focal length", f, "intrinsics: fy");
  f = good;
  f.cx = std::numeric_limits<double>::quiet_NaN();
  add("NaN principal point", f, "intrinsics: cx");
  f = good;
  f.cy = std::numeric_limits<double>::infinity();
  add("infinite principal point", f, "intrinsics: cy");
  if (good.depth.pixel_format == image_t::FORMAT_DEPTH_U16) {
    f = good;
    f.depth_scale_m = 0.0;
    add("zero depth scale", f, "depth_scale_m must be finite and > 0");
  }

  // ---- Instances and labels ----
  double max_label = 0.0;
  cv::minMaxLoc(labels, nullptr, &max_label);
  f = good;
  // Instance 0 now names a label with no pixels, so its own label is named by no one.
  f.instances[0].label = static_cast<int32_t>(max_label) + 1;
  add("label named by no instance", f, "is named by no instance");
  f = good;
  f.instances.assign(static_cast<size_t>(max_instances) + 1, good.instances[0]);
  f.num_instances = static_cast<int32_t>(f.instances.size());
  add("too many instances", f, "too many");
  const image_t empty_labels = EncodeImage(cv::Mat::zeros(labels.size(), labels.type()),
                                           good.labels.pixel_format, image_t::COMPRESSION_ZSTD);
  f = good;
  f.labels = empty_labels;
  for (instance_t& instance : f.instances) instance.label = 5;
  add("instance label without pixels", f, "label 5 has no pixels", kOk,
      pose_estimate_t::STATUS_BAD_INPUT);
  f = good;
  f.labels = empty_labels;
  for (instance_t& instance : f.instances) instance.label = -3;
  add("negative instance label", f, "label must be > 0 for a mask, or 0 with a box", kOk,
      pose_estimate_t::STATUS_BAD_INPUT);
  f = good;
  f.labels = empty_labels;
  for (instance_t& instance : f.instances) {
    // Neither mask nor box: a detection request, here for an object without a cache.
    instance.label = 0;
    instance.object_id = "obj_999997";
  }
  add("detection request of an unknown object", f, "no template cache for object id 'obj_999997'",
      kOk, pose_estimate_t::STATUS_UNKNOWN_OBJECT);
  // Boxes (label 0): one wholly outside the image, one of no height.
  f = good;
  f.labels = empty_labels;
  for (instance_t& instance : f.instances) {
    instance.label = 0;
    const int32_t box[4] = {good.color.width + 5, 10, 40, 30};
    std::copy(box, box + 4, instance.box);
  }
  add("box outside the image", f, "lies outside the", kOk, pose_estimate_t::STATUS_BAD_INPUT);
  f = good;
  f.labels = empty_labels;
  for (instance_t& instance : f.instances) {
    instance.label = 0;
    const int32_t box[4] = {10, 10, 40, 0};
    std::copy(box, box + 4, instance.box);
  }
  add("box of no height", f, "box height must be > 0", kOk, pose_estimate_t::STATUS_BAD_INPUT);
  // Identity unknown (no object id): a candidate without a cache, an empty candidate id.
  f = good;
  for (instance_t& instance : f.instances) {
    instance.object_id.clear();
    instance.candidate_ids = {"obj_999998"};
    instance.num_candidate_ids = 1;
  }
  add("unknown candidate id", f, "candidate 'obj_999998' has no template cache", kOk,
      pose_estimate_t::STATUS_UNKNOWN_OBJECT);
  f = good;
  for (instance_t& instance : f.instances) {
    instance.object_id.clear();
    instance.candidate_ids = {""};
    instance.num_candidate_ids = 1;
  }
  add("empty candidate id", f, "candidate_ids[0] is empty", kOk, pose_estimate_t::STATUS_BAD_INPUT);
  f = good;
  for (instance_t& instance : f.instances) instance.object_id = "obj_999999";
  add("unknown object id", f, "no template cache for object id 'obj_999999'", kOk,
      pose_estimate_t::STATUS_UNKNOWN_OBJECT);

  // ---- The message itself ----
  {
    // A byte array whose declared length exceeds the message (lcm-gen would allocate it):
    // color.size sits after fingerprint, utime, seq, the two strings, the two ids, the five
    // doubles and color's width, height, row_stride, pixel_format, compression.
    std::vector<uint8_t> bytes = EncodeMessage(good);
    const size_t color_size_offset =
        8 + 16 + (4 + good.camera_id.size() + 1) + (4 + good.source.size() + 1) + 8 + 40 + 14;
    const uint32_t huge = 0x7FFFFFF0u;
    for (int i = 0; i < 4; ++i)
      bytes[color_size_offset + i] = static_cast<uint8_t>(huge >> (24 - 8 * i));
    cases.push_back({"huge declared payload size", kBad, 0, "color.size declares", true, bytes});
    // A truncated message: fingerprint and seq intact, body cut.
    std::vector<uint8_t> truncated = EncodeMessage(good);
    truncated.resize(truncated.size() / 2);
    cases.push_back(
        {"truncated message", kBad, 0, "did not decode as g6d.rgbd_frame_t", true, truncated});
  }
  {
    // Another LCM type on the channel (fingerprint mismatch), and plain garbage.
    pose_array_t other{};
    other.seq = good.seq;
    std::vector<uint8_t> bytes(static_cast<size_t>(other.getEncodedSize()));
    other.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    cases.push_back(
        {"fingerprint mismatch", kBad, 0, "did not decode as g6d.rgbd_frame_t", false, bytes});
    std::vector<uint8_t> garbage(5000);
    std::mt19937 rng(static_cast<uint32_t>(good.seq));
    for (uint8_t& b : garbage) b = static_cast<uint8_t>(rng());
    cases.push_back({"garbage", kBad, 0, "did not decode as g6d.rgbd_frame_t", false, garbage});
  }
  return cases;
}

}  // namespace g6d::synthetic
