#include "wire/frame_codec.h"

#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/camera.h"
#include "core/error.h"

// image_t multi-byte pixels are little-endian on the wire; decoding copies bytes as they
// are, which is only right on a little-endian host.
#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "frame_codec assumes a little-endian host (image_t pixels are little-endian)"
#endif

namespace g6d {
namespace {

bool IsColorFormat(int8_t format) {
  return format == image_t::FORMAT_RGB8 || format == image_t::FORMAT_BGR8 ||
         format == image_t::FORMAT_MONO8;
}

bool IsKnownCompression(int8_t compression) {
  return compression == image_t::COMPRESSION_NONE || compression == image_t::COMPRESSION_ZSTD ||
         compression == image_t::COMPRESSION_PNG || compression == image_t::COMPRESSION_JPEG;
}

// Empty when `compression` can carry `format`, else why not.
std::string CompressionSupportError(int8_t format, int8_t compression) {
  std::ostringstream out;
  if (compression == image_t::COMPRESSION_JPEG && !IsColorFormat(format)) {
    out << "JPEG compression is only for RGB8, BGR8 and MONO8 (lossy), not "
        << PixelFormatName(format);
  } else if (compression == image_t::COMPRESSION_PNG && format == image_t::FORMAT_DEPTH_F32) {
    out << "PNG compression cannot hold DEPTH_F32 (use ZSTD or NONE)";
  }
  return out.str();
}

// ---- zstd with one reusable context per thread ---------------------------------------

struct ZstdDCtxDeleter {
  void operator()(ZSTD_DCtx* context) const { ZSTD_freeDCtx(context); }
};
struct ZstdCCtxDeleter {
  void operator()(ZSTD_CCtx* context) const { ZSTD_freeCCtx(context); }
};

ZSTD_DCtx* ThreadDecompressionContext() {
  thread_local std::unique_ptr<ZSTD_DCtx, ZstdDCtxDeleter> context(ZSTD_createDCtx());
  if (!context) G6D_THROW("cannot create a zstd decompression context");
  return context.get();
}

ZSTD_CCtx* ThreadCompressionContext() {
  thread_local std::unique_ptr<ZSTD_CCtx, ZstdCCtxDeleter> context(ZSTD_createCCtx());
  if (!context) G6D_THROW("cannot create a zstd compression context");
  return context.get();
}

std::vector<uint8_t> ZstdCompress(const uint8_t* data, size_t size, int level) {
  ZSTD_CCtx* context = ThreadCompressionContext();
  ZSTD_CCtx_reset(context, ZSTD_reset_session_and_parameters);
  auto check = [](size_t code, const char* what) {
    if (ZSTD_isError(code))
      G6D_THROW("EncodeImage: zstd " << what << ": " << ZSTD_getErrorName(code));
  };
  check(ZSTD_CCtx_setParameter(context, ZSTD_c_compressionLevel, level), "level");
  // The frame checksum makes corrupted payloads fail loudly instead of decoding to noise.
  check(ZSTD_CCtx_setParameter(context, ZSTD_c_checksumFlag, 1), "checksum flag");
  check(ZSTD_CCtx_setParameter(context, ZSTD_c_contentSizeFlag, 1), "content size flag");
  std::vector<uint8_t> out(ZSTD_compressBound(size));
  const size_t written = ZSTD_compress2(context, out.data(), out.size(), data, size);
  check(written, "compress");
  out.resize(written);
  return out;
}

// ---- PNG / JPEG headers: the declared size, read before the codec allocates ----------

uint32_t ReadBigEndian32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

// Width and height from the IHDR chunk of a PNG file; false when it is not one.
bool PngSize(const std::vector<uint8_t>& bytes, int64_t* width, int64_t* height) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (bytes.size() < 33 || std::memcmp(bytes.data(), kSignature, 8) != 0) return false;
  if (std::memcmp(bytes.data() + 12, "IHDR", 4) != 0) return false;
  *width = ReadBigEndian32(bytes.data() + 16);
  *height = ReadBigEndian32(bytes.data() + 20);
  return true;
}

// Width and height from the first SOFn segment of a JPEG file; false when there is none
// before the scan data or the segment structure is broken.
bool JpegSize(const std::vector<uint8_t>& bytes, int64_t* width, int64_t* height) {
  const size_t n = bytes.size();
  if (n < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8) return false;
  size_t pos = 2;
  while (pos + 1 < n) {
    if (bytes[pos] != 0xFF) return false;
    while (pos < n && bytes[pos] == 0xFF) ++pos;  // fill bytes
    if (pos >= n) return false;
    const uint8_t marker = bytes[pos++];
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) continue;  // no length
    if (marker == 0xD9 || marker == 0xDA) return false;                  // EOI/SOS before SOF
    if (pos + 2 > n) return false;
    const size_t length = (size_t{bytes[pos]} << 8) | bytes[pos + 1];
    if (length < 2 || pos + length > n) return false;
    const bool is_sof =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (is_sof) {
      if (length < 7) return false;
      *height = (int64_t{bytes[pos + 3]} << 8) | bytes[pos + 4];
      *width = (int64_t{bytes[pos + 5]} << 8) | bytes[pos + 6];
      return true;
    }
    pos += length;
  }
  return false;
}

