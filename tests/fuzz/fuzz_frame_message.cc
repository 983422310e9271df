// libFuzzer harness: raw LCM payload bytes of a g6d.rgbd_frame_t, handled exactly as
// g6d-service handles what it receives (Service::HandleMessage in service/service.cc):
// the wire check, the id peek used to name a rejected frame, the message decode and the
// whole-frame validation and decode. Only g6d::Error, the documented error type, is
// caught; any other exception, a crash or a sanitizer report is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "fuzz_limits.h"
#include "wire/frame_codec.h"

namespace {

using g6d::fuzz::FuzzLimits;

// Documented guarantees of DecodeFrame() (frame_codec.h) on a frame it accepted.
void CheckDecodedFrame(const g6d::rgbd_frame_t& message, const g6d::DecodedFrame& decoded) {
  const g6d::Frame& frame = decoded.frame;
  const cv::Size size(message.color.width, message.color.height);
  G6D_CHECK(frame.rgb.type() == CV_8UC3 && frame.rgb.size() == size);
  G6D_CHECK(frame.depth.type() == CV_32FC1 && frame.depth.size() == size);
  for (int v = 0; v < frame.depth.rows; ++v) {
    const float* row = frame.depth.ptr<float>(v);
    for (int u = 0; u < frame.depth.cols; ++u) G6D_CHECK(std::isfinite(row[u]) && row[u] >= 0.0f);
  }
  G6D_CHECK(decoded.labels.size() == size);
  G6D_CHECK(decoded.instances.size() == message.instances.size());
  for (const g6d::DecodedInstance& instance : decoded.instances) {
    if (instance.error.empty() && instance.detect) {
      // A detection request: no mask and no box; the count is at least 1.
      G6D_CHECK(instance.mask.empty() && instance.mask_pixels == 0 && instance.box.empty());
      G6D_CHECK(instance.count >= 1);
    } else if (instance.error.empty()) {
      G6D_CHECK(!instance.detect && instance.count == 1);
      G6D_CHECK(instance.mask.type() == CV_8UC1 && instance.mask.size() == size);
      G6D_CHECK(instance.mask_pixels > 0 &&
                cv::countNonZero(instance.mask) == instance.mask_pixels);
      // A box mask is its box, clipped to the image.
      if (!instance.box.empty()) {
        G6D_CHECK((instance.box & cv::Rect(cv::Point(), size)) == instance.box);
        G6D_CHECK(instance.box.area() == instance.mask_pixels);
      }
    } else {
      G6D_CHECK(instance.mask.empty() && !instance.detect);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const g6d::DecodeLimits limits = FuzzLimits();
  const int64_t length = static_cast<int64_t>(size);
  const std::string problem = g6d::CheckEncodedRgbdFrame(data, length);
  int64_t utime = 0, seq = 0;
  g6d::PeekRgbdFrameIds(data, length, &utime, &seq);

  g6d::rgbd_frame_t message;
  try {
    message = g6d::DecodeRgbdFrameMessage(data, length);
  } catch (const g6d::Error&) {
    return 0;
  }
  // DecodeRgbdFrameMessage() runs the same check first: bytes the check refused must never
  // reach lcm-gen's decoder.
  G6D_CHECK(problem.empty());
  try {
    const g6d::DecodedFrame decoded = g6d::DecodeFrame(message, limits);
    CheckDecodedFrame(message, decoded);
  } catch (const g6d::Error&) {
  }
  return 0;
}
