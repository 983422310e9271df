#pragma once
/// @file image_codec.h
/// Encoding and decoding of one g6d.image_t plane (raw, zstd, PNG, JPEG) to and from
/// cv::Mat, within DecodeLimits: the image half of the wire codec (frame_codec.h is the
/// message half).
///
/// Pixel layout. `pixel_format` names the layout of the raw (decompressed) image: RGB8 is
/// R, G, B bytes per pixel, BGR8 is B, G, R. PNG and JPEG payloads hold true colours (a
/// viewer shows the right image), so an RGB8 plane stored as PNG/JPEG decodes to RGB order
/// and a BGR8 one to BGR order. All multi-byte values are little-endian (the host order on
/// every platform we build for; checked at compile time).
///
/// Errors. Everything here throws g6d::Error with a message that starts with the plane it
/// is about ("color: ...", "depth: ...") and says what was expected and what was found.
/// Nothing allocates more than DecodeLimits allows.

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "g6d/image_t.hpp"
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

/// True for the colour formats RGB8, BGR8 and MONO8.
bool IsColorFormat(int8_t pixel_format);

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

}  // namespace g6d