// Copies `height` rows of `row_bytes` from `source` (rows `stride` apart) into `image`.
void CopyRows(const uint8_t* source, int64_t stride, int height, int64_t row_bytes,
              cv::Mat* image) {
  for (int v = 0; v < height; ++v) {
    std::memcpy(image->ptr(v), source + stride * v, static_cast<size_t>(row_bytes));
  }
}

// Raw pixels of a continuous copy of `image` (no copy when already continuous).
cv::Mat Continuous(const cv::Mat& image) { return image.isContinuous() ? image : image.clone(); }

// ---- LCM wire walking -----------------------------------------------------------------

// Reads the big-endian LCM wire format with bounds checks; every method returns false
// instead of reading past the end.
class WireReader {
 public:
  WireReader(const void* data, int64_t size)
      : data_(static_cast<const uint8_t*>(data)), size_(size) {}
  int64_t remaining() const { return size_ - pos_; }
  bool Skip(int64_t n) {
    if (n < 0 || n > remaining()) return false;
    pos_ += n;
    return true;
  }
  bool I32(int32_t* value) {
    if (remaining() < 4) return false;
    *value = static_cast<int32_t>(ReadBigEndian32(data_ + pos_));
    pos_ += 4;
    return true;
  }
  bool I64(int64_t* value) {
    if (remaining() < 8) return false;
    const uint64_t high = ReadBigEndian32(data_ + pos_), low = ReadBigEndian32(data_ + pos_ + 4);
    *value = static_cast<int64_t>((high << 32) | low);
    pos_ += 8;
    return true;
  }

 private:
  const uint8_t* data_;
  int64_t size_;
  int64_t pos_ = 0;
};

// Walks a string field: int32 length including the terminating NUL, then the bytes.
std::string CheckString(WireReader* reader, const char* field) {
  int32_t length = 0;
  if (!reader->I32(&length)) return std::string("truncated at ") + field;
  if (length < 1 || length > reader->remaining()) {
    std::ostringstream out;
    out << field << " declares " << length << " bytes but " << reader->remaining() << " remain";
    return out.str();
  }
  reader->Skip(length);
  return {};
}

// Walks an image_t (nested: no fingerprint).
std::string CheckImage(WireReader* reader, const char* field) {
  int32_t size = 0;
  if (!reader->Skip(3 * 4 + 2) || !reader->I32(&size)) return std::string("truncated at ") + field;
  if (size < 0 || size > reader->remaining()) {
    std::ostringstream out;
    out << field << ".size declares " << size << " bytes but " << reader->remaining() << " remain";
    return out.str();
  }
  reader->Skip(size);
  return {};
}

}  // namespace

