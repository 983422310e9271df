#include "bop_to_lcm.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/timer.h"
#include "eval/mask_degrade.h"
#include "wire/frame_codec.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;

std::string SixDigits(int value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%06d", value);
  return buffer;
}

int8_t ColorCompression(ColorEncoding encoding) {
  switch (encoding) {
    case ColorEncoding::kRaw:
      return image_t::COMPRESSION_NONE;
    case ColorEncoding::kZstd:
      return image_t::COMPRESSION_ZSTD;
    case ColorEncoding::kPng:
      return image_t::COMPRESSION_PNG;
    case ColorEncoding::kJpeg:
      return image_t::COMPRESSION_JPEG;
  }
  G6D_CHECK(false);
  return image_t::COMPRESSION_NONE;
}

// depth/<im_id>.png exactly as stored (16-bit units of depth_scale mm): the frame carries
// the raw values and the scale, so nothing is rounded on the way.
cv::Mat ReadRawDepth(const BopScene& scene, int im_id) {
  const fs::path path = fs::path(scene.directory) / "depth" / (SixDigits(im_id) + ".png");
  if (!fs::is_regular_file(path)) G6D_THROW("depth image " << path.string() << " does not exist");
  const cv::Mat depth = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (depth.empty()) G6D_THROW("cannot read depth image " << path.string());
  if (depth.type() != CV_16UC1) {
    G6D_THROW("depth image " << path.string() << " must be 16-bit single channel, got "
                             << depth.channels() << " channel(s) of depth code " << depth.depth());
  }
  return depth;
}

int64_t Round(double value) { return static_cast<int64_t>(std::llround(value)); }

constexpr int kMaxFrameRange = 1000000;  // ids in one a-b range of a frame list

}  // namespace

ColorEncoding ParseColorEncoding(const std::string& text) {
  if (text == "raw") return ColorEncoding::kRaw;
  if (text == "zstd") return ColorEncoding::kZstd;
  if (text == "png") return ColorEncoding::kPng;
  if (text == "jpeg" || text == "jpg") return ColorEncoding::kJpeg;
  G6D_THROW("colour encoding '" << text << "' is not one of raw, zstd, png, jpeg");
}

InstanceInput ParseInstanceInput(const std::string& text) {
  if (text == "label") return InstanceInput::kLabel;
  if (text == "box") return InstanceInput::kBox;
  if (text == "none") return InstanceInput::kNone;
  G6D_THROW("instance input '" << text << "' is not one of label, box, none");
}

IdentityInput ParseIdentityInput(const std::string& text) {
  if (text == "given") return IdentityInput::kGiven;
  if (text == "unknown") return IdentityInput::kUnknown;
  G6D_THROW("identity input '" << text << "' is not one of given, unknown");
}

cv::Rect BoxOfMask(const cv::Mat& mask, int margin_px) {
  if (cv::countNonZero(mask) == 0) return {};
  // The benchmark's box mask itself, so that both get exactly the same pixels.
  MaskDegradeOptions box;
  box.mode = MaskDegradation::kBox;
  box.size_px = margin_px;
  return cv::boundingRect(DegradeMask(mask, {}, box, /*instance_key=*/0));
}

