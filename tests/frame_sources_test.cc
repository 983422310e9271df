// Lost frames are visible (issue 24): FrameSources' seq rules, the receive buffer probe,
// and the status of a real g6d::Service over a real LCM bus (memq) fed frames of two
// cameras with seq gaps, out-of-order seqs and a publisher restart.
#include "service/frame_sources.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "service/service.h"
#include "service_test_util.h"
#include "wire/image_codec.h"

namespace g6d {
namespace {

using std::chrono::seconds;

TEST(FrameSources, CountsGapsOutOfOrderAndRestartsPerSource) {
  FrameSources sources(/*restart_window=*/100);
  // left: 3 -> 6 loses 4 and 5; 5 and 7 come late; 7 -> 10 loses 8 and 9.
  for (int64_t seq : {1, 2, 3, 6, 7, 5, 7, 10}) sources.Record("left", seq, true);
  // right: 101 -> 104 loses 2, 102 comes late, 3 is a restart (104 - 3 >= 100), then 4.
  for (int64_t seq : {100, 101, 104, 102, 3, 4}) sources.Record("right", seq, true);
  const std::vector<SourceCounts> counts = sources.Sources();
  ASSERT_EQ(counts.size(), 2u);
  EXPECT_EQ(counts[0].id, "left");
  EXPECT_EQ(counts[0].received, 8);
  EXPECT_EQ(counts[0].lost, 4);
  EXPECT_EQ(counts[0].out_of_order, 2);
  EXPECT_EQ(counts[0].restarts, 0);
  EXPECT_EQ(counts[0].last_seq, 10);
  EXPECT_EQ(counts[1].id, "right");
  EXPECT_EQ(counts[1].received, 6);
  EXPECT_EQ(counts[1].lost, 2);
  EXPECT_EQ(counts[1].out_of_order, 1);
  EXPECT_EQ(counts[1].restarts, 1);
  EXPECT_EQ(counts[1].last_seq, 4);
  const SourceCounts total = sources.Total();
  EXPECT_EQ(total.received, 14);
  EXPECT_EQ(total.lost, 6);
  EXPECT_EQ(total.out_of_order, 3);
}

TEST(FrameSources, FirstFrameOfASourceLosesNothing) {
  FrameSources sources;
  sources.Record("cam", 5000, true);  // the service started mid-stream
  sources.Record("cam", 5001, true);
  EXPECT_EQ(sources.Sources()[0].lost, 0);
  EXPECT_EQ(sources.Sources()[0].last_seq, 5001);
}

TEST(FrameSources, WithoutSeqCountsReceivedOnly) {
  FrameSources sources;
  for (int64_t seq : {0, 7, 3}) EXPECT_EQ(sources.Record("bot_core", seq, false), "");
  const SourceCounts counts = sources.Sources()[0];
  EXPECT_FALSE(counts.has_seq);
  EXPECT_EQ(counts.received, 3);
  EXPECT_EQ(counts.lost, 0);
  EXPECT_EQ(counts.out_of_order, 0);
  EXPECT_EQ(counts.last_seq, -1);
}

TEST(FrameSources, ManyCameraIdsShareOneOtherSource) {
  FrameSources sources;
  for (size_t i = 0; i < FrameSources::kMaxSources + 5; ++i) {
    sources.Record("cam" + std::to_string(100 + i), 1, true);
  }
  const std::vector<SourceCounts> counts = sources.Sources();
  ASSERT_EQ(counts.size(), FrameSources::kMaxSources + 1);
  const auto other = std::find_if(counts.begin(), counts.end(), [](const SourceCounts& c) {
    return c.id == FrameSources::kOtherSources;
  });
  ASSERT_NE(other, counts.end());
  EXPECT_EQ(other->received, 5);
  EXPECT_FALSE(other->has_seq);  // seqs of different cameras are not comparable
  EXPECT_EQ(sources.Total().lost, 0);
}

TEST(FrameSources, WarningsNameTheSourceAndAreRateLimited) {
  FrameSources sources(100, seconds(5));
  const FrameSources::Clock::time_point t0{};
  EXPECT_EQ(sources.Record("left", 1, true, t0), "");
  const std::string first = sources.Record("left", 4, true, t0 + seconds(1));
  EXPECT_NE(first.find("camera 'left'"), std::string::npos) << first;
  EXPECT_NE(first.find("2 frames lost"), std::string::npos) << first;
  // Within the period: counted, not logged.
  EXPECT_EQ(sources.Record("left", 7, true, t0 + seconds(2)), "");
  EXPECT_EQ(sources.Record("left", 6, true, t0 + seconds(3)), "");
  // After it: what was not logged, in one line.
  const std::string second = sources.Record("left", 8, true, t0 + seconds(7));
  EXPECT_NE(second.find("2 frames lost"), std::string::npos) << second;
  EXPECT_NE(second.find("1 out of order"), std::string::npos) << second;
  EXPECT_NE(second.find("lost 4"), std::string::npos) << second;
  // Nothing new: nothing to say.
  EXPECT_EQ(sources.Record("left", 9, true, t0 + seconds(20)), "");
}

TEST(ProbeReceiveBuffer, ReadsWhatTheKernelGrantsForTheUrl) {
  const ReceiveBuffer memq = ProbeReceiveBuffer("memq://");
  EXPECT_FALSE(memq.udpm);
  EXPECT_EQ(ReceiveBufferWarning(memq, kVgaFrameBytes), "");

  const ReceiveBuffer plain = ProbeReceiveBuffer("udpm://239.255.76.67:7611?ttl=0");
  EXPECT_TRUE(plain.udpm);
  EXPECT_EQ(plain.requested_bytes, 0);
  EXPECT_GT(plain.granted_bytes, 0);

  const ReceiveBuffer asked =
      ProbeReceiveBuffer("udpm://239.255.76.67:7611?ttl=0&recv_buf_size=131072");
  EXPECT_EQ(asked.requested_bytes, 131072);
  // Linux grants twice the request (bookkeeping overhead), within net.core.rmem_max.
  EXPECT_GE(asked.granted_bytes, 131072);
  const std::string warning = ReceiveBufferWarning(asked, asked.granted_bytes + 1);
  EXPECT_NE(warning.find("recv_buf_size"), std::string::npos) << warning;
  EXPECT_NE(warning.find("net.core.rmem_max"), std::string::npos) << warning;
  EXPECT_NE(warning.find("7611"), std::string::npos) << warning;
  EXPECT_EQ(ReceiveBufferWarning(asked, asked.granted_bytes), "");
}

/// A small valid frame without instances: decodes, and is answered without the solver.
rgbd_frame_t SmallFrame(const std::string& camera_id, int64_t seq) {
  rgbd_frame_t frame{};
  frame.utime = 1000000 + seq;
  frame.seq = seq;
  frame.camera_id = camera_id;
  frame.source = "frame_sources_test";
  frame.scene_id = -1;
  frame.image_id = -1;
  frame.fx = frame.fy = 40.0;
  frame.cx = 16.0;
  frame.cy = 12.0;
  frame.depth_scale_m = 0.001;
  frame.color = EncodeImage(cv::Mat(24, 32, CV_8UC3, cv::Scalar(90, 120, 150)),
                            image_t::FORMAT_RGB8, image_t::COMPRESSION_NONE);
  frame.depth = EncodeImage(cv::Mat(24, 32, CV_16U, cv::Scalar(800)), image_t::FORMAT_DEPTH_U16,
                            image_t::COMPRESSION_ZSTD);
  frame.labels = EncodeImage(cv::Mat::zeros(24, 32, CV_8U), image_t::FORMAT_LABEL_U8,
                             image_t::COMPRESSION_ZSTD);
  frame.num_instances = 0;
  return frame;
}

std::vector<uint8_t> Encode(const rgbd_frame_t& frame) {
  std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
  frame.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

TEST(PeekRgbdFrameSource, ReadsCameraAndSeqOfABrokenFrame) {
  std::vector<uint8_t> bytes = Encode(SmallFrame("wrist_cam", 4711));
  std::string camera_id;
  int64_t seq = 0;
  ASSERT_TRUE(PeekRgbdFrameSource(bytes.data(), 60, &camera_id, &seq));  // cut after the id
  EXPECT_EQ(camera_id, "wrist_cam");
  EXPECT_EQ(seq, 4711);
  EXPECT_FALSE(PeekRgbdFrameSource(bytes.data(), 30, &camera_id, &seq));  // cut inside it
  EXPECT_FALSE(PeekRgbdFrameSource(nullptr, 0, &camera_id, &seq));
  bytes[0] ^= 0xff;  // another type's fingerprint
  EXPECT_FALSE(PeekRgbdFrameSource(bytes.data(), static_cast<int64_t>(bytes.size()), &camera_id, &seq));
}

TEST(ServiceStatus, CountsLostAndOutOfOrderFramesPerCamera) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  ServiceOptions options;
  options.lcm_url = "memq://";
  options.templates_dir = "unused: the store is given";
  options.input_channel = "SOURCES_RGBD";
  options.output_channel = "SOURCES_POSES";
  options.status_channel = "SOURCES_STATUS";
  options.status_period_s = 0.05;
  options.workers = 1;
  // memq never loses a message, but LCM drops one when the subscription queue is full: the
  // only frames missing here are the ones never sent.
  options.subscription_queue = 1000;
  test::ServiceListener listener(&lcm, options.output_channel, options.status_channel);
  Service service(options, TemplateStore(), &lcm);
  service.Start();
  // The two cameras of the FrameSources test above, interleaved on one channel.
  const std::vector<std::pair<std::string, int64_t>> frames = {
      {"left", 1},   {"right", 100}, {"left", 2},   {"left", 3},  {"right", 101},
      {"left", 6},   {"right", 104}, {"left", 7},   {"left", 5},  {"right", 102},
      {"left", 7},   {"right", 3},   {"left", 10},  {"right", 4}};
  for (const auto& [camera, seq] : frames) {
    const rgbd_frame_t frame = SmallFrame(camera, seq);
    ASSERT_EQ(lcm.publish(options.input_channel, &frame), 0);
  }
  // Rejected, but arrived: left 11 cut short after its camera id (counted under left, no
  // gap before 12), and garbage that names no camera (counted nowhere but rejected).
  const std::vector<uint8_t> truncated = Encode(SmallFrame("left", 11));
  ASSERT_EQ(lcm.publish(options.input_channel, truncated.data(), 200), 0);
  const std::vector<uint8_t> garbage(100, 0x5a);
  ASSERT_EQ(lcm.publish(options.input_channel, garbage.data(), 100), 0);
  const rgbd_frame_t after = SmallFrame("left", 12);
  ASSERT_EQ(lcm.publish(options.input_channel, &after), 0);
  const int64_t sent = static_cast<int64_t>(frames.size()) + 3;
  const std::optional<service_status_t> status =
      listener.statuses.PopUntil(seconds(30), [&](const service_status_t& s) {
        return s.frames_received == sent &&
               s.frames_processed + s.frames_dropped + s.frames_rejected == sent;
      });
  service.Stop();
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->frames_rejected, 2);
  EXPECT_EQ(status->frames_lost, 6);
  EXPECT_EQ(status->frames_out_of_order, 3);
  EXPECT_EQ(status->recv_buffer_bytes, 0);  // memq: no socket
  ASSERT_EQ(status->num_sources, 2);
  ASSERT_EQ(status->source_ids.size(), 2u);
  EXPECT_EQ(status->source_ids, (std::vector<std::string>{"left", "right"}));
  EXPECT_EQ(status->source_has_seq, (std::vector<int8_t>{1, 1}));
  EXPECT_EQ(status->source_received, (std::vector<int64_t>{10, 6}));
  EXPECT_EQ(status->source_lost, (std::vector<int64_t>{4, 2}));
  EXPECT_EQ(status->source_out_of_order, (std::vector<int64_t>{2, 1}));
  EXPECT_EQ(status->source_restarts, (std::vector<int64_t>{0, 1}));
  EXPECT_EQ(status->source_last_seq, (std::vector<int64_t>{12, 4}));
}

}  // namespace
}  // namespace g6d
