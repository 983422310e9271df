// EncodeImage/DecodeImage round trips for every pixel format x compression, and every bad
// input the service must refuse with a clear message (DecodeImage, DecodeFrame and the
// raw LCM message check).
#include "wire/frame_codec.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "g6d/pose_array_t.hpp"

namespace g6d {
namespace {

constexpr int kWidth = 64;
constexpr int kHeight = 48;

// A deterministic test image of `type` with smooth structure (so JPEG stays close).
cv::Mat MakeImage(int type, uint64_t seed) {
  cv::Mat image(kHeight, kWidth, type);
  std::mt19937_64 rng(seed);
  const int offset = static_cast<int>(rng() % 50);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const int value = offset + u * 2 + v * 3;
      switch (type) {
        case CV_8UC3:
          image.at<cv::Vec3b>(v, u) = cv::Vec3b(value % 256, (value * 2) % 256, 200 - v);
          break;
        case CV_8UC1:
          image.at<uint8_t>(v, u) = static_cast<uint8_t>(value % 256);
          break;
        case CV_16UC1:
          image.at<uint16_t>(v, u) = static_cast<uint16_t>(400 + value * 37);
          break;
        case CV_32FC1:
          image.at<float>(v, u) = 0.4f + value * 0.001f;
          break;
      }
    }
  }
  return image;
}

double MaxAbsDifference(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_INF); }

struct FormatCase {
  int8_t format;
  int type;
};
const FormatCase kFormats[] = {
    {image_t::FORMAT_RGB8, CV_8UC3},       {image_t::FORMAT_BGR8, CV_8UC3},
    {image_t::FORMAT_MONO8, CV_8UC1},      {image_t::FORMAT_DEPTH_U16, CV_16UC1},
    {image_t::FORMAT_DEPTH_F32, CV_32FC1}, {image_t::FORMAT_LABEL_U8, CV_8UC1},
    {image_t::FORMAT_LABEL_U16, CV_16UC1},
};
const int8_t kCompressions[] = {image_t::COMPRESSION_NONE, image_t::COMPRESSION_ZSTD,
                                image_t::COMPRESSION_PNG, image_t::COMPRESSION_JPEG};

bool Supported(int8_t format, int8_t compression) {
  if (compression == image_t::COMPRESSION_JPEG)
    return format == image_t::FORMAT_RGB8 || format == image_t::FORMAT_BGR8 ||
           format == image_t::FORMAT_MONO8;
  if (compression == image_t::COMPRESSION_PNG) return format != image_t::FORMAT_DEPTH_F32;
  return true;
}

// Expects `fn` to throw g6d::Error whose message contains every word in `words`.
template <typename Fn>
void ExpectError(Fn fn, const std::vector<std::string>& words) {
  try {
    fn();
    ADD_FAILURE() << "no error; expected one mentioning '" << words.front() << "'";
  } catch (const Error& e) {
    const std::string message = e.what();
    for (const std::string& word : words) {
      EXPECT_NE(message.find(word), std::string::npos) << "'" << word << "' not in: " << message;
    }
  }
}

TEST(EncodeImage, RoundTripEveryFormatAndCompression) {
  for (const FormatCase& format : kFormats) {
    for (int8_t compression : kCompressions) {
      SCOPED_TRACE(PixelFormatName(format.format) + " / " + CompressionName(compression));
      const cv::Mat image = MakeImage(format.type, 3);
      if (!Supported(format.format, compression)) {
        ExpectError([&] { EncodeImage(image, format.format, compression); }, {"EncodeImage"});
        continue;
      }
      const image_t encoded = EncodeImage(image, format.format, compression);
      EXPECT_EQ(encoded.width, kWidth);
      EXPECT_EQ(encoded.height, kHeight);
      EXPECT_EQ(encoded.row_stride, kWidth * BytesPerPixel(format.format));
      EXPECT_EQ(encoded.size, static_cast<int32_t>(encoded.data.size()));
      const cv::Mat decoded = DecodeImage(encoded, "plane");
      ASSERT_EQ(decoded.type(), format.type);
      ASSERT_EQ(decoded.size(), image.size());
      if (compression == image_t::COMPRESSION_JPEG) {
        EXPECT_LT(cv::norm(decoded, image, cv::NORM_L1) / image.total() / image.channels(), 8.0);
      } else {
        EXPECT_EQ(MaxAbsDifference(decoded, image), 0.0);
      }
    }
  }
}

