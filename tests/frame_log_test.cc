// FrameLogReader: frames back out of an LCM log, with clear words for a missing, empty,
// truncated or corrupted log, foreign channels and events that are not frames.
#include "frame_log.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "g6d/pose_array_t.hpp"
#include "wire/frame_codec.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

rgbd_frame_t SmallFrame(int64_t seq) {
  rgbd_frame_t frame{};
  frame.utime = 1000 + seq;
  frame.seq = seq;
  frame.camera_id = "cam";
  frame.source = "unit";
  frame.scene_id = 3;
  frame.image_id = static_cast<int32_t>(10 + seq);
  frame.fx = frame.fy = 500.0;
  frame.cx = 16.0;
  frame.cy = 12.0;
  frame.depth_scale_m = 0.001;
  frame.color = EncodeImage(cv::Mat(24, 32, CV_8UC3, cv::Scalar(1, 2, 3)), image_t::FORMAT_RGB8,
                            image_t::COMPRESSION_NONE);
  frame.depth = EncodeImage(cv::Mat(24, 32, CV_16UC1, cv::Scalar(700)), image_t::FORMAT_DEPTH_U16,
                            image_t::COMPRESSION_ZSTD);
  frame.labels = EncodeImage(cv::Mat::zeros(24, 32, CV_8UC1), image_t::FORMAT_LABEL_U8,
                             image_t::COMPRESSION_ZSTD);
  frame.num_instances = 0;
  return frame;
}

// Writes one event of raw bytes.
void WriteEvent(lcm::LogFile* log, const std::string& channel, int64_t timestamp,
                std::vector<uint8_t> bytes) {
  lcm::LogEvent event;
  event.timestamp = timestamp;
  event.channel = channel;
  event.datalen = static_cast<int32_t>(bytes.size());
  event.data = bytes.data();
  ASSERT_EQ(log->writeEvent(&event), 0);
}

template <typename Message>
std::vector<uint8_t> Encode(const Message& message) {
  std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// A log of `frames` frames on G6D_RGBD.
std::string WriteFrameLog(const std::string& name, int frames) {
  const std::string path = test::TempDir(name) + "/frames.lcmlog";
  lcm::LogFile log(path, "w");
  for (int i = 0; i < frames; ++i) WriteEvent(&log, "G6D_RGBD", 100000 * i, Encode(SmallFrame(i)));
  return path;
}

std::vector<FrameEvent> ReadAll(FrameLogReader* reader) {
  std::vector<FrameEvent> events;
  FrameEvent event;
  while (reader->Next(&event)) events.push_back(event);
  return events;
}

std::string Joined(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

TEST(FrameLogReader, CleanLogHasNoProblems) {
  const std::string path = WriteFrameLog("frame_log_clean", 3);
  FrameLogReader reader(path, "G6D_RGBD");
  const std::vector<FrameEvent> events = ReadAll(&reader);
  ASSERT_EQ(events.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(events[i].frame.seq, i);
    EXPECT_EQ(events[i].frame.image_id, 10 + i);
    EXPECT_EQ(events[i].timestamp_us, 100000 * i);
    EXPECT_EQ(events[i].event_number, i);
  }
  EXPECT_EQ(reader.stats().events, 3);
  EXPECT_EQ(reader.stats().frames, 3);
  EXPECT_FALSE(reader.stats().Truncated());
  EXPECT_EQ(reader.stats().skipped_bytes, 0);
  EXPECT_TRUE(reader.stats().Problems().empty()) << Joined(reader.stats().Problems());
}

TEST(FrameLogReader, TruncatedLogKeepsTheCompleteEventsAndSaysSo) {
  const std::string path = WriteFrameLog("frame_log_truncated", 3);
  const auto size = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, size - 100);
  const FrameLogStats stats = ScanFrameLog(path, "G6D_RGBD");
  EXPECT_EQ(stats.frames, 2);
  EXPECT_TRUE(stats.Truncated());
  EXPECT_GT(stats.trailing_bytes, 0);
  EXPECT_LT(stats.trailing_bytes, static_cast<int64_t>(size));
  EXPECT_THAT(Joined(stats.Problems()), AllOf(HasSubstr(path), HasSubstr("truncated"),
                                              HasSubstr("after 2 complete event(s)")));

  // Cut inside the 28-byte header of the last event, too.
  const std::string header_cut = WriteFrameLog("frame_log_header_cut", 2);
  FrameLogStats one;
  {
    const auto first_size = std::filesystem::file_size(WriteFrameLog("frame_log_one", 1));
    std::filesystem::resize_file(header_cut, first_size + 10);
    one = ScanFrameLog(header_cut, "G6D_RGBD");
  }
  EXPECT_EQ(one.frames, 1);
  EXPECT_EQ(one.trailing_bytes, 10);
}

TEST(FrameLogReader, ForeignChannelsAndUndecodableEventsAreSkippedAndCounted) {
  const std::string path = test::TempDir("frame_log_foreign") + "/mixed.lcmlog";
  {
    lcm::LogFile log(path, "w");
    pose_array_t answer{};
    answer.source = "unit";
    WriteEvent(&log, "G6D_RGBD", 0, Encode(SmallFrame(0)));
    WriteEvent(&log, "G6D_POSES", 1, Encode(answer));
    WriteEvent(&log, "CAMERA_INFO", 2, {1, 2, 3});
    WriteEvent(&log, "G6D_POSES", 3, Encode(answer));
    WriteEvent(&log, "G6D_RGBD", 4, Encode(answer));  // right channel, wrong type
    WriteEvent(&log, "G6D_RGBD", 5, {9, 9, 9, 9});    // right channel, garbage
    WriteEvent(&log, "G6D_RGBD", 6, Encode(SmallFrame(1)));
  }
  FrameLogReader reader(path, "G6D_RGBD");
  const std::vector<FrameEvent> events = ReadAll(&reader);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].frame.seq, 0);
  EXPECT_EQ(events[1].frame.seq, 1);
  EXPECT_EQ(events[1].event_number, 6);
  const FrameLogStats& stats = reader.stats();
  EXPECT_EQ(stats.events, 7);
  EXPECT_EQ(stats.ForeignEvents(), 3);
  EXPECT_EQ(stats.foreign_channels.at("G6D_POSES"), 2);
  EXPECT_EQ(stats.foreign_channels.at("CAMERA_INFO"), 1);
  EXPECT_EQ(stats.undecodable, 2);
  EXPECT_EQ(stats.first_undecodable_event, 4);
  EXPECT_THAT(
      Joined(stats.Problems()),
      AllOf(HasSubstr("skipped 3 event(s) of other channels (CAMERA_INFO: 1, G6D_POSES: 2)"),
            HasSubstr("2 event(s) of channel G6D_RGBD do not decode as g6d_rgbd_frame_t (first: "
                      "event 4)")));
}

