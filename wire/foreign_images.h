#pragma once
/// @file foreign_images.h
/// Drake and bot_core image messages built field by field, as their publishers fill them
/// (Drake's ImageToLcmImageArrayT: lcmt_image with a header, zlib or raw; bot_core
/// openni/realsense-to-LCM drivers: image_t with utime and no metadata): for
/// g6d-bop2lcm --as, the seed corpus and the tests of the input adapters.

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "bot_core/image_t.hpp"
#include "drake/lcmt_image.hpp"

namespace g6d {

/// The pixels of `image`, rows packed (no padding), as they go on the wire.
std::vector<uint8_t> PixelBytes(const cv::Mat& image);

/// zlib (compress2) of `raw` at `level`; throws g6d::Error when zlib fails.
std::vector<uint8_t> ZlibCompress(const std::vector<uint8_t>& raw, int level = 6);

/// One Drake image: size, row stride, little-endian, the pixel format and channel type
/// given, the pixels zlib-compressed (or raw), and a header with `seq`, `utime` and
/// `frame_name`.
drake::lcmt_image MakeDrakeImage(const cv::Mat& image, int8_t pixel_format, int8_t channel_type, bool zlib,
                                 int32_t seq, int64_t utime, const std::string& frame_name);

/// One bot_core image: size, row stride, `pixelformat`, `data` as given (raw, JPEG or
/// zlib bytes), no metadata.
bot_core::image_t MakeBotCoreImage(const cv::Mat& image, int32_t pixelformat, std::vector<uint8_t> data,
                                   int64_t utime);

}  // namespace g6d