TEST(EncodeImage, PngAndJpegFilesHoldTrueColours) {
  // A pure red RGB8 image must be red in the file, i.e. BGR (0, 0, 255) for OpenCV.
  const cv::Mat red(8, 8, CV_8UC3, cv::Scalar(255, 0, 0));
  for (int8_t compression : {image_t::COMPRESSION_PNG, image_t::COMPRESSION_JPEG}) {
    const image_t encoded = EncodeImage(red, image_t::FORMAT_RGB8, compression);
    image_t as_bgr = encoded;
    as_bgr.pixel_format = image_t::FORMAT_BGR8;
    const cv::Vec3b bgr = DecodeImage(as_bgr, "color").at<cv::Vec3b>(4, 4);
    EXPECT_GT(bgr[2], 240);
    EXPECT_LT(bgr[0], 15);
    const cv::Vec3b rgb = DecodeImage(encoded, "color").at<cv::Vec3b>(4, 4);
    EXPECT_GT(rgb[0], 240);
  }
}

TEST(EncodeImage, RefusesTypeMismatchAndEmptyImage) {
  ExpectError(
      [] { EncodeImage(cv::Mat(4, 4, CV_8UC1), image_t::FORMAT_RGB8, image_t::COMPRESSION_NONE); },
      {"RGB8", "CV_8UC3", "CV_8UC1"});
  ExpectError([] { EncodeImage(cv::Mat(4, 4, CV_8UC1), 42, image_t::COMPRESSION_NONE); },
              {"unknown pixel format"});
  ExpectError([] { EncodeImage(cv::Mat(4, 4, CV_8UC1), image_t::FORMAT_MONO8, 9); },
              {"unknown compression"});
  ExpectError([] { EncodeImage(cv::Mat(), image_t::FORMAT_MONO8, image_t::COMPRESSION_NONE); },
              {"empty"});
}

TEST(EncodeImage, NonContinuousInputIsPacked) {
  const cv::Mat big = MakeImage(CV_16UC1, 5);
  const cv::Mat view = big(cv::Rect(3, 2, 20, 10));
  ASSERT_FALSE(view.isContinuous());
  for (int8_t compression :
       {image_t::COMPRESSION_NONE, image_t::COMPRESSION_ZSTD, image_t::COMPRESSION_PNG}) {
    const cv::Mat decoded =
        DecodeImage(EncodeImage(view, image_t::FORMAT_DEPTH_U16, compression), "depth");
    EXPECT_EQ(MaxAbsDifference(decoded, view), 0.0);
  }
}

TEST(DecodeImage, HonoursRowStride) {
  const cv::Mat image = MakeImage(CV_16UC1, 7);
  const int padded_stride = kWidth * 2 + 6;
  image_t plane;
  plane.width = kWidth;
  plane.height = kHeight;
  plane.row_stride = padded_stride;
  plane.pixel_format = image_t::FORMAT_DEPTH_U16;
  plane.compression = image_t::COMPRESSION_NONE;
  plane.data.assign(static_cast<size_t>(padded_stride) * kHeight, 0xAB);
  for (int v = 0; v < kHeight; ++v)
    std::memcpy(&plane.data[v * padded_stride], image.ptr(v), kWidth * 2);
  plane.size = static_cast<int32_t>(plane.data.size());
  EXPECT_EQ(MaxAbsDifference(DecodeImage(plane, "depth"), image), 0.0);

  // The same padded rows through zstd.
  const image_t packed = EncodeImage(cv::Mat(kHeight, padded_stride, CV_8UC1, plane.data.data()),
                                     image_t::FORMAT_LABEL_U8, image_t::COMPRESSION_ZSTD);
  image_t zstd = plane;
  zstd.compression = image_t::COMPRESSION_ZSTD;
  zstd.data = packed.data;
  zstd.size = packed.size;
  EXPECT_EQ(MaxAbsDifference(DecodeImage(zstd, "depth"), image), 0.0);
}

image_t GoodPlane(int8_t compression) {
  return EncodeImage(MakeImage(CV_8UC3, 1), image_t::FORMAT_RGB8, compression);
}

TEST(DecodeImage, RefusesPayloadSizeMismatch) {
  image_t plane = GoodPlane(image_t::COMPRESSION_NONE);
  plane.data.pop_back();
  plane.size -= 1;
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "payload", "expected"});
  plane = GoodPlane(image_t::COMPRESSION_NONE);
  plane.size += 10;  // size field disagrees with the data
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "size field"});
  plane = GoodPlane(image_t::COMPRESSION_NONE);
  plane.height = kHeight + 1;  // declared height does not match the bytes
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "does not match"});
  plane = GoodPlane(image_t::COMPRESSION_ZSTD);
  plane.width = kWidth / 2;
  plane.row_stride = kWidth / 2 * 3;
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "zstd", "needs"});
  plane = GoodPlane(image_t::COMPRESSION_PNG);
  plane.width = kWidth + 2;
  plane.row_stride = (kWidth + 2) * 3;
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "PNG file is 64x48"});
}

