#pragma once
/// @file foreign_log.h
/// A log of g6d.rgbd_frame_t rewritten as the messages another LCM stack publishes
/// (Drake's drake.lcmt_image_array, libbot's bot_core.images_t), with the service options
/// file that makes g6d-service read them and the frame ids g6d-replay needs to turn the
/// answers into BOP rows (foreign messages carry no scene or image id).
///
/// Per frame: colour RGB8 (Drake: zlib; bot_core: raw RGB, or MJPEG when asked), depth
/// (Drake: float32 metres exactly as g6d-service decodes the original frame, zlib;
/// bot_core: DEPTH_MM_ZIPPED, millimetres rounded to the nearest integer) and the instance
/// labels (Drake: LABEL int16, zlib; bot_core: MASK_ZIPPED, 8 or 16 bits). A foreign label
/// names an object, not an instance: label values are assigned per object id (1, 2, ... in
/// order of first appearance) and a second instance of an object in one frame is dropped
/// (counted). Every frame must have the intrinsics and size of the first (one camera).

#include <cstdint>
#include <map>
#include <string>

#include "core/camera.h"
#include "frame_log.h"
#include "wire/input_adapters.h"

namespace g6d {

/// Options of ConvertFrameLog().
struct ForeignLogOptions {
  InputType type = InputType::kDrake;  ///< kDrake or kBotCore
  bool bot_core_mjpeg = false;         ///< bot_core colour as MJPEG instead of raw RGB
  int jpeg_quality = 90;               ///< MJPEG quality 1..100

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// What ConvertFrameLog() wrote.
struct ForeignLogReport {
  int frames = 0;                          ///< events written
  int instances = 0;                       ///< labelled instances over all frames
  int dropped_instances = 0;               ///< second instances of an object in a frame
  Camera camera;                           ///< the intrinsics of every frame
  std::map<int32_t, std::string> labels;   ///< label value -> object id
  std::map<int64_t, ForeignFrameIds> ids;  ///< frame utime -> its ids
};

/// Rewrites the frames of `channel` in the g6d log `g6d_log` as `options.type` messages on
/// the same channel into `out_log` (overwritten), same utimes and log timestamps. Throws
/// g6d::Error naming the frame on a frame that does not decode, intrinsics or a size that
/// differ from the first frame's, or a log that cannot be written.
ForeignLogReport ConvertFrameLog(const std::string& g6d_log, const std::string& channel,
                                 const ForeignLogOptions& options, const std::string& out_log);

/// The g6d-service options file for such a log: input channel, input_type, camera and
/// labels (for kG6d only the input channel). `g6d-service --templates DIR --config FILE`
/// accepts it as it is.
std::string ServiceOptionsYamlFor(const std::string& channel, InputType type,
                                  const ForeignLogReport& report);

/// Writes / reads the frame ids file: CSV `utime,scene_id,image_id,source`, a header line
/// first. Read throws g6d::Error naming the file and line.
void WriteForeignFrameIds(const std::string& path, const std::map<int64_t, ForeignFrameIds>& ids);
std::map<int64_t, ForeignFrameIds> ReadForeignFrameIds(const std::string& path);

}  // namespace g6d
