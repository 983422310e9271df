// g6d-bop2lcm and bop_to_lcm.h: a BOP scene becomes an LCM log whose frames decode back to
// exactly the dataset's images, depth, masks and ids.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>
#include <vector>

#include "bop_to_lcm.h"
#include "core/error.h"
#include "eval/bop.h"
#include "eval/mask_degrade.h"
#include "process_util.h"
#include "wire/frame_codec.h"
#include "synthetic_bop.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;

const std::string kBop2Lcm = test::BinaryDir() + "/replay/g6d-bop2lcm";

struct LoggedFrame {
  int64_t timestamp_us = 0;
  std::string channel;
  rgbd_frame_t frame;
};

// Reads every event with lcm::LogFile (the reader lcm-logplayer uses) and decodes it.
std::vector<LoggedFrame> ReadLog(const std::string& path) {
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good()) << path;
  std::vector<LoggedFrame> frames;
  if (!log.good()) return frames;
  while (const lcm::LogEvent* event = log.readNextEvent()) {
    LoggedFrame logged;
    logged.timestamp_us = event->timestamp;
    logged.channel = event->channel;
    EXPECT_EQ(logged.frame.decode(event->data, 0, event->datalen), event->datalen)
        << "event " << event->eventnum << " of " << path << " is not a whole g6d_rgbd_frame_t";
    frames.push_back(std::move(logged));
  }
  return frames;
}

double MaxAbsDifference(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return 1e9;
  return cv::norm(a, b, cv::NORM_INF);
}

// The GT indices a BOP'19 target list asks for in one image (first inst_count of each object).
std::vector<int> TargetInstances(const BopFrame& frame, int scene_id,
                                 const std::vector<BopTarget>& targets) {
  std::set<int> indices;
  for (const BopTarget& target : targets) {
    if (target.scene_id != scene_id || target.im_id != frame.im_id) continue;
    int taken = 0;
    for (size_t i = 0; i < frame.gt.size() && taken < target.inst_count; ++i) {
      if (frame.gt[i].obj_id == target.obj_id) {
        indices.insert(static_cast<int>(i));
        ++taken;
      }
    }
  }
  return {indices.begin(), indices.end()};
}

// Everything a frame carries must be the dataset's, bit for bit (lossless colour).
void ExpectFrameIsDatasetImage(const rgbd_frame_t& message, const BopScene& scene,
                               const std::vector<int>& expected_gt_indices,
                               const std::string& source) {
  SCOPED_TRACE("scene " + std::to_string(message.scene_id) + " image " +
               std::to_string(message.image_id));
  ASSERT_EQ(message.scene_id, scene.scene_id);
  const BopFrame& frame = scene.Frame(message.image_id);
  EXPECT_EQ(message.source, source);
  EXPECT_EQ(message.fx, frame.camera.fx);
  EXPECT_EQ(message.fy, frame.camera.fy);
  EXPECT_EQ(message.cx, frame.camera.cx);
  EXPECT_EQ(message.cy, frame.camera.cy);
  EXPECT_DOUBLE_EQ(message.depth_scale_m, frame.depth_scale / 1000.0);

  const cv::Mat rgb = DecodeImage(message.color, "color");
  EXPECT_EQ(message.color.pixel_format, int{image_t::FORMAT_RGB8});
  EXPECT_EQ(MaxAbsDifference(rgb, LoadBopRgb(scene, frame.im_id)), 0.0) << "colour differs";

  char name[32];
  std::snprintf(name, sizeof(name), "/depth/%06d.png", frame.im_id);
  const cv::Mat depth_png = cv::imread(scene.directory + name, cv::IMREAD_UNCHANGED);
  EXPECT_EQ(message.depth.pixel_format, int{image_t::FORMAT_DEPTH_U16});
  EXPECT_EQ(message.depth.compression, int{image_t::COMPRESSION_ZSTD});
  EXPECT_EQ(MaxAbsDifference(DecodeImage(message.depth, "depth"), depth_png), 0.0)
      << "depth differs";

  ASSERT_EQ(message.num_instances, static_cast<int>(expected_gt_indices.size()));
  ASSERT_EQ(message.instances.size(), expected_gt_indices.size());
  EXPECT_EQ(message.labels.compression, int{image_t::COMPRESSION_ZSTD});
  const cv::Mat labels = DecodeImage(message.labels, "labels");
  cv::Mat expected_labels = cv::Mat::zeros(labels.size(), labels.type());
  for (size_t i = 0; i < expected_gt_indices.size(); ++i) {
    const instance_t& instance = message.instances[i];
    const int gt_idx = expected_gt_indices[i];
    EXPECT_EQ(instance.gt_index, gt_idx);
    EXPECT_EQ(instance.label, gt_idx + 1);
    EXPECT_EQ(instance.object_id, BopObjectName(frame.gt[gt_idx].obj_id));
    EXPECT_EQ(instance.score, 1.0f);
    const cv::Mat mask = LoadBopMaskVisib(scene, frame.im_id, gt_idx);
    expected_labels.setTo(instance.label, mask);
    EXPECT_EQ(cv::countNonZero(labels == instance.label), cv::countNonZero(mask))
        << "gt_idx " << gt_idx;
  }
  EXPECT_EQ(MaxAbsDifference(labels, expected_labels), 0.0)
      << "labels differ from the mask_visib images";
  // And the service's own validation accepts it.
  EXPECT_NO_THROW(DecodeFrame(message));
}

