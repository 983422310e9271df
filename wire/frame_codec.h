#pragma once
/// @file frame_codec.h
/// Encoding and decoding of g6d.image_t planes and validation of whole g6d.rgbd_frame_t
/// messages: the boundary where untrusted bytes from the bus become solver input.
///
/// Pixel layout. `pixel_format` names the layout of the raw (decompressed) image: RGB8 is
/// R, G, B bytes per pixel, BGR8 is B, G, R. PNG and JPEG payloads hold true colours (a
/// viewer shows the right image), so an RGB8 plane stored as PNG/JPEG decodes to RGB order
/// and a BGR8 one to BGR order. All multi-byte values are little-endian (the host order on
/// every platform we build for; checked at compile time).
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
#include "wire/names.h"

namespace g6d {

/// Limits that protect decoding from huge declared sizes.
struct DecodeLimits {
  int max_width = 8192;                 ///< widest accepted image, pixels
  int max_height = 8192;                ///< tallest accepted image, pixels
  int64_t max_raw_bytes = 512LL << 20;  ///< largest raw (decompressed) plane, bytes
  int max_instances = 256;              ///< most instances accepted in one frame

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Options of EncodeImage() beyond the format: compression effort and quality.
struct EncodeOptions {
  int zstd_level = 1;     ///< 1 (fastest) .. 19; 1 already shrinks depth ~3x
  int png_level = 1;      ///< PNG deflate level 0..9 (OpenCV's IMWRITE_PNG_COMPRESSION)
  int jpeg_quality = 90;  ///< JPEG quality 1..100

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Bytes per raw pixel of an image_t pixel format; 0 for an unknown format.
int BytesPerPixel(int8_t pixel_format);

/// The OpenCV type a pixel format decodes to (CV_8UC3, CV_8UC1, CV_16UC1, CV_32FC1); -1
/// for an unknown format.
int OpenCvTypeOf(int8_t pixel_format);

/// Encodes `image` into an image_t. `image` type must match pixel_format: FORMAT_RGB8/BGR8 ->
/// CV_8UC3, FORMAT_MONO8 and FORMAT_LABEL_U8 -> CV_8UC1, FORMAT_DEPTH_U16 and FORMAT_LABEL_U16 ->
/// CV_16UC1, FORMAT_DEPTH_F32 -> CV_32FC1. compression: COMPRESSION_NONE/ZSTD/PNG/JPEG (JPEG only
/// for RGB8/BGR8/MONO8). row_stride = width * bytes per pixel. Throws g6d::Error naming the
/// mismatch.
image_t EncodeImage(const cv::Mat& image, int8_t pixel_format, int8_t compression);

/// EncodeImage() with explicit compression effort / quality.
image_t EncodeImage(const cv::Mat& image, int8_t pixel_format, int8_t compression,
                    const EncodeOptions& options);

/// Decodes an image_t into a cv::Mat of the natural type above (channel order as stored, no
/// conversion, row_stride honoured). Throws g6d::Error with a message starting with `what` (e.g.
/// "color") that names the problem (size mismatch, unknown format/compression, corrupted payload,
/// too large, ...). The returned Mat owns its (continuous) pixels.
cv::Mat DecodeImage(const image_t& image, const std::string& what, const DecodeLimits& limits = {});

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
