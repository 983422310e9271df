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

/// One frame event of the log.
struct FrameEvent {
  int64_t event_number = 0;  ///< index of the event in the log (all channels)
  int64_t timestamp_us = 0;  ///< log timestamp, microseconds
  rgbd_frame_t frame;        ///< decoded message
};

/// Streams the frame events of one channel out of an LCM log. State (the open file and the
/// counts) lives across calls, hence a class.
class FrameLogReader {
 public:
  /// Opens `path`. Throws g6d::Error naming the path when it does not exist, is not a
  /// regular file, or cannot be opened.
  FrameLogReader(const std::string& path, const std::string& channel);
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
  std::unique_ptr<lcm::LogFile> log_;
  FrameLogStats stats_;
  int64_t position_ = 0;  ///< file offset after the last complete event
  bool done_ = false;
};

/// Reads the whole log once (for counts before a replay). Throws as FrameLogReader.
FrameLogStats ScanFrameLog(const std::string& path, const std::string& channel);

}  // namespace g6d
