// g6d-replay and replay.h: frames of a log go to a service, answers come back matched by
// source/seq, and become BOP CSV rows and a summary. An in-process fake service on LCM's
// memq provider covers the bookkeeping (timeouts, late and lost answers, modes); the end-to-
// end test runs the real binaries: g6d-bop2lcm -> log -> g6d-replay -> g6d-service.
#include "replay.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "frame_log.h"
#include "g6d/service_status_t.hpp"
#include "process_util.h"
#include "synthetic_bop.h"
#include "test_util.h"
#include "wire/frame_codec.h"
#include "wire/lcm_loop.h"
#include "wire/names.h"

namespace g6d {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

const std::string kBop2Lcm = test::BinaryDir() + "/replay/g6d-bop2lcm";
const std::string kReplay = test::BinaryDir() + "/replay/g6d-replay";
const std::string kService = test::BinaryDir() + "/service/g6d-service";
const std::string kBuildTemplates = test::BinaryDir() + "/tools/g6d-build-templates";

// A small frame with two instances (labels 1 and 2) of two BOP objects.
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
  cv::Mat labels = cv::Mat::zeros(24, 32, CV_8UC1);
  labels(cv::Rect(2, 2, 8, 8)).setTo(1);
  labels(cv::Rect(20, 10, 8, 8)).setTo(2);
  frame.color = EncodeImage(cv::Mat(24, 32, CV_8UC3, cv::Scalar(1, 2, 3)), image_t::FORMAT_RGB8,
                            image_t::COMPRESSION_NONE);
  frame.depth = EncodeImage(cv::Mat(24, 32, CV_16UC1, cv::Scalar(700)), image_t::FORMAT_DEPTH_U16,
                            image_t::COMPRESSION_ZSTD);
  frame.labels = EncodeImage(labels, image_t::FORMAT_LABEL_U8, image_t::COMPRESSION_ZSTD);
  for (int label : {1, 2}) {
    instance_t instance{};  // {}: no box, no candidates (lcm-gen leaves members uninitialized)
    instance.object_id = BopObjectName(4 + label);
    instance.label = label;
    instance.score = 1.0f;
    instance.gt_index = label - 1;
    frame.instances.push_back(instance);
  }
  frame.num_instances = 2;
  return frame;
}

// A log of `count` frames at `period_us`.
std::string WriteFrameLog(const std::string& name, int count, int64_t period_us = 100000) {
  const std::string path = test::TempDir(name) + "/frames.lcmlog";
  lcm::LogFile log(path, "w");
  for (int i = 0; i < count; ++i) {
    const rgbd_frame_t frame = SmallFrame(i);
    std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
    frame.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    lcm::LogEvent event;
    event.timestamp = period_us * i;
    event.channel = "G6D_RGBD";
    event.datalen = static_cast<int32_t>(bytes.size());
    event.data = bytes.data();
    EXPECT_EQ(log.writeEvent(&event), 0);
  }
  return path;
}

// The deterministic answer of the fake service to `frame`: label 1 solved, label 2 not.
pose_array_t FakeAnswer(const rgbd_frame_t& frame) {
  pose_array_t answer{};
  answer.utime = frame.utime + 5;
  answer.source_utime = frame.utime;
  answer.seq = frame.seq;
  answer.camera_id = frame.camera_id;
  answer.source = frame.source;
  answer.scene_id = frame.scene_id;
  answer.image_id = frame.image_id;
  answer.status = pose_array_t::STATUS_OK;
  answer.message = "ok";
  for (const instance_t& instance : frame.instances) {
    pose_estimate_t estimate{};
    estimate.object_id = instance.object_id;
    estimate.label = instance.label;
    estimate.gt_index = instance.gt_index;
    estimate.status =
        instance.label == 1 ? pose_estimate_t::STATUS_OK : pose_estimate_t::STATUS_NO_SOLUTION;
    estimate.message = instance.label == 1 ? "ok" : "no acceptable pose";
    const Eigen::Quaterniond rotation(
        Eigen::AngleAxisd(0.1 + 0.2 * frame.seq, Eigen::Vector3d(1, 2, 3).normalized()));
    estimate.orientation[0] = rotation.w();
    estimate.orientation[1] = rotation.x();
    estimate.orientation[2] = rotation.y();
    estimate.orientation[3] = rotation.z();
    estimate.position[0] = 0.01 * frame.seq;
    estimate.position[1] = -0.02;
    estimate.position[2] = 0.5 + 0.001 * instance.label;
    estimate.score = 0.2;
    estimate.confidence = 0.9 - 0.1 * frame.seq;
    estimate.solve_time_s = 0.01;
    // Frame 0 starts track 3, frame 1 continues it, frame 2 re-detects it.
    estimate.track_id = instance.label == 1 ? 3 : -1;
    if (instance.label == 1 && frame.seq % 3 == 1) {
      estimate.mode = pose_estimate_t::MODE_TRACKED;
      estimate.frames_since_detection = 1;
    } else if (instance.label == 1 && frame.seq % 3 == 2) {
      estimate.mode = pose_estimate_t::MODE_REDETECTED;
    }
    answer.estimates.push_back(estimate);
  }
  answer.num_estimates = static_cast<int32_t>(answer.estimates.size());
  answer.total_s = 0.25 + frame.seq;
  return answer;
}

