// The input adapters on messages built field by field the way Drake's
// ImageToLcmImageArrayT and libbot/openni-style bot_core.images_t publishers build them:
// decoded planes equal the source pixels (exactly where lossless, within JPEG's error for
// MJPEG), named labels become instances, and every bad message is refused with a message
// that names the image and the problem.

#include "wire/input_adapters.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "bot_core/images_t.hpp"
#include "core/error.h"
#include "drake/lcmt_image_array.hpp"
#include "wire/foreign_images.h"
#include "wire/frame_codec.h"

namespace g6d {
namespace {

using testing::HasSubstr;

constexpr int kWidth = 64, kHeight = 48;

Camera TestCamera() { return Camera{60.0, 61.0, 31.5, 23.5, kWidth, kHeight}; }

AdapterOptions TestOptions() {
  AdapterOptions options;
  options.camera = TestCamera();
  options.label_objects = {{1, "obj_000001"}, {2, "obj_000002"}};
  return options;
}

// A textured colour image (CV_8UC3, RGB), depth in metres with a hole, and labels: object
// 1 in a rectangle, object 2 in a circle, 5 (named by no map entry) in a corner.
struct Planes {
  cv::Mat rgb, depth_m, labels;
};

Planes MakePlanes() {
  Planes planes;
  planes.rgb = cv::Mat(kHeight, kWidth, CV_8UC3);
  cv::RNG rng(7);
  rng.fill(planes.rgb, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(planes.rgb, planes.rgb, cv::Size(5, 5), 1.5);  // JPEG-friendly
  planes.depth_m = cv::Mat(kHeight, kWidth, CV_32F);
  for (int v = 0; v < kHeight; ++v)
    for (int u = 0; u < kWidth; ++u) planes.depth_m.at<float>(v, u) = 0.5f + 0.001f * (u + 2 * v);
  planes.depth_m(cv::Rect(0, 0, 4, 4)) = 0.0f;
  planes.labels = cv::Mat(kHeight, kWidth, CV_16S, cv::Scalar(0));
  planes.labels(cv::Rect(10, 10, 15, 12)) = 1;
  cv::circle(planes.labels, cv::Point(45, 30), 8, cv::Scalar(2), cv::FILLED);
  planes.labels(cv::Rect(58, 0, 6, 6)) = 5;
  return planes;
}

template <typename Message>
std::vector<uint8_t> Encode(const Message& message) {
  std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
  EXPECT_GE(message.encode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
  return bytes;
}

// ---- Drake, as ImageToLcmImageArrayT fills lcmt_image -------------------------------------

drake::lcmt_image DrakeImage(const cv::Mat& image, int8_t pixel_format, int8_t channel_type,
                             bool compress, const std::string& frame_name) {
  return MakeDrakeImage(image, pixel_format, channel_type, compress, 0, 1234567, frame_name);
}

drake::lcmt_image_array DrakeArray(const Planes& planes, bool compress) {
  cv::Mat rgba;
  cv::cvtColor(planes.rgb, rgba, cv::COLOR_RGB2RGBA);
  drake::lcmt_image_array array;
  array.header.seq = 42;
  array.header.utime = 1234567;
  array.header.frame_name = "";
  using I = drake::lcmt_image;
  // Drake's order: colour, depth, label; the adapter must not rely on it (shuffled here).
  array.images = {
      DrakeImage(planes.labels, I::PIXEL_FORMAT_LABEL, I::CHANNEL_TYPE_INT16, compress, "label"),
      DrakeImage(rgba, I::PIXEL_FORMAT_RGBA, I::CHANNEL_TYPE_UINT8, compress, "color_camera"),
      DrakeImage(planes.depth_m, I::PIXEL_FORMAT_DEPTH, I::CHANNEL_TYPE_FLOAT32, compress, "depth"),
  };
  array.num_images = 3;
  return array;
}

// The decoded frame must carry exactly the source planes.
void ExpectPlanes(const DecodedFrame& decoded, const Planes& planes, double max_color_error) {
  ASSERT_EQ(decoded.frame.rgb.size(), planes.rgb.size());
  cv::Mat difference;
  cv::absdiff(decoded.frame.rgb, planes.rgb, difference);
  EXPECT_LE(cv::mean(difference)[0], max_color_error);
  EXPECT_EQ(cv::norm(decoded.frame.depth, planes.depth_m, cv::NORM_INF), 0.0);
  ASSERT_EQ(decoded.instances.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    const DecodedInstance& instance = decoded.instances[i];
    EXPECT_EQ(instance.label, i + 1);
    EXPECT_EQ(instance.object_id, "obj_00000" + std::to_string(i + 1));
    EXPECT_EQ(instance.error, "");
    EXPECT_EQ(instance.mask_pixels, cv::countNonZero(planes.labels == i + 1));
  }
  // Label 5 (in no map entry) is background.
  EXPECT_EQ(cv::countNonZero(decoded.labels(cv::Rect(58, 0, 6, 6))), 0);
}

TEST(AdaptMessage, DrakeZlibRgbaFloatDepthInt16Labels) {
  const Planes planes = MakePlanes();
  const std::vector<uint8_t> bytes = Encode(DrakeArray(planes, /*compress=*/true));
  FrameHeader header;
  const rgbd_frame_t frame = AdaptMessage(InputType::kDrake, bytes.data(),
                                          static_cast<int64_t>(bytes.size()), TestOptions(), {},
                                          /*seq=*/-1, &header);
  EXPECT_EQ(header.utime, 1234567);
  EXPECT_EQ(header.seq, 42);
  EXPECT_EQ(frame.source, "drake");
  EXPECT_EQ(frame.scene_id, -1);  // no dataset ids in a Drake message
  EXPECT_EQ(frame.image_id, -1);
  EXPECT_EQ(frame.camera_id, "color_camera");  // Drake's frame name of the colour image
  EXPECT_EQ(frame.fx, 60.0);
  EXPECT_EQ(frame.cy, 23.5);
  ExpectPlanes(DecodeFrame(frame), planes, 0.0);
}

TEST(AdaptMessage, DrakeUncompressedRgbAndMillimetreDepth) {
  const Planes planes = MakePlanes();
  drake::lcmt_image_array array = DrakeArray(planes, /*compress=*/false);
  using I = drake::lcmt_image;
  array.images[1] = DrakeImage(planes.rgb, I::PIXEL_FORMAT_RGB, I::CHANNEL_TYPE_UINT8, false, "c");
  cv::Mat depth_mm;
  planes.depth_m.convertTo(depth_mm, CV_16U, 1000.0);
  array.images[2] = DrakeImage(depth_mm, I::PIXEL_FORMAT_DEPTH, I::CHANNEL_TYPE_UINT16, false, "d");
  const std::vector<uint8_t> bytes = Encode(array);
  const DecodedFrame decoded = DecodeFrame(AdaptMessage(
      InputType::kDrake, bytes.data(), static_cast<int64_t>(bytes.size()), TestOptions(), {}, -1));
  cv::Mat expected_depth;
  depth_mm.convertTo(expected_depth, CV_32F, 0.001);
  EXPECT_LT(cv::norm(decoded.frame.depth, expected_depth, cv::NORM_INF), 1e-6);
  EXPECT_EQ(cv::norm(decoded.frame.rgb, planes.rgb, cv::NORM_INF), 0.0);
}

// Applies `change` to a good Drake array and expects AdaptMessage to refuse it with `words`.
void ExpectDrakeRefused(const std::function<void(drake::lcmt_image_array*)>& change,
                        const std::string& words, AdapterOptions options = TestOptions()) {
  drake::lcmt_image_array array = DrakeArray(MakePlanes(), true);
  change(&array);
  const std::vector<uint8_t> bytes = Encode(array);
  try {
    AdaptMessage(InputType::kDrake, bytes.data(), static_cast<int64_t>(bytes.size()), options, {},
                 -1);
    ADD_FAILURE() << "accepted; expected an error with '" << words << "'";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(words));
    EXPECT_THAT(e.what(), testing::StartsWith("drake: "));
  }
}

TEST(AdaptMessage, DrakeBadImagesAreRefusedByName) {
  ExpectDrakeRefused(
      [](auto* a) {
        a->images.erase(a->images.begin());
        a->num_images = 2;
      },
      "no LABEL image (instance labels) among the 2 images");
  ExpectDrakeRefused(
      [](auto* a) {
        a->images.pop_back();
        a->num_images = 2;
      },
      "no DEPTH image among the 2 images");
  ExpectDrakeRefused([](auto* a) { a->images[2].data[10] ^= 0xFF; },
                     "depth image: zlib data is corrupted");
  ExpectDrakeRefused([](auto* a) { a->images[1].bigendian = true; },
                     "big-endian data is not supported");
  ExpectDrakeRefused([](auto* a) { a->images[1].compression_method = 9; },
                     "unknown compression_method 9");
  ExpectDrakeRefused(
      [](auto* a) { a->images[2].channel_type = drake::lcmt_image::CHANNEL_TYPE_INT32; },
      "expected FLOAT32 (metres) or UINT16 (mm)");
  AdapterOptions wrong_size = TestOptions();
  wrong_size.camera.width = 640;
  ExpectDrakeRefused([](auto*) {}, "the camera YAML says 640x48 but the colour image is 64x48",
                     wrong_size);
}

TEST(AdaptMessage, DrakeGarbageAndOtherTypesAreRefusedBeforeDecoding) {
  const std::vector<uint8_t> good = Encode(DrakeArray(MakePlanes(), true));
  // Truncated: the declared sizes no longer fit.
  EXPECT_THAT(CheckEncodedDrakeImageArray(good.data(), static_cast<int64_t>(good.size()) - 5),
              HasSubstr("remain"));
  // A huge declared size is refused without allocating it.
  std::vector<uint8_t> huge = good;
  const size_t num_images_offset = 8 + 4 + 8 + 4 + 1;  // fingerprint, seq, utime, "" frame name
  huge[num_images_offset] = 0x7F;
  EXPECT_THAT(CheckEncodedDrakeImageArray(huge.data(), static_cast<int64_t>(huge.size())),
              HasSubstr("num_images declares"));
  // A bot_core message on a Drake channel.
  bot_core::images_t other;
  other.utime = 1;
  other.n_images = 0;
  const std::vector<uint8_t> other_bytes = Encode(other);
  try {
    AdaptMessage(InputType::kDrake, other_bytes.data(), static_cast<int64_t>(other_bytes.size()),
                 TestOptions(), {}, -1);
    ADD_FAILURE() << "accepted a bot_core.images_t as drake.lcmt_image_array";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("is not drake.lcmt_image_array's"));
  }
}

// ---- bot_core, as openni/realsense-to-LCM publishers fill images_t ---------------------------

bot_core::image_t BotImage(const cv::Mat& image, int32_t pixelformat, std::vector<uint8_t> data) {
  return MakeBotCoreImage(image, pixelformat, std::move(data), 7654321);
}

bot_core::images_t BotImages(const Planes& planes, bool mjpeg, bool zip_depth) {
  using I = bot_core::image_t;
  bot_core::images_t images;
  images.utime = 7654321;
  cv::Mat bgr;
  cv::cvtColor(planes.rgb, bgr, cv::COLOR_RGB2BGR);
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95});
  images.images.push_back(mjpeg ? BotImage(planes.rgb, I::PIXEL_FORMAT_MJPEG, jpeg)
                                : BotImage(planes.rgb, I::PIXEL_FORMAT_RGB, PixelBytes(planes.rgb)));
  images.image_types.push_back(int16_t{bot_core::images_t::LEFT});
  cv::Mat depth_mm;
  planes.depth_m.convertTo(depth_mm, CV_16U, 1000.0);
  // Depth publishers mark zipped depth PIXEL_FORMAT_INVALID (-2) and raw depth LE_GRAY16.
  images.images.push_back(zip_depth
                              ? BotImage(depth_mm, I::PIXEL_FORMAT_INVALID, ZlibCompress(PixelBytes(depth_mm)))
                              : BotImage(depth_mm, I::PIXEL_FORMAT_LE_GRAY16, PixelBytes(depth_mm)));
  images.image_types.push_back(zip_depth ? int16_t{bot_core::images_t::DEPTH_MM_ZIPPED}
                                         : int16_t{bot_core::images_t::DEPTH_MM});
  cv::Mat mask;
  planes.labels.convertTo(mask, CV_8U);
  images.images.push_back(BotImage(mask, I::PIXEL_FORMAT_GRAY, ZlibCompress(PixelBytes(mask))));
  images.image_types.push_back(int16_t{bot_core::images_t::MASK_ZIPPED});
  images.n_images = 3;
  return images;
}

