#include "wire/input_adapters.h"

#include <yaml-cpp/yaml.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <vector>

#include "bot_core/images_t.hpp"
#include "core/error.h"
#include "drake/lcmt_image_array.hpp"

namespace g6d {
namespace {

// ---- Pre-decode checks ------------------------------------------------------------------

// Reads big-endian LCM fields from a buffer without ever reading past its end.
class BigEndianReader {
 public:
  BigEndianReader(const void* data, int64_t size)
      : data_(static_cast<const uint8_t*>(data)), size_(size) {}
  int64_t remaining() const { return size_ - pos_; }
  bool Skip(int64_t bytes) {
    if (bytes < 0 || bytes > remaining()) return false;
    pos_ += bytes;
    return true;
  }
  bool I64(int64_t* value) { return Read(8, value); }
  bool I32(int32_t* value) { return Read(4, value); }

 private:
  template <typename T>
  bool Read(int bytes, T* value) {
    if (remaining() < bytes) return false;
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v = (v << 8) | data_[pos_ + i];
    pos_ += bytes;
    *value = static_cast<T>(v);
    return true;
  }
  const uint8_t* data_;
  int64_t size_;
  int64_t pos_ = 0;
};

// An LCM string: int32 length (including the terminating NUL), then the bytes.
std::string SkipString(BigEndianReader* reader, const std::string& field) {
  int32_t length = 0;
  if (!reader->I32(&length)) return "truncated at " + field;
  if (length < 1 || !reader->Skip(length))
    return field + " declares " + std::to_string(length) + " bytes but " +
           std::to_string(reader->remaining()) + " remain";
  return {};
}

// An int32 count followed by that many elements of at least `min_element_bytes` each.
std::string ReadCount(BigEndianReader* reader, const std::string& field, int64_t min_element_bytes,
                      int32_t* count) {
  if (!reader->I32(count)) return "truncated at " + field;
  if (*count < 0 || *count * min_element_bytes > reader->remaining())
    return field + " declares " + std::to_string(*count) + " elements but only " +
           std::to_string(reader->remaining()) + " bytes remain";
  return {};
}

std::string FingerprintError(int64_t got, int64_t expected, const std::string& type) {
  std::ostringstream out;
  out << "fingerprint 0x" << std::hex << static_cast<uint64_t>(got) << " is not " << type << "'s 0x"
      << static_cast<uint64_t>(expected)
      << " (another message type, a different definition of it, or garbage on the channel)";
  return out.str();
}

// drake.lcmt_header: int32 seq, int64 utime, string frame_name.
std::string SkipDrakeHeader(BigEndianReader* reader, const std::string& field) {
  if (!reader->Skip(4 + 8)) return "truncated at " + field;
  return SkipString(reader, field + ".frame_name");
}

}  // namespace

std::string CheckEncodedDrakeImageArray(const void* data, int64_t size) {
  if (data == nullptr || size < 8)
    return "message of " + std::to_string(size) + " bytes is too short";
  BigEndianReader reader(data, size);
  int64_t fingerprint = 0;
  reader.I64(&fingerprint);
  if (fingerprint != drake::lcmt_image_array::getHash())
    return FingerprintError(fingerprint, drake::lcmt_image_array::getHash(),
                            "drake.lcmt_image_array");
  if (std::string e = SkipDrakeHeader(&reader, "header"); !e.empty()) return e;
  int32_t num_images = 0;
  // An image takes at least a header (4 + 8 + 4 + 1), 4 int32 and 4 bytes.
  if (std::string e = ReadCount(&reader, "num_images", 37, &num_images); !e.empty()) return e;
  for (int32_t i = 0; i < num_images; ++i) {
    const std::string field = "images[" + std::to_string(i) + "]";
    if (std::string e = SkipDrakeHeader(&reader, field + ".header"); !e.empty()) return e;
    int32_t data_size = 0;
    if (!reader.Skip(3 * 4) || !reader.I32(&data_size)) return "truncated at " + field;
    if (data_size < 0 || !reader.Skip(data_size))
      return field + ".size declares " + std::to_string(data_size) + " bytes but " +
             std::to_string(reader.remaining()) + " remain";
    if (!reader.Skip(4)) return "truncated at " + field + ".compression_method";
  }
  return {};
}

std::string CheckEncodedBotCoreImages(const void* data, int64_t size) {
  if (data == nullptr || size < 8)
    return "message of " + std::to_string(size) + " bytes is too short";
  BigEndianReader reader(data, size);
  int64_t fingerprint = 0;
  reader.I64(&fingerprint);
  if (fingerprint != bot_core::images_t::getHash())
    return FingerprintError(fingerprint, bot_core::images_t::getHash(), "bot_core.images_t");
  if (!reader.Skip(8)) return "truncated at utime";
  int32_t n_images = 0;
  // A type (2) and an image (8 + 5 x 4 + 4) per entry.
  if (std::string e = ReadCount(&reader, "n_images", 34, &n_images); !e.empty()) return e;
  if (!reader.Skip(2 * int64_t{n_images})) return "truncated at image_types";
  for (int32_t i = 0; i < n_images; ++i) {
    const std::string field = "images[" + std::to_string(i) + "]";
    int32_t data_size = 0;
    if (!reader.Skip(8 + 4 * 4) || !reader.I32(&data_size)) return "truncated at " + field;
    if (data_size < 0 || !reader.Skip(data_size))
      return field + ".size declares " + std::to_string(data_size) + " bytes but " +
             std::to_string(reader.remaining()) + " remain";
    int32_t nmetadata = 0;
    if (std::string e = ReadCount(&reader, field + ".nmetadata", 9, &nmetadata); !e.empty())
      return e;
    for (int32_t m = 0; m < nmetadata; ++m) {
      if (std::string e = SkipString(&reader, field + ".metadata.key"); !e.empty()) return e;
      int32_t n = 0;
      if (!reader.I32(&n) || n < 0 || !reader.Skip(n)) return "truncated at " + field + ".metadata";
    }
  }
  return {};
}

namespace {

// ---- Shared conversion helpers ------------------------------------------------------------

// Inflates zlib `compressed` into exactly `expected_bytes` bytes.
std::vector<uint8_t> Inflate(const std::vector<uint8_t>& compressed, int64_t expected_bytes,
                             const std::string& what) {
  std::vector<uint8_t> raw(static_cast<size_t>(expected_bytes));
  uLongf raw_size = static_cast<uLongf>(expected_bytes);
  const int status =
      uncompress(raw.data(), &raw_size, compressed.data(), static_cast<uLong>(compressed.size()));
  if (status == Z_BUF_ERROR)
    G6D_THROW(what << ": zlib data inflates to more than the " << expected_bytes
                   << " bytes the image size needs");
  if (status != Z_OK) G6D_THROW(what << ": zlib data is corrupted (" << zError(status) << ")");
  if (static_cast<int64_t>(raw_size) != expected_bytes)
    G6D_THROW(what << ": zlib data inflates to " << raw_size << " bytes, the image size needs "
                   << expected_bytes);
  return raw;
}

void CheckSize(int64_t width, int64_t height, const DecodeLimits& limits, const std::string& what) {
  if (width < 1 || height < 1 || width > limits.max_width || height > limits.max_height)
    G6D_THROW(what << ": size " << width << "x" << height << " is outside 1x1.." << limits.max_width
                   << "x" << limits.max_height);
}

// A cv::Mat of `type` from raw rows `row_stride` bytes apart (row_stride 0 = packed).
cv::Mat FromRaw(const std::vector<uint8_t>& raw, int width, int height, int64_t row_stride,
                int type, const DecodeLimits& limits, const std::string& what) {
  const int64_t row_bytes = int64_t{width} * CV_ELEM_SIZE(type);
  if (row_stride == 0) row_stride = row_bytes;
  if (row_stride < row_bytes)
    G6D_THROW(what << ": row_stride " << row_stride << " is smaller than a row of " << row_bytes
                   << " bytes (" << width << " pixels)");
  if (row_stride * height > limits.max_raw_bytes)
    G6D_THROW(what << ": " << row_stride * height << " raw bytes exceed the limit of "
                   << limits.max_raw_bytes);
  const int64_t needed = row_stride * (height - 1) + row_bytes;
  if (static_cast<int64_t>(raw.size()) < needed)
    G6D_THROW(what << ": " << raw.size() << " bytes hold no " << width << "x" << height
                   << " image with row_stride " << row_stride << " (needs " << needed << ")");
  cv::Mat image(height, width, type);
  for (int v = 0; v < height; ++v)
    std::memcpy(image.ptr(v), raw.data() + row_stride * v, static_cast<size_t>(row_bytes));
  return image;
}

// Any 8-bit colour layout -> CV_8UC3 RGB.
cv::Mat ToRgb(const cv::Mat& image, bool bgr_order) {
  cv::Mat rgb;
  switch (image.channels()) {
    case 1:
      cv::cvtColor(image, rgb, cv::COLOR_GRAY2RGB);
      break;
    case 3:
      if (bgr_order) {
        cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
      } else {
        rgb = image;
      }
      break;
    case 4:
      cv::cvtColor(image, rgb, bgr_order ? cv::COLOR_BGRA2RGB : cv::COLOR_RGBA2RGB);
      break;
    default:
      G6D_CHECK(false && "colour images have 1, 3 or 4 channels");
  }
  return rgb;
}

// Keeps the label values the map names (0 elsewhere) as CV_16U; the named values that
// have pixels, in increasing order.
cv::Mat MapLabels(const cv::Mat& labels, const std::map<int32_t, std::string>& label_objects,
                  std::vector<int32_t>* present) {
  cv::Mat as_int;
  labels.convertTo(as_int, CV_32S);
  cv::Mat mapped(labels.size(), CV_16U, cv::Scalar(0));
  std::set<int32_t> seen;
  for (int v = 0; v < as_int.rows; ++v) {
    const int32_t* in = as_int.ptr<int32_t>(v);
    uint16_t* out = mapped.ptr<uint16_t>(v);
    for (int u = 0; u < as_int.cols; ++u) {
      const int32_t label = in[u];
      if (label <= 0 || label > 65535 || label_objects.count(label) == 0) continue;
      out[u] = static_cast<uint16_t>(label);
      seen.insert(label);
    }
  }
  present->assign(seen.begin(), seen.end());
  return mapped;
}

// The g6d frame of decoded planes: colour CV_8UC3 RGB, depth CV_32F metres or CV_16U mm,
// labels CV_16U (only named labels).
rgbd_frame_t MakeFrame(const cv::Mat& rgb, const cv::Mat& depth, const cv::Mat& labels,
                       const std::vector<int32_t>& present, const AdapterOptions& options,
                       const std::string& what) {
  if (rgb.cols != options.camera.width || rgb.rows != options.camera.height)
    G6D_THROW(what << ": the camera YAML says " << options.camera.width << "x"
                   << options.camera.height << " but the colour image is " << rgb.cols << "x"
                   << rgb.rows);
  rgbd_frame_t frame;
  frame.utime = 0;
  frame.seq = -1;
  frame.scene_id = -1;  // foreign messages carry no dataset ids
  frame.image_id = -1;
  frame.fx = options.camera.fx;
  frame.fy = options.camera.fy;
  frame.cx = options.camera.cx;
  frame.cy = options.camera.cy;
  frame.color = EncodeImage(rgb, image_t::FORMAT_RGB8, image_t::COMPRESSION_NONE);
  if (depth.type() == CV_32F) {
    frame.depth_scale_m = 1.0;
    frame.depth = EncodeImage(depth, image_t::FORMAT_DEPTH_F32, image_t::COMPRESSION_NONE);
  } else {
    frame.depth_scale_m = 0.001;
    frame.depth = EncodeImage(depth, image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_NONE);
  }
  frame.labels = EncodeImage(labels, image_t::FORMAT_LABEL_U16, image_t::COMPRESSION_NONE);
  for (int32_t label : present) {
    instance_t instance{};  // {}: no box, no candidates (lcm-gen leaves members uninitialized)
    instance.object_id = options.label_objects.at(label);
    instance.label = label;
    instance.score = 1.0f;
    instance.gt_index = -1;
    frame.instances.push_back(instance);
  }
  for (const auto& [object_id, count] : options.find_objects) {
    instance_t instance{};  // label 0, no box: a detection request
    instance.object_id = object_id;
    instance.score = 1.0f;
    instance.gt_index = -1;
    instance.count = count;
    frame.instances.push_back(instance);
  }
  frame.num_instances = static_cast<int32_t>(frame.instances.size());
  return frame;
}

template <typename Message>
Message DecodeChecked(const void* data, int64_t size, const std::string& check,
                      const std::string& what) {
  if (!check.empty()) G6D_THROW(what << ": message did not decode: " << check);
  if (size > std::numeric_limits<int>::max())
    G6D_THROW(what << ": " << size << " bytes is too large");
  Message message;
  if (message.decode(data, 0, static_cast<int>(size)) < 0)
    G6D_THROW(what << ": message did not decode (malformed)");
  return message;
}

// ---- Drake ----------------------------------------------------------------------------------

using drake::lcmt_image;

std::string DrakePixelFormatName(int8_t format) {
  switch (format) {
    case lcmt_image::PIXEL_FORMAT_GRAY:
      return "GRAY";
    case lcmt_image::PIXEL_FORMAT_RGB:
      return "RGB";
    case lcmt_image::PIXEL_FORMAT_BGR:
      return "BGR";
    case lcmt_image::PIXEL_FORMAT_RGBA:
      return "RGBA";
    case lcmt_image::PIXEL_FORMAT_BGRA:
      return "BGRA";
    case lcmt_image::PIXEL_FORMAT_DEPTH:
      return "DEPTH";
    case lcmt_image::PIXEL_FORMAT_LABEL:
      return "LABEL";
    case lcmt_image::PIXEL_FORMAT_MASK:
      return "MASK";
    case lcmt_image::PIXEL_FORMAT_DISPARITY:
      return "DISPARITY";
  }
  return "pixel_format " + std::to_string(format);
}

bool IsDrakeColor(int8_t format) {
  return format == lcmt_image::PIXEL_FORMAT_GRAY || format == lcmt_image::PIXEL_FORMAT_RGB ||
         format == lcmt_image::PIXEL_FORMAT_BGR || format == lcmt_image::PIXEL_FORMAT_RGBA ||
         format == lcmt_image::PIXEL_FORMAT_BGRA;
}

int DrakeChannels(int8_t format) {
  switch (format) {
    case lcmt_image::PIXEL_FORMAT_RGB:
    case lcmt_image::PIXEL_FORMAT_BGR:
      return 3;
    case lcmt_image::PIXEL_FORMAT_RGBA:
    case lcmt_image::PIXEL_FORMAT_BGRA:
      return 4;
    default:
      return 1;
  }
}

// The OpenCV depth (CV_8U, ...) of a channel type; -1 when g6d does not read it.
int DrakeCvDepth(int8_t channel_type) {
  switch (channel_type) {
    case lcmt_image::CHANNEL_TYPE_UINT8:
      return CV_8U;
    case lcmt_image::CHANNEL_TYPE_INT16:
      return CV_16S;
    case lcmt_image::CHANNEL_TYPE_UINT16:
      return CV_16U;
    case lcmt_image::CHANNEL_TYPE_FLOAT32:
      return CV_32F;
  }
  return -1;
}

// Decodes one lcmt_image to a cv::Mat of its own layout (channel order as stored).
cv::Mat DecodeDrakeImage(const lcmt_image& image, const DecodeLimits& limits,
                         const std::string& what) {
  CheckSize(image.width, image.height, limits, what);
  if (image.bigendian) G6D_THROW(what << ": big-endian data is not supported");
  const int depth = DrakeCvDepth(image.channel_type);
  if (depth < 0) G6D_THROW(what << ": channel_type " << int{image.channel_type} << " is not read");
  const int type = CV_MAKETYPE(depth, DrakeChannels(image.pixel_format));
  const int64_t packed_bytes = int64_t{image.width} * image.height * CV_ELEM_SIZE(type);
  if (packed_bytes > limits.max_raw_bytes)
    G6D_THROW(what << ": " << packed_bytes << " raw bytes exceed the limit of "
                   << limits.max_raw_bytes);
  switch (image.compression_method) {
    case lcmt_image::COMPRESSION_METHOD_NOT_COMPRESSED:
      return FromRaw(image.data, image.width, image.height, image.row_stride, type, limits, what);
    case lcmt_image::COMPRESSION_METHOD_ZLIB: {
      // Drake's writer compresses the packed pixels; row_stride names the packed row.
      const int64_t stride =
          image.row_stride > 0 ? image.row_stride : int64_t{image.width} * CV_ELEM_SIZE(type);
      const std::vector<uint8_t> raw = Inflate(image.data, stride * image.height, what);
      return FromRaw(raw, image.width, image.height, stride, type, limits, what);
    }
    case lcmt_image::COMPRESSION_METHOD_PNG:
    case lcmt_image::COMPRESSION_METHOD_JPEG: {
      const bool jpeg = image.compression_method == lcmt_image::COMPRESSION_METHOD_JPEG;
      if (jpeg && depth != CV_8U) G6D_THROW(what << ": JPEG is only for 8-bit colour images");
      cv::Mat decoded;
      try {
        decoded = cv::imdecode(image.data, cv::IMREAD_UNCHANGED);
      } catch (const cv::Exception& e) {
        G6D_THROW(what << ": corrupted " << (jpeg ? "JPEG" : "PNG") << " payload: " << e.what());
      }
      if (decoded.empty())
        G6D_THROW(what << ": corrupted " << (jpeg ? "JPEG" : "PNG") << " payload");
      if (decoded.cols != image.width || decoded.rows != image.height || decoded.depth() != depth ||
          decoded.channels() != CV_MAT_CN(type)) {
        G6D_THROW(what << ": payload decodes to " << decoded.cols << "x" << decoded.rows << " "
                       << cv::typeToString(decoded.type()) << ", the message says " << image.width
                       << "x" << image.height << " " << cv::typeToString(type));
      }
      // OpenCV decodes colour to BGR(A) order: store it back in the message's order.
      if (decoded.channels() == 3 && image.pixel_format == lcmt_image::PIXEL_FORMAT_RGB)
        cv::cvtColor(decoded, decoded, cv::COLOR_BGR2RGB);
      if (decoded.channels() == 4 && image.pixel_format == lcmt_image::PIXEL_FORMAT_RGBA)
        cv::cvtColor(decoded, decoded, cv::COLOR_BGRA2RGBA);
      return decoded;
    }
  }
  G6D_THROW(what << ": unknown compression_method " << int{image.compression_method});
}

rgbd_frame_t AdaptDrake(const void* data, int64_t size, const AdapterOptions& options,
                        const DecodeLimits& limits, FrameHeader* header) {
  const auto message = DecodeChecked<drake::lcmt_image_array>(
      data, size, CheckEncodedDrakeImageArray(data, size), "drake");
  header->utime = message.header.utime;
  header->seq = message.header.seq;
  const lcmt_image *color = nullptr, *depth = nullptr, *labels = nullptr;
  for (const lcmt_image& image : message.images) {
    if (IsDrakeColor(image.pixel_format) && color == nullptr) color = &image;
    if (image.pixel_format == lcmt_image::PIXEL_FORMAT_DEPTH && depth == nullptr) depth = &image;
    if (image.pixel_format == lcmt_image::PIXEL_FORMAT_LABEL && labels == nullptr) labels = &image;
  }
  const std::string among = " among the " + std::to_string(message.images.size()) + " images";
  if (color == nullptr) G6D_THROW("drake: no colour image (RGB, RGBA, BGR, BGRA or GRAY)" << among);
  if (depth == nullptr) G6D_THROW("drake: no DEPTH image" << among);
  if (labels == nullptr && options.find_objects.empty())
    G6D_THROW("drake: no LABEL image (instance labels)" << among << ", and no objects to find (find)");

  const std::string color_what =
      "drake: colour image (" + DrakePixelFormatName(color->pixel_format) + ")";
  if (color->channel_type != lcmt_image::CHANNEL_TYPE_UINT8)
    G6D_THROW(color_what << ": channel_type " << int{color->channel_type} << ", expected UINT8");
  const cv::Mat rgb = ToRgb(DecodeDrakeImage(*color, limits, color_what),
                            color->pixel_format == lcmt_image::PIXEL_FORMAT_BGR ||
                                color->pixel_format == lcmt_image::PIXEL_FORMAT_BGRA);

  if (depth->channel_type != lcmt_image::CHANNEL_TYPE_FLOAT32 &&
      depth->channel_type != lcmt_image::CHANNEL_TYPE_UINT16)
    G6D_THROW("drake: depth image: channel_type " << int{depth->channel_type}
                                                  << ", expected FLOAT32 (metres) or UINT16 (mm)");
  const cv::Mat depth_image = DecodeDrakeImage(*depth, limits, "drake: depth image");

  std::vector<int32_t> present;
  cv::Mat mapped = cv::Mat::zeros(rgb.size(), CV_16U);  // no label image: only objects to find
  if (labels != nullptr) {
    if (labels->channel_type != lcmt_image::CHANNEL_TYPE_INT16 &&
        labels->channel_type != lcmt_image::CHANNEL_TYPE_UINT16 &&
        labels->channel_type != lcmt_image::CHANNEL_TYPE_UINT8)
      G6D_THROW("drake: label image: channel_type " << int{labels->channel_type}
                                                    << ", expected INT16, UINT16 or UINT8");
    mapped = MapLabels(DecodeDrakeImage(*labels, limits, "drake: label image"), options.label_objects, &present);
  }

  rgbd_frame_t frame = MakeFrame(rgb, depth_image, mapped, present, options, "drake");
  frame.utime = message.header.utime;
  frame.seq = message.header.seq;
  frame.camera_id = options.camera_id.empty() ? color->header.frame_name : options.camera_id;
  frame.source = "drake";
  return frame;
}

// ---- bot_core -------------------------------------------------------------------------------

using BotImage = bot_core::image_t;
using bot_core::images_t;

std::string BotPixelFormatName(int32_t format) {
  switch (format) {
    case BotImage::PIXEL_FORMAT_MJPEG:
      return "MJPEG";
    case BotImage::PIXEL_FORMAT_RGB:
      return "RGB";
    case BotImage::PIXEL_FORMAT_BGR:
      return "BGR";
    case BotImage::PIXEL_FORMAT_RGBA:
      return "RGBA";
    case BotImage::PIXEL_FORMAT_BGRA:
      return "BGRA";
    case BotImage::PIXEL_FORMAT_GRAY:
      return "GRAY";
    case BotImage::PIXEL_FORMAT_LE_GRAY16:
      return "LE_GRAY16";
    case BotImage::PIXEL_FORMAT_BE_GRAY16:
      return "BE_GRAY16";
    case BotImage::PIXEL_FORMAT_INVALID:
      return "INVALID";
  }
  return "pixelformat " + std::to_string(format);
}

cv::Mat DecodeBotColor(const BotImage& image, const DecodeLimits& limits) {
  const std::string what = "bot_core: LEFT image (" + BotPixelFormatName(image.pixelformat) + ")";
  CheckSize(image.width, image.height, limits, what);
  if (image.pixelformat == BotImage::PIXEL_FORMAT_MJPEG) {
    cv::Mat decoded;
    try {
      decoded = cv::imdecode(image.data, cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION);
    } catch (const cv::Exception& e) {
      G6D_THROW(what << ": corrupted JPEG payload: " << e.what());
    }
    if (decoded.empty()) G6D_THROW(what << ": corrupted JPEG payload (decoder failed)");
    if (decoded.cols != image.width || decoded.rows != image.height)
      G6D_THROW(what << ": JPEG is " << decoded.cols << "x" << decoded.rows << ", the message says "
                     << image.width << "x" << image.height);
    return ToRgb(decoded, /*bgr_order=*/true);
  }
  int channels = 0;
  bool bgr = false;
  switch (image.pixelformat) {
    case BotImage::PIXEL_FORMAT_GRAY:
      channels = 1;
      break;
    case BotImage::PIXEL_FORMAT_RGB:
      channels = 3;
      break;
    case BotImage::PIXEL_FORMAT_BGR:
      channels = 3;
      bgr = true;
      break;
    case BotImage::PIXEL_FORMAT_RGBA:
      channels = 4;
      break;
    case BotImage::PIXEL_FORMAT_BGRA:
      channels = 4;
      bgr = true;
      break;
    default:
      G6D_THROW(what << ": not a colour format g6d reads (MJPEG, RGB, BGR, RGBA, BGRA, GRAY)");
  }
  return ToRgb(FromRaw(image.data, image.width, image.height, image.row_stride,
                       CV_MAKETYPE(CV_8U, channels), limits, what),
               bgr);
}

// Depth in millimetres as CV_16U: raw (DEPTH_MM) or zlib (DEPTH_MM_ZIPPED) 16-bit pixels,
// little-endian unless the pixel format says BE_GRAY16.
cv::Mat DecodeBotDepth(const BotImage& image, bool zipped, const DecodeLimits& limits) {
  const std::string what =
      std::string("bot_core: ") + (zipped ? "DEPTH_MM_ZIPPED" : "DEPTH_MM") + " image";
  CheckSize(image.width, image.height, limits, what);
  const int64_t row_bytes = int64_t{image.width} * 2;
  const int64_t stride = image.row_stride >= row_bytes ? image.row_stride : row_bytes;
  if (stride * image.height > limits.max_raw_bytes)
    G6D_THROW(what << ": " << stride * image.height << " raw bytes exceed the limit of "
                   << limits.max_raw_bytes);
  cv::Mat depth =
      zipped ? FromRaw(Inflate(image.data, stride * image.height, what), image.width, image.height,
                       stride, CV_16U, limits, what)
             : FromRaw(image.data, image.width, image.height, stride, CV_16U, limits, what);
  if (image.pixelformat == BotImage::PIXEL_FORMAT_BE_GRAY16) {
    for (int v = 0; v < depth.rows; ++v) {
      uint16_t* row = depth.ptr<uint16_t>(v);
      for (int u = 0; u < depth.cols; ++u)
        row[u] = static_cast<uint16_t>((row[u] >> 8) | (row[u] << 8));
    }
  }
  return depth;
}

// MASK_ZIPPED: zlib-compressed labels of 8 or 16 bits (from the inflated size).
cv::Mat DecodeBotMask(const BotImage& image, const DecodeLimits& limits) {
  const std::string what = "bot_core: MASK_ZIPPED image";
  CheckSize(image.width, image.height, limits, what);
  const int64_t pixels = int64_t{image.width} * image.height;
  if (2 * pixels > limits.max_raw_bytes)
    G6D_THROW(what << ": " << 2 * pixels << " raw bytes exceed the limit of "
                   << limits.max_raw_bytes);
  // Inflate into room for 16-bit labels; the inflated size says which.
  std::vector<uint8_t> raw(static_cast<size_t>(2 * pixels));
  uLongf raw_size = static_cast<uLongf>(raw.size());
  const int status =
      uncompress(raw.data(), &raw_size, image.data.data(), static_cast<uLong>(image.data.size()));
  if (status != Z_OK) G6D_THROW(what << ": zlib data is corrupted (" << zError(status) << ")");
  int type = -1;
  if (static_cast<int64_t>(raw_size) == pixels) type = CV_8U;
  if (static_cast<int64_t>(raw_size) == 2 * pixels) type = CV_16U;
  if (type < 0)
    G6D_THROW(what << ": zlib data inflates to " << raw_size << " bytes, expected " << pixels
                   << " (8-bit labels) or " << 2 * pixels << " (16-bit) for " << image.width << "x"
                   << image.height);
  raw.resize(raw_size);
  return FromRaw(raw, image.width, image.height, 0, type, limits, what);
}

rgbd_frame_t AdaptBotCore(const void* data, int64_t size, const AdapterOptions& options,
                          const DecodeLimits& limits, int64_t seq, FrameHeader* header) {
  const auto message =
      DecodeChecked<images_t>(data, size, CheckEncodedBotCoreImages(data, size), "bot_core");
  header->utime = message.utime;
  header->seq = seq;
  const BotImage *color = nullptr, *depth = nullptr, *mask = nullptr;
  bool depth_zipped = false;
  for (size_t i = 0; i < message.images.size(); ++i) {
    const int16_t type = message.image_types[i];
    if (type == images_t::LEFT && color == nullptr) color = &message.images[i];
    if ((type == images_t::DEPTH_MM || type == images_t::DEPTH_MM_ZIPPED) && depth == nullptr) {
      depth = &message.images[i];
      depth_zipped = type == images_t::DEPTH_MM_ZIPPED;
    }
    if (type == images_t::MASK_ZIPPED && mask == nullptr) mask = &message.images[i];
  }
  const std::string among = " among the " + std::to_string(message.images.size()) + " images";
  if (color == nullptr) G6D_THROW("bot_core: no LEFT (colour) image" << among);
  if (depth == nullptr) G6D_THROW("bot_core: no DEPTH_MM or DEPTH_MM_ZIPPED image" << among);
  if (mask == nullptr && options.find_objects.empty())
    G6D_THROW("bot_core: no MASK_ZIPPED image (instance labels)" << among << ", and no objects to find (find)");

  const cv::Mat rgb = DecodeBotColor(*color, limits);
  const cv::Mat depth_mm = DecodeBotDepth(*depth, depth_zipped, limits);
  std::vector<int32_t> present;
  const cv::Mat mapped = mask != nullptr ? MapLabels(DecodeBotMask(*mask, limits), options.label_objects, &present)
                                         : cv::Mat(cv::Mat::zeros(rgb.size(), CV_16U));
  rgbd_frame_t frame = MakeFrame(rgb, depth_mm, mapped, present, options, "bot_core");
  frame.utime = message.utime;
  frame.seq = seq;
  frame.camera_id = options.camera_id.empty() ? "bot_core" : options.camera_id;
  frame.source = "bot_core";
  return frame;
}

// ---- YAML -------------------------------------------------------------------------------------

YAML::Node LoadYamlText(const std::string& text, const std::string& name) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    G6D_THROW(name << ": not valid YAML: " << e.what());
  }
}

