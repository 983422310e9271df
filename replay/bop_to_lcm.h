#pragma once
/// @file bop_to_lcm.h
/// BOP scene folder -> LCM event log of g6d_rgbd_frame_t (the input of g6d-service), one
/// event per image, in im_id order, for g6d-replay or lcm-logplayer.
///
/// Per image: colour from rgb/ (RGB8, compressed as asked), depth from depth/ as the raw
/// 16-bit PNG values (DEPTH_U16, zstd) with depth_scale_m = scene_camera.json depth_scale
/// (mm per unit) / 1000, and the mask_visib/ masks of the chosen instances painted into one
/// label image (LABEL_U8 when every label fits, else LABEL_U16; zstd). Instance `label` =
/// BOP gt_idx + 1, `gt_index` = gt_idx, `object_id` = BOP stem "obj_%06d", `score` = 1.
/// With InstanceInput::kBox an instance is a box instead (label 0, no label image at all:
/// a 0 x 0 label plane); with InstanceInput::kNone each object of the image is one
/// detection request (no mask, no box, `count` its instances; no label image); with
/// IdentityInput::kUnknown its object_id is empty.

#include <cstdint>
#include <string>
#include <vector>

#include "eval/bop.h"
#include "g6d/rgbd_frame_t.hpp"
#include "wire/frame_codec.h"