// ---- Options --------------------------------------------------------------------------

std::string DecodeLimits::Check() const {
  std::ostringstream out;
  if (max_width < 1)
    out << "max_width must be >= 1 (got " << max_width << ")";
  else if (max_height < 1)
    out << "max_height must be >= 1 (got " << max_height << ")";
  else if (max_raw_bytes < 1)
    out << "max_raw_bytes must be >= 1 (got " << max_raw_bytes << ")";
  else if (max_instances < 0)
    out << "max_instances must be >= 0 (got " << max_instances << ")";
  return out.str();
}

std::string EncodeOptions::Check() const {
  std::ostringstream out;
  if (zstd_level < 1 || zstd_level > ZSTD_maxCLevel())
    out << "zstd_level must be in 1.." << ZSTD_maxCLevel() << " (got " << zstd_level << ")";
  else if (png_level < 0 || png_level > 9)
    out << "png_level must be in 0..9 (got " << png_level << ")";
  else if (jpeg_quality < 1 || jpeg_quality > 100)
    out << "jpeg_quality must be in 1..100 (got " << jpeg_quality << ")";
  return out.str();
}

// ---- Formats --------------------------------------------------------------------------

int BytesPerPixel(int8_t pixel_format) {
  switch (pixel_format) {
    case image_t::FORMAT_RGB8:
    case image_t::FORMAT_BGR8:
      return 3;
    case image_t::FORMAT_MONO8:
    case image_t::FORMAT_LABEL_U8:
      return 1;
    case image_t::FORMAT_DEPTH_U16:
    case image_t::FORMAT_LABEL_U16:
      return 2;
    case image_t::FORMAT_DEPTH_F32:
      return 4;
    default:
      return 0;
  }
}

int OpenCvTypeOf(int8_t pixel_format) {
  switch (pixel_format) {
    case image_t::FORMAT_RGB8:
    case image_t::FORMAT_BGR8:
      return CV_8UC3;
    case image_t::FORMAT_MONO8:
    case image_t::FORMAT_LABEL_U8:
      return CV_8UC1;
    case image_t::FORMAT_DEPTH_U16:
    case image_t::FORMAT_LABEL_U16:
      return CV_16UC1;
    case image_t::FORMAT_DEPTH_F32:
      return CV_32FC1;
    default:
      return -1;
  }
}

// ---- EncodeImage ----------------------------------------------------------------------

image_t EncodeImage(const cv::Mat& image, int8_t pixel_format, int8_t compression) {
  return EncodeImage(image, pixel_format, compression, EncodeOptions());
}

