#pragma once
/// @file frame_codec.h
/// Validation and decoding of whole g6d.rgbd_frame_t messages: the boundary where
/// untrusted bytes from the bus become solver input. The planes are decoded with
/// image_codec.h (included here, so this header gives the whole codec).
///
/// Errors. Everything here throws g6d::Error with a message that starts with the plane or
/// field it is about ("color: ...", "depth: ...", "intrinsics: ...") and says what was
/// expected and what was found. Nothing allocates more than DecodeLimits allows.

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "g6d/image_t.hpp"
#include "g6d/rgbd_frame_t.hpp"
#include "core/frame.h"
#include "wire/image_codec.h"
#include "wire/names.h"

namespace g6d {

/// Checks, before any decoding, that `size` bytes hold a well-formed encoded
/// g6d.rgbd_frame_t: the fingerprint is ours and every declared string, byte array and
/// instance count fits inside the buffer. lcm-gen's decoders allocate a declared array
/// size before checking it against the buffer, so a hostile or corrupted message could
/// make them allocate gigabytes; call this first. Empty when safe, else the reason.
std::string CheckEncodedRgbdFrame(const void* data, int64_t size);

/// Reads utime and seq of an encoded g6d.rgbd_frame_t whose body may be malformed, so
/// that an error answer can still name the frame. False when the fingerprint is not ours
/// or the bytes end before seq.
bool PeekRgbdFrameIds(const void* data, int64_t size, int64_t* utime, int64_t* seq);

/// Decodes a g6d.rgbd_frame_t from raw LCM bytes after CheckEncodedRgbdFrame(). Throws
/// g6d::Error("message: ...") when the bytes are not one (wrong fingerprint, garbage,
/// truncated, bad declared sizes).
rgbd_frame_t DecodeRgbdFrameMessage(const void* data, int64_t size);

/// One requested instance after decoding: its identity and its mask.
struct DecodedInstance {
  std::string object_id;  ///< as in the request
  int32_t label = 0;      ///< as in the request
  float score = 0.0f;     ///< detection score, as in the request
  int32_t gt_index = -1;  ///< as in the request
  cv::Mat mask;           ///< CV_8U frame size, 255 where labels == label (empty when error set)
  int mask_pixels = 0;    ///< pixels carrying this label
  /// Empty when the instance can be solved; else why not (label <= 0, label has no
  /// pixels, empty object id). The frame's other instances are still usable.
  std::string error;
};

/// A validated, decoded frame: what the solver needs.
struct DecodedFrame {
  /// camera (fx fy cx cy, size of the colour image), rgb CV_8UC3 in RGB order (MONO8 is
  /// replicated to three channels), depth CV_32F metres with 0 = no measurement (NaN,
  /// infinite and negative values become 0).
  Frame frame;
  cv::Mat labels;                          ///< CV_8U or CV_16U label image as sent, 0 = background
  std::vector<DecodedInstance> instances;  ///< in request order
};

/// Validates and decodes a whole frame. Throws g6d::Error naming the field when the frame
/// as a whole is unusable: bad intrinsics ("intrinsics: fx must be ..."), bad depth scale
/// (not finite, <= 0, or so large that 65535 x depth_scale_m overflows a float),
/// a plane that does not decode or has the wrong format ("color: ...", "depth: ...",
/// "labels: ..."), planes of different sizes, too many instances, or a label value in
/// the label image that no instance names ("labels: label 7 (1234 pixels) is named by no
/// instance"). Problems of a single instance (label with no pixels, label <= 0, empty
/// object id) are reported in that DecodedInstance's `error` instead.
DecodedFrame DecodeFrame(const rgbd_frame_t& message, const DecodeLimits& limits = {});

}  // namespace g6d
