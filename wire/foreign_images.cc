#include "wire/foreign_images.h"

#include <zlib.h>

#include "core/error.h"

namespace g6d {

std::vector<uint8_t> PixelBytes(const cv::Mat& image) {
  const cv::Mat packed = image.isContinuous() ? image : image.clone();
  return std::vector<uint8_t>(packed.datastart, packed.dataend);
}

std::vector<uint8_t> ZlibCompress(const std::vector<uint8_t>& raw, int level) {
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::vector<uint8_t> out(size);
  if (compress2(out.data(), &size, raw.data(), static_cast<uLong>(raw.size()), level) != Z_OK) {
    G6D_THROW("zlib compression of " << raw.size() << " bytes failed");
  }
  out.resize(size);
  return out;
}

drake::lcmt_image MakeDrakeImage(const cv::Mat& image, int8_t pixel_format, int8_t channel_type, bool zlib,
                                 int32_t seq, int64_t utime, const std::string& frame_name) {
  drake::lcmt_image message;
  message.header.seq = seq;
  message.header.utime = utime;
  message.header.frame_name = frame_name;
  message.width = image.cols;
  message.height = image.rows;
  message.row_stride = static_cast<int32_t>(image.cols * image.elemSize());
  message.bigendian = false;
  message.pixel_format = pixel_format;
  message.channel_type = channel_type;
  message.compression_method = zlib ? drake::lcmt_image::COMPRESSION_METHOD_ZLIB
                                    : drake::lcmt_image::COMPRESSION_METHOD_NOT_COMPRESSED;
  message.data = zlib ? ZlibCompress(PixelBytes(image)) : PixelBytes(image);
  message.size = static_cast<int32_t>(message.data.size());
  return message;
}

bot_core::image_t MakeBotCoreImage(const cv::Mat& image, int32_t pixelformat, std::vector<uint8_t> data,
                                   int64_t utime) {
  bot_core::image_t message;
  message.utime = utime;
  message.width = image.cols;
  message.height = image.rows;
  message.row_stride = static_cast<int32_t>(image.cols * image.elemSize());
  message.pixelformat = pixelformat;
  message.data = std::move(data);
  message.size = static_cast<int32_t>(message.data.size());
  message.nmetadata = 0;
  return message;
}

}  // namespace g6d
