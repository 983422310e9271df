#pragma once
/// @file names.h
/// Names of the g6d message enums (pixel formats, compressions, statuses), for messages,
/// logs, CSV and JSON. Unknown values give "unknown(<value>)", never an exception.

#include <cstdint>
#include <string>

namespace g6d {

/// "RGB8", "DEPTH_U16", ... of an image_t pixel format, or "unknown(<value>)".
std::string PixelFormatName(int8_t pixel_format);

/// "NONE", "ZSTD", "PNG", "JPEG" of an image_t compression, or "unknown(<value>)".
std::string CompressionName(int8_t compression);

/// "ok", "no_solution", "bad_input", "unknown_object", "internal_error" of a
/// pose_estimate_t status, or "unknown(<value>)".
std::string EstimateStatusName(int8_t status);

/// "detected", "tracked", "redetected" of a pose_estimate_t mode (as AnswerMode's names,
/// track/tracker.h), or "unknown(<value>)".
std::string EstimateModeName(int8_t mode);

/// "ok", "bad_frame" of a pose_array_t status, or "unknown(<value>)".
std::string FrameStatusName(int8_t status);

}  // namespace g6d