TEST(DecodeImage, RefusesUnknownFormatOrCompression) {
  image_t plane = GoodPlane(image_t::COMPRESSION_NONE);
  plane.pixel_format = 99;
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "unknown pixel format 99"});
  plane = GoodPlane(image_t::COMPRESSION_NONE);
  plane.compression = 7;
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "unknown compression 7"});
  plane = EncodeImage(MakeImage(CV_16UC1, 1), image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_NONE);
  plane.compression = image_t::COMPRESSION_JPEG;
  ExpectError([&] { DecodeImage(plane, "depth"); }, {"depth:", "JPEG"});
}

TEST(DecodeImage, RefusesCorruptedPayloads) {
  image_t zstd = GoodPlane(image_t::COMPRESSION_ZSTD);
  for (size_t i = zstd.data.size() / 2; i < zstd.data.size(); i += 3) zstd.data[i] ^= 0x5A;
  ExpectError([&] { DecodeImage(zstd, "color"); }, {"color:", "corrupted zstd"});
  zstd = GoodPlane(image_t::COMPRESSION_ZSTD);
  std::fill(zstd.data.begin(), zstd.data.begin() + 4, 0);  // magic number gone
  ExpectError([&] { DecodeImage(zstd, "color"); }, {"color:", "corrupted zstd"});

  image_t png = GoodPlane(image_t::COMPRESSION_PNG);
  for (size_t i = png.data.size() / 2; i < png.data.size(); i += 5) png.data[i] ^= 0x33;
  ExpectError([&] { DecodeImage(png, "color"); }, {"color:", "corrupted PNG"});
  png = GoodPlane(image_t::COMPRESSION_PNG);
  png.data.resize(png.data.size() / 2);
  png.size = static_cast<int32_t>(png.data.size());
  ExpectError([&] { DecodeImage(png, "color"); }, {"color:", "corrupted PNG"});

  image_t jpeg = GoodPlane(image_t::COMPRESSION_JPEG);
  jpeg.data.resize(jpeg.data.size() * 2 / 3);  // truncated
  jpeg.size = static_cast<int32_t>(jpeg.data.size());
  ExpectError([&] { DecodeImage(jpeg, "color"); }, {"color:", "corrupted JPEG"});
  jpeg = GoodPlane(image_t::COMPRESSION_JPEG);
  std::fill(jpeg.data.begin(), jpeg.data.begin() + 40, 0x00);  // header destroyed
  ExpectError([&] { DecodeImage(jpeg, "color"); }, {"color:", "corrupted JPEG"});
  jpeg.data.assign(100, 0x42);
  jpeg.size = 100;
  ExpectError([&] { DecodeImage(jpeg, "color"); }, {"color:", "corrupted JPEG"});
}

TEST(DecodeImage, RefusesHugeOrNonPositiveDeclaredSizes) {
  image_t plane = GoodPlane(image_t::COMPRESSION_ZSTD);
  plane.width = 1 << 20;
  plane.row_stride = 3 << 20;
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "too large"});
  plane = GoodPlane(image_t::COMPRESSION_ZSTD);
  plane.row_stride = std::numeric_limits<int32_t>::max();
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "too large"});
  plane = GoodPlane(image_t::COMPRESSION_ZSTD);
  plane.row_stride = 5;
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "row_stride"});
  plane = GoodPlane(image_t::COMPRESSION_NONE);
  plane.width = -4;
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "> 0"});
  plane = GoodPlane(image_t::COMPRESSION_NONE);
  plane.height = 0;
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "> 0"});
  // A small PNG claiming a huge image is refused before the codec allocates it.
  plane = GoodPlane(image_t::COMPRESSION_PNG);
  plane.data[16] = 0x7F;  // IHDR width high byte
  ExpectError([&] { DecodeImage(plane, "color"); }, {"color:", "PNG file is"});
  DecodeLimits tight;
  tight.max_raw_bytes = 100;
  ExpectError([&] { DecodeImage(GoodPlane(image_t::COMPRESSION_NONE), "color", tight); },
              {"color:", "too large"});
}

// ---- Frames ---------------------------------------------------------------------------

// A valid 64x48 frame: two instances with labels 1 and 2.
rgbd_frame_t MakeFrame() {
  rgbd_frame_t frame;
  frame.utime = 1;
  frame.seq = 7;
  frame.camera_id = "cam0";
  frame.source = "test";
  frame.scene_id = -1;
  frame.image_id = -1;
  frame.fx = 60.0;
  frame.fy = 60.0;
  frame.cx = 32.0;
  frame.cy = 24.0;
  frame.depth_scale_m = 0.001;
  frame.color = EncodeImage(MakeImage(CV_8UC3, 1), image_t::FORMAT_BGR8, image_t::COMPRESSION_JPEG);
  cv::Mat depth_mm(kHeight, kWidth, CV_16UC1, cv::Scalar(800));
  frame.depth = EncodeImage(depth_mm, image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_ZSTD);
  cv::Mat labels(kHeight, kWidth, CV_8UC1, cv::Scalar(0));
  labels(cv::Rect(10, 10, 10, 10)).setTo(1);
  labels(cv::Rect(30, 20, 5, 4)).setTo(2);
  frame.labels = EncodeImage(labels, image_t::FORMAT_LABEL_U8, image_t::COMPRESSION_ZSTD);
  for (int label : {1, 2}) {
    instance_t instance{};  // {}: no box, no candidates (lcm-gen leaves members uninitialized)
    instance.object_id = "obj_00000" + std::to_string(label);
    instance.label = label;
    instance.score = 0.9f;
    instance.gt_index = label - 1;
    frame.instances.push_back(instance);
  }
  frame.num_instances = 2;
  return frame;
}

