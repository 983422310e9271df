// g6d::Service in-process over a real LCM bus (memq): poses end to end, every kind of bad
// input interleaved with good frames, mailbox drops, stale frames, shutdown.
#include "service/service.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "eval/metrics.h"
#include "service_test_util.h"

namespace g6d {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

constexpr int kNumViews = 4;

class ServiceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new test::ServiceScene(test::MakeServiceScene(kNumViews, 11));
  }
  static void TearDownTestSuite() { delete scene_; }

  static TemplateStore Store() {
    TemplateStore store;
    store.banks[test::kBoxId] = std::make_shared<TemplateBank>(scene_->bank);
    store.loaded.push_back({"memory", test::kBoxId, static_cast<int>(scene_->bank.templates.size()),
                            scene_->bank.diameter_m});
    return store;
  }

  static ServiceOptions Options(const std::string& suffix) {
    ServiceOptions options;
    options.templates_dir = "unused-in-process";
    options.input_channel = "G6D_RGBD_" + suffix;
    options.output_channel = "G6D_POSES_" + suffix;
    options.status_channel = "G6D_STATUS_" + suffix;
    options.workers = 2;
    options.solver = test::QuickSolverOptions();
    return options;
  }

  void StartService(const ServiceOptions& options) {
    options_ = options;
    listener_ = std::make_unique<test::ServiceListener>(&lcm_, options.output_channel,
                                                        options.status_channel);
    service_ = std::make_unique<Service>(options, Store(), &lcm_);
    service_->Start();
  }

  void Publish(const rgbd_frame_t& frame) {
    ASSERT_EQ(lcm_.publish(options_.input_channel, &frame), 0);
  }

  /// The next answer, failing the test when none arrives within a generous bound.
  pose_array_t NextAnswer() {
    std::optional<pose_array_t> answer = listener_->answers.Pop(seconds(60));
    if (!answer) ADD_FAILURE() << "no answer within 60 s";
    return answer.value_or(pose_array_t{});
  }

  void TearDown() override {
    if (service_) service_->Stop();
    service_.reset();
    listener_.reset();
  }

  static test::ServiceScene* scene_;
  lcm::LCM lcm_{"memq://"};
  ServiceOptions options_;
  std::unique_ptr<test::ServiceListener> listener_;
  std::unique_ptr<Service> service_;
};
test::ServiceScene* ServiceTest::scene_ = nullptr;

TEST_F(ServiceTest, AnswersWithPosesWithinAddTenthDiameter) {
  ASSERT_TRUE(lcm_.good());
  StartService(Options("e2e"));
  const double diameter = scene_->bank.diameter_m;
  const int8_t compressions[] = {image_t::COMPRESSION_NONE, image_t::COMPRESSION_ZSTD,
                                 image_t::COMPRESSION_PNG, image_t::COMPRESSION_JPEG};
  for (int i = 0; i < kNumViews; ++i) {
    const test::SyntheticView& view = scene_->views[i];
    Publish(test::MakeRgbdFrame(view, 100 + i, test::kBoxId, "cam0", compressions[i % 4]));
    const pose_array_t answer = NextAnswer();
    EXPECT_EQ(answer.seq, 100 + i);
    EXPECT_EQ(answer.camera_id, "cam0");
    EXPECT_EQ(answer.source, "service_test");
    EXPECT_EQ(answer.image_id, 100 + i);
    ASSERT_EQ(answer.status, +pose_array_t::STATUS_OK) << answer.message;
    ASSERT_EQ(answer.num_estimates, 1);
    const pose_estimate_t& estimate = answer.estimates[0];
    ASSERT_EQ(estimate.status, +pose_estimate_t::STATUS_OK) << estimate.message;
    EXPECT_EQ(estimate.object_id, test::kBoxId);
    EXPECT_EQ(estimate.label, 1);
    const double add =
        ComputeAdd(test::PoseOf(estimate), view.cam_from_object, scene_->mesh.vertices);
    EXPECT_LT(add, 0.1 * diameter)
        << "view " << i << " (" << CompressionName(compressions[i % 4]) << ")";
    const double norm = std::sqrt(estimate.orientation[0] * estimate.orientation[0] +
                                  estimate.orientation[1] * estimate.orientation[1] +
                                  estimate.orientation[2] * estimate.orientation[2] +
                                  estimate.orientation[3] * estimate.orientation[3]);
    EXPECT_NEAR(norm, 1.0, 1e-9);
    EXPECT_GE(estimate.score, 0.0);
    EXPECT_GT(estimate.confidence, 0.0);
    EXPECT_GT(estimate.iou, 0.5);
    EXPECT_GE(estimate.hypotheses, 1);
    EXPECT_LE(estimate.hypotheses, 2);
    EXPECT_GT(estimate.solve_time_s, 0.0);
    // Every named timing is there, and end to end covers decode + solve.
    ASSERT_EQ(answer.timing_names.size(), answer.timing_s.size());
    for (const char* name : {"queue_wait", "decode", "features", "match", "pnp", "observable",
                             "icp", "mhpo", "solve", "publish"}) {
      EXPECT_NE(std::find(answer.timing_names.begin(), answer.timing_names.end(), name),
                answer.timing_names.end())
          << name;
    }
    double decode_s = 0.0, solve_s = 0.0;
    for (size_t t = 0; t < answer.timing_names.size(); ++t) {
      EXPECT_GE(answer.timing_s[t], 0.0) << answer.timing_names[t];
      if (answer.timing_names[t] == "decode") decode_s = answer.timing_s[t];
      if (answer.timing_names[t] == "solve") solve_s = answer.timing_s[t];
    }
    EXPECT_GE(answer.total_s, decode_s + solve_s);
  }
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.frames_received, kNumViews);
  EXPECT_EQ(counters.frames_processed, kNumViews);
  EXPECT_EQ(counters.frames_rejected, 0);
  EXPECT_GT(counters.latency_p50_s, 0.0);
}