Planes MillimetrePlanes() {
  Planes planes = MakePlanes();
  cv::Mat depth_mm;
  planes.depth_m.convertTo(depth_mm, CV_16U, 1000.0);
  depth_mm.convertTo(planes.depth_m, CV_32F, 0.001);
  return planes;
}

TEST(AdaptMessage, BotCoreMjpegZippedDepthAndMask) {
  const Planes planes = MillimetrePlanes();
  const std::vector<uint8_t> bytes = Encode(BotImages(planes, /*mjpeg=*/true, /*zip_depth=*/true));
  FrameHeader header;
  const rgbd_frame_t frame = AdaptMessage(InputType::kBotCore, bytes.data(),
                                          static_cast<int64_t>(bytes.size()), TestOptions(), {},
                                          /*seq=*/17, &header);
  EXPECT_EQ(header.utime, 7654321);
  EXPECT_EQ(header.seq, 17);
  EXPECT_EQ(frame.camera_id, "bot_core");
  const DecodedFrame decoded = DecodeFrame(frame);
  // Colour is the JPEG's own pixels (decoded independently here), in RGB order.
  const bot_core::images_t sent = BotImages(planes, true, true);
  Planes expected = planes;
  cv::cvtColor(cv::imdecode(sent.images[0].data, cv::IMREAD_COLOR), expected.rgb,
               cv::COLOR_BGR2RGB);
  ExpectPlanes(decoded, expected, 0.0);
}

