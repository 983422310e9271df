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

/// One requested instance after decoding: its identity (or candidates) and its mask.
///
/// Where the object is. A label > 0 names its pixels in the label image (the mask); a
/// label of 0 with a box (width > 0) makes the mask the filled box, clipped to the image
/// (the solver's default MaskTrust::kDepth then removes the table and the background from
/// it); a label > 0 wins over a box, which is then ignored. Which object: object_id, or,
/// when it is empty, one of candidate_ids (every loaded object when none are listed),
/// chosen by the service with EstimatePoseOfUnknownObject.
///
/// Neither mask nor box (label 0, box width <= 0): a detection request. The service finds
/// up to `count` instances of the object (of each candidate, or of every loaded object,
/// when object_id is empty) in its own depth proposals (DetectObjects, solver/detect.h).
struct DecodedInstance {
  int32_t index = -1;     ///< position in the frame's instances (echoed as request_index)
  std::string object_id;  ///< as in the request; empty = identity unknown
  int32_t label = 0;      ///< as in the request
  float score = 0.0f;     ///< detection score, as in the request
  int32_t gt_index = -1;  ///< as in the request
  /// The request's box clipped to the image, pixels, when the mask is that box (label 0);
  /// empty (0 x 0) otherwise.
  cv::Rect box;
  /// Identity unknown: the candidates as requested, each once, in request order (empty =
  /// every loaded object). Empty when object_id is set.
  std::vector<std::string> candidate_ids;
  /// A detection request: no mask and no box (label 0, box width <= 0); `mask` is empty.
  bool detect = false;
  /// A detection request's count: answer up to this many instances of each object (>= 1;
  /// instance_t::count <= 0 means 1). 1 otherwise.
  int count = 1;
  cv::Mat mask;           ///< CV_8U frame size, 255 where labels == label or inside box (empty for a detection request or when error set)
  int mask_pixels = 0;    ///< pixels of the mask
  /// Empty when the instance can be solved; else why not (label < 0, label has no
  /// pixels, a box of width > 0 and no height, a box outside the image, an empty
  /// candidate id). The frame's other instances are still usable. Whether the object or
  /// the candidates have template caches is the service's to check.
  std::string error;

  /// True when the request named no object: the service searches the candidates.
  bool identity_unknown() const { return object_id.empty(); }
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
/// instance"). A label plane of 0 x 0 pixels (no bytes, any format) means "no label image":
/// every instance then needs a box or is a detection request. Problems of a single instance (see
/// DecodedInstance::error) are reported in that DecodedInstance's `error` instead.
DecodedFrame DecodeFrame(const rgbd_frame_t& message, const DecodeLimits& limits = {});

}  // namespace g6d