class Bop2LcmSynthetic : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // One folder per process: ctest runs the cases of this suite as parallel processes.
    const std::string dir = test::TempDir("bop2lcm_synthetic_" + std::to_string(::getpid()));
    dataset_ = new test::SyntheticBop(test::WriteSyntheticBopDataset(dir + "/tiny", {}));
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(std::filesystem::path(dataset_->root).parent_path());
    delete dataset_;
  }
  static test::SyntheticBop* dataset_;
};
test::SyntheticBop* Bop2LcmSynthetic::dataset_ = nullptr;

TEST_F(Bop2LcmSynthetic, TargetFramesDecodeBackExactly) {
  const std::string log_path = test::TempDir("bop2lcm_targets") + "/scene.lcmlog";
  BopToLcmOptions options;
  options.fps = 4.0;
  options.start_utime = 1000;
  const BopToLcmReport report = WriteBopSceneLog(options, dataset_->root, 1, log_path);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_EQ(report.source, "tiny");
  EXPECT_EQ(report.frames_written, 2);  // image 1 has no target
  EXPECT_EQ(report.instances_written, 3);
  EXPECT_EQ(report.overlap_pixels, 0);

  const std::vector<LoggedFrame> frames = ReadLog(log_path);
  ASSERT_EQ(frames.size(), 2u);
  const BopScene scene = LoadBopScene(dataset_->root, 1);
  const std::vector<BopTarget> targets =
      LoadBopTargets(dataset_->root + "/test_targets_bop19.json");
  const int expected_images[2] = {0, 2};
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].channel, "G6D_RGBD");
    EXPECT_EQ(frames[i].timestamp_us, 1000 + static_cast<int64_t>(i) * 250000);  // 4 Hz
    EXPECT_EQ(frames[i].frame.utime, frames[i].timestamp_us);
    EXPECT_EQ(frames[i].frame.seq, static_cast<int64_t>(i));
    EXPECT_EQ(frames[i].frame.image_id, expected_images[i]);
    const BopFrame& frame = scene.Frame(frames[i].frame.image_id);
    ExpectFrameIsDatasetImage(frames[i].frame, scene, TargetInstances(frame, 1, targets), "tiny");
  }
  EXPECT_EQ(frames[0].frame.instances[0].object_id, "obj_000001");
  EXPECT_EQ(frames[1].frame.instances[0].object_id, "obj_000002");
  EXPECT_EQ(frames[0].frame.labels.pixel_format, int{image_t::FORMAT_LABEL_U8});
  EXPECT_DOUBLE_EQ(frames[0].frame.depth_scale_m, 0.0005);
}

