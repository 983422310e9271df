// libFuzzer harness: every BOP JSON reader of lib/eval/bop.h through its text entry point.
// The first input byte picks the reader (value modulo 4):
//   0 ParseBopTargets      test_targets_bop19.json
//   1 ParseBopCamera       camera.json
//   2 ParseBopModelsInfo   models/models_info.json
//   3 ParseBopSceneFrames  scene_camera.json NUL scene_gt.json [NUL scene_gt_info.json]
// the rest is the JSON text (for the scene reader, the files separated by NUL bytes,
// which JSON text cannot contain). Only g6d::Error is caught; anything else is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "eval/bop.h"

namespace {

// Splits at NUL bytes into at most `max_parts` parts (the last keeps any further NULs).
std::vector<std::string> SplitAtNul(const std::string& text, size_t max_parts) {
  std::vector<std::string> parts;
  size_t begin = 0;
  while (parts.size() + 1 < max_parts) {
    const size_t end = text.find('\0', begin);
    if (end == std::string::npos) break;
    parts.push_back(text.substr(begin, end - begin));
    begin = end + 1;
  }
  parts.push_back(text.substr(begin));
  return parts;
}

void RunReader(uint8_t selector, const std::string& text) {
  switch (selector % 4) {
    case 0:
      g6d::ParseBopTargets(text, "fuzz targets");
      break;
    case 1: {
      const g6d::BopCameraInfo info = g6d::ParseBopCamera(text, "fuzz camera");
      G6D_CHECK(info.camera.Check().empty());
      break;
    }
    case 2:
      for (const auto& [obj_id, object] : g6d::ParseBopModelsInfo(text, "fuzz models", "models")) {
        G6D_CHECK(object.obj_id == obj_id);
        G6D_CHECK(std::isfinite(object.diameter_m) && object.diameter_m > 0.0);
      }
      break;
    default: {
      const std::vector<std::string> parts = SplitAtNul(text, 3);
      const std::optional<std::string> gt_info =
          parts.size() > 2 ? std::optional<std::string>(parts[2]) : std::nullopt;
      const std::vector<g6d::BopFrame> frames = g6d::ParseBopSceneFrames(
          parts[0], parts.size() > 1 ? parts[1] : std::string(), gt_info, 640, 480);
      for (size_t i = 1; i < frames.size(); ++i) G6D_CHECK(frames[i - 1].im_id < frames[i].im_id);
      break;
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    RunReader(data[0], text);
  } catch (const g6d::Error&) {
  }
  return 0;
}
