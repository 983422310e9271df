// g6d-status (issue 24): the real binary with --once against g6d_service_status_t
// messages published on a real udpm bus (loopback, ttl=0): one line per service with its
// counts, sources and latency; a service whose status stopped is marked STALE; channels
// that do not match the regex, and other message types on matching channels, are left out.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "g6d/pose_array_t.hpp"
#include "g6d/service_status_t.hpp"
#include "process_util.h"
#include "test_paths.h"

namespace g6d {
namespace {

const std::string kStatusBinary = test::BinaryDir() + "/tools/g6d-status";

/// A bus of this test run only (ports 7610-7629 are this test's).
std::string BusUrl() {
  return "udpm://239.255.76.67:" + std::to_string(7610 + getpid() % 20) + "?ttl=0";
}

service_status_t Status(const std::string& name, int64_t received) {
  service_status_t status{};
  status.service_name = name;
  status.input_channel = "G6D_RGBD_" + name;
  status.output_channel = "G6D_POSES_" + name;
  status.uptime_s = 754.0;  // 12m34s
  status.frames_received = received;
  status.frames_processed = 40;
  status.frames_dropped = 50;
  status.frames_stale = 1;
  status.frames_rejected = 2;
  status.latency_p50_s = 0.2125;
  status.latency_p95_s = 0.3404;
  status.busy = 1;
  status.workers = 2;
  status.hypotheses = 18;
  status.objects = {"obj_000005", "obj_000008"};
  status.num_objects = 2;
  status.frames_lost = 7;
  status.frames_out_of_order = 3;
  status.recv_buffer_bytes = 8388608;
  status.source_ids = {name};
  status.source_has_seq = {1};
  status.source_received = {received};
  status.source_lost = {7};
  status.source_out_of_order = {3};
  status.source_restarts = {0};
  status.source_last_seq = {received + 6};
  status.num_sources = 1;
  return status;
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream stream(text);
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  return lines;
}

/// The line naming `channel` (its last column), or empty.
std::string LineOf(const std::string& output, const std::string& channel) {
  for (const std::string& line : Lines(output)) {
    if (line.size() >= channel.size() &&
        line.compare(line.size() - channel.size(), channel.size(), channel) == 0) {
      return line;
    }
  }
  return "";
}

TEST(StatusTool, PrintsOneLinePerServiceAndMarksStoppedOnesStale) {
  ASSERT_TRUE(std::filesystem::exists(kStatusBinary)) << kStatusBinary;
  const std::string url = BusUrl();
  lcm::LCM lcm(url);
  ASSERT_TRUE(lcm.good()) << url;
  // cam0 publishes all along (10 Hz), cam1 only in the first 3 s, then stops (the tool
  // takes up to about 1.7 s to subscribe under ThreadSanitizer on a loaded machine); a
  // pose array on a matching channel and a status on a channel that does not match.
  std::atomic<bool> done{false};
  std::thread publisher([&] {
    const auto start = std::chrono::steady_clock::now();
    while (!done) {
      const service_status_t cam0 = Status("cam0", 100), cam1 = Status("cam1", 200),
                             elsewhere = Status("elsewhere", 300);
      lcm.publish("G6D_STATUS_cam0", &cam0);
      if (std::chrono::steady_clock::now() - start < std::chrono::seconds(3)) {
        lcm.publish("G6D_STATUS_cam1", &cam1);
      }
      lcm.publish("OTHER_cam2", &elsewhere);
      const pose_array_t not_a_status{};
      lcm.publish("G6D_STATUS_NOT_REALLY", &not_a_status);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the publishing rate
    }
  });
  const test::CommandResult result = test::RunCommand(
      kStatusBinary + " --lcm-url '" + url + "' --once --wait-s 5 --stale-s 1 2>&1");
  done = true;
  publisher.join();
  ASSERT_EQ(result.exit_code, 0) << result.output;
  std::cout << result.output;
  const std::vector<std::string> lines = Lines(result.output);
  ASSERT_EQ(lines.size(), 3u) << result.output;  // the header and two services
  EXPECT_EQ(lines[0].rfind("SERVICE", 0), 0u) << result.output;

  const std::string cam0 = LineOf(result.output, "G6D_STATUS_cam0");
  ASSERT_FALSE(cam0.empty()) << result.output;
  std::istringstream fields(cam0);
  std::vector<std::string> f;
  for (std::string word; fields >> word;) f.push_back(word);
  // name, sources, uptime, recv, proc, drop, stale, rej, lost, ooo, p50, p95, busy, obj, age
  ASSERT_GE(f.size(), 16u) << cam0;
  EXPECT_EQ(f[0], "cam0");
  EXPECT_EQ(f[1], "cam0");
  EXPECT_EQ(f[2], "12m34s");
  EXPECT_EQ(f[3], "100");
  EXPECT_EQ(f[4], "40");
  EXPECT_EQ(f[5], "50");
  EXPECT_EQ(f[6], "1");
  EXPECT_EQ(f[7], "2");
  EXPECT_EQ(f[8], "7");
  EXPECT_EQ(f[9], "3");
  EXPECT_EQ(f[10], "212.5");
  EXPECT_EQ(f[11], "340.4");
  EXPECT_EQ(f[12], "yes");
  EXPECT_EQ(f[13], "2");
  EXPECT_EQ(cam0.find("STALE"), std::string::npos) << cam0;

  const std::string cam1 = LineOf(result.output, "G6D_STATUS_cam1");
  ASSERT_FALSE(cam1.empty()) << result.output;
  EXPECT_EQ(cam1.rfind("cam1 ", 0), 0u) << cam1;
  EXPECT_NE(cam1.find(" 200 "), std::string::npos) << cam1;
  EXPECT_NE(cam1.find("STALE"), std::string::npos) << cam1;

  EXPECT_EQ(result.output.find("elsewhere"), std::string::npos) << result.output;
  EXPECT_EQ(result.output.find("NOT_REALLY"), std::string::npos) << result.output;
}

TEST(StatusTool, OnceWithoutAnyStatusSaysSoAndFails) {
  ASSERT_TRUE(std::filesystem::exists(kStatusBinary)) << kStatusBinary;
  const test::CommandResult result = test::RunCommand(
      kStatusBinary + " --lcm-url '" + BusUrl() + "' --channel 'NOBODY_STATUS' --once --wait-s 0.3 2>&1");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("no g6d_service_status_t yet"), std::string::npos) << result.output;
}

TEST(StatusTool, RefusesBadOptions) {
  ASSERT_TRUE(std::filesystem::exists(kStatusBinary)) << kStatusBinary;
  const test::CommandResult result = test::RunCommand(kStatusBinary + " --once --wait-s -1 2>&1");
  EXPECT_NE(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("--wait-s"), std::string::npos) << result.output;
}

}  // namespace
}  // namespace g6d
