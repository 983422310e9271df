// libFuzzer harness: raw LCM payload bytes of a Drake lcmt_image_array (first input byte
// even) or a bot_core images_t (odd), handled as g6d-service handles them with
// --input-type drake / bot_core: the input adapter (pre-decode size check, message decode,
// image decompression, label mapping), then the whole-frame validation and decode. Only
// g6d::Error, the documented error type, is caught; any other exception, a crash or a
// sanitizer report is a finding.
#include <cstddef>
#include <cstdint>

#include "core/error.h"
#include "fuzz_limits.h"
#include "wire/frame_codec.h"
#include "wire/input_adapters.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const g6d::DecodeLimits limits = g6d::fuzz::FuzzLimits();
  static const g6d::AdapterOptions options = [] {
    g6d::AdapterOptions adapter;
    adapter.camera = g6d::Camera{60.0, 60.0, 31.5, 23.5, 64, 48};
    adapter.label_objects = {{1, "obj_000001"}, {2, "obj_000002"}};
    return adapter;
  }();
  const g6d::InputType type = data[0] % 2 == 0 ? g6d::InputType::kDrake : g6d::InputType::kBotCore;
  g6d::FrameHeader header;
  g6d::rgbd_frame_t frame;
  try {
    frame = g6d::AdaptMessage(type, data + 1, static_cast<int64_t>(size) - 1, options, limits,
                              /*seq=*/0, &header);
  } catch (const g6d::Error&) {
    return 0;
  }
  // An adapted frame names only labels of the map, each with pixels.
  for (const g6d::instance_t& instance : frame.instances)
    G6D_CHECK(options.label_objects.count(instance.label) == 1);
  try {
    const g6d::DecodedFrame decoded = g6d::DecodeFrame(frame, limits);
    G6D_CHECK(decoded.frame.rgb.type() == CV_8UC3);
    for (const g6d::DecodedInstance& instance : decoded.instances)
      G6D_CHECK(instance.error.empty() && instance.mask_pixels > 0);
  } catch (const g6d::Error&) {
    // Sizes that disagree between the planes, and the like: refused, not crashed.
  }
  return 0;
}