TEST(AdaptMessage, BotCoreRawRgbAndRawDepth) {
  const Planes planes = MillimetrePlanes();
  const std::vector<uint8_t> bytes = Encode(BotImages(planes, false, false));
  const DecodedFrame decoded = DecodeFrame(AdaptMessage(
      InputType::kBotCore, bytes.data(), static_cast<int64_t>(bytes.size()), TestOptions(), {}, 0));
  ExpectPlanes(decoded, planes, 0.0);
}

TEST(AdaptMessage, BotCoreBadImagesAreRefusedByName) {
  const auto refused = [](const std::function<void(bot_core::images_t*)>& change,
                          const std::string& words) {
    bot_core::images_t images = BotImages(MillimetrePlanes(), true, true);
    change(&images);
    const std::vector<uint8_t> bytes = Encode(images);
    try {
      AdaptMessage(InputType::kBotCore, bytes.data(), static_cast<int64_t>(bytes.size()),
                   TestOptions(), {}, 0);
      ADD_FAILURE() << "accepted; expected an error with '" << words << "'";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(words));
    }
  };
  refused(
      [](auto* m) {
        m->images.pop_back();
        m->image_types.pop_back();
        m->n_images = 2;
      },
      "bot_core: no MASK_ZIPPED image (instance labels) among the 2 images");
  refused(
      [](auto* m) {
        m->images[0].data.resize(100);
        m->images[0].size = 100;
      },
      "bot_core: LEFT image (MJPEG): corrupted JPEG payload");
  refused([](auto* m) { m->images[0].pixelformat = bot_core::image_t::PIXEL_FORMAT_UYVY; },
          "not a colour format g6d reads");
  refused([](auto* m) { m->images[1].data[5] ^= 0x55; }, "DEPTH_MM_ZIPPED image: zlib data");
  refused([](auto* m) { m->images[2].width = 10; }, "MASK_ZIPPED image: zlib data");
}

