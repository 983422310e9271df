// Round trips of the g6d LCM message types through encode/decode and through a real
// in-process LCM bus (memq).
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "g6d/pose_array_t.hpp"
#include "g6d/rgbd_frame_t.hpp"
#include "bot_core/images_t.hpp"
#include "bot_core/rigid_transform_t.hpp"
#include "drake/lcmt_image_array.hpp"
#include "g6d/service_status_t.hpp"
#include "process_util.h"
#include "test_paths.h"

namespace {

g6d::rgbd_frame_t MakeFrame() {
  g6d::rgbd_frame_t frame;
  frame.utime = 1234567;
  frame.seq = 42;
  frame.camera_id = "cam0";
  frame.source = "unit-test";
  frame.scene_id = 2;
  frame.image_id = 17;
  frame.fx = 572.4;
  frame.fy = 573.5;
  frame.cx = 325.2;
  frame.cy = 242.0;
  frame.depth_scale_m = 0.001;
  frame.color.width = 4;
  frame.color.height = 2;
  frame.color.row_stride = 12;
  frame.color.pixel_format = g6d::image_t::FORMAT_RGB8;
  frame.color.compression = g6d::image_t::COMPRESSION_NONE;
  frame.color.data.assign(24, 7);
  frame.color.size = 24;
  frame.depth = frame.color;
  frame.depth.pixel_format = g6d::image_t::FORMAT_DEPTH_U16;
  frame.labels = frame.color;
  frame.labels.pixel_format = g6d::image_t::FORMAT_LABEL_U8;
  g6d::instance_t instance{};
  instance.object_id = "obj_000005";
  instance.label = 3;
  instance.score = 0.9f;
  instance.gt_index = 1;
  frame.instances.push_back(instance);
  frame.num_instances = 1;
  return frame;
}

TEST(RgbdFrame, EncodeDecodeRoundTrip) {
  const g6d::rgbd_frame_t frame = MakeFrame();
  std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
  ASSERT_EQ(frame.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  g6d::rgbd_frame_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  EXPECT_EQ(decoded.camera_id, "cam0");
  EXPECT_EQ(decoded.image_id, 17);
  EXPECT_EQ(decoded.color.data, frame.color.data);
  ASSERT_EQ(decoded.num_instances, 1);
  EXPECT_EQ(decoded.instances[0].object_id, "obj_000005");
  EXPECT_EQ(decoded.instances[0].label, 3);
}

TEST(RgbdFrame, DecodeRefusesOtherTypeAndTruncation) {
  const g6d::rgbd_frame_t frame = MakeFrame();
  std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
  frame.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  g6d::pose_array_t wrong_type;
  EXPECT_LT(wrong_type.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0)
      << "the LCM fingerprint must reject a frame decoded as a pose array";
  g6d::rgbd_frame_t truncated;
  EXPECT_LT(truncated.decode(bytes.data(), 0, static_cast<int>(bytes.size()) - 5), 0);
}

g6d::pose_array_t MakeAnswer() {
  g6d::pose_array_t answer{};
  answer.seq = 42;
  answer.message = "ok";
  g6d::pose_estimate_t estimate{};
  estimate.object_id = "obj_000005";
  estimate.message = "ok";
  estimate.orientation[0] = 1.0;
  estimate.truncated = 1;
  estimate.ambiguous = 1;
  estimate.has_runner_up = 1;
  const double runner_up_position[3] = {0.01, -0.02, 0.7};
  const double runner_up_orientation[4] = {0.5, 0.5, -0.5, 0.5};
  std::copy(runner_up_position, runner_up_position + 3, estimate.runner_up_position);
  std::copy(runner_up_orientation, runner_up_orientation + 4, estimate.runner_up_orientation);
  estimate.runner_up_score = 0.125;
  estimate.appearance_valid = 1;
  estimate.appearance_agreement = 0.75;
  answer.estimates.push_back(estimate);
  answer.num_estimates = 1;
  return answer;
}

std::vector<uint8_t> Encode(const g6d::pose_array_t& answer) {
  std::vector<uint8_t> bytes(static_cast<size_t>(answer.getEncodedSize()));
  EXPECT_EQ(answer.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  return bytes;
}

TEST(PoseArray, EstimateFieldsOfCacheFormatTwoRoundTrip) {
  const std::vector<uint8_t> bytes = Encode(MakeAnswer());
  g6d::pose_array_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  ASSERT_EQ(decoded.num_estimates, 1);
  const g6d::pose_estimate_t& estimate = decoded.estimates[0];
  EXPECT_EQ(estimate.truncated, 1);
  EXPECT_EQ(estimate.ambiguous, 1);
  EXPECT_EQ(estimate.has_runner_up, 1);
  EXPECT_EQ(estimate.runner_up_position[2], 0.7);
  EXPECT_EQ(estimate.runner_up_orientation[2], -0.5);
  EXPECT_EQ(estimate.runner_up_score, 0.125);
  EXPECT_EQ(estimate.appearance_valid, 1);
  EXPECT_EQ(estimate.appearance_agreement, 0.75);
}

// The fingerprint of g6d.pose_array_t as generated from the .lcm files before the estimate
// fields of cache format 2 were added (lcmtypes/ at commit 8d349b5; the fingerprint
// depends only on the type definitions, not on the lcm-gen version).
constexpr int64_t kPoseArrayHashBeforeFormatTwo = 0x454ad5de046b95beLL;

TEST(PoseArray, MessagesOfThePreviousDefinitionAreRefused) {
  // A subscriber built from the previous .lcm checks for the old fingerprint and refuses
  // today's answers; a subscriber built from today's refuses answers of an old service.
  EXPECT_NE(g6d::pose_array_t::getHash(), kPoseArrayHashBeforeFormatTwo);
  std::vector<uint8_t> bytes = Encode(MakeAnswer());
  for (int i = 0; i < 8; ++i) {
    bytes[static_cast<size_t>(i)] =
        static_cast<uint8_t>(static_cast<uint64_t>(kPoseArrayHashBeforeFormatTwo) >> (56 - 8 * i));
  }
  g6d::pose_array_t decoded;
  EXPECT_LT(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
}

// The fingerprints of g6d.pose_array_t and g6d.service_status_t before tracking added
// pose_estimate_t's mode, track_id and frames_since_detection and the status's answer
// counts (lcmtypes/ at commit 3c68ddf).
constexpr int64_t kPoseArrayHashBeforeTracking = static_cast<int64_t>(0xcb38e506c27561f4ULL);
constexpr int64_t kServiceStatusHashBeforeTracking = static_cast<int64_t>(0xf98fa35959369da9ULL);

TEST(PoseArray, TrackingFieldsRoundTripAndChangeTheFingerprints) {
  EXPECT_NE(g6d::pose_array_t::getHash(), kPoseArrayHashBeforeTracking);
  EXPECT_NE(g6d::service_status_t::getHash(), kServiceStatusHashBeforeTracking);
  g6d::pose_array_t answer = MakeAnswer();
  answer.estimates[0].mode = g6d::pose_estimate_t::MODE_REDETECTED;
  answer.estimates[0].track_id = 12;
  answer.estimates[0].frames_since_detection = 0;
  g6d::pose_estimate_t tracked = answer.estimates[0];
  tracked.mode = g6d::pose_estimate_t::MODE_TRACKED;
  tracked.frames_since_detection = 29;
  answer.estimates.push_back(tracked);
  answer.num_estimates = 2;
  const std::vector<uint8_t> bytes = Encode(answer);
  g6d::pose_array_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  ASSERT_EQ(decoded.num_estimates, 2);
  EXPECT_EQ(decoded.estimates[0].mode, +g6d::pose_estimate_t::MODE_REDETECTED);
  EXPECT_EQ(decoded.estimates[0].track_id, 12);
  EXPECT_EQ(decoded.estimates[1].mode, +g6d::pose_estimate_t::MODE_TRACKED);
  EXPECT_EQ(decoded.estimates[1].frames_since_detection, 29);
  EXPECT_EQ(+g6d::pose_estimate_t::MODE_DETECTED, 0);
  EXPECT_EQ(+g6d::pose_estimate_t::MODE_TRACKED, 1);
  EXPECT_EQ(+g6d::pose_estimate_t::MODE_REDETECTED, 2);
}

// The fingerprints of g6d.rgbd_frame_t and g6d.pose_array_t before box and
// unknown-identity input added instance_t's box and candidate_ids and pose_estimate_t's
// mask_iou and identity answer (lcmtypes/ at commit 2002510).
constexpr int64_t kRgbdFrameHashBeforeBoxes = static_cast<int64_t>(0x568267b30981ab65ULL);
constexpr int64_t kPoseArrayHashBeforeBoxes = static_cast<int64_t>(0x612567f1bee1fffaULL);

TEST(RgbdFrame, BoxAndCandidateIdsRoundTripAndChangeTheFingerprint) {
  EXPECT_NE(g6d::rgbd_frame_t::getHash(), kRgbdFrameHashBeforeBoxes);
  g6d::rgbd_frame_t frame = MakeFrame();
  g6d::instance_t boxed{};
  boxed.label = 0;
  const int32_t box[4] = {120, 80, 64, 48};
  std::copy(box, box + 4, boxed.box);
  boxed.candidate_ids = {"obj_000001", "obj_000005"};
  boxed.num_candidate_ids = 2;
  boxed.gt_index = -1;
  frame.instances.push_back(boxed);
  frame.num_instances = 2;
  std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
  ASSERT_EQ(frame.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  g6d::rgbd_frame_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  ASSERT_EQ(decoded.num_instances, 2);
  // The first instance was made with {}: no box, no candidates.
  for (int i = 0; i < 4; ++i) EXPECT_EQ(decoded.instances[0].box[i], 0);
  EXPECT_EQ(decoded.instances[0].num_candidate_ids, 0);
  const g6d::instance_t& got = decoded.instances[1];
  EXPECT_EQ(got.object_id, "");
  for (int i = 0; i < 4; ++i) EXPECT_EQ(got.box[i], box[i]);
  EXPECT_EQ(got.num_candidate_ids, 2);
  EXPECT_EQ(got.candidate_ids, boxed.candidate_ids);
  // A subscriber of the previous definition refuses the new frames.
  for (int i = 0; i < 8; ++i) {
    bytes[static_cast<size_t>(i)] =
        static_cast<uint8_t>(static_cast<uint64_t>(kRgbdFrameHashBeforeBoxes) >> (56 - 8 * i));
  }
  EXPECT_LT(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
}

TEST(PoseArray, MaskIouAndIdentityFieldsRoundTripAndChangeTheFingerprint) {
  EXPECT_NE(g6d::pose_array_t::getHash(), kPoseArrayHashBeforeBoxes);
  g6d::pose_array_t answer = MakeAnswer();
  g6d::pose_estimate_t& estimate = answer.estimates[0];
  estimate.mask_iou = 0.625;
  estimate.identity_searched = 1;
  estimate.runner_up_object_id = "obj_000002";
  estimate.runner_up_object_score = 0.375;
  estimate.candidates_tried = 3;
  const std::vector<uint8_t> bytes = Encode(answer);
  g6d::pose_array_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  ASSERT_EQ(decoded.num_estimates, 1);
  const g6d::pose_estimate_t& got = decoded.estimates[0];
  EXPECT_EQ(got.mask_iou, 0.625);
  EXPECT_EQ(got.identity_searched, 1);
  EXPECT_EQ(got.runner_up_object_id, "obj_000002");
  EXPECT_EQ(got.runner_up_object_score, 0.375);
  EXPECT_EQ(got.candidates_tried, 3);
  // The fields before them are where they were.
  EXPECT_EQ(got.object_id, "obj_000005");
  EXPECT_EQ(got.appearance_agreement, 0.75);
}

// The fingerprints before mask-free input added instance_t's count and pose_estimate_t's
// request_index, found_without_mask and region (lcmtypes/ at commit 790e8c6).
constexpr int64_t kRgbdFrameHashBeforeDetection = static_cast<int64_t>(0xa3742d8b4390b73dULL);
constexpr int64_t kPoseArrayHashBeforeDetection = static_cast<int64_t>(0x792d51346f23c0d1ULL);

TEST(RgbdFrame, DetectionRequestCountRoundTripsAndChangesTheFingerprint) {
  EXPECT_NE(g6d::rgbd_frame_t::getHash(), kRgbdFrameHashBeforeDetection);
  g6d::rgbd_frame_t frame = MakeFrame();
  g6d::instance_t request{};  // label 0, no box: a detection request
  request.object_id = "obj_000005";
  request.gt_index = -1;
  request.count = 3;
  frame.instances.push_back(request);
  frame.num_instances = 2;
  std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
  ASSERT_EQ(frame.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  g6d::rgbd_frame_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  ASSERT_EQ(decoded.num_instances, 2);
  EXPECT_EQ(decoded.instances[0].count, 0);  // made with {}: the default, 1
  EXPECT_EQ(decoded.instances[1].count, 3);
  EXPECT_EQ(decoded.instances[1].label, 0);
  EXPECT_EQ(decoded.instances[1].box[2], 0);
  EXPECT_EQ(decoded.instances[1].object_id, "obj_000005");
}

TEST(PoseArray, DetectionFieldsRoundTripAndChangeTheFingerprint) {
  EXPECT_NE(g6d::pose_array_t::getHash(), kPoseArrayHashBeforeDetection);
  g6d::pose_array_t answer = MakeAnswer();
  g6d::pose_estimate_t& estimate = answer.estimates[0];
  estimate.request_index = 4;
  estimate.found_without_mask = 1;
  const int32_t region[4] = {100, 50, 80, 60};
  std::copy(region, region + 4, estimate.region_box);
  estimate.region_pixels = 3210;
  const std::vector<uint8_t> bytes = Encode(answer);
  g6d::pose_array_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  ASSERT_EQ(decoded.num_estimates, 1);
  const g6d::pose_estimate_t& got = decoded.estimates[0];
  EXPECT_EQ(got.request_index, 4);
  EXPECT_EQ(got.found_without_mask, 1);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(got.region_box[i], region[i]);
  EXPECT_EQ(got.region_pixels, 3210);
  // The fields before them are where they were.
  EXPECT_EQ(got.object_id, "obj_000005");
  EXPECT_EQ(got.appearance_agreement, 0.75);
}

class Receiver {
 public:
  void Handle(const lcm::ReceiveBuffer*, const std::string& channel,
              const g6d::service_status_t* status) {
    channels.push_back(channel);
    objects = status->objects;
  }
  std::vector<std::string> channels;
  std::vector<std::string> objects;
};

TEST(ServiceStatus, TravelsOverMemqBus) {
  lcm::LCM bus("memq://");
  ASSERT_TRUE(bus.good());
  Receiver receiver;
  bus.subscribe("G6D_STATUS_TEST", &Receiver::Handle, &receiver);
  g6d::service_status_t status{};
  status.service_name = "cam0";
  status.objects = {"obj_000001", "obj_000005"};
  status.num_objects = 2;
  ASSERT_EQ(bus.publish("G6D_STATUS_TEST", &status), 0);
  ASSERT_GT(bus.handleTimeout(1000), 0);
  ASSERT_EQ(receiver.channels.size(), 1u);
  EXPECT_EQ(receiver.objects, status.objects);
}

// The foreign types round-trip like ours, and nested types are part of the fingerprint.
TEST(ForeignTypes, BotCoreImagesAndDrakeImageArrayRoundTrip) {
  bot_core::images_t images;
  images.utime = 99;
  images.n_images = 1;
  images.image_types = {bot_core::images_t::DEPTH_MM_ZIPPED};
  bot_core::image_t image;
  image.utime = 99;
  image.width = 2;
  image.height = 1;
  image.row_stride = 4;
  image.pixelformat = bot_core::image_t::PIXEL_FORMAT_INVALID;
  image.data = {1, 2, 3};
  image.size = 3;
  image.nmetadata = 0;
  images.images = {image};
  std::vector<uint8_t> bytes(static_cast<size_t>(images.getEncodedSize()));
  ASSERT_EQ(images.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  bot_core::images_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  EXPECT_EQ(decoded.images[0].data, image.data);
  EXPECT_EQ(decoded.image_types[0], 6);  // DEPTH_MM_ZIPPED, as every bot_core publisher uses it
  EXPECT_NE(bot_core::images_t::getHash(), bot_core::image_t::getHash());
  EXPECT_NE(drake::lcmt_image_array::getHash(), drake::lcmt_image::getHash());
  // A rigid transform is not an image array: the fingerprint check refuses it.
  bot_core::rigid_transform_t transform{};
  std::vector<uint8_t> transform_bytes(static_cast<size_t>(transform.getEncodedSize()));
  transform.encode(transform_bytes.data(), 0, static_cast<int>(transform_bytes.size()));
  drake::lcmt_image_array array;
  EXPECT_LT(array.decode(transform_bytes.data(), 0, static_cast<int>(transform_bytes.size())), 0);
}

// lcm-spy's jar and the Python classes hold every package (where Java is installed).
TEST(GeneratedBindings, JarAndPythonHoldEveryPackage) {
  const std::string dir = g6d::test::BinaryDir() + "/lcmtypes";
  for (const char* file : {"/python/g6d/pose_array_t.py", "/python/bot_core/images_t.py",
                           "/python/drake/lcmt_image_array.py"}) {
    EXPECT_TRUE(std::ifstream(dir + file).good()) << dir + file;
  }
  if (!std::ifstream(dir + "/g6d_lcmtypes.jar").good()) {
    GTEST_SKIP() << "no " << dir << "/g6d_lcmtypes.jar (Java or lcm.jar not installed)";
  }
  const g6d::test::CommandResult listing = g6d::test::RunCommand("unzip -l " + dir + "/g6d_lcmtypes.jar");
  ASSERT_EQ(listing.exit_code, 0) << listing.output;
  for (const char* entry : {"g6d/pose_array_t.class", "bot_core/images_t.class",
                            "bot_core/rigid_transform_t.class", "drake/lcmt_image_array.class",
                            "drake/lcmt_header.class"}) {
    EXPECT_NE(listing.output.find(entry), std::string::npos) << entry << " not in the jar";
  }
}

// The fingerprint of g6d.service_status_t before the cache reloading fields (issue 24:
// reload, cache_generation, object_cache_hashes, refused_files, refused_reasons).
constexpr int64_t kServiceStatusHashBeforeReload = static_cast<int64_t>(0xcd1f4af21bca1ad9ULL);

TEST(ServiceStatus, ReloadFieldsRoundTripAndChangeTheFingerprint) {
  EXPECT_NE(g6d::service_status_t::getHash(), kServiceStatusHashBeforeReload);
  g6d::service_status_t status{};
  status.objects = {"obj_000001", "obj_000005"};
  status.num_objects = 2;
  status.object_cache_hashes = {"0123456789abcdef", "fedcba9876543210"};
  status.num_cache_hashes = 2;
  status.reload = 1;
  status.cache_generation = 7;
  status.refused_files = {"/caches/bad.g6dcache"};
  status.refused_reasons = {"corrupted: checksum mismatch"};
  status.num_refused = 1;
  std::vector<uint8_t> bytes(static_cast<size_t>(status.getEncodedSize()));
  ASSERT_EQ(status.encode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  g6d::service_status_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  EXPECT_EQ(decoded.object_cache_hashes, status.object_cache_hashes);
  EXPECT_EQ(decoded.reload, 1);
  EXPECT_EQ(decoded.cache_generation, 7);
  EXPECT_EQ(decoded.refused_files, status.refused_files);
  EXPECT_EQ(decoded.refused_reasons, status.refused_reasons);
}

}  // namespace