// Answers frames on the same memq LCM (its handler runs on RunReplay's handle thread).
class FakeService {
 public:
  enum class Behaviour { kAnswer, kSilentOnSeq1, kOneFrameLate };

  FakeService(lcm::LCM* lcm, Behaviour behaviour) : lcm_(lcm), behaviour_(behaviour) {
    subscription_ = lcm_->subscribe("G6D_RGBD", &FakeService::Handle, this);
  }
  ~FakeService() { lcm_->unsubscribe(subscription_); }

  void Handle(const lcm::ReceiveBuffer*, const std::string&, const rgbd_frame_t* frame) {
    ++received_;
    if (frame->seq == 0) {  // an answer for somebody else's frame, once
      pose_array_t other = FakeAnswer(*frame);
      other.source = "another-camera";
      lcm_->publish("G6D_POSES", &other);
    }
    switch (behaviour_) {
      case Behaviour::kAnswer:
        Publish(FakeAnswer(*frame));
        break;
      case Behaviour::kSilentOnSeq1:
        if (frame->seq != 1) Publish(FakeAnswer(*frame));
        break;
      case Behaviour::kOneFrameLate:
        if (has_pending_) Publish(pending_);
        pending_ = FakeAnswer(*frame);
        has_pending_ = true;
        break;
    }
  }

  int received() const { return received_; }
  const std::vector<pose_array_t>& published() const { return published_; }

 private:
  void Publish(const pose_array_t& answer) {
    published_.push_back(answer);
    lcm_->publish("G6D_POSES", &answer);
  }

  lcm::LCM* lcm_;
  const Behaviour behaviour_;
  lcm::Subscription* subscription_ = nullptr;
  int received_ = 0;
  bool has_pending_ = false;
  pose_array_t pending_;
  std::vector<pose_array_t> published_;
};

ReplayReport Replay(const std::string& log_path, FakeService::Behaviour behaviour,
                    const ReplayOptions& options, std::vector<pose_array_t>* published = nullptr,
                    std::vector<ReplayProgress>* progress = nullptr) {
  lcm::LCM lcm("memq://");
  EXPECT_TRUE(lcm.good());
  FakeService service(&lcm, behaviour);
  FrameLogReader reader(log_path, options.channel);
  ReplayReport report = RunReplay(options, &reader, &lcm, 3, [&](const ReplayProgress& update) {
    if (progress != nullptr) progress->push_back(update);
  });
  if (published != nullptr) *published = service.published();
  return report;
}

TEST(RunReplay, WaitModeAnswersEveryFrameInOrder) {
  const std::string log_path = WriteFrameLog("replay_wait", 3);
  ReplayOptions options;
  options.timeout_ms = 5000;
  std::vector<pose_array_t> published;
  std::vector<ReplayProgress> progress;
  const ReplayReport report =
      Replay(log_path, FakeService::Behaviour::kAnswer, options, &published, &progress);
  EXPECT_TRUE(report.success) << report.message;
  EXPECT_EQ(report.sent, 3);
  EXPECT_EQ(report.answered, 3);
  EXPECT_EQ(report.lost, 0);
  EXPECT_EQ(report.timed_out, 0);
  EXPECT_EQ(report.unmatched_answers, 1);  // the other camera's answer
  EXPECT_EQ(report.estimates, 6);
  EXPECT_EQ(report.estimates_by_status.at("ok"), 3);
  EXPECT_EQ(report.estimates_by_status.at("no_solution"), 3);
  // OK estimates only, by mode.
  EXPECT_EQ(report.estimates_by_mode.at("detected"), 1);
  EXPECT_EQ(report.estimates_by_mode.at("tracked"), 1);
  EXPECT_EQ(report.estimates_by_mode.at("redetected"), 1);
  EXPECT_DOUBLE_EQ(report.service_p50_s, 1.25);
  EXPECT_DOUBLE_EQ(report.service_max_s, 2.25);
  EXPECT_LE(report.latency_p50_s, report.latency_max_s);
  ASSERT_EQ(report.frames.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(report.frames[i].seq, i);
    EXPECT_EQ(report.frames[i].image_id, 10 + i);
    EXPECT_TRUE(report.frames[i].answered);
    // utime is re-stamped to the send time, and the answer echoes that stamp.
    EXPECT_GT(report.frames[i].sent_utime, 1000000000000000LL);
    EXPECT_EQ(report.frames[i].answer.source_utime, report.frames[i].sent_utime);
  }
  // One progress update per settled frame, each naming it.
  ASSERT_EQ(progress.size(), 3u);
  EXPECT_EQ(progress[2].sent, 3);
  EXPECT_EQ(progress[2].answered, 3);
  ASSERT_NE(progress[2].last, nullptr);
}