TEST_F(Bop2LcmSynthetic, AllInstancesWithoutTargets) {
  const std::string log_path = test::TempDir("bop2lcm_all") + "/scene.lcmlog";
  BopToLcmOptions options;
  options.use_targets = false;
  options.color = ColorEncoding::kZstd;
  const BopToLcmReport report = WriteBopSceneLog(options, dataset_->root, 1, log_path);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_TRUE(report.targets_file.empty());
  const std::vector<LoggedFrame> frames = ReadLog(log_path);
  ASSERT_EQ(frames.size(), 3u);
  const BopScene scene = LoadBopScene(dataset_->root, 1);
  for (const LoggedFrame& logged : frames) {
    EXPECT_EQ(logged.frame.color.compression, int{image_t::COMPRESSION_ZSTD});
    ExpectFrameIsDatasetImage(logged.frame, scene, {0, 1}, "tiny");
  }
}

TEST_F(Bop2LcmSynthetic, FrameListAndOtherTargetsFile) {
  const std::string dir = test::TempDir("bop2lcm_list");
  std::ofstream(dir + "/targets.json")
      << R"([{"scene_id": 1, "im_id": 1, "obj_id": 1, "inst_count": 1},
                                              {"scene_id": 1, "im_id": 2, "obj_id": 1, "inst_count": 1}])";
  BopToLcmOptions options;
  options.targets_file = dir + "/targets.json";
  options.frames = ParseFrameList("0-1");
  const BopToLcmReport report = WriteBopSceneLog(options, dataset_->root, 1, dir + "/scene.lcmlog");
  ASSERT_TRUE(report.success) << report.message;
  const std::vector<LoggedFrame> frames = ReadLog(dir + "/scene.lcmlog");
  ASSERT_EQ(frames.size(), 1u);  // image 0 has no target in this file, image 2 is not listed
  EXPECT_EQ(frames[0].frame.image_id, 1);
  ASSERT_EQ(frames[0].frame.num_instances, 1);
  EXPECT_EQ(frames[0].frame.instances[0].gt_index, 0);

  options.frames = {0};
  const BopToLcmReport none = WriteBopSceneLog(options, dataset_->root, 1, dir + "/none.lcmlog");
  EXPECT_FALSE(none.success);
  EXPECT_THAT(none.message, HasSubstr("no image of scene 1"));

  options.frames = {7};
  EXPECT_THROW(WriteBopSceneLog(options, dataset_->root, 1, dir + "/bad.lcmlog"), Error);
}

TEST_F(Bop2LcmSynthetic, JpegColourIsCloseAndTheRestExact) {
  const std::string log_path = test::TempDir("bop2lcm_jpeg") + "/scene.lcmlog";
  BopToLcmOptions options;
  options.color = ColorEncoding::kJpeg;
  ASSERT_TRUE(WriteBopSceneLog(options, dataset_->root, 1, log_path).success);
  const std::vector<LoggedFrame> frames = ReadLog(log_path);
  ASSERT_EQ(frames.size(), 2u);
  const BopScene scene = LoadBopScene(dataset_->root, 1);
  const cv::Mat rgb = DecodeImage(frames[0].frame.color, "color");
  EXPECT_EQ(frames[0].frame.color.compression, int{image_t::COMPRESSION_JPEG});
  cv::Mat difference;
  cv::absdiff(rgb, LoadBopRgb(scene, 0), difference);
  EXPECT_LT(cv::mean(difference)[0], 6.0) << "JPEG colour too far from the PNG";
}

