#pragma once
/// @file bop.h
/// Reading datasets in the BOP layout (https://github.com/thodan/bop_toolkit,
/// docs/bop_datasets_format.md):
///
///   <root>/camera.json                 optional: fx fy cx cy width height depth_scale
///   <root>/models/models_info.json     per obj_id: diameter (mm), symmetries_*, and the
///                                      g6d extensions `mesh` (path relative to models/)
///                                      and `units` ("mm" or "m", unit of that mesh file)
///   <root>/test_targets_bop19.json     optional: BOP'19 evaluation targets
///   <root>/<split>/<scene_id:06d>/     scene_camera.json, scene_gt.json,
///                                      scene_gt_info.json (optional), rgb/, depth/,
///                                      mask/, mask_visib/
///
/// Units: BOP files hold millimetres; everything returned here is in metres (poses,
/// diameters, symmetry offsets, depth images). `depth_scale` stays as BOP defines it:
/// millimetres per depth PNG unit. Object ids are integers plus the BOP file stem
/// (`obj_000005`). Bad or missing files throw g6d::Error naming the file and the field.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/camera.h"
#include "eval/metrics.h"
#include "mesh/mesh.h"

namespace g6d {

/// The BOP file stem of an object id: 5 -> "obj_000005". Throws g6d::Error when
/// obj_id is negative or has more than six digits.
std::string BopObjectName(int obj_id);

/// Parses a BOP object stem: "obj_000005" -> 5. Throws g6d::Error naming the text when it
/// is not "obj_" followed by six digits.
int ParseBopObjectName(const std::string& name);

/// One object of models/models_info.json.
struct BopObjectInfo {
  int obj_id = 0;             ///< BOP integer id
  std::string name;           ///< BOP stem, "obj_000005"
  double diameter_m = 0.0;    ///< largest vertex distance, metres (file: mm)
  Eigen::AlignedBox3d box_m;  ///< from min_* and size_* when given (else empty), metres
  std::string mesh_path;      ///< <root>/models/<mesh>, default obj_XXXXXX.ply
  Units mesh_units = Units::kMillimetres;  ///< unit of the numbers in the mesh file
  /// `symmetries_discrete` as object_from_object transforms, translation in metres, the
  /// 3x3 part as given (not orthonormalized). The identity is not included.
  std::vector<Eigen::Isometry3d> symmetries_discrete;
  /// `symmetries_continuous` (axis, offset in metres).
  std::vector<ContinuousSymmetry> symmetries_continuous;

