#include "frame_log.h"

#include <cstdio>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <sstream>

#include "core/error.h"
#include "bot_core/images_t.hpp"
#include "drake/lcmt_image_array.hpp"
#include "wire/frame_codec.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;

// An LCM log event on disk: sync word, event number, timestamp, channel length, data
// length (28 bytes, big-endian), then the channel name and the data.
constexpr int64_t kEventHeaderBytes = 4 + 8 + 8 + 4 + 4;

}  // namespace

int64_t FrameLogStats::ForeignEvents() const {
  int64_t total = 0;
  for (const auto& [channel, count] : foreign_channels) total += count;
  return total;
}

std::vector<std::string> FrameLogStats::Problems() const {
  std::vector<std::string> problems;
  if (!foreign_channels.empty()) {
    std::ostringstream line;
    line << path << ": skipped " << ForeignEvents() << " event(s) of other channels (";
    bool first = true;
    for (const auto& [name, count] : foreign_channels) {
      line << (first ? "" : ", ") << name << ": " << count;
      first = false;
    }
    line << "); frames are read from channel " << channel;
    problems.push_back(line.str());
  }
  if (undecodable > 0) {
    std::ostringstream line;
    line << path << ": " << undecodable << " event(s) of channel " << channel
         << " do not decode as g6d_rgbd_frame_t (first: event " << first_undecodable_event
         << "); they were skipped";
    problems.push_back(line.str());
  }
  if (skipped_bytes > 0) {
    std::ostringstream line;
    line << path << ": " << skipped_bytes
         << " byte(s) before an event are not an LCM event (corrupted log); they were skipped";
    problems.push_back(line.str());
  }
  if (trailing_bytes > 0) {
    std::ostringstream line;
    line << path << ": truncated or corrupted: reading stopped at byte "
         << (file_bytes - trailing_bytes) << " of " << file_bytes << " after " << events
         << " complete event(s); the last " << trailing_bytes
         << " byte(s) are not a complete LCM event and were ignored";
    problems.push_back(line.str());
  }
  if (frames == 0) {
    std::ostringstream line;
    line << path << ": no g6d_rgbd_frame_t event on channel " << channel << " (" << events
         << " event(s) in the log)";
    problems.push_back(line.str());
  }
  return problems;
}

FrameLogReader::FrameLogReader(
    const std::string& path, const std::string& channel, InputType type,
    std::map<int64_t, ForeignFrameIds> ids)
    : type_(type), ids_(std::move(ids)) {
  stats_.path = path;
  stats_.channel = channel;
  std::error_code error;
  if (!fs::exists(path, error)) G6D_THROW("LCM log '" << path << "' does not exist");
  if (!fs::is_regular_file(path, error))
    G6D_THROW("LCM log '" << path << "' is not a regular file");
  stats_.file_bytes = static_cast<int64_t>(fs::file_size(path, error));
  log_ = std::make_unique<lcm::LogFile>(path, "r");
  if (!log_->good()) G6D_THROW("cannot open LCM log '" << path << "' for reading");
}

FrameLogReader::~FrameLogReader() = default;

rgbd_frame_t FrameLogReader::ForeignFrameIdentity(const void* data, int64_t size,
                                                  int64_t event_number) const {
  rgbd_frame_t frame;
  frame.source = InputTypeName(type_);
  frame.scene_id = frame.image_id = -1;
  frame.num_instances = 0;
  if (type_ == InputType::kDrake) {
    if (const std::string e = CheckEncodedDrakeImageArray(data, size); !e.empty()) G6D_THROW(e);
    drake::lcmt_image_array message;
    if (message.decode(data, 0, static_cast<int>(size)) < 0) G6D_THROW("malformed");
    frame.utime = message.header.utime;
    frame.seq = message.header.seq;
  } else {
    if (const std::string e = CheckEncodedBotCoreImages(data, size); !e.empty()) G6D_THROW(e);
    bot_core::images_t message;
    if (message.decode(data, 0, static_cast<int>(size)) < 0) G6D_THROW("malformed");
    frame.utime = message.utime;
    frame.seq = event_number;
  }
  const auto ids = ids_.find(frame.utime);
  if (ids != ids_.end()) {
    frame.source = ids->second.source;
    frame.scene_id = ids->second.scene_id;
    frame.image_id = ids->second.image_id;
  }
  return frame;
}

bool FrameLogReader::Next(FrameEvent* event) {
  while (!done_) {
    const lcm::LogEvent* log_event = log_->readNextEvent();
    if (log_event == nullptr) {
      // lcm_eventlog_read_next_event() gives NULL at a clean end, for a partial last
      // event, and when an event is not followed by the next sync word (it then drops
      // that event and stops); the bytes past the last returned event tell them apart.
      stats_.trailing_bytes = stats_.file_bytes - position_;
      done_ = true;
      break;
    }
    // Before the first event it scans silently over garbage to a sync word; count that.
    const int64_t end = static_cast<int64_t>(std::ftell(log_->getFilePtr()));
    const int64_t size = kEventHeaderBytes + static_cast<int64_t>(log_event->channel.size()) +
                         static_cast<int64_t>(log_event->datalen);
    stats_.skipped_bytes += end - size - position_;
    position_ = end;
    const int64_t number = stats_.events++;
    if (log_event->channel != stats_.channel) {
      ++stats_.foreign_channels[log_event->channel];
      continue;
    }
    try {
      if (type_ == InputType::kG6d) {
        event->frame = DecodeRgbdFrameMessage(log_event->data, log_event->datalen);
      } else {
        event->frame = ForeignFrameIdentity(log_event->data, log_event->datalen, number);
        event->raw.assign(static_cast<const uint8_t*>(log_event->data),
                          static_cast<const uint8_t*>(log_event->data) + log_event->datalen);
      }
    } catch (const Error&) {
      if (stats_.undecodable++ == 0) stats_.first_undecodable_event = number;
      continue;
    }
    event->event_number = number;
    event->timestamp_us = log_event->timestamp;
    ++stats_.frames;
    return true;
  }
  return false;
}

FrameLogStats ScanFrameLog(const std::string& path, const std::string& channel,
                           InputType type) {
  FrameLogReader reader(path, channel, type);
  FrameEvent event;
  while (reader.Next(&event)) {
  }
  return reader.stats();
}

}  // namespace g6d