// ---- YAML ------------------------------------------------------------------------------------

TEST(ParseCameraYaml, PlainAndBotParamPinholeLayouts) {
  const Camera plain = ParseCameraYaml(
      "fx: 600\nfy: 601\ncx: 320.5\ncy: 240.5\nwidth: 640\nheight: 480\n", "cam.yaml");
  EXPECT_EQ(plain.fx, 600.0);
  EXPECT_EQ(plain.fy, 601.0);
  EXPECT_EQ(plain.cx, 320.5);
  EXPECT_EQ(plain.cy, 240.5);
  EXPECT_EQ(plain.width, 640);
  EXPECT_EQ(plain.height, 480);
  const Camera pinhole = ParseCameraYaml(
      "intrinsic_cal:\n  width: 640\n  height: 480\n  pinhole: [600, 601, 0, 320.5, 240.5]\n",
      "bot.yaml");
  EXPECT_EQ(pinhole.fx, 600.0);
  EXPECT_EQ(pinhole.fy, 601.0);
  EXPECT_EQ(pinhole.cx, 320.5);
  EXPECT_EQ(pinhole.cy, 240.5);
  EXPECT_THROW(
      {
        try {
          ParseCameraYaml("pinhole: [600, 601, 2, 320, 240]\nwidth: 640\nheight: 480\n", "b.yaml");
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("b.yaml: pinhole skew 2 is not supported"));
          throw;
        }
      },
      Error);
  EXPECT_THROW(
      {
        try {
          ParseCameraYaml("fx: 600\nfy: 601\ncx: 320\nwidth: 640\nheight: 480\n", "c.yaml");
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("c.yaml: key 'cy' is missing"));
          throw;
        }
      },
      Error);
}