TEST(DecodeFrame, DecodesAGoodFrame) {
  const rgbd_frame_t message = MakeFrame();
  const DecodedFrame decoded = DecodeFrame(message);
  EXPECT_EQ(decoded.frame.camera.width, kWidth);
  EXPECT_EQ(decoded.frame.camera.fx, 60.0);
  ASSERT_EQ(decoded.frame.rgb.type(), CV_8UC3);
  ASSERT_EQ(decoded.frame.depth.type(), CV_32FC1);
  EXPECT_NEAR(decoded.frame.depth.at<float>(5, 5), 0.8f, 1e-6);
  ASSERT_EQ(decoded.instances.size(), 2u);
  EXPECT_TRUE(decoded.instances[0].error.empty());
  EXPECT_EQ(decoded.instances[0].mask_pixels, 100);
  EXPECT_EQ(decoded.instances[1].mask_pixels, 20);
  EXPECT_EQ(cv::countNonZero(decoded.instances[1].mask), 20);
  EXPECT_EQ(decoded.instances[1].gt_index, 1);
  // BGR8 JPEG colour arrives as RGB.
  cv::Mat expected_rgb;
  cv::cvtColor(MakeImage(CV_8UC3, 1), expected_rgb, cv::COLOR_BGR2RGB);
  EXPECT_LT(cv::norm(decoded.frame.rgb, expected_rgb, cv::NORM_L1) / expected_rgb.total() / 3, 8.0);
}

TEST(DecodeFrame, F32DepthNaNAndNegativeBecomeZero) {
  rgbd_frame_t message = MakeFrame();
  cv::Mat depth(kHeight, kWidth, CV_32FC1, cv::Scalar(0.7f));
  depth.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  depth.at<float>(0, 1) = -1.0f;
  depth.at<float>(0, 2) = std::numeric_limits<float>::infinity();
  message.depth = EncodeImage(depth, image_t::FORMAT_DEPTH_F32, image_t::COMPRESSION_NONE);
  message.depth_scale_m = 0.0;  // irrelevant for F32
  const DecodedFrame decoded = DecodeFrame(message);
  EXPECT_EQ(decoded.frame.depth.at<float>(0, 0), 0.0f);
  EXPECT_EQ(decoded.frame.depth.at<float>(0, 1), 0.0f);
  EXPECT_EQ(decoded.frame.depth.at<float>(0, 2), 0.0f);
  EXPECT_EQ(decoded.frame.depth.at<float>(0, 3), 0.7f);
}

TEST(DecodeFrame, RefusesBadIntrinsics) {
  for (double bad : {0.0, -500.0, std::nan("")}) {
    rgbd_frame_t message = MakeFrame();
    message.fx = bad;
    ExpectError([&] { DecodeFrame(message); }, {"intrinsics:", "fx"});
    message = MakeFrame();
    message.fy = bad;
    ExpectError([&] { DecodeFrame(message); }, {"intrinsics:", "fy"});
  }
  rgbd_frame_t message = MakeFrame();
  message.cx = std::numeric_limits<double>::infinity();
  ExpectError([&] { DecodeFrame(message); }, {"intrinsics:", "cx"});
  message = MakeFrame();
  message.depth_scale_m = std::nan("");
  ExpectError([&] { DecodeFrame(message); }, {"depth_scale_m"});
}

// Found by fuzzing (tests/fuzz/regressions/frame_message/huge-depth-scale): a finite but
// huge depth_scale_m made every DEPTH_U16 depth +inf, although DecodeFrame promises finite
// depth.
TEST(DecodeFrame, FuzzHugeDepthScaleOverflowsFloat) {
  rgbd_frame_t message = MakeFrame();
  message.depth_scale_m = 2.65452e+233;
  ExpectError([&] { DecodeFrame(message); }, {"depth_scale_m", "too large", "float"});
  message.depth_scale_m = std::numeric_limits<float>::max() / 65536.0;  // the largest allowed
  const DecodedFrame decoded = DecodeFrame(message);
  EXPECT_TRUE(std::isfinite(decoded.frame.depth.at<float>(5, 5)));
  EXPECT_GT(decoded.frame.depth.at<float>(5, 5), 0.0f);
}