image_t EncodeImage(const cv::Mat& image, int8_t pixel_format, int8_t compression,
                    const EncodeOptions& options) {
  if (const std::string error = options.Check(); !error.empty())
    G6D_THROW("EncodeImage: EncodeOptions: " << error);
  const int bytes_per_pixel = BytesPerPixel(pixel_format);
  if (bytes_per_pixel == 0) G6D_THROW("EncodeImage: unknown pixel format " << int{pixel_format});
  if (!IsKnownCompression(compression))
    G6D_THROW("EncodeImage: unknown compression " << int{compression});
  if (const std::string error = CompressionSupportError(pixel_format, compression); !error.empty())
    G6D_THROW("EncodeImage: " << error);
  const int expected_type = OpenCvTypeOf(pixel_format);
  if (image.type() != expected_type) {
    G6D_THROW("EncodeImage: pixel format " << PixelFormatName(pixel_format) << " needs a "
                                           << cv::typeToString(expected_type) << " image (got "
                                           << cv::typeToString(image.type()) << ")");
  }
  if (image.empty()) G6D_THROW("EncodeImage: the image is empty");

  image_t out;
  out.width = image.cols;
  out.height = image.rows;
  out.row_stride = image.cols * bytes_per_pixel;
  out.pixel_format = pixel_format;
  out.compression = compression;
  if (compression == image_t::COMPRESSION_NONE || compression == image_t::COMPRESSION_ZSTD) {
    const cv::Mat raw = Continuous(image);
    const size_t raw_bytes = raw.total() * raw.elemSize();
    if (compression == image_t::COMPRESSION_NONE) {
      out.data.assign(raw.data, raw.data + raw_bytes);
    } else {
      out.data = ZstdCompress(raw.data, raw_bytes, options.zstd_level);
    }
  } else {
    // PNG/JPEG files hold true colours; OpenCV's codecs read and write BGR order.
    cv::Mat file_order;  // never an alias of `image`: cvtColor must not write into it
    if (pixel_format == image_t::FORMAT_RGB8) {
      cv::cvtColor(image, file_order, cv::COLOR_RGB2BGR);
    } else {
      file_order = image;
    }
    std::vector<int> parameters;
    std::string extension;
    if (compression == image_t::COMPRESSION_PNG) {
      extension = ".png";
      parameters = {cv::IMWRITE_PNG_COMPRESSION, options.png_level};
    } else {
      extension = ".jpg";
      parameters = {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality};
    }
    if (!cv::imencode(extension, file_order, out.data, parameters))
      G6D_THROW("EncodeImage: OpenCV could not encode " << extension);
  }
  if (out.data.size() > static_cast<size_t>(std::numeric_limits<int32_t>::max()))
    G6D_THROW("EncodeImage: encoded payload of " << out.data.size() << " bytes exceeds 2 GiB");
  out.size = static_cast<int32_t>(out.data.size());
  return out;
}

// ---- DecodeImage ----------------------------------------------------------------------

