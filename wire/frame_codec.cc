#include "wire/frame_codec.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "core/camera.h"
#include "core/error.h"

namespace g6d {
namespace {

uint32_t ReadBigEndian32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

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
  // An encoded instance takes at least 4 + 1 (object id) + 3 x 4 (label, score, gt_index)
  // + 4 x 4 (box) + 4 (num_candidate_ids) + 4 (count) bytes; a candidate id at least 4 + 1.
  constexpr int64_t kMinInstanceBytes = 41;
  constexpr int64_t kMinStringBytes = 5;
  if (num_instances < 0 || num_instances * kMinInstanceBytes > reader.remaining()) {
    return "num_instances declares " + std::to_string(num_instances) + " instances but only " +
           std::to_string(reader.remaining()) + " bytes remain";
  }
  for (int32_t i = 0; i < num_instances; ++i) {
    const std::string where = "instances[" + std::to_string(i) + "]";
    if (std::string e = CheckString(&reader, "instances[].object_id"); !e.empty()) return e;
    int32_t num_candidates = 0;
    if (!reader.Skip(3 * 4 + 4 * 4) || !reader.I32(&num_candidates)) return "truncated at " + where;
    if (num_candidates < 0 || num_candidates * kMinStringBytes > reader.remaining()) {
      return where + ".num_candidate_ids declares " + std::to_string(num_candidates) +
             " ids but only " + std::to_string(reader.remaining()) + " bytes remain";
    }
    for (int32_t c = 0; c < num_candidates; ++c) {
      if (std::string e = CheckString(&reader, "instances[].candidate_ids[]"); !e.empty()) return e;
    }
    if (!reader.Skip(4)) return "truncated at " + where + ".count";
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
  // A label plane of no pixels and no bytes: no label image (box instances only).
  const bool no_label_image =
      message.labels.width == 0 && message.labels.height == 0 && message.labels.data.empty();
  if (!no_label_image && message.labels.pixel_format != image_t::FORMAT_LABEL_U8 &&
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
    if (plane == &message.labels && no_label_image) continue;
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

  out.labels = no_label_image ? cv::Mat(cv::Mat::zeros(out.frame.rgb.size(), CV_8UC1))
                              : DecodeImage(message.labels, "labels", limits);
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
  const cv::Rect image_rect(0, 0, out.labels.cols, out.labels.rows);
  for (size_t i = 0; i < message.instances.size(); ++i) {
    const instance_t& request = message.instances[i];
    DecodedInstance instance;
    instance.object_id = request.object_id;
    instance.label = request.label;
    instance.score = request.score;
    instance.gt_index = request.gt_index;
    instance.index = static_cast<int32_t>(i);
    const std::string name =
        "instance " + std::to_string(i) +
        (request.object_id.empty() ? std::string(" (identity unknown)") : " (" + request.object_id + ")");
    std::ostringstream error;
    bool refused = false;  // a candidate list that cannot be used
    if (request.object_id.empty()) {
      // Identity unknown: the candidates, each once (the service checks they are loaded).
      if (request.num_candidate_ids != static_cast<int64_t>(request.candidate_ids.size()) ||
          request.num_candidate_ids < 0) {
        error << name << ": num_candidate_ids " << request.num_candidate_ids << " but "
              << request.candidate_ids.size() << " candidate ids";
        refused = true;
      }
      // A set, not a scan of the list: a hostile message may list many thousands of ids.
      std::set<std::string> seen;
      for (size_t c = 0; c < request.candidate_ids.size() && !refused; ++c) {
        const std::string& id = request.candidate_ids[c];
        if (id.empty()) {
          error << name << ": candidate_ids[" << c << "] is empty";
          refused = true;
        } else if (seen.insert(id).second) {
          instance.candidate_ids.push_back(id);
        }
      }
    }
    if (refused) {
      // The error says why.
    } else if (request.label < 0) {
      error << name << ": label must be > 0 for a mask, or 0 with a box (got " << request.label << ")";
    } else if (request.label > 0) {
      // A label wins over a box: the box is not read.
      if (request.label >= static_cast<int>(counts.size()) || counts[request.label] == 0) {
        error << name << ": label " << request.label << " has no pixels in the label image";
      } else {
        instance.mask_pixels = counts[request.label];
        cv::compare(out.labels, cv::Scalar(request.label), instance.mask, cv::CMP_EQ);
      }
    } else {
      // Label 0: the box is the mask. 64-bit sums: x + width may overflow an int32.
      const int64_t x = request.box[0], y = request.box[1], width = request.box[2],
                    height = request.box[3];
      if (width <= 0) {
        // Neither mask nor box: the service finds the object itself (a detection request).
        instance.detect = true;
        instance.count = std::max(1, request.count);
      } else if (height <= 0) {
        error << name << ": box height must be > 0 (got " << height << ")";
      } else if (x >= image_rect.width || y >= image_rect.height || x + width <= 0 ||
                 y + height <= 0) {
        error << name << ": box (x " << x << ", y " << y << ", width " << width << ", height "
              << height << ") lies outside the " << image_rect.width << "x" << image_rect.height
              << " image";
      } else {
        const int64_t x0 = std::max<int64_t>(x, 0), y0 = std::max<int64_t>(y, 0);
        const int64_t x1 = std::min<int64_t>(x + width, image_rect.width);
        const int64_t y1 = std::min<int64_t>(y + height, image_rect.height);
        instance.box = cv::Rect(static_cast<int>(x0), static_cast<int>(y0),
                                static_cast<int>(x1 - x0), static_cast<int>(y1 - y0));
        instance.mask = cv::Mat::zeros(image_rect.size(), CV_8UC1);
        instance.mask(instance.box).setTo(255);
        instance.mask_pixels = instance.box.area();
      }
    }
    instance.error = error.str();
    if (!instance.error.empty()) {
      instance.detect = false;
      instance.count = 1;
      instance.mask.release();
      instance.mask_pixels = 0;
      instance.box = cv::Rect();
    }
    out.instances.push_back(std::move(instance));
  }
  return out;
}

}  // namespace g6d