TEST(ParseLabelMapYaml, MapsLabelsToObjectIds) {
  const auto labels = ParseLabelMapYaml("labels:\n  1: obj_000005\n  7: obj_000008\n", "l.yaml");
  EXPECT_EQ(labels, (std::map<int32_t, std::string>{{1, "obj_000005"}, {7, "obj_000008"}}));
  EXPECT_EQ(ParseLabelMapYaml("3: mug\n", "top.yaml").at(3), "mug");
  try {
    ParseLabelMapYaml("labels: {0: obj_000001}\n", "z.yaml");
    ADD_FAILURE() << "label 0 accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("z.yaml: label 0 is outside 1..65535"));
  }
}

// A stack with no segmenter: no label image, objects to find in every frame.
TEST(AdaptMessage, WithoutALabelImageTheObjectsToFindAreDetectionRequests) {
  const Planes planes = MakePlanes();
  drake::lcmt_image_array array = DrakeArray(planes, /*compress=*/true);
  array.images.erase(array.images.begin());  // the LABEL image
  array.num_images = 2;
  const std::vector<uint8_t> bytes = Encode(array);
  AdapterOptions options = TestOptions();
  EXPECT_THROW(AdaptMessage(InputType::kDrake, bytes.data(), static_cast<int64_t>(bytes.size()), options, {}, -1),
               Error);
  options.label_objects.clear();
  options.find_objects = {{"obj_000002", 3}};
  const DecodedFrame decoded = DecodeFrame(
      AdaptMessage(InputType::kDrake, bytes.data(), static_cast<int64_t>(bytes.size()), options, {}, -1));
  ASSERT_EQ(decoded.instances.size(), 1u);
  EXPECT_EQ(decoded.instances[0].object_id, "obj_000002");
  EXPECT_EQ(decoded.instances[0].label, 0);
  EXPECT_TRUE(decoded.instances[0].detect);
  EXPECT_EQ(decoded.instances[0].count, 3);
  EXPECT_EQ(decoded.instances[0].error, "");

  // bot_core without its MASK_ZIPPED image, and with it: labelled instances plus the request.
  bot_core::images_t images = BotImages(MillimetrePlanes(), true, true);
  images.images.pop_back();
  images.image_types.pop_back();
  images.n_images = 2;
  const std::vector<uint8_t> bot_bytes = Encode(images);
  const DecodedFrame bot = DecodeFrame(
      AdaptMessage(InputType::kBotCore, bot_bytes.data(), static_cast<int64_t>(bot_bytes.size()), options, {}, 0));
  ASSERT_EQ(bot.instances.size(), 1u);
  EXPECT_TRUE(bot.instances[0].detect);
  options.label_objects = TestOptions().label_objects;
  const std::vector<uint8_t> full = Encode(BotImages(MillimetrePlanes(), true, true));
  const DecodedFrame both = DecodeFrame(
      AdaptMessage(InputType::kBotCore, full.data(), static_cast<int64_t>(full.size()), options, {}, 0));
  ASSERT_EQ(both.instances.size(), 3u);
  EXPECT_EQ(both.instances[0].label, 1);
  EXPECT_EQ(both.instances[1].label, 2);
  EXPECT_TRUE(both.instances[2].detect);
}

TEST(AdapterOptions, CheckNamesTheMissingPiece) {
  AdapterOptions options;
  EXPECT_EQ(options.Check(InputType::kG6d), "");
  EXPECT_THAT(options.Check(InputType::kDrake), HasSubstr("needs a camera YAML"));
  options.camera = TestCamera();
  EXPECT_THAT(options.Check(InputType::kBotCore), HasSubstr("needs a label map"));
  options.label_objects = {{1, "obj_000001"}};
  EXPECT_EQ(options.Check(InputType::kBotCore), "");
  EXPECT_EQ(ParseInputType("bot_core"), InputType::kBotCore);
  EXPECT_THROW(ParseInputType("ros"), Error);
}

}  // namespace
}  // namespace g6d