TEST(RunReplay, SilentFrameIsLostAfterTheTimeoutAndTheRestGoesOn) {
  const std::string log_path = WriteFrameLog("replay_silent", 3);
  ReplayOptions options;
  options.timeout_ms = 200;
  const ReplayReport report = Replay(log_path, FakeService::Behaviour::kSilentOnSeq1, options);
  EXPECT_FALSE(report.success);
  EXPECT_THAT(report.message, HasSubstr("1 of 3 frame(s) got no answer on G6D_POSES"));
  EXPECT_EQ(report.sent, 3);
  EXPECT_EQ(report.answered, 2);
  EXPECT_EQ(report.lost, 1);
  EXPECT_EQ(report.timed_out, 1);
  EXPECT_EQ(report.late, 0);
  EXPECT_FALSE(report.frames[1].answered);
  EXPECT_TRUE(report.frames[1].timed_out);
  EXPECT_TRUE(report.frames[2].answered);
}

TEST(RunReplay, LateAnswersCountAsAnsweredAndTimedOut) {
  // The fake answers each frame only when the next one arrives, i.e. after the timeout.
  const std::string log_path = WriteFrameLog("replay_late", 3);
  ReplayOptions options;
  options.timeout_ms = 150;
  const ReplayReport report = Replay(log_path, FakeService::Behaviour::kOneFrameLate, options);
  EXPECT_EQ(report.sent, 3);
  EXPECT_EQ(report.answered, 2);
  EXPECT_EQ(report.late, 2);
  EXPECT_EQ(report.lost, 1);
  EXPECT_EQ(report.timed_out, 3);
  EXPECT_TRUE(report.frames[0].answered);
  EXPECT_GE(report.frames[0].latency_s, 0.15);
  EXPECT_FALSE(report.frames[2].answered);
}

TEST(RunReplay, RateAndRealtimeModesSendEverything) {
  const std::string log_path = WriteFrameLog("replay_rate", 3, 50000);
  ReplayOptions options;
  ParseReplayMode("rate:200", &options);
  const ReplayReport rate = Replay(log_path, FakeService::Behaviour::kAnswer, options);
  EXPECT_TRUE(rate.success) << rate.message;
  EXPECT_EQ(rate.answered, 3);
  EXPECT_GE(rate.wall_s, 2 / 200.0);  // frames at 0, 5 and 10 ms

  ParseReplayMode("realtime", &options);
  const ReplayReport realtime = Replay(log_path, FakeService::Behaviour::kAnswer, options);
  EXPECT_TRUE(realtime.success) << realtime.message;
  EXPECT_EQ(realtime.answered, 3);
  EXPECT_GE(realtime.wall_s, 0.1);  // the log spans 100 ms
}

TEST(RunReplay, RefusesBadOptions) {
  const std::string log_path = WriteFrameLog("replay_bad_options", 1);
  lcm::LCM lcm("memq://");
  FrameLogReader reader(log_path, "G6D_RGBD");
  ReplayOptions options;
  options.results_channel = "G6D_RGBD";
  EXPECT_THROW(RunReplay(options, &reader, &lcm), Error);
  options = ReplayOptions();
  options.timeout_ms = 0;
  EXPECT_THROW(RunReplay(options, &reader, &lcm), Error);
}

TEST(ParseReplayMode, NamesAndErrors) {
  ReplayOptions options;
  ParseReplayMode("rate:12.5", &options);
  EXPECT_EQ(options.mode, ReplayMode::kRate);
  EXPECT_EQ(options.rate_hz, 12.5);
  EXPECT_EQ(ReplayModeName(options), "rate:12.5");
  ParseReplayMode("wait", &options);
  EXPECT_EQ(options.mode, ReplayMode::kWait);
  ParseReplayMode("realtime", &options);
  EXPECT_EQ(options.mode, ReplayMode::kRealtime);
  EXPECT_THROW(ParseReplayMode("rate:", &options), Error);
  EXPECT_THROW(ParseReplayMode("rate:-3", &options), Error);
  EXPECT_THROW(ParseReplayMode("rate:5hz", &options), Error);
  EXPECT_THROW(ParseReplayMode("fast", &options), Error);
}

TEST(Percentile, NearestRank) {
  EXPECT_EQ(Percentile({}, 0.5), 0.0);
  EXPECT_EQ(Percentile({3.0, 1.0, 2.0}, 0.5), 2.0);
  EXPECT_EQ(Percentile({3.0, 1.0, 2.0}, 1.0), 3.0);
  EXPECT_EQ(Percentile({4.0, 1.0, 2.0, 3.0}, 0.0), 1.0);
}