// ---- Bad input ------------------------------------------------------------------------

/// One kind of bad message and what its answer must say.
struct BadCase {
  std::string name;
  int8_t frame_status;         ///< expected pose_array_t status
  int8_t estimate_status;      ///< expected status of the single estimate (frame OK only)
  std::string words;           ///< must appear in the frame or estimate message
  bool seq_known;              ///< false: the answer carries seq -1
  std::vector<uint8_t> bytes;  ///< the LCM message as published
};

std::vector<uint8_t> Encode(const rgbd_frame_t& frame) {
  std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
  frame.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

/// Every kind of bad input of the issue, built from a good frame with sequence number `seq`.
std::vector<BadCase> MakeBadCases(const test::SyntheticView& view, int64_t seq) {
  const int8_t kOk = pose_array_t::STATUS_OK, kBad = pose_array_t::STATUS_BAD_FRAME;
  const rgbd_frame_t good = test::MakeRgbdFrame(view, seq, test::kBoxId);
  std::vector<BadCase> cases;
  auto add = [&](const std::string& name, const rgbd_frame_t& frame, const std::string& words,
                 int8_t frame_status = pose_array_t::STATUS_BAD_FRAME, int8_t estimate_status = 0) {
    cases.push_back({name, frame_status, estimate_status, words, true, Encode(frame)});
  };
  rgbd_frame_t f = good;
  f.color.data.resize(f.color.data.size() - 7);
  f.color.size = static_cast<int32_t>(f.color.data.size());
  add("payload size mismatch", f, "color: payload");
  f = good;
  f.color.pixel_format = 42;
  add("unknown pixel format", f, "color: pixel format unknown(42)");
  f = good;
  f.depth.compression = 9;
  add("unknown compression", f, "depth: unknown compression 9");
  f = good;
  for (size_t i = f.depth.data.size() / 3; i < f.depth.data.size(); i += 11)
    f.depth.data[i] ^= 0xA5;
  add("corrupted zstd", f, "depth: corrupted zstd");
  f = good;
  f.color = EncodeImage(view.rgb, image_t::FORMAT_RGB8, image_t::COMPRESSION_PNG);
  for (size_t i = f.color.data.size() / 2; i < f.color.data.size(); i += 97)
    f.color.data[i] ^= 0x3C;
  add("corrupted PNG", f, "color: corrupted PNG");
  f = good;
  f.color = EncodeImage(view.rgb, image_t::FORMAT_RGB8, image_t::COMPRESSION_JPEG);
  f.color.data.resize(f.color.data.size() / 2);
  f.color.size = static_cast<int32_t>(f.color.data.size());
  add("corrupted JPEG", f, "color: corrupted JPEG");
  f = good;
  {
    cv::Mat small_depth(240, 320, CV_16UC1, cv::Scalar(700));
    f.depth = EncodeImage(small_depth, image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_ZSTD);
  }
  add("depth and colour sizes differ", f, "depth: size 320x240 differs from color 640x480");
  f = good;
  f.fx = 0.0;
  add("zero focal length", f, "intrinsics: fx");
  f = good;
  f.fy = -500.0;
  add("negative focal length", f, "intrinsics: fy");
  f = good;
  f.cx = std::numeric_limits<double>::quiet_NaN();
  add("NaN principal point", f, "intrinsics: cx");
  f = good;
  f.instances[0].label = 2;  // the label image holds label 1 only
  add("label named by no instance", f, "labels: label 1");
  f = good;
  f.instances[0].label = 5;
  f.labels = EncodeImage(cv::Mat::zeros(480, 640, CV_8UC1), image_t::FORMAT_LABEL_U8,
                         image_t::COMPRESSION_ZSTD);
  add("instance label without pixels", f, "label 5 has no pixels", kOk,
      pose_estimate_t::STATUS_BAD_INPUT);
  f = good;
  f.instances[0].object_id = "obj_999999";
  add("unknown object id", f, "no template cache for object id 'obj_999999'", kOk,
      pose_estimate_t::STATUS_UNKNOWN_OBJECT);
  f = good;
  f.color.width = 100000;
  f.color.row_stride = 300000;
  f.depth.width = f.labels.width = 100000;
  add("huge declared image size", f, "too large");
  {
    // A byte array whose declared length exceeds the message (lcm-gen would allocate it).
    std::vector<uint8_t> bytes = Encode(good);
    const size_t color_size_offset =
        8 + 16 + (4 + good.camera_id.size() + 1) + (4 + good.source.size() + 1) + 8 + 40 + 14;
    const uint32_t huge = 0x7FFFFFF0u;
    for (int i = 0; i < 4; ++i)
      bytes[color_size_offset + i] = static_cast<uint8_t>(huge >> (24 - 8 * i));
    cases.push_back({"huge declared payload size", kBad, 0, "color.size declares", true, bytes});
    // A truncated message: fingerprint and seq intact, body cut.
    std::vector<uint8_t> truncated = Encode(good);
    truncated.resize(truncated.size() / 2);
    cases.push_back(
        {"truncated message", kBad, 0, "did not decode as g6d.rgbd_frame_t", true, truncated});
  }
  {
    // Another LCM type on the channel (fingerprint mismatch), and plain garbage.
    pose_array_t other{};
    other.seq = seq;
    std::vector<uint8_t> bytes(static_cast<size_t>(other.getEncodedSize()));
    other.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    cases.push_back(
        {"fingerprint mismatch", kBad, 0, "did not decode as g6d.rgbd_frame_t", false, bytes});
    std::vector<uint8_t> garbage(5000);
    std::mt19937 rng(static_cast<uint32_t>(seq));
    for (uint8_t& b : garbage) b = static_cast<uint8_t>(rng());
    cases.push_back({"garbage", kBad, 0, "did not decode as g6d.rgbd_frame_t", false, garbage});
  }
  return cases;
}

/// Writes `seq` into an encoded rgbd_frame_t (big-endian int64 after fingerprint and utime).
void PatchSeq(std::vector<uint8_t>* bytes, int64_t seq) {
  for (int i = 0; i < 8; ++i)
    (*bytes)[16 + i] = static_cast<uint8_t>(static_cast<uint64_t>(seq) >> (56 - 8 * i));
}

TEST_F(ServiceTest, HundredGoodAndHundredBadFramesInterleaved) {
  StartService(Options("mixed"));
  // The bad messages of every view, built once; each send patches its sequence number in.
  std::vector<std::vector<BadCase>> bad_cases;
  for (int v = 0; v < kNumViews; ++v) bad_cases.push_back(MakeBadCases(scene_->views[v], 0));
  const size_t num_cases = bad_cases[0].size();
  int good_results = 0, error_results = 0, frame_rejects = 0;
  std::vector<int> seen_cases(num_cases, 0);
  for (int i = 0; i < 200; ++i) {
    const int64_t seq = 1000 + i;
    if (i % 2 == 0) {
      const test::SyntheticView& view = scene_->views[(i / 2) % kNumViews];
      Publish(test::MakeRgbdFrame(view, seq, test::kBoxId));
      const pose_array_t answer = NextAnswer();
      EXPECT_EQ(answer.seq, seq);
      if (answer.status == pose_array_t::STATUS_OK && answer.num_estimates == 1 &&
          answer.estimates[0].status == pose_estimate_t::STATUS_OK) {
        ++good_results;
      } else {
        ADD_FAILURE() << "good frame " << seq << ": " << answer.message
                      << (answer.num_estimates > 0 ? " / " + answer.estimates[0].message : "");
      }
      continue;
    }
    const size_t which = static_cast<size_t>(i / 2) % num_cases;
    BadCase bad = bad_cases[which % kNumViews][which];
    if (bad.seq_known) PatchSeq(&bad.bytes, seq);
    SCOPED_TRACE(bad.name);
    ++seen_cases[which];
    ASSERT_EQ(lcm_.publish(options_.input_channel, bad.bytes.data(),
                           static_cast<unsigned>(bad.bytes.size())),
              0);
    const pose_array_t answer = NextAnswer();
    EXPECT_EQ(answer.seq, bad.seq_known ? seq : -1);
    EXPECT_EQ(answer.status, bad.frame_status) << answer.message;
    std::string message = answer.message;
    if (answer.status == pose_array_t::STATUS_OK) {
      ASSERT_EQ(answer.num_estimates, 1);
      EXPECT_EQ(answer.estimates[0].status, bad.estimate_status);
      message = answer.estimates[0].message;
    } else {
      EXPECT_EQ(answer.num_estimates, 0);
      ++frame_rejects;
    }
    EXPECT_NE(message.find(bad.words), std::string::npos)
        << "'" << bad.words << "' not in: " << message;
    const bool is_error =
        answer.status != pose_array_t::STATUS_OK ||
        (answer.num_estimates == 1 && answer.estimates[0].status != pose_estimate_t::STATUS_OK);
    error_results += is_error ? 1 : 0;
  }
  EXPECT_EQ(good_results, 100);
  EXPECT_EQ(error_results, 100);
  for (size_t c = 0; c < num_cases; ++c)
    EXPECT_GT(seen_cases[c], 0) << "case " << c << " never sent";

  // Still alive and answering: one more good frame, and the counters add up.
  Publish(test::MakeRgbdFrame(scene_->views[0], 5000, test::kBoxId));
  const pose_array_t last = NextAnswer();
  EXPECT_EQ(last.seq, 5000);
  ASSERT_EQ(last.num_estimates, 1);
  EXPECT_EQ(last.estimates[0].status, +pose_estimate_t::STATUS_OK);
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.frames_received, 201);
  EXPECT_EQ(counters.frames_rejected, frame_rejects);
  EXPECT_EQ(counters.frames_processed, 201 - frame_rejects);
  EXPECT_EQ(counters.frames_dropped, 0);
  // The status channel reports the same.
  const auto status = listener_->statuses.PopUntil(
      seconds(10), [](const service_status_t& s) { return s.frames_received == 201; });
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->frames_rejected, frame_rejects);
  EXPECT_EQ(status->num_objects, 1);
  EXPECT_EQ(status->objects[0], test::kBoxId);
  EXPECT_EQ(status->hypotheses, 2);
  EXPECT_EQ(status->workers, 2);
}

