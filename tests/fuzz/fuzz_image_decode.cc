// libFuzzer harness: DecodeImage() on one g6d.image_t whose header fields come from the
// first 16 bytes of the input and whose payload is the rest. Random mutation of a whole
// LCM message rarely gets a plane's header right, so this target reaches the zstd, PNG
// and JPEG paths directly. Only g6d::Error is caught; anything else is a finding.
//
// Input layout (little-endian):
//   [0, 4)   int32 width        [4, 8)  int32 height      [8, 12) int32 row_stride
//   [12]     int8 pixel_format  [13]    int8 compression
//   [14, 16) int16 size_delta: the size field is the payload length plus this
//   [16, ..) payload (image_t::data)
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "core/error.h"
#include "fuzz_limits.h"
#include "wire/frame_codec.h"

namespace {

constexpr size_t kHeaderBytes = 16;

int32_t LoadI32(const uint8_t* p) {
  uint32_t bits = 0;
  for (int i = 0; i < 4; ++i) bits |= uint32_t{p[i]} << (8 * i);
  return static_cast<int32_t>(bits);
}

using g6d::fuzz::FuzzLimits;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const g6d::DecodeLimits limits = FuzzLimits();
  if (size < kHeaderBytes) return 0;
  g6d::image_t image;
  image.width = LoadI32(data);
  image.height = LoadI32(data + 4);
  image.row_stride = LoadI32(data + 8);
  image.pixel_format = static_cast<int8_t>(data[12]);
  image.compression = static_cast<int8_t>(data[13]);
  const int16_t size_delta = static_cast<int16_t>(data[14] | (data[15] << 8));
  image.data.assign(data + kHeaderBytes, data + size);
  image.size = static_cast<int32_t>(image.data.size()) + size_delta;
  try {
    const cv::Mat decoded = g6d::DecodeImage(image, "fuzz", limits);
    // Documented result: the natural type of the format, the declared size, owned and
    // continuous pixels.
    G6D_CHECK(decoded.type() == g6d::OpenCvTypeOf(image.pixel_format));
    G6D_CHECK(decoded.cols == image.width && decoded.rows == image.height);
    G6D_CHECK(decoded.isContinuous());
  } catch (const g6d::Error&) {
  }
  return 0;
}
