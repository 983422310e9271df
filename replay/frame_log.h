#pragma once
/// @file frame_log.h
/// Reading g6d_rgbd_frame_t events back from a standard LCM event log (lcm::LogFile), with
/// the problems a person needs to hear about: a missing or empty file, a truncated or
/// corrupted tail, garbage before the first event, events of other channels, and events of
/// the frame channel that do not decode as g6d_rgbd_frame_t.

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "g6d/rgbd_frame_t.hpp"
#include "wire/input_adapters.h"

namespace lcm {
class LogFile;
}

namespace g6d {

/// What reading a log found so far (complete after FrameLogReader::Next() returned false).
struct FrameLogStats {
  std::string path;         ///< the log file
  std::string channel;      ///< the frame channel
  int64_t file_bytes = 0;   ///< size of the file
  int64_t events = 0;       ///< complete events of any channel
  int64_t frames = 0;       ///< events of `channel` that decode as g6d_rgbd_frame_t
  int64_t undecodable = 0;  ///< events of `channel` that do not decode
  std::map<std::string, int64_t> foreign_channels;  ///< skipped events per other channel
  int64_t skipped_bytes = 0;  ///< bytes before an event that are not an event (corruption)
  /// Bytes after the last event read: a partial event (truncated log), or everything from
  /// an event that is not followed by the next event's sync word on (LCM's reader stops
  /// there, dropping that event too).
  int64_t trailing_bytes = 0;
  int64_t first_undecodable_event = -1;  ///< event number of the first undecodable event

  /// Events of other channels in total.
  int64_t ForeignEvents() const;
  /// True when reading stopped before the end of the file (truncated or corrupted).
  bool Truncated() const { return trailing_bytes > 0; }
  /// One line per problem (foreign channels, undecodable events, skipped or trailing
  /// bytes, no frames at all), each naming the file; empty when the log is clean.
  std::vector<std::string> Problems() const;
};

/// The request identity of a frame written as a foreign message, which loses it
/// (foreign_log.h writes and reads these).
struct ForeignFrameIds {
  std::string source;
  int32_t scene_id = -1;
  int32_t image_id = -1;
};

/// One frame event of the log.
struct FrameEvent {
  int64_t event_number = 0;  ///< index of the event in the log (all channels)
  int64_t timestamp_us = 0;  ///< log timestamp, microseconds
  /// The decoded message. For a foreign input type only its identity: utime, seq (Drake's
  /// header seq; the event number for bot_core), source (the input type name, or the frame
  /// ids file's) and scene/image ids (from the frame ids file, else -1); no images.
  rgbd_frame_t frame;
  std::vector<uint8_t> raw;  ///< the event's bytes, for a foreign input type (sent as they are)
};

/// Streams the frame events of one channel out of an LCM log. State (the open file and the
/// counts) lives across calls, hence a class.
class FrameLogReader {
 public:
  /// Opens `path`. Throws g6d::Error naming the path when it does not exist, is not a
  /// regular file, or cannot be opened.
  /// `type` is the message type of the channel (drake / bot_core events are checked and
  /// decoded as those types); `ids` (optional) gives their scene and image ids by utime.
  FrameLogReader(const std::string& path, const std::string& channel,
                 InputType type = InputType::kG6d,
                 std::map<int64_t, ForeignFrameIds> ids = {});
  ~FrameLogReader();
  FrameLogReader(const FrameLogReader&) = delete;
  FrameLogReader& operator=(const FrameLogReader&) = delete;

  /// Reads up to the next decodable frame of the channel into *event, counting (not
  /// returning) foreign and undecodable events. Returns false at the end of the log
  /// (stats() is then complete, trailing bytes included).
  bool Next(FrameEvent* event);

  /// Counts so far.
  const FrameLogStats& stats() const { return stats_; }

 private:
  /// utime, seq, source and ids of a foreign event; throws g6d::Error when it does not decode.
  rgbd_frame_t ForeignFrameIdentity(const void* data, int64_t size, int64_t event_number) const;

  std::unique_ptr<lcm::LogFile> log_;
  FrameLogStats stats_;
  int64_t position_ = 0;  ///< file offset after the last complete event
  bool done_ = false;
  InputType type_ = InputType::kG6d;
  std::map<int64_t, ForeignFrameIds> ids_;
};

/// Reads the whole log once (for counts before a replay). Throws as FrameLogReader.
FrameLogStats ScanFrameLog(const std::string& path, const std::string& channel,
                           InputType type = InputType::kG6d);

}  // namespace g6d