TEST_F(ServiceTest, OneBadInstanceDoesNotSpoilTheOthers) {
  StartService(Options("instances"));
  rgbd_frame_t frame = test::MakeRgbdFrame(scene_->views[1], 7, test::kBoxId);
  instance_t empty = frame.instances[0];
  empty.label = 9;  // no pixels
  instance_t unknown = frame.instances[0];
  unknown.object_id = "obj_000404";  // label 1 again: the same mask, an object without cache
  frame.instances = {frame.instances[0], empty, unknown};
  frame.num_instances = 3;
  Publish(frame);
  const pose_array_t answer = NextAnswer();
  ASSERT_EQ(answer.status, +pose_array_t::STATUS_OK) << answer.message;
  ASSERT_EQ(answer.num_estimates, 3);
  EXPECT_EQ(answer.estimates[0].status, +pose_estimate_t::STATUS_OK) << answer.estimates[0].message;
  EXPECT_EQ(answer.estimates[1].status, +pose_estimate_t::STATUS_BAD_INPUT);
  EXPECT_EQ(answer.estimates[1].label, 9);
  EXPECT_EQ(answer.estimates[2].status, +pose_estimate_t::STATUS_UNKNOWN_OBJECT);
  EXPECT_EQ(answer.estimates[2].object_id, "obj_000404");
}