std::string ReadFile(const std::string& path, const std::string& what) {
  std::ifstream file(path);
  if (!file) G6D_THROW(path << ": cannot open the " << what << " file");
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

template <typename T>
T Get(const YAML::Node& node, const std::string& key, const std::string& name) {
  if (!node[key]) G6D_THROW(name << ": key '" << key << "' is missing");
  try {
    return node[key].as<T>();
  } catch (const YAML::Exception&) {
    G6D_THROW(name << ": key '" << key << "' has a value of the wrong type");
  }
}

}  // namespace

std::string InputTypeName(InputType type) {
  switch (type) {
    case InputType::kG6d:
      return "g6d";
    case InputType::kDrake:
      return "drake";
    case InputType::kBotCore:
      return "bot_core";
  }
  return "unknown";
}

InputType ParseInputType(const std::string& text) {
  for (InputType type : {InputType::kG6d, InputType::kDrake, InputType::kBotCore})
    if (text == InputTypeName(type)) return type;
  G6D_THROW("input type '" << text << "' is not one of g6d, drake, bot_core");
}

std::string AdapterOptions::Check(InputType type) const {
  if (type == InputType::kG6d) return {};
  std::ostringstream out;
  if (!(camera.fx > 0.0) || !(camera.fy > 0.0) || !std::isfinite(camera.fx) ||
      !std::isfinite(camera.fy))
    out << "camera: fx and fy must be > 0 (got " << camera.fx << ", " << camera.fy << "; the "
        << InputTypeName(type) << " input needs a camera YAML)";
  else if (!std::isfinite(camera.cx) || !std::isfinite(camera.cy))
    out << "camera: cx and cy must be finite";
  else if (camera.width < 1 || camera.height < 1)
    out << "camera: width and height must be >= 1 (got " << camera.width << "x" << camera.height
        << ")";
  else if (label_objects.empty() && find_objects.empty())
    out << "labels: the " << InputTypeName(type)
        << " input needs a label map (label value -> object id) or objects to find (find)";
  for (const auto& [object_id, count] : find_objects) {
    if (!out.str().empty()) break;
    if (object_id.empty())
      out << "find: an empty object id";
    else if (count < 1)
      out << "find: object " << object_id << " has count " << count << " (must be >= 1)";
  }
  for (const auto& [label, object_id] : label_objects) {
    if (!out.str().empty()) break;
    if (label <= 0 || label > 65535)
      out << "labels: label " << label << " is outside 1..65535";
    else if (object_id.empty())
      out << "labels: label " << label << " has an empty object id";
  }
  return out.str();
}