TEST(DecodeFrame, RefusesPlanesOfDifferentSizes) {
  rgbd_frame_t message = MakeFrame();
  message.depth = EncodeImage(cv::Mat(kHeight / 2, kWidth / 2, CV_16UC1, cv::Scalar(800)),
                              image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_ZSTD);
  ExpectError([&] { DecodeFrame(message); }, {"depth:", "differs from color"});
  message = MakeFrame();
  message.labels = EncodeImage(cv::Mat(kHeight, kWidth + 1, CV_8UC1, cv::Scalar(0)),
                               image_t::FORMAT_LABEL_U8, image_t::COMPRESSION_NONE);
  ExpectError([&] { DecodeFrame(message); }, {"labels:", "differs from color"});
}

TEST(DecodeFrame, RefusesWrongPlaneFormats) {
  rgbd_frame_t message = MakeFrame();
  std::swap(message.color, message.depth);
  ExpectError([&] { DecodeFrame(message); }, {"color:", "not a colour format"});
  message = MakeFrame();
  message.depth.pixel_format = image_t::FORMAT_LABEL_U16;
  ExpectError([&] { DecodeFrame(message); }, {"depth:", "not a depth format"});
  message = MakeFrame();
  message.labels.pixel_format = 77;
  ExpectError([&] { DecodeFrame(message); }, {"labels:", "not a label format"});
  message = MakeFrame();
  message.depth.data[message.depth.data.size() / 2] ^= 0xFF;
  ExpectError([&] { DecodeFrame(message); }, {"depth:", "corrupted zstd"});
}

TEST(DecodeFrame, RefusesLabelsNamedByNoInstance) {
  rgbd_frame_t message = MakeFrame();
  message.instances.pop_back();
  message.num_instances = 1;
  ExpectError([&] { DecodeFrame(message); },
              {"labels:", "label 2 (20 pixels) is named by no instance"});
}

// An instance: `object_id`, `label`, and a box when `box` has a width.
instance_t MakeInstance(const std::string& object_id, int32_t label, cv::Rect box = cv::Rect()) {
  instance_t instance{};
  instance.object_id = object_id;
  instance.label = label;
  instance.gt_index = -1;
  instance.box[0] = box.x;
  instance.box[1] = box.y;
  instance.box[2] = box.width;
  instance.box[3] = box.height;
  return instance;
}

TEST(DecodeFrame, InstanceProblemsStayWithTheInstance) {
  rgbd_frame_t message = MakeFrame();
  instance_t no_id = MakeInstance("", 1);
  no_id.candidate_ids = {"obj_000001", ""};
  no_id.num_candidate_ids = 2;
  instance_t miscounted = MakeInstance("", 1);
  miscounted.num_candidate_ids = 1;  // but no id: a message built in-process, never decoded
  message.instances.insert(
      message.instances.end(),
      {MakeInstance("obj_000009", 3),  // no pixel carries label 3
       MakeInstance("obj_000009", 0),  // no mask and no box: a detection request, no error
       MakeInstance("obj_000009", 300),  // a LABEL_U8 image cannot hold it
       MakeInstance("obj_000009", -2), no_id,
       MakeInstance("obj_000009", 0, cv::Rect(kWidth, 0, 5, 5)),    // right of the image
       MakeInstance("obj_000009", 0, cv::Rect(-10, -10, 10, 10)),  // up and left of it
       MakeInstance("obj_000009", 0, cv::Rect(2, 2, 5, -1)),
       MakeInstance("obj_000009", 3, cv::Rect(2, 2, 5, 5)),  // the label wins: no fallback to the box
       miscounted});
  message.num_instances = static_cast<int32_t>(message.instances.size());
  const DecodedFrame decoded = DecodeFrame(message);
  ASSERT_EQ(decoded.instances.size(), 12u);
  EXPECT_TRUE(decoded.instances[0].error.empty());
  EXPECT_TRUE(decoded.instances[1].error.empty());
  const char* expected[] = {
      "instance 2 (obj_000009): label 3 has no pixels",
      "",
      "label 300 has no pixels",
      "label must be > 0 for a mask, or 0 with a box (got -2)",
      "instance 6 (identity unknown): candidate_ids[1] is empty",
      "box (x 64, y 0, width 5, height 5) lies outside the 64x48 image",
      "box (x -10, y -10, width 10, height 10) lies outside",
      "box height must be > 0 (got -1)",
      "instance 10 (obj_000009): label 3 has no pixels",
      "num_candidate_ids 1 but 0 candidate ids"};
  EXPECT_TRUE(decoded.instances[3].error.empty()) << decoded.instances[3].error;
  EXPECT_TRUE(decoded.instances[3].detect);
  for (size_t i = 2; i < decoded.instances.size(); ++i) {
    SCOPED_TRACE("instance " + std::to_string(i));
    EXPECT_EQ(decoded.instances[i].index, static_cast<int32_t>(i));
    if (i == 3) continue;
    EXPECT_FALSE(decoded.instances[i].detect);
    EXPECT_NE(decoded.instances[i].error.find(expected[i - 2]), std::string::npos)
        << decoded.instances[i].error;
    EXPECT_TRUE(decoded.instances[i].mask.empty());
    EXPECT_EQ(decoded.instances[i].mask_pixels, 0);
  }
}