TEST_F(ServiceTest, NewerFrameReplacesTheWaitingOne) {
  StartService(Options("drops"));
  // Published back to back: while the first is solved, later ones replace each other in
  // the mailbox. Whatever the timing, every frame is either answered or counted as a
  // drop, and the newest frame is always answered.
  const int kFrames = 4;
  for (int i = 0; i < kFrames; ++i)
    Publish(test::MakeRgbdFrame(scene_->views[i % kNumViews], 200 + i, test::kBoxId));
  int answered = 0;
  bool newest_answered = false;
  while (!newest_answered) {
    const std::optional<pose_array_t> answer = listener_->answers.Pop(seconds(60));
    ASSERT_TRUE(answer.has_value()) << "the newest frame was never answered";
    ++answered;
    newest_answered = answer->seq == 200 + kFrames - 1;
  }
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.frames_received, kFrames);
  EXPECT_EQ(answered + counters.frames_dropped, kFrames);
  EXPECT_EQ(counters.frames_processed, answered);
}

TEST_F(ServiceTest, StaleFramesAreDroppedAndCounted) {
  ServiceOptions options = Options("stale");
  options.max_age_ms = 2000;
  StartService(options);
  rgbd_frame_t old_frame = test::MakeRgbdFrame(scene_->views[0], 300, test::kBoxId);
  old_frame.utime -= 60 * 1000000LL;  // a minute old
  Publish(old_frame);
  // A fresh frame with an unknown object (answered without solving) shows the service has
  // handled everything published before it.
  rgbd_frame_t fresh = test::MakeRgbdFrame(scene_->views[0], 301, "obj_000404");
  Publish(fresh);
  const pose_array_t answer = NextAnswer();
  EXPECT_EQ(answer.seq, 301);
  const ServiceCounters counters = service_->Counters();
  EXPECT_EQ(counters.frames_received, 2);
  EXPECT_EQ(counters.frames_stale, 1);
  EXPECT_EQ(listener_->answers.Size(), 0u);
}

