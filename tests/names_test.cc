// The names of the message enums: every defined value has its own name, unknown values say
// so with the number.

#include "wire/names.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include "g6d/image_t.hpp"
#include "g6d/pose_array_t.hpp"
#include "g6d/pose_estimate_t.hpp"

namespace g6d {
namespace {

TEST(PixelFormatName, NamesEveryFormatOnce) {
  std::set<std::string> names;
  for (int8_t format : {image_t::FORMAT_RGB8, image_t::FORMAT_BGR8, image_t::FORMAT_MONO8,
                        image_t::FORMAT_DEPTH_U16, image_t::FORMAT_DEPTH_F32,
                        image_t::FORMAT_LABEL_U8, image_t::FORMAT_LABEL_U16}) {
    names.insert(PixelFormatName(format));
  }
  EXPECT_EQ(names.size(), 7u);
  EXPECT_EQ(PixelFormatName(image_t::FORMAT_DEPTH_U16), "DEPTH_U16");
  EXPECT_EQ(PixelFormatName(99), "unknown(99)");
}

TEST(CompressionName, NamesEveryCompression) {
  EXPECT_EQ(CompressionName(image_t::COMPRESSION_NONE), "NONE");
  EXPECT_EQ(CompressionName(image_t::COMPRESSION_ZSTD), "ZSTD");
  EXPECT_EQ(CompressionName(image_t::COMPRESSION_PNG), "PNG");
  EXPECT_EQ(CompressionName(image_t::COMPRESSION_JPEG), "JPEG");
  EXPECT_EQ(CompressionName(-3), "unknown(-3)");
}

TEST(EstimateStatusName, NamesEveryStatus) {
  EXPECT_EQ(EstimateStatusName(pose_estimate_t::STATUS_OK), "ok");
  EXPECT_EQ(EstimateStatusName(pose_estimate_t::STATUS_NO_SOLUTION), "no_solution");
  EXPECT_EQ(EstimateStatusName(pose_estimate_t::STATUS_BAD_INPUT), "bad_input");
  EXPECT_EQ(EstimateStatusName(pose_estimate_t::STATUS_UNKNOWN_OBJECT), "unknown_object");
  EXPECT_EQ(EstimateStatusName(pose_estimate_t::STATUS_INTERNAL_ERROR), "internal_error");
  EXPECT_EQ(EstimateStatusName(42), "unknown(42)");
}

TEST(EstimateModeName, NamesEveryModeAsTheTrackerDoes) {
  EXPECT_EQ(EstimateModeName(pose_estimate_t::MODE_DETECTED), "detected");
  EXPECT_EQ(EstimateModeName(pose_estimate_t::MODE_TRACKED), "tracked");
  EXPECT_EQ(EstimateModeName(pose_estimate_t::MODE_REDETECTED), "redetected");
  EXPECT_EQ(EstimateModeName(3), "unknown(3)");
}

TEST(FrameStatusName, NamesEveryStatus) {
  EXPECT_EQ(FrameStatusName(pose_array_t::STATUS_OK), "ok");
  EXPECT_EQ(FrameStatusName(pose_array_t::STATUS_BAD_FRAME), "bad_frame");
  EXPECT_EQ(FrameStatusName(7), "unknown(7)");
}

}  // namespace
}  // namespace g6d