  /// True when the file lists any symmetry (ADD-S rather than ADD is the usual choice).
  bool IsSymmetric() const {
    return !symmetries_discrete.empty() || !symmetries_continuous.empty();
  }
  /// The identity plus all symmetries, continuous ones discretized the bop_toolkit way
  /// (see `SymmetryTransforms()`), for MSSD and MSPD.
  std::vector<Eigen::Isometry3d> Symmetries(
      double max_discretization_step = kBopMaxSymmetryDiscretizationStep) const {
    return SymmetryTransforms(symmetries_discrete, symmetries_continuous, max_discretization_step);
  }
};

/// One entry of test_targets_bop19.json: estimate `inst_count` instances of `obj_id` in
/// image (scene_id, im_id).
struct BopTarget {
  int scene_id = 0;
  int im_id = 0;
  int obj_id = 0;
  int inst_count = 0;
};

/// Reads a BOP'19 targets file (a JSON list of {scene_id, im_id, obj_id, inst_count}), e.g.
/// <root>/test_targets_bop19.json. Throws g6d::Error naming the file and the entry when it
/// is missing, malformed or a field is missing or not an integer.
std::vector<BopTarget> LoadBopTargets(const std::string& path);

/// LoadBopTargets() on the text of a targets file; `source` names it in error messages
/// (as the path does for the loader). Every LoadBop*() reads its JSON files whole and hands
/// the text to one of these Parse*() functions, so fuzzers and tests reach all the JSON
/// parsing without files. Throws g6d::Error naming the source and the field.
std::vector<BopTarget> ParseBopTargets(const std::string& json_text, const std::string& source);

/// What camera.json holds.
struct BopCameraInfo {
  Camera camera;             ///< fx fy cx cy width height, valid by Camera::Check()
  double depth_scale = 1.0;  ///< mm per depth PNG unit; 1 when the file has none
};

/// Parses the text of camera.json (fx, fy, cx, cy, width, height required; depth_scale
/// optional). Throws g6d::Error naming `source` and the field when one is missing, of the
/// wrong type or out of range.
BopCameraInfo ParseBopCamera(const std::string& json_text, const std::string& source);

/// Parses the text of models/models_info.json: objects by obj_id, mesh paths resolved
/// against `models_dir`, millimetres converted to metres. Throws g6d::Error naming
/// `source` and the field (see LoadBopDataset()).
std::map<int, BopObjectInfo> ParseBopModelsInfo(const std::string& json_text,
                                                const std::string& source,
                                                const std::string& models_dir);

/// What LoadBopDataset() finds at the dataset root (scenes themselves are loaded lazily
/// with LoadBopScene()).
struct BopDataset {
  std::string root;            ///< dataset folder as given
  std::string split = "test";  ///< split folder the scenes were listed from
  /// camera.json when present (width and height from it too); depth_scale alongside.
  std::optional<Camera> camera;
  double camera_depth_scale = 1.0;       ///< camera.json depth_scale, mm per unit (1 if absent)
  std::map<int, BopObjectInfo> objects;  ///< by obj_id, from models/models_info.json
  std::vector<BopTarget> targets;        ///< test_targets_bop19.json (empty if absent)
  bool has_targets = false;              ///< whether test_targets_bop19.json exists
  std::vector<int> scene_ids;            ///< sorted ids of the <split>/NNNNNN folders

  /// The object with this id; throws g6d::Error naming the id when it is unknown.
  const BopObjectInfo& Object(int obj_id) const;
};

/// Reads camera.json (optional), models/models_info.json (required),
/// test_targets_bop19.json (optional) and lists the scene folders under <root>/<split>.
/// Throws g6d::Error naming the file and field for missing required files, malformed JSON
/// or fields of the wrong type.
BopDataset LoadBopDataset(const std::string& root, const std::string& split = "test");

/// scene_gt_info.json entry of one GT instance (pixels, BOP definitions).
struct BopGtInfo {
  std::array<int, 4> bbox_obj = {-1, -1, -1, -1};    ///< x, y, w, h of the full silhouette
  std::array<int, 4> bbox_visib = {-1, -1, -1, -1};  ///< x, y, w, h of the visible part
  int px_count_all = 0;                              ///< silhouette pixels (also outside the image)
  int px_count_valid = 0;                            ///< silhouette pixels with valid depth
  int px_count_visib = 0;                            ///< visible pixels
  double visib_fract = 0.0;                          ///< px_count_visib / px_count_all
};

/// One ground-truth instance of an image.
struct BopGtInstance {
  int obj_id = 0;
  /// From cam_R_m2c (row-major) and cam_t_m2c (mm -> m). The 3x3 part is kept exactly as
  /// given, NOT orthonormalized: masks and depth of the datasets were rendered with it
  /// (LM-O has det(R) up to 1.014). Use Orthonormalize() from core/se3.h where a proper
  /// rotation is needed, and do not rely on Isometry3d::inverse() being exact.
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();
  std::optional<BopGtInfo> info;  ///< from scene_gt_info.json when present
};

/// One image of a scene.
struct BopFrame {
  int im_id = 0;
  /// cam_K of scene_camera.json; width and height from camera.json, else from this
  /// scene's first readable RGB (or depth) image, else 0.
  Camera camera;
  double depth_scale = 1.0;       ///< mm per depth PNG unit (depth_mm = value * depth_scale)
  std::vector<BopGtInstance> gt;  ///< scene_gt.json list, in file order (gt_idx = index)
};

/// The GT instances a target (obj_id, inst_count) asks for, BOP's rule
/// (eval_calc_scores.py): the inst_count instances of the object with the largest
/// visib_fract (ties, and instances without gt_info, in scene_gt order), returned in scene_gt
/// order. A hidden instance of an object seen twice is not asked for.
std::vector<int> TargetGtIndices(const BopFrame& frame, int obj_id, int inst_count);

/// One scene folder: cameras and ground truth of all its images.
struct BopScene {
  std::string root;       ///< dataset root
  std::string directory;  ///< <root>/<split>/<scene_id:06d>
  int scene_id = 0;
  std::vector<BopFrame> frames;  ///< every image of scene_camera.json, sorted by im_id