TEST(DecodeFrame, BoxBecomesTheFilledMaskClippedToTheImage) {
  rgbd_frame_t message = MakeFrame();
  message.instances.push_back(MakeInstance("obj_000003", 0, cv::Rect(40, 30, 8, 6)));
  message.instances.push_back(MakeInstance("obj_000004", 0, cv::Rect(-5, 40, 20, 100)));  // clipped
  message.num_instances = 4;
  const DecodedFrame decoded = DecodeFrame(message);
  ASSERT_EQ(decoded.instances.size(), 4u);
  const DecodedInstance& inside = decoded.instances[2];
  ASSERT_TRUE(inside.error.empty()) << inside.error;
  EXPECT_FALSE(inside.identity_unknown());
  EXPECT_EQ(inside.box, cv::Rect(40, 30, 8, 6));
  EXPECT_EQ(inside.mask_pixels, 48);
  ASSERT_EQ(inside.mask.type(), CV_8UC1);
  EXPECT_EQ(cv::countNonZero(inside.mask), 48);
  EXPECT_EQ(cv::countNonZero(inside.mask(inside.box)), 48);
  const DecodedInstance& clipped = decoded.instances[3];
  ASSERT_TRUE(clipped.error.empty()) << clipped.error;
  EXPECT_EQ(clipped.box, cv::Rect(0, 40, 15, kHeight - 40));
  EXPECT_EQ(cv::countNonZero(clipped.mask), 15 * (kHeight - 40));
  // A labelled instance has no box, and its mask is its label's.
  EXPECT_EQ(decoded.instances[0].box, cv::Rect());
  EXPECT_EQ(decoded.instances[0].mask_pixels, 100);
}

TEST(DecodeFrame, NoLabelImageForBoxesOnly) {
  rgbd_frame_t message = MakeFrame();
  message.labels = image_t{};  // 0 x 0, no bytes: no label image
  message.instances = {MakeInstance("obj_000001", 0, cv::Rect(10, 10, 10, 10)),
                       MakeInstance("obj_000002", 2)};
  message.num_instances = 2;
  const DecodedFrame decoded = DecodeFrame(message);
  ASSERT_EQ(decoded.labels.size(), cv::Size(kWidth, kHeight));
  EXPECT_EQ(cv::countNonZero(decoded.labels), 0);
  EXPECT_TRUE(decoded.instances[0].error.empty()) << decoded.instances[0].error;
  EXPECT_EQ(decoded.instances[0].mask_pixels, 100);
  // A label needs a label image.
  EXPECT_NE(decoded.instances[1].error.find("label 2 has no pixels"), std::string::npos);
  // A label plane with a size is still checked against the colour's.
  message.labels.width = 3;
  ExpectError([&] { DecodeFrame(message); }, {"labels:"});
}

TEST(DecodeFrame, RefusesTooManyInstances) {
  rgbd_frame_t message = MakeFrame();
  DecodeLimits limits;
  limits.max_instances = 1;
  ExpectError([&] { DecodeFrame(message, limits); }, {"instances:", "too many"});
}

TEST(DecodeFrame, Label16AndMono8) {
  rgbd_frame_t message = MakeFrame();
  cv::Mat labels(kHeight, kWidth, CV_16UC1, cv::Scalar(0));
  labels(cv::Rect(1, 1, 4, 4)).setTo(1000);
  message.labels = EncodeImage(labels, image_t::FORMAT_LABEL_U16, image_t::COMPRESSION_PNG);
  message.instances.resize(1);
  message.instances[0].label = 1000;
  message.num_instances = 1;
  message.color =
      EncodeImage(MakeImage(CV_8UC1, 2), image_t::FORMAT_MONO8, image_t::COMPRESSION_NONE);
  const DecodedFrame decoded = DecodeFrame(message);
  EXPECT_EQ(decoded.instances[0].mask_pixels, 16);
  EXPECT_EQ(decoded.frame.rgb.type(), CV_8UC3);
}

// ---- Raw LCM bytes --------------------------------------------------------------------

