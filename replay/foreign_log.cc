#include "foreign_log.h"


#include <cmath>
#include <cstdio>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <vector>

#include "bot_core/images_t.hpp"
#include "core/error.h"
#include "drake/lcmt_image_array.hpp"
#include "frame_log.h"
#include "wire/foreign_images.h"
#include "wire/frame_codec.h"

namespace g6d {
namespace {

template <typename Message>
std::vector<uint8_t> Encode(const Message& message) {
  std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
  G6D_CHECK(message.encode(bytes.data(), 0, static_cast<int>(bytes.size())) >= 0);
  return bytes;
}

bool SameCamera(const Camera& a, const Camera& b) {
  return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.width == b.width &&
         a.height == b.height;
}

std::string Number(double value) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.17g", value);
  return text;
}

}  // namespace

std::string ForeignLogOptions::Check() const {
  if (type == InputType::kG6d) return "type must be drake or bot_core";
  if (jpeg_quality < 1 || jpeg_quality > 100)
    return "jpeg_quality must be in 1..100 (got " + std::to_string(jpeg_quality) + ")";
  return {};
}

ForeignLogReport ConvertFrameLog(const std::string& g6d_log, const std::string& channel,
                                 const ForeignLogOptions& options, const std::string& out_log) {
  if (const std::string bad = options.Check(); !bad.empty())
    G6D_THROW("ForeignLogOptions: " << bad);
  FrameLogReader reader(g6d_log, channel);
  lcm::LogFile out(out_log, "w");
  if (!out.good()) G6D_THROW("cannot write the LCM log '" << out_log << "'");
  ForeignLogReport report;
  std::map<std::string, int32_t> label_of;  // object id -> label value
  FrameEvent event;
  while (reader.Next(&event)) {
    const rgbd_frame_t& frame = event.frame;
    const std::string what = "frame seq " + std::to_string(frame.seq);
    DecodedFrame decoded;
    try {
      decoded = DecodeFrame(frame);
    } catch (const Error& e) {
      G6D_THROW(g6d_log << ": " << what << " does not decode: " << e.what());
    }
    if (report.frames == 0) {
      report.camera = decoded.frame.camera;
    } else if (!SameCamera(report.camera, decoded.frame.camera)) {
      G6D_THROW(g6d_log << ": " << what << " has other intrinsics or size than the first frame; "
                        << InputTypeName(options.type)
                        << " messages carry no intrinsics, so a log must hold one camera");
    }
    // Relabel per object id; a second instance of an object in this frame is dropped.
    cv::Mat labels(decoded.labels.size(), CV_16U, cv::Scalar(0));
    std::set<int32_t> used;
    for (const DecodedInstance& instance : decoded.instances) {
      if (!instance.error.empty()) continue;
      auto [it, inserted] = label_of.emplace(instance.object_id, 0);
      if (inserted) {
        it->second = static_cast<int32_t>(label_of.size());
        report.labels[it->second] = instance.object_id;
      }
      if (!used.insert(it->second).second) {
        ++report.dropped_instances;
        continue;
      }
      labels.setTo(it->second, instance.mask);
      ++report.instances;
    }
    std::vector<uint8_t> bytes;
    if (options.type == InputType::kDrake) {
      using I = drake::lcmt_image;
      cv::Mat labels16;
      labels.convertTo(labels16, CV_16S);
      drake::lcmt_image_array message;
      message.header.seq = static_cast<int32_t>(frame.seq);
      message.header.utime = frame.utime;
      message.header.frame_name = frame.camera_id;
      auto image = [&](const cv::Mat& plane, int8_t format, int8_t channel) {
        return MakeDrakeImage(plane, format, channel, true, message.header.seq, frame.utime, frame.camera_id);
      };
      message.images = {image(decoded.frame.rgb, I::PIXEL_FORMAT_RGB, I::CHANNEL_TYPE_UINT8),
                        image(decoded.frame.depth, I::PIXEL_FORMAT_DEPTH, I::CHANNEL_TYPE_FLOAT32),
                        image(labels16, I::PIXEL_FORMAT_LABEL, I::CHANNEL_TYPE_INT16)};
      message.num_images = 3;
      bytes = Encode(message);
    } else {
      using I = bot_core::image_t;
      bot_core::images_t message;
      message.utime = frame.utime;
      if (options.bot_core_mjpeg) {
        cv::Mat bgr;
        cv::cvtColor(decoded.frame.rgb, bgr, cv::COLOR_RGB2BGR);
        std::vector<uint8_t> jpeg;
        cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality});
        message.images.push_back(
            MakeBotCoreImage(decoded.frame.rgb, I::PIXEL_FORMAT_MJPEG, jpeg, frame.utime));
      } else {
        message.images.push_back(
            MakeBotCoreImage(decoded.frame.rgb, I::PIXEL_FORMAT_RGB, PixelBytes(decoded.frame.rgb), frame.utime));
      }
      cv::Mat depth_mm;  // saturating, rounded to the nearest millimetre
      decoded.frame.depth.convertTo(depth_mm, CV_16U, 1000.0);
      message.images.push_back(
          MakeBotCoreImage(depth_mm, I::PIXEL_FORMAT_INVALID, ZlibCompress(PixelBytes(depth_mm)), frame.utime));
      cv::Mat mask = labels;
      if (report.labels.size() <= 255) labels.convertTo(mask, CV_8U);
      message.images.push_back(
          MakeBotCoreImage(mask, I::PIXEL_FORMAT_GRAY, ZlibCompress(PixelBytes(mask)), frame.utime));
      message.image_types = {int16_t{bot_core::images_t::LEFT},
                             int16_t{bot_core::images_t::DEPTH_MM_ZIPPED},
                             int16_t{bot_core::images_t::MASK_ZIPPED}};
      message.n_images = 3;
      bytes = Encode(message);
    }
    lcm::LogEvent out_event;
    out_event.eventnum = report.frames;
    out_event.timestamp = event.timestamp_us;
    out_event.channel = channel;
    out_event.datalen = static_cast<int32_t>(bytes.size());
    out_event.data = bytes.data();
    if (out.writeEvent(&out_event) != 0)
      G6D_THROW("cannot write to the LCM log '" << out_log << "'");
    if (!report.ids
             .emplace(frame.utime, ForeignFrameIds{frame.source, frame.scene_id, frame.image_id})
             .second)
      G6D_THROW(g6d_log << ": " << what << " has the utime of an earlier frame (" << frame.utime
                        << "); answers are matched by utime");
    ++report.frames;
  }
  return report;
}