Camera ParseCameraYaml(const std::string& text, const std::string& name) {
  YAML::Node root = LoadYamlText(text, name);
  if (!root.IsMap()) G6D_THROW(name << ": a camera file must be a mapping");
  if (root["intrinsic_cal"]) root = root["intrinsic_cal"];
  Camera camera;
  if (root["pinhole"]) {
    // bot-param: pinhole = [fx, fy, skew, cx, cy].
    const std::vector<double> pinhole = Get<std::vector<double>>(root, "pinhole", name);
    if (pinhole.size() != 5)
      G6D_THROW(name << ": key 'pinhole' must be [fx, fy, skew, cx, cy] (got " << pinhole.size()
                     << " numbers)");
    if (pinhole[2] != 0.0)
      G6D_THROW(name << ": pinhole skew " << pinhole[2] << " is not supported (must be 0)");
    camera.fx = pinhole[0];
    camera.fy = pinhole[1];
    camera.cx = pinhole[3];
    camera.cy = pinhole[4];
  } else {
    camera.fx = Get<double>(root, "fx", name);
    camera.fy = Get<double>(root, "fy", name);
    camera.cx = Get<double>(root, "cx", name);
    camera.cy = Get<double>(root, "cy", name);
  }
  camera.width = Get<int>(root, "width", name);
  camera.height = Get<int>(root, "height", name);
  return camera;
}