std::vector<uint8_t> Encode(const rgbd_frame_t& message) {
  std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// Writes a big-endian int32 at `offset`.
void PutI32(std::vector<uint8_t>* bytes, size_t offset, int32_t value) {
  for (int i = 0; i < 4; ++i)
    (*bytes)[offset + i] = static_cast<uint8_t>(static_cast<uint32_t>(value) >> (24 - 8 * i));
}

TEST(DecodeRgbdFrameMessage, AcceptsEncodedFrames) {
  rgbd_frame_t message = MakeFrame();
  const std::vector<uint8_t> bytes = Encode(message);
  EXPECT_EQ(CheckEncodedRgbdFrame(bytes.data(), static_cast<int64_t>(bytes.size())), "");
  const rgbd_frame_t decoded =
      DecodeRgbdFrameMessage(bytes.data(), static_cast<int64_t>(bytes.size()));
  EXPECT_EQ(decoded.seq, 7);
  EXPECT_EQ(decoded.instances[1].object_id, "obj_000002");
  // Empty planes and no instances are well formed too (DecodeFrame refuses them later).
  rgbd_frame_t empty{};
  const std::vector<uint8_t> empty_bytes = Encode(empty);
  EXPECT_EQ(CheckEncodedRgbdFrame(empty_bytes.data(), static_cast<int64_t>(empty_bytes.size())),
            "");
}

TEST(DecodeRgbdFrameMessage, RefusesOtherTypesGarbageAndTruncation) {
  pose_array_t other{};
  std::vector<uint8_t> bytes(static_cast<size_t>(other.getEncodedSize()));
  other.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  ExpectError([&] { DecodeRgbdFrameMessage(bytes.data(), static_cast<int64_t>(bytes.size())); },
              {"message:", "g6d.rgbd_frame_t", "fingerprint"});
  const std::vector<uint8_t> garbage(1000, 0x5C);
  ExpectError([&] { DecodeRgbdFrameMessage(garbage.data(), 1000); }, {"message:", "fingerprint"});
  ExpectError([&] { DecodeRgbdFrameMessage(garbage.data(), 3); }, {"message:", "too short"});
  const std::vector<uint8_t> frame = Encode(MakeFrame());
  ExpectError([&] { DecodeRgbdFrameMessage(frame.data(), static_cast<int64_t>(frame.size()) - 9); },
              {"message:"});
}

TEST(DecodeRgbdFrameMessage, RefusesHugeDeclaredSizesWithoutAllocating) {
  const rgbd_frame_t message = MakeFrame();
  std::vector<uint8_t> bytes = Encode(message);
  // Offset of color.size: fingerprint, utime, seq, two strings, two ids, five doubles,
  // then width, height, row_stride, format, compression.
  const size_t color_size_offset =
      8 + 16 + (4 + message.camera_id.size() + 1) + (4 + message.source.size() + 1) + 8 + 40 + 14;
  for (int32_t huge : {std::numeric_limits<int32_t>::max(), -5}) {
    std::vector<uint8_t> bad = bytes;
    PutI32(&bad, color_size_offset, huge);
    ExpectError([&] { DecodeRgbdFrameMessage(bad.data(), static_cast<int64_t>(bad.size())); },
                {"message:", "color.size declares"});
  }
  // A string length far past the end.
  std::vector<uint8_t> bad = bytes;
  PutI32(&bad, 8 + 16, 1 << 30);
  ExpectError([&] { DecodeRgbdFrameMessage(bad.data(), static_cast<int64_t>(bad.size())); },
              {"message:", "camera_id declares"});
  // num_instances: the last instance has 4 + 11 (object id) + 12 (label, score, gt_index)
  // + 16 (box) + 4 (num_candidate_ids) + 4 (count) bytes, the first as many.
  const size_t num_instances_offset = bytes.size() - 2 * (4 + 11 + 12 + 16 + 4 + 4) - 4;
  bad = bytes;
  PutI32(&bad, num_instances_offset, 1 << 30);
  ExpectError([&] { DecodeRgbdFrameMessage(bad.data(), static_cast<int64_t>(bad.size())); },
              {"message:", "num_instances declares"});
  // num_candidate_ids of the last instance (before its count, the last 4 bytes), far more
  // than remain.
  for (int32_t huge : {1 << 30, -1}) {
    bad = bytes;
    PutI32(&bad, bytes.size() - 8, huge);
    ExpectError([&] { DecodeRgbdFrameMessage(bad.data(), static_cast<int64_t>(bad.size())); },
                {"message:", "instances[1].num_candidate_ids declares"});
  }
}

// The box and candidate fields of an instance survive the wire, and the check walks them.
TEST(DecodeRgbdFrameMessage, BoxAndCandidateIdsRoundTrip) {
  rgbd_frame_t message = MakeFrame();
  instance_t& instance = message.instances[1];
  instance.object_id.clear();
  instance.label = 0;
  const int32_t box[4] = {3, 4, 20, 10};
  std::copy(box, box + 4, instance.box);
  instance.candidate_ids = {"obj_000001", "obj_000002"};
  instance.num_candidate_ids = 2;
  // Label 2 is now named by no instance: take it out of the label image.
  cv::Mat labels(kHeight, kWidth, CV_8UC1, cv::Scalar(0));
  labels(cv::Rect(10, 10, 10, 10)).setTo(1);
  message.labels = EncodeImage(labels, image_t::FORMAT_LABEL_U8, image_t::COMPRESSION_ZSTD);
  const std::vector<uint8_t> bytes = Encode(message);
  EXPECT_EQ(CheckEncodedRgbdFrame(bytes.data(), static_cast<int64_t>(bytes.size())), "");
  const rgbd_frame_t decoded =
      DecodeRgbdFrameMessage(bytes.data(), static_cast<int64_t>(bytes.size()));
  ASSERT_EQ(decoded.num_instances, 2);
  EXPECT_EQ(decoded.instances[0].box[2], 0);  // {}: no box
  EXPECT_EQ(decoded.instances[0].num_candidate_ids, 0);
  const instance_t& got = decoded.instances[1];
  EXPECT_EQ(got.object_id, "");
  EXPECT_EQ(got.label, 0);
  EXPECT_EQ(std::vector<int32_t>(got.box, got.box + 4), std::vector<int32_t>(box, box + 4));
  EXPECT_EQ(got.candidate_ids, instance.candidate_ids);
  const DecodedFrame frame = DecodeFrame(decoded);
  ASSERT_TRUE(frame.instances[1].error.empty()) << frame.instances[1].error;
  EXPECT_TRUE(frame.instances[1].identity_unknown());
  EXPECT_EQ(frame.instances[1].box, cv::Rect(3, 4, 20, 10));
  EXPECT_EQ(frame.instances[1].candidate_ids, instance.candidate_ids);
  // A candidate id cut short by the end of the message is refused before decoding (the
  // instance's count, 4 bytes, follows it), and so is a missing count.
  ExpectError(
      [&] { DecodeRgbdFrameMessage(bytes.data(), static_cast<int64_t>(bytes.size()) - 7); },
      {"message:", "candidate_ids"});
  ExpectError(
      [&] { DecodeRgbdFrameMessage(bytes.data(), static_cast<int64_t>(bytes.size()) - 2); },
      {"message:", "instances[1].count"});
}

// Neither mask nor box: a detection request with its count (<= 0 means 1), for an object
// or, without an object id, for its candidates; no mask and no error. A box of width > 0
// and no height is still refused.
TEST(DecodeFrame, NoMaskAndNoBoxIsADetectionRequestWithItsCount) {
  rgbd_frame_t message = MakeFrame();
  instance_t three = MakeInstance("obj_000003", 0);
  three.count = 3;
  instance_t negative = MakeInstance("obj_000004", 0, cv::Rect(5, 5, 0, 10));  // width 0: no box
  negative.count = -2;
  instance_t unknown = MakeInstance("", 0);
  unknown.candidate_ids = {"obj_000001", "obj_000002", "obj_000001"};
  unknown.num_candidate_ids = 3;
  unknown.count = 2;
  instance_t flat = MakeInstance("obj_000005", 0, cv::Rect(5, 5, 10, 0));
  flat.count = 4;
  message.instances.insert(message.instances.end(), {three, negative, unknown, flat});
  message.num_instances = static_cast<int32_t>(message.instances.size());
  // Through the wire, as the service gets it.
  const std::vector<uint8_t> bytes = Encode(message);
  const DecodedFrame frame =
      DecodeFrame(DecodeRgbdFrameMessage(bytes.data(), static_cast<int64_t>(bytes.size())));
  ASSERT_EQ(frame.instances.size(), 6u);
  EXPECT_FALSE(frame.instances[0].detect);  // a label
  EXPECT_EQ(frame.instances[0].count, 1);
  const int expected_count[] = {3, 1, 2};
  for (size_t i = 2; i < 5; ++i) {
    SCOPED_TRACE("instance " + std::to_string(i));
    const DecodedInstance& request = frame.instances[i];
    EXPECT_TRUE(request.error.empty()) << request.error;
    EXPECT_TRUE(request.detect);
    EXPECT_EQ(request.count, expected_count[i - 2]);
    EXPECT_EQ(request.index, static_cast<int32_t>(i));
    EXPECT_TRUE(request.mask.empty());
    EXPECT_EQ(request.mask_pixels, 0);
    EXPECT_EQ(request.box, cv::Rect());
  }
  EXPECT_TRUE(frame.instances[4].identity_unknown());
  EXPECT_EQ(frame.instances[4].candidate_ids,
            (std::vector<std::string>{"obj_000001", "obj_000002"}));
  EXPECT_FALSE(frame.instances[5].detect);
  EXPECT_EQ(frame.instances[5].count, 1);
  EXPECT_NE(frame.instances[5].error.find("box height must be > 0 (got 0)"), std::string::npos)
      << frame.instances[5].error;
}

}  // namespace
}  // namespace g6d