  /// The frame with this im_id; throws g6d::Error naming it when absent.
  const BopFrame& Frame(int im_id) const;
  /// Number of GT instances over all frames.
  int InstanceCount() const;
};

/// Reads <root>/<split>/<scene_id:06d>/scene_camera.json and scene_gt.json (both
/// required; every scene_gt image must have a camera) and scene_gt_info.json (optional;
/// when present its lists must match scene_gt.json). Throws g6d::Error naming the file and
/// field on a missing file, malformed JSON, a wrong type or inconsistent lengths.
BopScene LoadBopScene(const std::string& root, int scene_id, const std::string& split = "test");

/// Names of a scene's three JSON files in error messages of ParseBopSceneFrames().
struct BopSceneSources {
  std::string camera = "scene_camera.json";    ///< names scene_camera.json
  std::string gt = "scene_gt.json";            ///< names scene_gt.json
  std::string gt_info = "scene_gt_info.json";  ///< names scene_gt_info.json
};

/// The JSON parsing of LoadBopScene() on texts: scene_camera.json, scene_gt.json and, when
/// given, scene_gt_info.json of one scene. Returns every image of scene_camera.json sorted
/// by im_id, each camera sized `width` x `height` (not checked; 0 when unknown). Throws
/// g6d::Error naming the source and the field, as LoadBopScene() does.
std::vector<BopFrame> ParseBopSceneFrames(const std::string& camera_json_text,
                                          const std::string& gt_json_text,
                                          const std::optional<std::string>& gt_info_json_text,
                                          int width, int height,
                                          const BopSceneSources& sources = {});

/// rgb/<im_id:06d>.png, or .jpg when there is no PNG, as CV_8UC3 in RGB order (gray
/// images are expanded). Throws g6d::Error naming the path when neither exists or is
/// unreadable.
cv::Mat LoadBopRgb(const BopScene& scene, int im_id);

/// depth/<im_id:06d>.png (16-bit) as CV_32F metres: value * depth_scale / 1000 with the
/// frame's depth_scale; 0 stays 0 (no measurement). `folder` names another depth folder of
/// the scene in the same units (synth_dev's exact `depth_gt`). Throws g6d::Error naming the
/// path when it is missing, unreadable or not 16-bit single channel, or im_id is not in the
/// scene.
cv::Mat LoadBopDepth(const BopScene& scene, int im_id, const std::string& folder = "depth");

/// mask_visib/<im_id:06d>_<gt_idx:06d>.png as CV_8U (0 or 255 in BOP data). Throws
/// g6d::Error naming the path when missing, unreadable or not single channel 8-bit.
cv::Mat LoadBopMaskVisib(const BopScene& scene, int im_id, int gt_idx);

/// mask/<im_id:06d>_<gt_idx:06d>.png (full silhouette, occlusion ignored); as
/// LoadBopMaskVisib().
cv::Mat LoadBopMask(const BopScene& scene, int im_id, int gt_idx);

}  // namespace g6d