cv::Mat DecodeImage(const image_t& image, const std::string& what, const DecodeLimits& limits) {
  if (const std::string error = limits.Check(); !error.empty())
    G6D_THROW(what << ": DecodeLimits: " << error);
  if (image.width <= 0 || image.height <= 0) {
    G6D_THROW(what << ": width and height must be > 0 (got " << image.width << "x" << image.height
                   << ")");
  }
  if (image.width > limits.max_width || image.height > limits.max_height) {
    G6D_THROW(what << ": declared size " << image.width << "x" << image.height
                   << " is too large (limit " << limits.max_width << "x" << limits.max_height
                   << ")");
  }
  const int bytes_per_pixel = BytesPerPixel(image.pixel_format);
  if (bytes_per_pixel == 0) G6D_THROW(what << ": unknown pixel format " << int{image.pixel_format});
  if (!IsKnownCompression(image.compression))
    G6D_THROW(what << ": unknown compression " << int{image.compression});
  if (const std::string error = CompressionSupportError(image.pixel_format, image.compression);
      !error.empty()) {
    G6D_THROW(what << ": " << error);
  }
  const int64_t row_bytes = int64_t{image.width} * bytes_per_pixel;
  if (image.row_stride < row_bytes) {
    G6D_THROW(what << ": row_stride " << image.row_stride
                   << " is smaller than width x bytes per pixel = " << image.width << " x "
                   << bytes_per_pixel << " = " << row_bytes);
  }
  const int64_t raw_bytes = int64_t{image.row_stride} * image.height;
  if (raw_bytes > limits.max_raw_bytes) {
    G6D_THROW(what << ": declared raw size " << raw_bytes << " bytes (row_stride "
                   << image.row_stride << " x height " << image.height << ") is too large (limit "
                   << limits.max_raw_bytes << ")");
  }
  if (image.size != static_cast<int64_t>(image.data.size())) {
    G6D_THROW(what << ": size field says " << image.size << " bytes but data holds "
                   << image.data.size());
  }

  const int type = OpenCvTypeOf(image.pixel_format);
  const std::string format = PixelFormatName(image.pixel_format);
  cv::Mat out(image.height, image.width, type);
  switch (image.compression) {
    case image_t::COMPRESSION_NONE: {
      if (static_cast<int64_t>(image.data.size()) != raw_bytes) {
        G6D_THROW(what << ": payload of " << image.data.size() << " bytes does not match "
                       << image.width << "x" << image.height << " " << format << " with row_stride "
                       << image.row_stride << " (expected " << raw_bytes << " bytes)");
      }
      CopyRows(image.data.data(), image.row_stride, image.height, row_bytes, &out);
      return out;
    }
    case image_t::COMPRESSION_ZSTD: {
      const unsigned long long content_size =
          ZSTD_getFrameContentSize(image.data.data(), image.data.size());
      if (content_size == ZSTD_CONTENTSIZE_ERROR) {
        G6D_THROW(what << ": corrupted zstd payload (" << image.data.size()
                       << " bytes, not a zstd frame)");
      }
      if (content_size != ZSTD_CONTENTSIZE_UNKNOWN &&
          content_size != static_cast<unsigned long long>(raw_bytes)) {
        G6D_THROW(what << ": zstd payload decompresses to " << content_size << " bytes, but "
                       << image.width << "x" << image.height << " " << format << " with row_stride "
                       << image.row_stride << " needs " << raw_bytes);
      }
      // Decompress straight into the image when rows are unpadded; the destination
      // capacity bounds the output, so a lying frame header cannot make it grow.
      std::vector<uint8_t> padded;
      uint8_t* destination = out.data;
      if (image.row_stride != row_bytes) {
        padded.resize(static_cast<size_t>(raw_bytes));
        destination = padded.data();
      }
      const size_t written =
          ZSTD_decompressDCtx(ThreadDecompressionContext(), destination,
                              static_cast<size_t>(raw_bytes), image.data.data(), image.data.size());
      if (ZSTD_isError(written)) {
        G6D_THROW(what << ": corrupted zstd payload: " << ZSTD_getErrorName(written));
      }
      if (static_cast<int64_t>(written) != raw_bytes) {
        G6D_THROW(what << ": zstd payload decompresses to " << written << " bytes, expected "
                       << raw_bytes);
      }
      if (!padded.empty()) CopyRows(padded.data(), image.row_stride, image.height, row_bytes, &out);
      return out;
    }
    case image_t::COMPRESSION_PNG:
    case image_t::COMPRESSION_JPEG: {
      const bool png = image.compression == image_t::COMPRESSION_PNG;
      const char* codec = png ? "PNG" : "JPEG";
      int64_t file_width = 0, file_height = 0;
      const bool header_ok = png ? PngSize(image.data, &file_width, &file_height)
                                 : JpegSize(image.data, &file_width, &file_height);
      if (!header_ok) G6D_THROW(what << ": corrupted " << codec << " payload (no valid header)");
      // Checked before decoding so that a small file declaring a huge image cannot make
      // the codec allocate it.
      if (file_width != image.width || file_height != image.height) {
        G6D_THROW(what << ": " << codec << " file is " << file_width << "x" << file_height
                       << " but the message declares " << image.width << "x" << image.height);
      }
      if (!png && (image.data.size() < 2 || image.data[image.data.size() - 2] != 0xFF ||
                   image.data.back() != 0xD9)) {
        // libjpeg only warns about truncated data and fills the rest with grey.
        G6D_THROW(what << ": corrupted JPEG payload (truncated: no end-of-image marker)");
      }
      int flags = cv::IMREAD_UNCHANGED;
      if (!png) {
        flags = (image.pixel_format == image_t::FORMAT_MONO8 ? cv::IMREAD_GRAYSCALE
                                                             : cv::IMREAD_COLOR) |
                cv::IMREAD_IGNORE_ORIENTATION;
      }
      cv::Mat decoded;
      try {
        decoded = cv::imdecode(image.data, flags);
      } catch (const cv::Exception& e) {
        G6D_THROW(what << ": corrupted " << codec << " payload: " << e.what());
      }
      if (decoded.empty())
        G6D_THROW(what << ": corrupted " << codec << " payload (decoder failed)");
      if (decoded.type() != type || decoded.cols != image.width || decoded.rows != image.height) {
        G6D_THROW(what << ": " << codec << " decodes to " << decoded.cols << "x" << decoded.rows
                       << " " << cv::typeToString(decoded.type()) << " but " << format << " needs "
                       << image.width << "x" << image.height << " " << cv::typeToString(type));
      }
      if (image.pixel_format == image_t::FORMAT_RGB8) {
        cv::cvtColor(decoded, out, cv::COLOR_BGR2RGB);
      } else {
        out = decoded;
      }
      return out;
    }
  }
  G6D_THROW(what << ": unknown compression " << int{image.compression});
}