std::string ServiceOptionsYamlFor(const std::string& channel, InputType type,
                                  const ForeignLogReport& report) {
  std::ostringstream yaml;
  yaml << "# g6d-service options for this log (g6d-bop2lcm): g6d-service --templates DIR "
          "--config <this file>\n";
  yaml << "input: " << channel << "\n";
  yaml << "input_type: " << InputTypeName(type) << "\n";
  if (type == InputType::kG6d) return yaml.str();
  const Camera& c = report.camera;
  yaml << "camera: {fx: " << Number(c.fx) << ", fy: " << Number(c.fy) << ", cx: " << Number(c.cx)
       << ", cy: " << Number(c.cy) << ", width: " << c.width << ", height: " << c.height << "}\n";
  yaml << "labels:\n";
  for (const auto& [label, object_id] : report.labels)
    yaml << "  " << label << ": " << object_id << "\n";
  return yaml.str();
}

void WriteForeignFrameIds(const std::string& path, const std::map<int64_t, ForeignFrameIds>& ids) {
  std::ofstream file(path);
  if (!file) G6D_THROW("cannot write the frame ids file '" << path << "'");
  file << "utime,scene_id,image_id,source\n";
  for (const auto& [utime, frame] : ids)
    file << utime << "," << frame.scene_id << "," << frame.image_id << "," << frame.source << "\n";
  if (!file) G6D_THROW("cannot write the frame ids file '" << path << "'");
}

std::map<int64_t, ForeignFrameIds> ReadForeignFrameIds(const std::string& path) {
  std::ifstream file(path);
  if (!file) G6D_THROW("cannot open the frame ids file '" << path << "'");
  std::map<int64_t, ForeignFrameIds> ids;
  std::string line;
  int number = 0;
  while (std::getline(file, line)) {
    if (++number == 1 || line.empty()) continue;  // header
    std::istringstream fields(line);
    std::string utime, scene, image, source;
    if (!std::getline(fields, utime, ',') || !std::getline(fields, scene, ',') ||
        !std::getline(fields, image, ',') || !std::getline(fields, source))
      G6D_THROW(path << ":" << number << ": expected utime,scene_id,image_id,source");
    try {
      ids[std::stoll(utime)] = ForeignFrameIds{source, std::stoi(scene), std::stoi(image)};
    } catch (const std::exception&) {
      G6D_THROW(path << ":" << number << ": '" << line << "' does not hold numbers");
    }
  }
  return ids;
}

}  // namespace g6d