Camera LoadCameraYaml(const std::string& path) {
  return ParseCameraYaml(ReadFile(path, "camera"), path);
}

std::map<int32_t, std::string> ParseLabelMapYaml(const std::string& text, const std::string& name) {
  YAML::Node root = LoadYamlText(text, name);
  if (root.IsMap() && root["labels"]) root = root["labels"];
  if (!root.IsMap())
    G6D_THROW(name << ": a label map must be a mapping of label value to object id");
  std::map<int32_t, std::string> labels;
  for (const auto& entry : root) {
    int32_t label = 0;
    std::string object_id;
    try {
      label = entry.first.as<int32_t>();
      object_id = entry.second.as<std::string>();
    } catch (const YAML::Exception&) {
      G6D_THROW(name << ": label map entry '" << entry.first.Scalar()
                     << "' must map an integer label to an object id");
    }
    if (label <= 0 || label > 65535)
      G6D_THROW(name << ": label " << label << " is outside 1..65535");
    if (object_id.empty()) G6D_THROW(name << ": label " << label << " has an empty object id");
    labels[label] = object_id;
  }
  return labels;
}

std::map<int32_t, std::string> LoadLabelMapYaml(const std::string& path) {
  return ParseLabelMapYaml(ReadFile(path, "label map"), path);
}

rgbd_frame_t AdaptMessage(InputType type, const void* data, int64_t size,
                          const AdapterOptions& options, const DecodeLimits& limits, int64_t seq,
                          FrameHeader* header) {
  FrameHeader ignored;
  if (header == nullptr) header = &ignored;
  switch (type) {
    case InputType::kG6d: {
      try {
        return DecodeRgbdFrameMessage(data, size);
      } catch (const Error&) {
        PeekRgbdFrameIds(data, size, &header->utime, &header->seq);
        throw;
      }
    }
    case InputType::kDrake:
      return AdaptDrake(data, size, options, limits, header);
    case InputType::kBotCore:
      return AdaptBotCore(data, size, options, limits, seq, header);
  }
  G6D_THROW("unknown input type");
}

}  // namespace g6d
