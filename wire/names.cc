#include "wire/names.h"

#include "g6d/image_t.hpp"
#include "g6d/pose_array_t.hpp"
#include "g6d/pose_estimate_t.hpp"

namespace g6d {
namespace {

std::string Unknown(int8_t value) { return "unknown(" + std::to_string(value) + ")"; }

}  // namespace

std::string PixelFormatName(int8_t pixel_format) {
  switch (pixel_format) {
    case image_t::FORMAT_RGB8:
      return "RGB8";
    case image_t::FORMAT_BGR8:
      return "BGR8";
    case image_t::FORMAT_MONO8:
      return "MONO8";
    case image_t::FORMAT_DEPTH_U16:
      return "DEPTH_U16";
    case image_t::FORMAT_DEPTH_F32:
      return "DEPTH_F32";
    case image_t::FORMAT_LABEL_U8:
      return "LABEL_U8";
    case image_t::FORMAT_LABEL_U16:
      return "LABEL_U16";
  }
  return Unknown(pixel_format);
}

std::string CompressionName(int8_t compression) {
  switch (compression) {
    case image_t::COMPRESSION_NONE:
      return "NONE";
    case image_t::COMPRESSION_ZSTD:
      return "ZSTD";
    case image_t::COMPRESSION_PNG:
      return "PNG";
    case image_t::COMPRESSION_JPEG:
      return "JPEG";
  }
  return Unknown(compression);
}

std::string EstimateStatusName(int8_t status) {
  switch (status) {
    case pose_estimate_t::STATUS_OK:
      return "ok";
    case pose_estimate_t::STATUS_NO_SOLUTION:
      return "no_solution";
    case pose_estimate_t::STATUS_BAD_INPUT:
      return "bad_input";
    case pose_estimate_t::STATUS_UNKNOWN_OBJECT:
      return "unknown_object";
    case pose_estimate_t::STATUS_INTERNAL_ERROR:
      return "internal_error";
  }
  return Unknown(status);
}

std::string EstimateModeName(int8_t mode) {
  switch (mode) {
    case pose_estimate_t::MODE_DETECTED:
      return "detected";
    case pose_estimate_t::MODE_TRACKED:
      return "tracked";
    case pose_estimate_t::MODE_REDETECTED:
      return "redetected";
  }
  return Unknown(mode);
}

std::string FrameStatusName(int8_t status) {
  switch (status) {
    case pose_array_t::STATUS_OK:
      return "ok";
    case pose_array_t::STATUS_BAD_FRAME:
      return "bad_frame";
  }
  return Unknown(status);
}

}  // namespace g6d