// ---- Message level ----------------------------------------------------------------------

std::string CheckEncodedRgbdFrame(const void* data, int64_t size) {
  if (data == nullptr || size < 8)
    return "message of " + std::to_string(size) + " bytes is too short";
  WireReader reader(data, size);
  int64_t fingerprint = 0;
  reader.I64(&fingerprint);
  if (fingerprint != rgbd_frame_t::getHash()) {
    std::ostringstream out;
    out << "fingerprint 0x" << std::hex << static_cast<uint64_t>(fingerprint)
        << " is not g6d.rgbd_frame_t's 0x" << static_cast<uint64_t>(rgbd_frame_t::getHash())
        << " (another message type or garbage on the channel)";
    return out.str();
  }
  if (!reader.Skip(2 * 8)) return "truncated at utime/seq";
  if (std::string e = CheckString(&reader, "camera_id"); !e.empty()) return e;
  if (std::string e = CheckString(&reader, "source"); !e.empty()) return e;
  if (!reader.Skip(2 * 4 + 5 * 8)) return "truncated at ids/intrinsics";
  for (const char* field : {"color", "depth", "labels"}) {
    if (std::string e = CheckImage(&reader, field); !e.empty()) return e;
  }
  int32_t num_instances = 0;
  if (!reader.I32(&num_instances)) return "truncated at num_instances";
  // An encoded instance takes at least 4 + 1 (object id) + 3 x 4 bytes.
  constexpr int64_t kMinInstanceBytes = 17;
  if (num_instances < 0 || num_instances * kMinInstanceBytes > reader.remaining()) {
    return "num_instances declares " + std::to_string(num_instances) + " instances but only " +
           std::to_string(reader.remaining()) + " bytes remain";
  }
  for (int32_t i = 0; i < num_instances; ++i) {
    if (std::string e = CheckString(&reader, "instances[].object_id"); !e.empty()) return e;
    if (!reader.Skip(3 * 4)) return "truncated at instances[" + std::to_string(i) + "]";
  }
  return {};
}

bool PeekRgbdFrameIds(const void* data, int64_t size, int64_t* utime, int64_t* seq) {
  if (data == nullptr) return false;
  WireReader reader(data, size);
  int64_t fingerprint = 0;
  if (!reader.I64(&fingerprint) || fingerprint != rgbd_frame_t::getHash()) return false;
  return reader.I64(utime) && reader.I64(seq);
}

rgbd_frame_t DecodeRgbdFrameMessage(const void* data, int64_t size) {
  if (const std::string error = CheckEncodedRgbdFrame(data, size); !error.empty()) {
    G6D_THROW("message: did not decode as g6d.rgbd_frame_t: " << error);
  }
  if (size > std::numeric_limits<int>::max())
    G6D_THROW("message: " << size << " bytes is too large");
  rgbd_frame_t message;
  int used = -1;
  try {
    used = message.decode(data, 0, static_cast<int>(size));
  } catch (const std::exception& e) {
    G6D_THROW("message: did not decode as g6d.rgbd_frame_t: " << e.what());
  }
  if (used < 0) G6D_THROW("message: did not decode as g6d.rgbd_frame_t (malformed)");
  return message;
}