namespace g6d {

/// How the colour image is stored in the frames.
enum class ColorEncoding {
  kRaw,   ///< uncompressed RGB8
  kZstd,  ///< zstd of the raw bytes (lossless)
  kPng,   ///< PNG (lossless)
  kJpeg,  ///< JPEG (lossy; smallest)
};

/// Parses "raw", "zstd", "png" or "jpeg"; throws g6d::Error naming the bad value otherwise.
ColorEncoding ParseColorEncoding(const std::string& text);

/// Parses an image id list such as "8,10-20,33" (ranges inclusive) into sorted unique ids.
/// Throws g6d::Error naming the bad item (not a number, negative, reversed range).
std::vector<int> ParseFrameList(const std::string& text);

/// Where each instance is, as the frames say it.
enum class InstanceInput {
  kLabel,  ///< its GT visible mask in the label image (label = gt_idx + 1)
  kBox,    ///< a box only: the bounding box of its GT visible mask grown by box_margin_px on
           ///< each side and clipped to the image (g6d-bench-dataset --degrade-masks box's
           ///< mask, DegradeMask kBox); an instance whose mask is empty is left out
  kNone,   ///< neither: one detection request per object of the image (label 0, no box,
           ///< gt_index -1) with `count` = how many of its instances were chosen (a target's
           ///< inst_count): the service finds them itself (BOP's localization task)
};

/// Parses "label", "box" or "none"; throws g6d::Error naming the bad value otherwise.
InstanceInput ParseInstanceInput(const std::string& text);

/// Which object each instance is, as the frames say it.
enum class IdentityInput {
  kGiven,    ///< object_id = the GT object
  kUnknown,  ///< object_id empty, no candidates listed: the service chooses among every loaded object
};

/// Parses "given" or "unknown"; throws g6d::Error naming the bad value otherwise.
IdentityInput ParseIdentityInput(const std::string& text);

/// Options of WriteBopSceneLog().
struct BopToLcmOptions {
  std::string channel = "G6D_RGBD";           ///< LCM channel of the events
  ColorEncoding color = ColorEncoding::kPng;  ///< colour storage (lossless by default)
  /// Compression effort: a log is written once and read many times, so spend more than a
  /// live camera would (the codec's defaults are zstd 1 and PNG 1).
  EncodeOptions encode{/*zstd_level=*/9, /*png_level=*/6, /*jpeg_quality=*/90};
  double fps = 10.0;        ///< event rate, Hz: event i at start + i / fps
  int64_t start_utime = 0;  ///< timestamp of the first event (and its frame utime), microseconds
  std::string camera_id = "bop";  ///< camera_id of every frame
  /// Image ids to include; empty = all images of the scene (intersected with the targets).
  std::vector<int> frames;
  /// BOP'19 targets file. Empty: <dataset>/test_targets_bop19.json when it exists.
  std::string targets_file;
  /// When false, every image and every GT instance is included, targets or not.
  bool use_targets = true;
  std::string split = "test";  ///< split folder of the scene
  InstanceInput instances = InstanceInput::kLabel;  ///< masks (label image), boxes, or neither
                                                    ///< (kNone needs IdentityInput::kGiven)
  /// kBox: margin added on each side of the GT visible mask's bounding box, pixels, >= 0
  /// (6, as g6d-bench-dataset's --degrade-px default).
  int box_margin_px = 6;
  IdentityInput identity = IdentityInput::kGiven;   ///< object ids given or left empty

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// What WriteBopSceneLog() did.
struct BopToLcmReport {
  bool success = false;
  std::string message = "not run";
  std::string source;          ///< `source` of every frame: the dataset folder name
  std::string targets_file;    ///< targets file used, empty when all instances were taken
  int frames_written = 0;      ///< events in the log
  int instances_written = 0;   ///< instances over all frames
  int images_in_scene = 0;     ///< images listed in scene_camera.json
  int missing_instances = 0;   ///< target instances not found in scene_gt.json
  int64_t overlap_pixels = 0;  ///< mask pixels claimed by two instances (last one kept)
  int empty_masks = 0;         ///< kBox: instances left out because their visible mask is empty
  int64_t bytes_written = 0;   ///< size of the log file
  double seconds = 0.0;        ///< wall time
};

/// The dataset folder name used as `source`: "../data/lmo/" -> "lmo".
std::string BopSourceName(const std::string& dataset_dir);

/// One image as a frame message with the given instances (indices into frame.gt), as
/// labels or boxes and with or without object ids (options.instances, options.identity).
/// `overlap_pixels` (optional) receives the number of label pixels that two of these
/// instances' visible masks both claim (the later instance keeps them; 0 with boxes);
/// `empty_masks` (optional) the box instances left out because their visible mask is
/// empty. Throws g6d::Error naming the file when an image is missing, unreadable or of the
/// wrong size or type.
rgbd_frame_t MakeBopFrameMessage(const BopScene& scene, const BopFrame& frame,
                                 const std::vector<int>& gt_indices, const std::string& source,
                                 const BopToLcmOptions& options, int64_t seq, int64_t utime,
                                 int64_t* overlap_pixels = nullptr, int* empty_masks = nullptr);

/// The box of an instance whose GT visible mask is `mask` (CV_8U, non-zero = visible), as
/// InstanceInput::kBox sends it: DegradeMask's kBox mask with margin `margin_px`, as a
/// rectangle inside the image; empty (0 x 0) when the mask is empty.
cv::Rect BoxOfMask(const cv::Mat& mask, int margin_px);

/// The GT indices of `frame` to send per image id: all of them without targets, else for
/// each target (scene_id, im_id, obj_id, inst_count) the inst_count most visible GT instances
/// of obj_id (TargetGtIndices, as g6d-bench-dataset and the BOP evaluation choose them).
/// `missing` (optional) receives how many
/// target instances the GT lacks.
std::vector<int> SelectInstances(const BopFrame& frame, int scene_id,
                                 const std::vector<BopTarget>* targets, int* missing = nullptr);

/// Converts scene `scene_id` of the BOP dataset at `dataset_dir` into an LCM log at
/// `log_path` (overwritten). Throws g6d::Error on bad options or bad dataset files (naming
/// the file and field) and when the log cannot be written. A scene with no image to write
/// gives success = false and a message saying why (an empty log is still written).
BopToLcmReport WriteBopSceneLog(const BopToLcmOptions& options, const std::string& dataset_dir,
                                int scene_id, const std::string& log_path);

}  // namespace g6d