// --instances box: each instance is the box of its visible mask (the mask the benchmark's
// --degrade-masks box gives the solver) and the frame carries no label image; --identity
// unknown leaves the object ids empty.
TEST_F(Bop2LcmSynthetic, BoxesAndUnknownIdentity) {
  const std::string log_path = test::TempDir("bop2lcm_boxes") + "/scene.lcmlog";
  BopToLcmOptions options;
  options.use_targets = false;
  options.instances = InstanceInput::kBox;
  options.identity = IdentityInput::kUnknown;
  const BopToLcmReport report = WriteBopSceneLog(options, dataset_->root, 1, log_path);
  ASSERT_TRUE(report.success) << report.message;
  const std::vector<LoggedFrame> frames = ReadLog(log_path);
  ASSERT_EQ(frames.size(), 3u);
  const BopScene scene = LoadBopScene(dataset_->root, 1);
  MaskDegradeOptions box_mode;
  box_mode.mode = MaskDegradation::kBox;
  box_mode.size_px = options.box_margin_px;
  int boxes = 0;
  for (const LoggedFrame& logged : frames) {
    const rgbd_frame_t& message = logged.frame;
    SCOPED_TRACE("image " + std::to_string(message.image_id));
    EXPECT_EQ(message.labels.width, 0);
    EXPECT_EQ(message.labels.height, 0);
    EXPECT_TRUE(message.labels.data.empty());
    const DecodedFrame decoded = DecodeFrame(message);
    ASSERT_EQ(decoded.instances.size(), message.instances.size());
    for (size_t i = 0; i < message.instances.size(); ++i) {
      const instance_t& instance = message.instances[i];
      EXPECT_EQ(instance.label, 0);
      EXPECT_EQ(instance.object_id, "");
      EXPECT_EQ(instance.num_candidate_ids, 0);
      const cv::Mat mask = LoadBopMaskVisib(scene, message.image_id, instance.gt_index);
      const cv::Rect expected = BoxOfMask(mask, options.box_margin_px);
      EXPECT_EQ(cv::Rect(instance.box[0], instance.box[1], instance.box[2], instance.box[3]),
                expected);
      // The service's mask of this box is exactly the benchmark's.
      ASSERT_TRUE(decoded.instances[i].error.empty()) << decoded.instances[i].error;
      EXPECT_TRUE(decoded.instances[i].identity_unknown());
      EXPECT_EQ(cv::countNonZero(decoded.instances[i].mask !=
                                 DegradeMask(mask, {}, box_mode, /*instance_key=*/0)),
                0);
      ++boxes;
    }
  }
  EXPECT_EQ(boxes, report.instances_written);
  EXPECT_GT(boxes, 0);
  EXPECT_EQ(report.instances_written + report.empty_masks, 6);  // 3 images x 2 GT instances
  // A box with no margin is the mask's own bounding box.
  cv::Mat mask = cv::Mat::zeros(20, 30, CV_8U);
  mask(cv::Rect(4, 5, 6, 7)).setTo(255);
  EXPECT_EQ(BoxOfMask(mask, 0), cv::Rect(4, 5, 6, 7));
  EXPECT_EQ(BoxOfMask(mask, 6), cv::Rect(0, 0, 16, 18));  // clipped at the top-left corner
  EXPECT_EQ(BoxOfMask(cv::Mat::zeros(20, 30, CV_8U), 6), cv::Rect());
}

// --instances none: per image, one detection request per target object (label 0, no box,
// count = its target instances, gt_index -1) and no label image; the service decodes each
// as a detection request. Unknown identity is refused with it.
TEST_F(Bop2LcmSynthetic, DetectionRequestsPerTargetObject) {
  const std::string log_path = test::TempDir("bop2lcm_none") + "/scene.lcmlog";
  BopToLcmOptions options;
  options.instances = InstanceInput::kNone;
  const BopToLcmReport report = WriteBopSceneLog(options, dataset_->root, 1, log_path);
  ASSERT_TRUE(report.success) << report.message;
  const std::vector<LoggedFrame> frames = ReadLog(log_path);
  ASSERT_EQ(frames.size(), 2u);  // the target images, as with labels
  const BopScene scene = LoadBopScene(dataset_->root, 1);
  const std::vector<BopTarget> targets =
      LoadBopTargets(dataset_->root + "/test_targets_bop19.json");
  int requested = 0;
  for (const LoggedFrame& logged : frames) {
    const rgbd_frame_t& message = logged.frame;
    SCOPED_TRACE("image " + std::to_string(message.image_id));
    EXPECT_EQ(message.labels.width, 0);
    EXPECT_TRUE(message.labels.data.empty());
    // How many instances of each object the targets chose in this image.
    std::map<std::string, int> chosen;
    const BopFrame& frame = scene.Frame(message.image_id);
    for (int gt_idx : TargetInstances(frame, 1, targets)) ++chosen[BopObjectName(frame.gt[gt_idx].obj_id)];
    ASSERT_EQ(message.instances.size(), chosen.size());
    const DecodedFrame decoded = DecodeFrame(message);
    for (size_t i = 0; i < message.instances.size(); ++i) {
      const instance_t& instance = message.instances[i];
      EXPECT_EQ(instance.label, 0);
      EXPECT_EQ(instance.box[2], 0);
      EXPECT_EQ(instance.gt_index, -1);
      ASSERT_EQ(chosen.count(instance.object_id), 1u) << instance.object_id;
      EXPECT_EQ(instance.count, chosen[instance.object_id]);
      EXPECT_TRUE(decoded.instances[i].error.empty()) << decoded.instances[i].error;
      EXPECT_TRUE(decoded.instances[i].detect);
      EXPECT_EQ(decoded.instances[i].count, instance.count);
      requested += instance.count;
    }
  }
  EXPECT_EQ(requested, 3);  // the targets' instances, as --instances label sends them
  EXPECT_EQ(report.instances_written, static_cast<int>(frames[0].frame.instances.size() +
                                                       frames[1].frame.instances.size()));
  options.identity = IdentityInput::kUnknown;
  EXPECT_NE(options.Check().find("instances none"), std::string::npos);
  EXPECT_EQ(ParseInstanceInput("none"), InstanceInput::kNone);
}