TEST_F(ServiceTest, StopWhileSolvingAbandonsOrFinishesAndJoins) {
  ServiceOptions options = Options("stop");
  options.status_period_s = 0.05;
  StartService(options);
  rgbd_frame_t frame = test::MakeRgbdFrame(scene_->views[2], 400, test::kBoxId);
  // Several instances of the same object: the ones not started when Stop() comes are
  // abandoned.
  frame.instances = std::vector<instance_t>(6, frame.instances[0]);
  frame.num_instances = 6;
  Publish(frame);
  // Stop once the service has taken the frame (usually in the middle of solving it).
  const auto taken = listener_->statuses.PopUntil(
      seconds(30), [](const service_status_t& status) { return status.frames_received == 1; });
  ASSERT_TRUE(taken.has_value());
  service_->Stop();
  const ServiceCounters counters = service_->Counters();
  EXPECT_FALSE(counters.busy);
  EXPECT_EQ(counters.frames_received, 1);
  EXPECT_EQ(counters.frames_processed + counters.frames_dropped, 1);
  service_->Stop();  // idempotent
}

TEST(Percentile, NearestRank) {
  EXPECT_EQ(Percentile({}, 0.5), 0.0);
  EXPECT_EQ(Percentile({3.0}, 0.95), 3.0);
  EXPECT_EQ(Percentile({4, 1, 3, 2}, 0.5), 2.0);
  EXPECT_EQ(Percentile({4, 1, 3, 2}, 0.95), 4.0);
  std::vector<double> hundred;
  for (int i = 1; i <= 100; ++i) hundred.push_back(i);
  EXPECT_EQ(Percentile(hundred, 0.95), 95.0);
}

TEST(LcmChannelRegex, EscapesRegexCharacters) {
  EXPECT_EQ(LcmChannelRegex("G6D_RGBD"), "G6D_RGBD");
  EXPECT_EQ(LcmChannelRegex("CAM.1(x)"), "CAM\\.1\\(x\\)");
}

}  // namespace
}  // namespace g6d
