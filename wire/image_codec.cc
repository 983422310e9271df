#include "wire/image_codec.h"

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
#error "image_codec assumes a little-endian host (image_t pixels are little-endian)"
#endif

namespace g6d {
namespace {

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

}  // namespace

bool IsColorFormat(int8_t format) {
  return format == image_t::FORMAT_RGB8 || format == image_t::FORMAT_BGR8 ||
         format == image_t::FORMAT_MONO8;
}

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

}  // namespace g6d