DecodedFrame DecodeFrame(const rgbd_frame_t& message, const DecodeLimits& limits) {
  if (const std::string error = limits.Check(); !error.empty())
    G6D_THROW("DecodeLimits: " << error);

  // Intrinsics and scales first: cheap, and the most common configuration mistake.
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(message.fx))
    G6D_THROW("intrinsics: fx must be finite and > 0 (got " << message.fx << ")");
  if (!positive(message.fy))
    G6D_THROW("intrinsics: fy must be finite and > 0 (got " << message.fy << ")");
  if (!std::isfinite(message.cx))
    G6D_THROW("intrinsics: cx must be finite (got " << message.cx << ")");
  if (!std::isfinite(message.cy))
    G6D_THROW("intrinsics: cy must be finite (got " << message.cy << ")");

  // Formats and sizes as declared, before decoding anything.
  if (!IsColorFormat(message.color.pixel_format)) {
    G6D_THROW("color: pixel format " << PixelFormatName(message.color.pixel_format)
                                     << " is not a colour format (RGB8, BGR8 or MONO8)");
  }
  if (message.depth.pixel_format != image_t::FORMAT_DEPTH_U16 &&
      message.depth.pixel_format != image_t::FORMAT_DEPTH_F32) {
    G6D_THROW("depth: pixel format " << PixelFormatName(message.depth.pixel_format)
                                     << " is not a depth format (DEPTH_U16 or DEPTH_F32)");
  }
  if (message.labels.pixel_format != image_t::FORMAT_LABEL_U8 &&
      message.labels.pixel_format != image_t::FORMAT_LABEL_U16) {
    G6D_THROW("labels: pixel format " << PixelFormatName(message.labels.pixel_format)
                                      << " is not a label format (LABEL_U8 or LABEL_U16)");
  }
  if (message.depth.pixel_format == image_t::FORMAT_DEPTH_U16 && !positive(message.depth_scale_m)) {
    G6D_THROW("depth_scale_m must be finite and > 0 for DEPTH_U16 depth (got "
              << message.depth_scale_m << ")");
  }
  // Depth becomes float metres: the largest raw value times the scale must stay a finite
  // float, or a huge scale would turn every measurement into infinity. FLT_MAX / 2^16 is
  // exact in float, so 65535 units times it stays finite whatever convertTo() rounds.
  constexpr double kMaxDepthScaleM = std::numeric_limits<float>::max() / 65536.0;
  if (message.depth.pixel_format == image_t::FORMAT_DEPTH_U16 &&
      message.depth_scale_m > kMaxDepthScaleM) {
    G6D_THROW("depth_scale_m " << message.depth_scale_m
                               << " is too large: depth in metres (up to 65535 x depth_scale_m) "
                               << "must fit a float (at most " << kMaxDepthScaleM << ")");
  }
  for (const auto& [plane, name] : {std::pair<const image_t*, const char*>{&message.depth, "depth"},
                                    {&message.labels, "labels"}}) {
    if (plane->width != message.color.width || plane->height != message.color.height) {
      G6D_THROW(name << ": size " << plane->width << "x" << plane->height << " differs from color "
                     << message.color.width << "x" << message.color.height);
    }
  }
  if (message.num_instances != static_cast<int64_t>(message.instances.size()) ||
      message.num_instances < 0) {
    G6D_THROW("instances: num_instances " << message.num_instances << " but "
                                          << message.instances.size() << " instances");
  }
  if (message.num_instances > limits.max_instances) {
    G6D_THROW("instances: " << message.num_instances << " instances is too many (limit "
                            << limits.max_instances << ")");
  }

  DecodedFrame out;
  const cv::Mat color = DecodeImage(message.color, "color", limits);
  if (message.color.pixel_format == image_t::FORMAT_RGB8) {
    out.frame.rgb = color;
  } else if (message.color.pixel_format == image_t::FORMAT_BGR8) {
    cv::cvtColor(color, out.frame.rgb, cv::COLOR_BGR2RGB);
  } else {
    cv::cvtColor(color, out.frame.rgb, cv::COLOR_GRAY2RGB);
  }

  const cv::Mat depth = DecodeImage(message.depth, "depth", limits);
  if (message.depth.pixel_format == image_t::FORMAT_DEPTH_U16) {
    depth.convertTo(out.frame.depth, CV_32F, message.depth_scale_m);
  } else {
    out.frame.depth = depth;
    // The solver treats 0 as "no measurement"; NaN, infinities and negative values from
    // a sensor driver mean the same thing.
    // A plain loop, not Mat::forEach: that would fan out over OpenCV's own thread pool
    // from the LCM thread, competing with the solver's workers.
    for (int v = 0; v < out.frame.depth.rows; ++v) {
      float* row = out.frame.depth.ptr<float>(v);
      for (int u = 0; u < out.frame.depth.cols; ++u) {
        if (!(row[u] > 0.0f && row[u] < std::numeric_limits<float>::infinity())) row[u] = 0.0f;
      }
    }
  }

  out.frame.camera = Camera{message.fx, message.fy,          message.cx,
                            message.cy, message.color.width, message.color.height};
  if (const std::string error = out.frame.camera.Check(); !error.empty())
    G6D_THROW("intrinsics: " << error);

  out.labels = DecodeImage(message.labels, "labels", limits);
  // Pixel count of every label value (at most 65536 bins).
  const bool wide = out.labels.type() == CV_16UC1;
  std::vector<int> counts(wide ? 65536 : 256, 0);
  for (int v = 0; v < out.labels.rows; ++v) {
    if (wide) {
      const uint16_t* row = out.labels.ptr<uint16_t>(v);
      for (int u = 0; u < out.labels.cols; ++u) ++counts[row[u]];
    } else {
      const uint8_t* row = out.labels.ptr<uint8_t>(v);
      for (int u = 0; u < out.labels.cols; ++u) ++counts[row[u]];
    }
  }
  std::vector<bool> named(counts.size(), false);
  for (const instance_t& instance : message.instances) {
    if (instance.label > 0 && instance.label < static_cast<int>(counts.size()))
      named[instance.label] = true;
  }
  int unnamed_labels = 0, first_unnamed = 0;
  for (size_t label = 1; label < counts.size(); ++label) {
    if (counts[label] > 0 && !named[label]) {
      if (unnamed_labels++ == 0) first_unnamed = static_cast<int>(label);
    }
  }
  if (unnamed_labels > 0) {
    G6D_THROW("labels: label " << first_unnamed << " (" << counts[first_unnamed]
                               << " pixels) is named by no instance"
                               << (unnamed_labels > 1
                                       ? " (" + std::to_string(unnamed_labels) + " such labels)"
                                       : std::string()));
  }

  out.instances.reserve(message.instances.size());
  for (size_t i = 0; i < message.instances.size(); ++i) {
    const instance_t& request = message.instances[i];
    DecodedInstance instance;
    instance.object_id = request.object_id;
    instance.label = request.label;
    instance.score = request.score;
    instance.gt_index = request.gt_index;
    std::ostringstream error;
    if (request.object_id.empty()) {
      error << "instance " << i << ": empty object id";
    } else if (request.label <= 0) {
      error << "instance " << i << " (" << request.object_id << "): label must be > 0 (got "
            << request.label << "; 0 is background)";
    } else if (request.label >= static_cast<int>(counts.size()) || counts[request.label] == 0) {
      error << "instance " << i << " (" << request.object_id << "): label " << request.label
            << " has no pixels in the label image";
    } else {
      instance.mask_pixels = counts[request.label];
      cv::compare(out.labels, cv::Scalar(request.label), instance.mask, cv::CMP_EQ);
    }
    instance.error = error.str();
    out.instances.push_back(std::move(instance));
  }
  return out;
}

}  // namespace g6d