TEST(FrameLogReader, GarbageIsSkippedBeforeAndStopsReadingBetweenEvents) {
  const std::string one = WriteFrameLog("frame_log_garbage_one", 1);
  const std::string two = WriteFrameLog("frame_log_garbage_two", 2);
  const std::string dir = test::TempDir("frame_log_garbage");
  auto concatenate = [&](const std::string& path, const std::vector<std::string>& parts) {
    std::ofstream out(path, std::ios::binary);
    for (const std::string& part : parts) {
      if (part.front() != '/') {
        out << part;
        continue;
      }
      std::ifstream in(part, std::ios::binary);
      out << in.rdbuf();
    }
  };
  concatenate(dir + "/leading.lcmlog", {"not an lcm event", two});
  const FrameLogStats leading = ScanFrameLog(dir + "/leading.lcmlog", "G6D_RGBD");
  EXPECT_EQ(leading.frames, 2);
  EXPECT_EQ(leading.skipped_bytes, 16);
  EXPECT_FALSE(leading.Truncated());
  EXPECT_THAT(Joined(leading.Problems()),
              HasSubstr("16 byte(s) before an event are not an LCM event"));

  // LCM's reader refuses an event not followed by a sync word and stops there.
  concatenate(dir + "/middle.lcmlog", {two, "not an lcm event", one});
  const int64_t event_bytes = static_cast<int64_t>(std::filesystem::file_size(one));
  const FrameLogStats middle = ScanFrameLog(dir + "/middle.lcmlog", "G6D_RGBD");
  EXPECT_EQ(middle.frames, 1);
  EXPECT_TRUE(middle.Truncated());
  EXPECT_EQ(middle.trailing_bytes, event_bytes + 16 + event_bytes);
  EXPECT_THAT(
      Joined(middle.Problems()),
      HasSubstr("truncated or corrupted: reading stopped at byte " + std::to_string(event_bytes)));
}

TEST(FrameLogReader, MissingEmptyAndNonLogFiles) {
  const std::string dir = test::TempDir("frame_log_missing");
  try {
    FrameLogReader reader(dir + "/absent.lcmlog", "G6D_RGBD");
    FAIL() << "no exception for a missing log";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("absent.lcmlog"), HasSubstr("does not exist")));
  }
  EXPECT_THROW(FrameLogReader(dir, "G6D_RGBD"), Error);  // a folder

  std::ofstream(dir + "/empty.lcmlog").close();
  const FrameLogStats empty = ScanFrameLog(dir + "/empty.lcmlog", "G6D_RGBD");
  EXPECT_EQ(empty.events, 0);
  EXPECT_THAT(Joined(empty.Problems()),
              HasSubstr("no g6d_rgbd_frame_t event on channel G6D_RGBD (0 event(s)"));

  std::ofstream(dir + "/text.lcmlog") << "just some text, not a log\n";
  const FrameLogStats text = ScanFrameLog(dir + "/text.lcmlog", "G6D_RGBD");
  EXPECT_EQ(text.frames, 0);
  EXPECT_TRUE(text.Truncated());
  EXPECT_THAT(Joined(text.Problems()), HasSubstr("not a complete LCM event"));
}

}  // namespace
}  // namespace g6d