TEST_F(Bop2LcmSynthetic, ToolWritesBoxesAndRefusesThemForForeignTypes) {
  const std::string dir = test::TempDir("bop2lcm_tool_boxes");
  const test::CommandResult ok = test::RunCommand(
      kBop2Lcm + " --dataset " + dataset_->root +
      " --scene 1 --instances box --identity unknown --box-margin-px 3 --out " + dir +
      "/a.lcmlog");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_THAT(ok.output, HasSubstr("3 instances (boxes, identity unknown)"));
  const std::vector<LoggedFrame> frames = ReadLog(dir + "/a.lcmlog");
  ASSERT_EQ(frames.size(), 2u);
  const BopScene scene = LoadBopScene(dataset_->root, 1);
  const instance_t& instance = frames[0].frame.instances[0];
  EXPECT_EQ(instance.label, 0);
  EXPECT_EQ(instance.object_id, "");
  EXPECT_EQ(cv::Rect(instance.box[0], instance.box[1], instance.box[2], instance.box[3]),
            BoxOfMask(LoadBopMaskVisib(scene, frames[0].frame.image_id, instance.gt_index), 3));

  const test::CommandResult foreign = test::RunCommand(
      kBop2Lcm + " --dataset " + dataset_->root + " --scene 1 --instances box --as drake --out " +
      dir + "/b.lcmlog");
  EXPECT_EQ(foreign.exit_code, 2);
  EXPECT_THAT(foreign.output, HasSubstr("--instances box or none and --identity unknown need --as g6d"));
  const test::CommandResult bad = test::RunCommand(kBop2Lcm + " --dataset " + dataset_->root +
                                                   " --scene 1 --instances mask --out " + dir +
                                                   "/c.lcmlog");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.output, HasSubstr("'mask' is not one of label, box"));
}