TEST(AnswersToBopEstimates, OkEstimatesWithBopIdsBecomeRows) {
  ReplayedFrame frame;
  frame.answered = true;
  frame.answer = FakeAnswer(SmallFrame(2));
  frame.answer.estimates.push_back(frame.answer.estimates[0]);
  frame.answer.estimates.back().object_id = "box";  // not a BOP stem
  frame.answer.num_estimates = 3;
  ReplayedFrame lost;
  lost.answer = FakeAnswer(SmallFrame(1));  // not answered: ignored
  int64_t skipped = 0;
  const std::vector<BopEstimate> rows = AnswersToBopEstimates({frame, lost}, &skipped);
  EXPECT_EQ(skipped, 1);
  ASSERT_EQ(rows.size(), 1u);
  const pose_estimate_t& estimate = frame.answer.estimates[0];
  EXPECT_EQ(rows[0].scene_id, 3);
  EXPECT_EQ(rows[0].im_id, 12);
  EXPECT_EQ(rows[0].obj_id, 5);
  EXPECT_EQ(rows[0].score, estimate.confidence);
  EXPECT_EQ(rows[0].time_s, frame.answer.total_s);
  const Eigen::Matrix3d rotation =
      Eigen::Quaterniond(estimate.orientation[0], estimate.orientation[1], estimate.orientation[2],
                         estimate.orientation[3])
          .toRotationMatrix();
  EXPECT_LT((rows[0].cam_from_object.linear() - rotation).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(rows[0].cam_from_object.translation(), Eigen::Vector3d(0.02, -0.02, 0.501));
}

TEST(ReplaySummaryJson, HoldsTheCounts) {
  const std::string log_path = WriteFrameLog("replay_summary", 3);
  ReplayOptions options;
  options.timeout_ms = 200;
  const ReplayReport report = Replay(log_path, FakeService::Behaviour::kSilentOnSeq1, options);
  const FrameLogStats stats = ScanFrameLog(log_path, "G6D_RGBD");
  const nlohmann::json summary = nlohmann::json::parse(ReplaySummaryJson(options, stats, report));
  EXPECT_EQ(summary["sent"], 3);
  EXPECT_EQ(summary["answered"], 2);
  EXPECT_EQ(summary["lost"], 1);
  EXPECT_EQ(summary["timed_out"], 1);
  EXPECT_EQ(summary["mode"], "wait");
  EXPECT_EQ(summary["estimates"]["ok"], 2);
  EXPECT_EQ(summary["estimates"]["failed"], 2);
  EXPECT_EQ(summary["estimates"]["by_status"]["no_solution"], 2);
  // Frames 0 and 2 were answered: a detection and a re-detection; every mode is named.
  EXPECT_EQ(summary["estimates"]["by_mode"]["detected"], 1);
  EXPECT_EQ(summary["estimates"]["by_mode"]["tracked"], 0);
  EXPECT_EQ(summary["estimates"]["by_mode"]["redetected"], 1);
  EXPECT_EQ(summary["frames"][2]["estimates"][0]["mode"], "redetected");
  EXPECT_EQ(summary["frames"][2]["estimates"][0]["track_id"], 3);
  EXPECT_EQ(summary["log"]["frames"], 3);
  EXPECT_EQ(summary["log"]["truncated"], false);
  EXPECT_TRUE(summary["latency_s"].contains("p95"));
  EXPECT_EQ(summary["success"], false);
}

// The tool's words for a broken log, with no service anywhere (memq: nobody answers).
TEST(ReplayTool, TruncatedForeignAndMissingLogs) {
  ASSERT_TRUE(std::filesystem::exists(kReplay)) << kReplay;
  const std::string dir = test::TempDir("replay_tool_logs");
  const std::string log_path = WriteFrameLog("replay_tool_truncated", 2);
  std::filesystem::resize_file(log_path, std::filesystem::file_size(log_path) - 50);
  const test::CommandResult truncated =
      test::RunCommand(kReplay + " --log " + log_path +
                       " --lcm-url memq:// --timeout-ms 100 --summary-json " + dir + "/s.json");
  EXPECT_EQ(truncated.exit_code, 1) << truncated.output;  // the one complete frame is lost
  EXPECT_THAT(truncated.output,
              AllOf(HasSubstr("truncated"), HasSubstr("after 1 complete event(s)"),
                    HasSubstr("[1/1] unit scene 3 image 10 seq 0: no answer (timed out)"),
                    HasSubstr("sent 1, answered 0, lost 1")));
  const nlohmann::json summary = nlohmann::json::parse(std::ifstream(dir + "/s.json"));
  EXPECT_EQ(summary["log"]["truncated"], true);

  const std::string mixed = dir + "/mixed.lcmlog";
  {
    lcm::LogFile log(mixed, "w");
    const rgbd_frame_t frame = SmallFrame(0);
    std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
    frame.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    for (const char* channel : {"OTHER", "G6D_RGBD", "OTHER"}) {
      lcm::LogEvent event;
      event.timestamp = 0;
      event.channel = channel;
      event.datalen = static_cast<int32_t>(bytes.size());
      event.data = bytes.data();
      log.writeEvent(&event);
    }
  }
  const test::CommandResult foreign =
      test::RunCommand(kReplay + " --log " + mixed + " --lcm-url memq:// --timeout-ms 100");
  EXPECT_THAT(foreign.output, HasSubstr("skipped 2 event(s) of other channels (OTHER: 2)"));
  const test::CommandResult wrong_channel = test::RunCommand(
      kReplay + " --log " + mixed + " --channel CAMERA --lcm-url memq:// --timeout-ms 100");
  EXPECT_EQ(wrong_channel.exit_code, 2);
  EXPECT_THAT(wrong_channel.output, HasSubstr("holds no frame on channel CAMERA"));

  const test::CommandResult missing =
      test::RunCommand(kReplay + " --log " + dir + "/absent.lcmlog");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_THAT(missing.output, HasSubstr("absent.lcmlog' does not exist"));
  const test::CommandResult bad_mode =
      test::RunCommand(kReplay + " --log " + mixed + " --mode fast");
  EXPECT_EQ(bad_mode.exit_code, 2);
  EXPECT_THAT(bad_mode.output, HasSubstr("'fast' is not one of wait, realtime, rate:HZ"));
}

// Collects every pose array published on a channel of a udpm URL, on its own thread.
class AnswerListener {
 public:
  AnswerListener(const std::string& url, const std::string& results_channel,
                 const std::string& status_channel)
      : lcm_(url) {
    lcm_.subscribe(results_channel, &AnswerListener::HandleAnswer, this);
    lcm_.subscribe(status_channel, &AnswerListener::HandleStatus, this);
    if (lcm_.good()) handle_thread_ = std::make_unique<LcmHandleThread>(&lcm_);
  }

  bool good() { return lcm_.good(); }

  void HandleAnswer(const lcm::ReceiveBuffer*, const std::string&, const pose_array_t* answer) {
    std::lock_guard<std::mutex> lock(mutex_);
    answers_.push_back(*answer);
  }
  void HandleStatus(const lcm::ReceiveBuffer*, const std::string&, const service_status_t* status) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      loaded_objects_ = std::max(loaded_objects_, status->num_objects);
    }
    changed_.notify_all();
  }

  /// Waits for a status naming at least `objects` loaded objects; false on timeout.
  bool WaitForService(int objects, std::chrono::seconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return loaded_objects_ >= objects; });
  }

  std::vector<pose_array_t> answers() {
    std::lock_guard<std::mutex> lock(mutex_);
    return answers_;
  }

 private:
  lcm::LCM lcm_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<pose_array_t> answers_;
  int loaded_objects_ = 0;
  std::unique_ptr<LcmHandleThread> handle_thread_;  ///< last: stops first
};