std::vector<int> ParseFrameList(const std::string& text) {
  std::set<int> ids;
  std::stringstream stream(text);
  std::string item;
  auto parse_id = [&](const std::string& number) {
    size_t used = 0;
    int value = -1;
    try {
      value = std::stoi(number, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != number.size() || value < 0) {
      G6D_THROW("frame list '" << text << "': '" << item << "' is not an image id or a range a-b");
    }
    return value;
  };
  while (std::getline(stream, item, ',')) {
    if (item.empty()) continue;
    const size_t dash = item.find('-', 1);
    if (dash == std::string::npos) {
      ids.insert(parse_id(item));
      continue;
    }
    const int first = parse_id(item.substr(0, dash));
    const int last = parse_id(item.substr(dash + 1));
    if (last < first) G6D_THROW("frame list '" << text << "': range '" << item << "' is reversed");
    // BOP image ids are at most six digits; a longer range is a typo, not a request.
    if (last - first >= kMaxFrameRange) {
      G6D_THROW("frame list '" << text << "': range '" << item << "' spans more than "
                               << kMaxFrameRange << " ids");
    }
    for (int id = first; id <= last; ++id) ids.insert(id);
  }
  if (ids.empty()) G6D_THROW("frame list '" << text << "' holds no image id");
  return {ids.begin(), ids.end()};
}

std::string BopToLcmOptions::Check() const {
  if (channel.empty()) return "channel must not be empty";
  if (!(fps > 0.0) || !std::isfinite(fps))
    return "fps must be finite and > 0, got " + std::to_string(fps);
  if (start_utime < 0) return "start_utime must be >= 0, got " + std::to_string(start_utime);
  if (split.empty()) return "split must not be empty";
  if (box_margin_px < 0) return "box_margin_px must be >= 0, got " + std::to_string(box_margin_px);
  if (instances == InstanceInput::kNone && identity != IdentityInput::kGiven)
    return "instances none (a detection request per object) needs identity given";
  const std::string bad_encode = encode.Check();
  if (!bad_encode.empty()) return "encode: " + bad_encode;
  return "";
}

std::string BopSourceName(const std::string& dataset_dir) {
  fs::path path = fs::absolute(fs::path(dataset_dir)).lexically_normal();
  if (path.filename().empty()) path = path.parent_path();
  return path.filename().string();
}

std::vector<int> SelectInstances(const BopFrame& frame, int scene_id,
                                 const std::vector<BopTarget>* targets, int* missing) {
  std::vector<int> indices;
  if (missing != nullptr) *missing = 0;
  if (targets == nullptr) {
    for (size_t i = 0; i < frame.gt.size(); ++i) indices.push_back(static_cast<int>(i));
    return indices;
  }
  std::set<int> chosen;
  for (const BopTarget& target : *targets) {
    if (target.scene_id != scene_id || target.im_id != frame.im_id) continue;
    // The target's inst_count most visible instances (BOP's rule, TargetGtIndices).
    const std::vector<int> found = TargetGtIndices(frame, target.obj_id, target.inst_count);
    chosen.insert(found.begin(), found.end());
    if (missing != nullptr) *missing += target.inst_count - static_cast<int>(found.size());
  }
  return {chosen.begin(), chosen.end()};
}

rgbd_frame_t MakeBopFrameMessage(const BopScene& scene, const BopFrame& frame,
                                 const std::vector<int>& gt_indices, const std::string& source,
                                 const BopToLcmOptions& options, int64_t seq, int64_t utime,
                                 int64_t* overlap_pixels, int* empty_masks) {
  const cv::Mat rgb = LoadBopRgb(scene, frame.im_id);
  const cv::Mat depth = ReadRawDepth(scene, frame.im_id);
  if (depth.size() != rgb.size()) {
    G6D_THROW("scene " << scene.scene_id << " image " << frame.im_id << ": depth is " << depth.cols
                       << "x" << depth.rows << " but rgb is " << rgb.cols << "x" << rgb.rows);
  }
  // Labels are gt_idx + 1, so a label names its BOP instance even without the instance list.
  int max_label = 0;
  for (int gt_idx : gt_indices) max_label = std::max(max_label, gt_idx + 1);
  const bool wide = max_label > 255;
  cv::Mat labels = cv::Mat::zeros(rgb.size(), wide ? CV_16UC1 : CV_8UC1);
  int64_t overlap = 0;
  int empty = 0;
  const bool boxes = options.instances == InstanceInput::kBox;
  const bool none = options.instances == InstanceInput::kNone;
  rgbd_frame_t message{};
  if (none) {
    // One detection request per object, in the order of its first chosen instance.
    for (int gt_idx : gt_indices) {
      const std::string object_id = BopObjectName(frame.gt[gt_idx].obj_id);
      auto request = std::find_if(message.instances.begin(), message.instances.end(),
                                  [&](const instance_t& i) { return i.object_id == object_id; });
      if (request != message.instances.end()) {
        ++request->count;
        continue;
      }
      instance_t instance{};  // {}: label 0 and no box: a detection request
      instance.object_id = object_id;
      instance.score = 1.0f;
      instance.gt_index = -1;  // it stands for every instance of the object
      instance.count = 1;
      message.instances.push_back(instance);
    }
  }
  for (int gt_idx : none ? std::vector<int>() : gt_indices) {
    const cv::Mat mask = LoadBopMaskVisib(scene, frame.im_id, gt_idx);
    if (mask.size() != rgb.size()) {
      G6D_THROW("scene " << scene.scene_id << " image " << frame.im_id << ": mask_visib of gt_idx "
                         << gt_idx << " is " << mask.cols << "x" << mask.rows << " but rgb is "
                         << rgb.cols << "x" << rgb.rows);
    }
    instance_t instance{};  // {}: no box, no candidates (lcm-gen leaves members uninitialized)
    instance.object_id =
        options.identity == IdentityInput::kGiven ? BopObjectName(frame.gt[gt_idx].obj_id) : "";
    instance.score = 1.0f;
    instance.gt_index = gt_idx;
    if (boxes) {
      // No label image pixels: the box is all the frame says about where the object is.
      const cv::Rect box = BoxOfMask(mask, options.box_margin_px);
      if (box.empty()) {
        ++empty;  // nothing visible: no box to send (the benchmark's box is empty too)
        continue;
      }
      instance.label = 0;
      instance.box[0] = box.x;
      instance.box[1] = box.y;
      instance.box[2] = box.width;
      instance.box[3] = box.height;
      message.instances.push_back(instance);
      continue;
    }
    const int label = gt_idx + 1;
    instance.label = label;
    for (int v = 0; v < mask.rows; ++v) {
      const uint8_t* in = mask.ptr<uint8_t>(v);
      for (int u = 0; u < mask.cols; ++u) {
        if (in[u] == 0) continue;
        if (wide) {
          uint16_t& out = labels.ptr<uint16_t>(v)[u];
          overlap += out != 0;
          out = static_cast<uint16_t>(label);
        } else {
          uint8_t& out = labels.ptr<uint8_t>(v)[u];
          overlap += out != 0;
          out = static_cast<uint8_t>(label);
        }
      }
    }
    message.instances.push_back(instance);
  }
  if (overlap_pixels != nullptr) *overlap_pixels = overlap;
  if (empty_masks != nullptr) *empty_masks = empty;

  message.utime = utime;
  message.seq = seq;
  message.camera_id = options.camera_id;
  message.source = source;
  message.scene_id = scene.scene_id;
  message.image_id = frame.im_id;
  message.fx = frame.camera.fx;
  message.fy = frame.camera.fy;
  message.cx = frame.camera.cx;
  message.cy = frame.camera.cy;
  message.depth_scale_m = frame.depth_scale / 1000.0;  // BOP depth_scale is mm per unit
  message.color =
      EncodeImage(rgb, image_t::FORMAT_RGB8, ColorCompression(options.color), options.encode);
  message.depth =
      EncodeImage(depth, image_t::FORMAT_DEPTH_U16, image_t::COMPRESSION_ZSTD, options.encode);
  if (boxes || none) {
    // No label image: a 0 x 0 plane (DecodeFrame reads it as "none").
    message.labels = image_t{};
    message.labels.pixel_format = image_t::FORMAT_LABEL_U8;
    message.labels.compression = image_t::COMPRESSION_NONE;
  } else {
    message.labels = EncodeImage(labels, wide ? image_t::FORMAT_LABEL_U16 : image_t::FORMAT_LABEL_U8,
                                 image_t::COMPRESSION_ZSTD, options.encode);
  }
  message.num_instances = static_cast<int32_t>(message.instances.size());
  return message;
}

BopToLcmReport WriteBopSceneLog(const BopToLcmOptions& options, const std::string& dataset_dir,
                                int scene_id, const std::string& log_path) {
  const std::string bad = options.Check();
  if (!bad.empty()) G6D_THROW("bop2lcm options: " << bad);
  Stopwatch watch;
  BopToLcmReport report;
  report.source = BopSourceName(dataset_dir);
  if (!fs::is_directory(dataset_dir))
    G6D_THROW("BOP dataset folder '" << dataset_dir << "' does not exist");

  std::vector<BopTarget> targets;
  bool with_targets = false;
  if (options.use_targets) {
    report.targets_file = options.targets_file;
    if (report.targets_file.empty()) {
      const fs::path default_file = fs::path(dataset_dir) / "test_targets_bop19.json";
      if (fs::exists(default_file)) report.targets_file = default_file.string();
    }
    if (!report.targets_file.empty()) {
      targets = LoadBopTargets(report.targets_file);
      with_targets = true;
    }
  }
  const BopScene scene = LoadBopScene(dataset_dir, scene_id, options.split);
  report.images_in_scene = static_cast<int>(scene.frames.size());
  for (int im_id : options.frames) scene.Frame(im_id);  // throws naming an unknown id

  // Open only after the dataset has been read, so a bad dataset leaves no empty log behind.
  lcm::LogFile log(log_path, "w");
  if (!log.good()) G6D_THROW("cannot open LCM log '" << log_path << "' for writing");
  const double period_us = 1e6 / options.fps;
  int64_t seq = 0;
  for (const BopFrame& frame : scene.frames) {
    if (!options.frames.empty() &&
        !std::binary_search(options.frames.begin(), options.frames.end(), frame.im_id)) {
      continue;
    }
    int missing = 0;
    const std::vector<int> gt_indices =
        SelectInstances(frame, scene_id, with_targets ? &targets : nullptr, &missing);
    report.missing_instances += missing;
    if (with_targets && gt_indices.empty()) continue;  // not a target image

    const int64_t utime = options.start_utime + Round(seq * period_us);
    int64_t overlap = 0;
    int empty = 0;
    const rgbd_frame_t message = MakeBopFrameMessage(scene, frame, gt_indices, report.source,
                                                     options, seq, utime, &overlap, &empty);
    report.empty_masks += empty;
    std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
    if (message.encode(bytes.data(), 0, static_cast<int>(bytes.size())) !=
        static_cast<int>(bytes.size())) {
      G6D_THROW("scene " << scene_id << " image " << frame.im_id
                         << ": the frame message does not encode");
    }
    lcm::LogEvent event;
    event.eventnum = seq;
    event.timestamp = utime;
    event.channel = options.channel;
    event.datalen = static_cast<int32_t>(bytes.size());
    event.data = bytes.data();
    if (log.writeEvent(&event) != 0) {
      G6D_THROW("cannot write event " << seq << " (image " << frame.im_id << ") to '" << log_path
                                      << "'");
    }
    report.overlap_pixels += overlap;
    report.instances_written += message.num_instances;
    ++report.frames_written;
    ++seq;
  }
  if (std::fflush(log.getFilePtr()) != 0) G6D_THROW("cannot write LCM log '" << log_path << "'");
  report.bytes_written = static_cast<int64_t>(fs::file_size(log_path));
  report.seconds = watch.ElapsedMs() / 1000.0;
  if (report.frames_written == 0) {
    report.message = "no image of scene " + std::to_string(scene_id) + " was selected" +
                     (with_targets ? " (no target in " + report.targets_file + ")" : "") +
                     (options.frames.empty() ? "" : " by the frame list");
    return report;
  }
  report.success = true;
  report.message = "ok";
  return report;
}

}  // namespace g6d