TEST_F(Bop2LcmSynthetic, ToolWritesALogAndNamesBadArguments) {
  ASSERT_TRUE(std::filesystem::exists(kBop2Lcm)) << kBop2Lcm;
  const std::string dir = test::TempDir("bop2lcm_tool");
  const test::CommandResult ok =
      test::RunCommand(kBop2Lcm + " --dataset " + dataset_->root +
                       " --scene 1 --color raw --fps 30 --out " + dir + "/a.lcmlog");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_THAT(ok.output, HasSubstr("2 of 3 images, 3 instances"));
  const std::vector<LoggedFrame> frames = ReadLog(dir + "/a.lcmlog");
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].timestamp_us - frames[0].timestamp_us, 33333);
  EXPECT_EQ(frames[0].frame.color.compression, int{image_t::COMPRESSION_NONE});

  const test::CommandResult bad_color =
      test::RunCommand(kBop2Lcm + " --dataset " + dataset_->root + " --scene 1 --color gif --out " +
                       dir + "/b.lcmlog");
  EXPECT_EQ(bad_color.exit_code, 2);
  EXPECT_THAT(bad_color.output, HasSubstr("'gif' is not one of raw, zstd, png, jpeg"));
  const test::CommandResult bad_scene = test::RunCommand(kBop2Lcm + " --dataset " + dataset_->root +
                                                         " --scene 4 --out " + dir + "/c.lcmlog");
  EXPECT_EQ(bad_scene.exit_code, 2);
  EXPECT_THAT(bad_scene.output, HasSubstr("000004"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/c.lcmlog"))
      << "no log for a scene that cannot be read";
  const test::CommandResult no_dataset = test::RunCommand(
      kBop2Lcm + " --dataset " + dir + "/nothing --scene 1 --out " + dir + "/d.lcmlog");
  EXPECT_EQ(no_dataset.exit_code, 2);
  EXPECT_THAT(no_dataset.output, HasSubstr("does not exist"));
}

TEST(ParseFrameList, RangesAndErrors) {
  EXPECT_EQ(ParseFrameList("8,10-12,3,8"), (std::vector<int>{3, 8, 10, 11, 12}));
  EXPECT_EQ(ParseFrameList("0"), (std::vector<int>{0}));
  EXPECT_THROW(ParseFrameList("5-2"), Error);
  EXPECT_THROW(ParseFrameList("a"), Error);
  EXPECT_THROW(ParseFrameList("1,,x-3"), Error);
  EXPECT_THROW(ParseFrameList(""), Error);
  EXPECT_THROW(ParseFrameList("-3"), Error);
  EXPECT_THROW(ParseFrameList("0-2000000000"), Error);
}

TEST(ParseColorEncoding, NamesAndErrors) {
  EXPECT_EQ(ParseColorEncoding("jpeg"), ColorEncoding::kJpeg);
  EXPECT_EQ(ParseColorEncoding("png"), ColorEncoding::kPng);
  EXPECT_EQ(ParseColorEncoding("zstd"), ColorEncoding::kZstd);
  EXPECT_EQ(ParseColorEncoding("raw"), ColorEncoding::kRaw);
  EXPECT_THROW(ParseColorEncoding("PNG"), Error);
}

TEST(BopSourceName, TrailingSlashAndDots) {
  EXPECT_EQ(BopSourceName("/data/lmo/"), "lmo");
  EXPECT_EQ(BopSourceName("/data/lmo"), "lmo");
  EXPECT_EQ(BopSourceName("/data/ycbv_real/./"), "ycbv_real");
}

// The real LM-O developers' set: every frame of the tool's log is the dataset's image.
TEST(Bop2LcmTool, LmoDecodesBackExactly) {
  G6D_REQUIRE_SHARED_DATA("lmo/test/000002");
  const std::string root = test::SharedDataPath("lmo");
  const std::string log_path = test::TempDir("bop2lcm_lmo") + "/lmo_000002.lcmlog";
  const test::CommandResult run =
      test::RunCommand(kBop2Lcm + " --dataset " + root + " --scene 2 --out " + log_path);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::vector<LoggedFrame> frames = ReadLog(log_path);
  const BopScene scene = LoadBopScene(root, 2);
  const std::vector<BopTarget> targets = LoadBopTargets(root + "/test_targets_bop19.json");
  std::set<int> target_images;
  for (const BopTarget& target : targets) target_images.insert(target.im_id);
  ASSERT_EQ(frames.size(), target_images.size());
  size_t instances = 0;
  auto image = target_images.begin();
  for (size_t i = 0; i < frames.size(); ++i, ++image) {
    EXPECT_EQ(frames[i].frame.image_id, *image);
    EXPECT_EQ(frames[i].frame.seq, static_cast<int64_t>(i));
    EXPECT_EQ(frames[i].timestamp_us, static_cast<int64_t>(i) * 100000);  // 10 Hz from 0
    const std::vector<int> expected = TargetInstances(scene.Frame(*image), 2, targets);
    ExpectFrameIsDatasetImage(frames[i].frame, scene, expected, "lmo");
    instances += expected.size();
  }
  EXPECT_EQ(instances, 449u);  // the README's target count
}

}  // namespace
}  // namespace g6d
