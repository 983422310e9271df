#pragma once
/// @file input_adapters.h
/// Input adapters: the RGB-D images other LCM stacks publish, turned into the
/// g6d.rgbd_frame_t the service answers, so validation, decoding, solving and answers are
/// the same for every input type.
///
///  - g6d:      g6d.rgbd_frame_t as it is.
///  - drake:    drake.lcmt_image_array as Drake's ImageToLcmImageArrayT publishes it: one
///              colour image (RGB/RGBA/BGR/BGRA/GRAY, uint8), one depth image (float32
///              metres or uint16 millimetres) and one LABEL image (int16/uint16 instance
///              labels), each raw, zlib, PNG or (colour only) JPEG compressed. Images are
///              found by pixel_format, not by position.
///  - bot_core: bot_core.images_t: a LEFT colour image (MJPEG, RGB, BGR, RGBA, BGRA or
///              GRAY), a DEPTH_MM or DEPTH_MM_ZIPPED (zlib) depth image in millimetres and a
///              MASK_ZIPPED (zlib) instance label image of 8 or 16 bits.
///
/// Neither foreign type carries the intrinsics or which label is which object: an
/// AdapterOptions holds them (the service reads them from YAML). Label values the label
/// map does not name are background; a named label with pixels becomes one instance.
/// Objects to find (AdapterOptions::find_objects) become detection requests in every
/// frame, and then the label image is optional.
///
/// Errors. Everything here throws g6d::Error with a message that starts with the input
/// type and says which image and what was expected ("drake: depth image: zlib data is
/// corrupted", "bot_core: no MASK_ZIPPED image (instance labels) among 2 images").

#include <cstdint>
#include <map>
#include <string>

#include "core/camera.h"
#include "g6d/rgbd_frame_t.hpp"
#include "wire/answer.h"
#include "wire/frame_codec.h"

namespace g6d {

/// The message type of the service's input channel.
enum class InputType { kG6d, kDrake, kBotCore };

/// "g6d", "drake", "bot_core".
std::string InputTypeName(InputType type);

/// Parses "g6d", "drake" or "bot_core"; throws g6d::Error naming the accepted values.
InputType ParseInputType(const std::string& text);

/// What a foreign message does not carry.
struct AdapterOptions {
  /// Intrinsics of the colour (= depth = label) image, pixels; width and height must match
  /// the images. Needed for drake and bot_core.
  Camera camera;
  /// Label value in the label / mask image -> object id. Values not listed are background.
  std::map<int32_t, std::string> label_objects;
  /// camera_id echoed in answers; empty = Drake's frame name, or "bot_core".
  std::string camera_id;
  /// Object id -> count: every frame also asks the service to find these objects with no
  /// mask (a detection request per object, instance_t.count = the count). With objects to
  /// find, the label / mask image may be absent (a stack without a segmenter).
  std::map<std::string, int> find_objects;

  /// Empty when valid for `type`, else names the bad field.
  std::string Check(InputType type) const;
};

/// Reads a camera YAML file: `fx, fy, cx, cy, width, height` (pixels), or bot-param's
/// pinhole layout `pinhole: [fx, fy, skew, cx, cy]` with `width` and `height`, either at the
/// top level or under `intrinsic_cal:`. A non-zero skew is refused. Throws g6d::Error naming
/// the file and key.
Camera LoadCameraYaml(const std::string& path);

/// The same from a parsed YAML text (`name` is used in error messages).
Camera ParseCameraYaml(const std::string& text, const std::string& name);

/// Reads a label map YAML file: `labels: {1: obj_000005, 2: obj_000008}` (or the mapping at
/// the top level). Throws g6d::Error naming the file and key on a label <= 0, an empty id
/// or a file that does not parse.
std::map<int32_t, std::string> LoadLabelMapYaml(const std::string& path);

/// The same from YAML text.
std::map<int32_t, std::string> ParseLabelMapYaml(const std::string& text, const std::string& name);

/// Converts one raw LCM message of type `type` into a g6d.rgbd_frame_t. For kG6d this is
/// DecodeRgbdFrameMessage(). `header` (optional) receives utime and seq as soon as they are
/// known, so an error answer can still name the frame. bot_core.images_t has no sequence
/// number: `seq` is used for it. Throws g6d::Error (see the file comment); the result still
/// goes through DecodeFrame() for validation.
rgbd_frame_t AdaptMessage(InputType type, const void* data, int64_t size,
                          const AdapterOptions& options, const DecodeLimits& limits, int64_t seq,
                          FrameHeader* header = nullptr);

/// Checks, before any decoding, that `size` bytes hold a well-formed encoded
/// drake.lcmt_image_array (fingerprint, every declared string and array inside the
/// buffer); lcm-gen's decoders allocate declared sizes before checking them. Empty when
/// safe, else the reason.
std::string CheckEncodedDrakeImageArray(const void* data, int64_t size);

/// The same for bot_core.images_t.
std::string CheckEncodedBotCoreImages(const void* data, int64_t size);

}  // namespace g6d