// bop2lcm -> log -> g6d-replay (wait) -> the real g6d-service -> CSV: ids preserved exactly,
// CSV poses equal the poses the service published, and so do the per-estimate JSON lines'
// flags, runner-up S and appearance agreement.
TEST(ReplayEndToEnd, SyntheticBopThroughTheRealService) {
  if (!std::filesystem::exists(kService)) {
    GTEST_SKIP() << kService << " is not built (the service target does not exist yet); skipping";
  }
  ASSERT_TRUE(std::filesystem::exists(kBuildTemplates)) << kBuildTemplates;
  const std::string dir = test::TempDir("replay_end_to_end");
  const test::SyntheticBop dataset = test::WriteSyntheticBopDataset(dir + "/tiny", {});
  std::filesystem::create_directories(dir + "/caches");
  for (int obj_id : dataset.obj_ids) {
    const std::string name = BopObjectName(obj_id);
    // 72 templates keep the test fast; accuracy is not what this test is about.
    const test::CommandResult build =
        test::RunCommand(kBuildTemplates + " --mesh " + dir + "/tiny/models/" + name +
                         ".ply --units mm --object-id " + name + " --out " + dir + "/caches/" +
                         name + ".g6dcache --views 72 --threads 2");
    ASSERT_EQ(build.exit_code, 0) << build.output;
  }
  const std::string log_path = dir + "/tiny.lcmlog";
  const test::CommandResult convert = test::RunCommand(
      kBop2Lcm + " --dataset " + dir + "/tiny --scene 1 --channel E2E_RGBD --out " + log_path);
  ASSERT_EQ(convert.exit_code, 0) << convert.output;

  // A port of this test run only: nothing else on the machine hears it or talks to it.
  const int port = 20000 + static_cast<int>(::getpid() % 20000);
  const std::string url =
      "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0&recv_buf_size=4194304";
  AnswerListener listener(url, "E2E_POSES", "E2E_STATUS");
  ASSERT_TRUE(listener.good()) << url;
  test::ChildProcess service(
      {kService, "--templates", dir + "/caches", "--input", "E2E_RGBD", "--output", "E2E_POSES",
       "--status", "E2E_STATUS", "--lcm-url", url, "--workers", "2"},
      dir + "/service.log");
  ASSERT_TRUE(service.started());
  auto service_log = [&] {
    std::ifstream in(dir + "/service.log");
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  ASSERT_TRUE(listener.WaitForService(2, std::chrono::seconds(60)))
      << "g6d-service did not report 2 loaded objects within 60 s; its log:\n"
      << service_log();

  const std::string csv = dir + "/results.csv", summary_path = dir + "/summary.json",
                    jsonl = dir + "/estimates.jsonl", answers_log = dir + "/answers.lcmlog";
  const test::CommandResult replay =
      test::RunCommand(kReplay + " --log " + log_path +
                       " --channel E2E_RGBD --results-channel E2E_POSES --lcm-url '" + url +
                       "' --mode wait --timeout-ms 60000 --results-csv " + csv +
                       " --summary-json " + summary_path + " --estimates-jsonl " + jsonl +
                       " --answers-log " + answers_log);
  ASSERT_EQ(replay.exit_code, 0) << replay.output << "\nservice log:\n" << service_log();
  EXPECT_EQ(service.Stop(), 0) << "g6d-service should exit 0 on SIGTERM; its log:\n"
                               << service_log();

  const nlohmann::json summary = nlohmann::json::parse(std::ifstream(summary_path));
  EXPECT_EQ(summary["sent"], 2);
  EXPECT_EQ(summary["answered"], 2);
  EXPECT_EQ(summary["lost"], 0);
  EXPECT_EQ(summary["estimates"]["total"], 3);

  // The answers the service published, as heard by this test.
  std::vector<pose_array_t> answers;
  for (const pose_array_t& answer : listener.answers()) {
    if (answer.source == "tiny") answers.push_back(answer);
  }
  ASSERT_EQ(answers.size(), 2u);
  std::sort(answers.begin(), answers.end(),
            [](const pose_array_t& a, const pose_array_t& b) { return a.seq < b.seq; });
  const BopScene scene = LoadBopScene(dir + "/tiny", 1);
  std::vector<BopEstimate> expected;
  const int expected_images[2] = {0, 2};
  for (size_t i = 0; i < answers.size(); ++i) {
    const pose_array_t& answer = answers[i];
    EXPECT_EQ(answer.seq, static_cast<int64_t>(i));
    EXPECT_EQ(answer.scene_id, 1);
    EXPECT_EQ(answer.image_id, expected_images[i]);
    EXPECT_EQ(answer.status, int{pose_array_t::STATUS_OK}) << answer.message;
    const BopFrame& frame = scene.Frame(answer.image_id);
    for (const pose_estimate_t& estimate : answer.estimates) {
      // Ids echoed exactly as bop2lcm sent them.
      ASSERT_GE(estimate.gt_index, 0);
      ASSERT_LT(estimate.gt_index, static_cast<int>(frame.gt.size()));
      EXPECT_EQ(estimate.label, estimate.gt_index + 1);
      EXPECT_EQ(estimate.object_id, BopObjectName(frame.gt[estimate.gt_index].obj_id));
      if (estimate.status != pose_estimate_t::STATUS_OK) continue;
      BopEstimate row;
      row.scene_id = answer.scene_id;
      row.im_id = answer.image_id;
      row.obj_id = frame.gt[estimate.gt_index].obj_id;
      row.score = estimate.confidence;
      row.cam_from_object.linear() =
          Eigen::Quaterniond(estimate.orientation[0], estimate.orientation[1],
                             estimate.orientation[2], estimate.orientation[3])
              .normalized()
              .toRotationMatrix();
      row.cam_from_object.translation() =
          Eigen::Vector3d(estimate.position[0], estimate.position[1], estimate.position[2]);
      row.time_s = answer.total_s;
      expected.push_back(row);
    }
  }
  EXPECT_GE(expected.size(), 1u) << "the service solved nothing; its log:\n" << service_log();

  // The per-estimate lines carry the flags, the runner-up's S and the appearance agreement
  // exactly as the service published them (null where it says there is none).
  std::map<std::pair<int, int>, nlohmann::json> lines;  // (image_id, gt_index) -> line
  {
    std::ifstream in(jsonl);
    std::string line;
    while (std::getline(in, line)) {
      const nlohmann::json j = nlohmann::json::parse(line);
      lines[{j["image_id"].get<int>(), j["gt_index"].get<int>()}] = j;
    }
  }
  size_t published = 0;
  for (const pose_array_t& answer : answers) {
    for (const pose_estimate_t& estimate : answer.estimates) {
      ++published;
      SCOPED_TRACE("image " + std::to_string(answer.image_id) + " gt " +
                   std::to_string(estimate.gt_index));
      const auto found = lines.find({answer.image_id, estimate.gt_index});
      ASSERT_NE(found, lines.end());
      const nlohmann::json& j = found->second;
      EXPECT_EQ(j["truncated"].get<bool>(), estimate.truncated != 0);
      EXPECT_EQ(j["mode"].get<std::string>(), EstimateModeName(estimate.mode));
      EXPECT_EQ(j["track_id"].get<int>(), estimate.track_id);
      EXPECT_EQ(j["frames_since_detection"].get<int>(), estimate.frames_since_detection);
      EXPECT_EQ(j["mask_iou"].get<double>(), estimate.mask_iou);
      EXPECT_EQ(j["identity_searched"].get<bool>(), false);
      EXPECT_EQ(j["candidates_tried"].get<int>(), estimate.candidates_tried);
      EXPECT_EQ(j["request_index"].get<int>(), estimate.request_index);
      EXPECT_EQ(j["found_without_mask"].get<bool>(), false);
      EXPECT_EQ(j["region_box"].size(), 4u);
      EXPECT_EQ(j["region_pixels"].get<int>(), 0);
      if (estimate.status == pose_estimate_t::STATUS_OK) {
        EXPECT_GT(estimate.mask_iou, 0.0);
        EXPECT_EQ(estimate.candidates_tried, 1);
      }
      // The service tracks by default: every solved instance has a track.
      if (estimate.status == pose_estimate_t::STATUS_OK) {
        EXPECT_GT(estimate.track_id, 0);
      }
      EXPECT_EQ(j["ambiguous"].get<bool>(), estimate.ambiguous != 0);
      if (estimate.has_runner_up) {
        EXPECT_EQ(j["runner_up_score"].get<double>(), estimate.runner_up_score);
      } else {
        EXPECT_TRUE(j["runner_up_score"].is_null()) << j.dump();
      }
      if (estimate.appearance_valid) {
        EXPECT_EQ(j["appearance_agreement"].get<double>(), estimate.appearance_agreement);
      } else {
        EXPECT_TRUE(j["appearance_agreement"].is_null()) << j.dump();
      }
    }
  }
  EXPECT_EQ(lines.size(), published);

  const std::vector<BopEstimate> rows = ReadBopCsv(csv);
  ASSERT_EQ(rows.size(), expected.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    SCOPED_TRACE("row " + std::to_string(i));
    EXPECT_EQ(rows[i].scene_id, expected[i].scene_id);
    EXPECT_EQ(rows[i].im_id, expected[i].im_id);
    EXPECT_EQ(rows[i].obj_id, expected[i].obj_id);
    EXPECT_EQ(rows[i].score, expected[i].score);
    EXPECT_EQ(rows[i].time_s, expected[i].time_s);
    EXPECT_EQ(rows[i].cam_from_object.linear(), expected[i].cam_from_object.linear());
    EXPECT_LT(
        (rows[i].cam_from_object.translation() - expected[i].cam_from_object.translation()).norm(),
        1e-12);
  }

  // examples/print_poses.py reads the answers g6d-replay logged (lcm-logger's format) with
  // the generated pure-Python classes and prints each one's object, pose, S_A, confidence.
  const std::string python_types = test::BinaryDir() + "/lcmtypes/python";
  ASSERT_TRUE(std::filesystem::exists(python_types + "/g6d/pose_array_t.py")) << python_types;
  const test::CommandResult printed = test::RunCommand(
      "python3 " + test::SourceDir() + "/examples/print_poses.py --log " + answers_log +
      " --channel E2E_POSES --types " + python_types);
  ASSERT_EQ(printed.exit_code, 0) << printed.output;
  EXPECT_THAT(printed.output, HasSubstr("2 answers on E2E_POSES"));
  int printed_ok = 0;
  for (const pose_array_t& answer : answers) {
    for (const pose_estimate_t& estimate : answer.estimates) {
      if (estimate.status != pose_estimate_t::STATUS_OK) {
        EXPECT_THAT(printed.output, HasSubstr(estimate.object_id + " label " +
                                              std::to_string(estimate.label) + ": "));
        continue;
      }
      char line[512];
      std::snprintf(line, sizeof(line),
                    "%s label %d: ok t = [%.4f %.4f %.4f] m  q = [%.5f %.5f %.5f %.5f]  "
                    "S_A = %.4f  confidence = %.3f",
                    estimate.object_id.c_str(), estimate.label, estimate.position[0],
                    estimate.position[1], estimate.position[2], estimate.orientation[0],
                    estimate.orientation[1], estimate.orientation[2], estimate.orientation[3],
                    estimate.score, estimate.confidence);
      EXPECT_THAT(printed.output, HasSubstr(line));
      // ... and how the answer was made: the service tracks by default.
      EXPECT_THAT(printed.output,
                  HasSubstr(std::string(line) + "  (" + EstimateModeName(estimate.mode) +
                            " track " + std::to_string(estimate.track_id)));
      ++printed_ok;
    }
  }
  EXPECT_EQ(printed_ok, static_cast<int>(expected.size()));
  // Not an LCM log: a clear error, exit status 1.
  const test::CommandResult not_a_log = test::RunCommand(
      "python3 " + test::SourceDir() + "/examples/print_poses.py --log " + csv + " --types " +
      python_types);
  EXPECT_EQ(not_a_log.exit_code, 1);
  EXPECT_THAT(not_a_log.output, HasSubstr("not an LCM log"));
}

// g6d-bop2lcm --as drake / bot_core writes the scene as those stacks' messages plus the
// service options file LOG.yaml; the real g6d-service reads them with nothing but
// --templates and --config LOG.yaml, g6d-replay --input-type matches the answers by utime,
// and the BOP CSV is the native log's, row for row (lossless here: raw colour, and depth in
// whole millimetres so bot_core's DEPTH_MM loses nothing).
TEST(ReplayEndToEnd, DrakeAndBotCoreLogsGiveTheNativePoses) {
  if (!std::filesystem::exists(kService)) GTEST_SKIP() << kService << " is not built";
  const std::string dir = test::TempDir("replay_foreign");
  test::SyntheticBopOptions bop_options;
  bop_options.depth_scale = 1.0;
  const test::SyntheticBop dataset = test::WriteSyntheticBopDataset(dir + "/tiny", bop_options);
  std::filesystem::create_directories(dir + "/caches");
  for (int obj_id : dataset.obj_ids) {
    const std::string name = BopObjectName(obj_id);
    const test::CommandResult build = test::RunCommand(
        kBuildTemplates + " --mesh " + dir + "/tiny/models/" + name + ".ply --units mm --object-id " +
        name + " --out " + dir + "/caches/" + name + ".g6dcache --views 72 --threads 2");
    ASSERT_EQ(build.exit_code, 0) << build.output;
  }
  const int port = 20000 + static_cast<int>((::getpid() + 7) % 20000);
  const std::string url =
      "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0&recv_buf_size=4194304";

  // One log per type, served by a service started from its LOG.yaml, replayed to a CSV.
  auto run = [&](const std::string& as, const std::string& color) -> std::vector<BopEstimate> {
    SCOPED_TRACE("--as " + as + " --color " + color);
    const std::string log = dir + "/" + as + "_" + color + ".lcmlog";
    const test::CommandResult convert =
        test::RunCommand(kBop2Lcm + " --dataset " + dir + "/tiny --scene 1 --channel CAM --as " +
                         as + " --color " + color + " --out " + log);
    EXPECT_EQ(convert.exit_code, 0) << convert.output;
    EXPECT_TRUE(std::filesystem::exists(log + ".yaml"));
    AnswerListener listener(url, "F_POSES", "F_STATUS");
    EXPECT_TRUE(listener.good());
    test::ChildProcess service({kService, "--templates", dir + "/caches", "--config", log + ".yaml",
                                "--output", "F_POSES", "--status", "F_STATUS", "--lcm-url", url},
                               log + ".service.log");
    EXPECT_TRUE(listener.WaitForService(2, std::chrono::seconds(60)));
    const std::string csv = log + ".csv";
    const test::CommandResult replay = test::RunCommand(
        kReplay + " --log " + log + " --channel CAM --input-type " + as +
        " --results-channel F_POSES --lcm-url '" + url + "' --timeout-ms 60000 --results-csv " + csv);
    EXPECT_EQ(replay.exit_code, 0) << replay.output;
    EXPECT_THAT(replay.output, HasSubstr("sent 2, answered 2, lost 0"));
    EXPECT_EQ(service.Stop(), 0);
    return ReadBopCsv(csv);
  };
  const std::vector<BopEstimate> native = run("g6d", "png");
  ASSERT_GE(native.size(), 1u);
  for (const std::string as : {"drake", "bot_core"}) {
    const std::vector<BopEstimate> rows = run(as, "raw");
    ASSERT_EQ(rows.size(), native.size()) << as;
    for (size_t i = 0; i < rows.size(); ++i) {
      SCOPED_TRACE(as + " row " + std::to_string(i));
      EXPECT_EQ(rows[i].scene_id, native[i].scene_id);
      EXPECT_EQ(rows[i].im_id, native[i].im_id);
      EXPECT_EQ(rows[i].obj_id, native[i].obj_id);
      EXPECT_EQ(rows[i].score, native[i].score);
      EXPECT_EQ(rows[i].cam_from_object.linear(), native[i].cam_from_object.linear());
      EXPECT_EQ(rows[i].cam_from_object.translation(), native[i].cam_from_object.translation());
    }
  }
  // bot_core with MJPEG colour: every frame answered; the poses are JPEG's to move.
  EXPECT_EQ(run("bot_core", "jpeg").size(), native.size());
  // The options file of a foreign log says everything the service needs.
  std::ifstream yaml(dir + "/drake_raw.lcmlog.yaml");
  const std::string text((std::istreambuf_iterator<char>(yaml)), std::istreambuf_iterator<char>());
  EXPECT_THAT(text, HasSubstr("input_type: drake"));
  EXPECT_THAT(text, HasSubstr("camera: {fx: 572.39999999999998"));
  EXPECT_THAT(text, HasSubstr("labels:\n  1: obj_000001\n  2: obj_000002\n"));
}

}  // namespace
}  // namespace g6d
