#pragma once
/// @file sample_scene.h
/// The embedded sample (g6d-make-sample): procedurally textured objects and a short RGB-D
/// sequence of them resting on a textured table, rendered with the project's own
/// renderers, written as a BOP dataset with ground truth. Everything comes from code and
/// one seed: no file is read that this library did not write.
///
/// Frames. The world frame is the table: z up, the table top at z = 0. Each image shows
/// every object resting on one of its stable faces at a random position and yaw inside a
/// small cluster (footprints never overlap), seen by a camera 0.5-0.9 m away looking down
/// at 40-65 degrees. Arrangements are redrawn until every object is inside the image and at
/// least `min_visible_fraction` visible, and (when possible) one object is partly hidden by
/// another, so the sequence has real mutual occlusion. In sequence mode one arrangement
/// holds for every image, the camera orbits it smoothly and one object jumps once
/// (SampleSequenceOptions); the same rules hold in every image.
///
/// Images. Masks and depth come from the exact CPU rasterizer (objects and table composed
/// by z-buffer), so mask_visib holds exactly the pixels where an object is the nearest
/// surface. Colour comes from OSMesa renders of each mesh (texture, Lambertian headlight)
/// composed with the same z-buffer at `supersampling` times the resolution and
/// area-downsampled (anti-aliased edges, as a real camera sees them), plus Gaussian colour
/// noise. Depth gets Gaussian noise and is stored as uint16 in units of depth_scale mm.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/executor.h"
#include "eval/bop.h"
#include "mesh/mesh.h"
#include "templates/template_bank.h"

namespace g6d {

/// One stable way an object rests on the table.
struct SampleRest {
  /// Rotation of the object in the table frame before the random yaw about +z.
  Eigen::Matrix3d table_from_object = Eigen::Matrix3d::Identity();
  /// When true a random rotation about the object's own z axis is applied first (a
  /// cylinder lying on its side rolls freely).
  bool free_roll_about_object_z = false;
};

/// A procedurally textured object of the sample.
struct SampleObject {
  int obj_id = 0;          ///< BOP id, 1-based
  std::string name;        ///< BOP stem "obj_000001"
  std::string kind;        ///< "box", "cylinder" or "prism"
  std::string dimensions;  ///< human-readable size, e.g. "box 120 x 80 x 45 mm"
  /// Metres, object frame centred on the bounding box, textured (RGB atlas + UVs), closed
  /// and counter-clockwise seen from outside, flat normals except on the cylinder side.
  Mesh mesh;
  std::vector<SampleRest> rests;  ///< stable rests, drawn uniformly
};

/// The objects of the sample in id order: 1 a box 120 x 80 x 45 mm, 2 a cylinder (can)
/// of radius 33 mm and height 110 mm, 3 a triangular prism of side 60 mm and length
/// 150 mm. Every face carries its own random packaging-like print (colour fields, shapes,
/// letters, a barcode) so ORB finds corners on every view and no two faces look alike.
/// `texture_px_per_mm` is the texture resolution. Deterministic for a seed. Throws
/// g6d::Error when count is not 1..3 or texture_px_per_mm is not in (0, 20].
std::vector<SampleObject> MakeSampleObjects(int count, uint64_t seed,
                                            double texture_px_per_mm = 2.5);

/// The table: a square of side `size_m` centred at the origin in the z = 0 plane, normal
/// +z, split into `cells` x `cells` quads (so that the rasterizer, which skips triangles
/// crossing the near plane, still draws everything in view), with a smooth wood-like
/// texture repeated every `tile_m` metres. Deterministic for a seed.
Mesh MakeSampleTable(double size_m, int cells, double tile_m, uint64_t seed);

/// Writes `mesh` (metres) as a Wavefront OBJ at `obj_path` with its material file (same
/// stem, .mtl) and texture (same stem, .png, RGB) beside it, numbers in metres. Vertices,
/// UVs and normals share indices. Throws g6d::Error naming the file when it cannot be
/// written or when the mesh has no texture.
void WriteTexturedObj(const Mesh& mesh, const std::string& obj_path);

/// Sequence mode of the sample (g6d-make-sample --sequence), for testing object tracking:
/// one arrangement for the whole sequence, a smooth camera orbit around the cluster at
/// `fps`, and one object that jumps once to a new place on the table.
///
/// The camera path, with s = image / (frames - 1) in [0, 1]: azimuth sweeps linearly
/// through `sweep` (drawn from [min_sweep_deg, max_sweep_deg], either direction), elevation
/// and distance change by one sinusoidal period of the drawn amplitudes, and the look-at
/// point drifts linearly by `look_at_drift_m`. When the sequence is so short that this
/// would move the camera faster than `max_camera_speed_m_s` or turn it faster than
/// `max_rotation_deg_s`, every amplitude (sweep included) is scaled down until it does not.
struct SampleSequenceOptions {
  bool enabled = false;  ///< false: every image a new arrangement and camera (the classic sample)
  double fps = 30.0;     ///< frame rate of the camera path, Hz
  /// Image (0-based) from which on the displaced object rests at its new place; -1 = none.
  /// Must be in 1..frames-1 otherwise.
  int abrupt_frame = -1;
  /// Index (0-based, object order) of the object that jumps; the last object when there
  /// are fewer.
  int abrupt_object = 1;
  double min_sweep_deg = 40.0;  ///< azimuth swept over the sequence, degrees
  double max_sweep_deg = 70.0;
  double min_elevation_wobble_deg = 2.0;  ///< amplitude of the elevation sinusoid, degrees
  double max_elevation_wobble_deg = 6.0;
  double min_distance_wobble_m = 0.02;  ///< amplitude of the distance sinusoid, metres
  double max_distance_wobble_m = 0.06;
  double look_at_drift_m = 0.02;      ///< the look-at point moves this far over the sequence
  double max_camera_speed_m_s = 0.3;  ///< camera centre speed bound, metres per second
  double max_rotation_deg_s = 30.0;   ///< camera rotation rate bound, degrees per second
  double min_jump_m = 0.06;           ///< translation of the displaced object, metres
  double max_jump_m = 0.12;
  double min_jump_turn_deg = 60.0;  ///< its rotation about the table normal, degrees
  double max_jump_turn_deg = 120.0;
  /// Valid candidates checked at most while looking for one with mutual occlusion (each
  /// costs a check of every image); then the first valid one is kept.
  int max_valid_candidates = 20;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Options of the sample scene. Every field has a meaning in metres, degrees or pixels.
struct SampleOptions {
  int num_objects = 3;  ///< objects in the scene (1..3), each present in every image
  int num_frames = 12;  ///< images of the sequence
  uint64_t seed = 1;    ///< every random choice (textures, poses, noise) derives from it
  /// Intrinsics and size of the RGB-D camera (a 640 x 480 RealSense-like camera).
  Camera camera{615.0, 615.0, 318.5, 241.5, 640, 480};
  double min_distance_m = 0.50;  ///< camera to the look-at point, metres
  double max_distance_m = 0.90;
  double min_elevation_deg = 40.0;  ///< viewing direction below the horizon, degrees
  double max_elevation_deg = 65.0;
  double look_at_jitter_m = 0.02;     ///< look-at point = cluster centroid + uniform jitter, metres
  double cluster_radius_m = 0.13;     ///< object centres lie within this radius of the table origin
  double contact_gap_m = 0.0005;      ///< objects hover this much above the table (no z-fighting)
  double footprint_margin_m = 0.004;  ///< minimum gap between object footprints, metres
  /// Every object must be at least this visible (visib_fract) in every image.
  double min_visible_fraction = 0.50;
  /// An arrangement is preferred when some object's visib_fract is below this (mutual
  /// occlusion); after `max_tries` arrangements without it the best valid one is kept.
  double occlusion_below_fraction = 0.93;
  int max_tries = 300;             ///< arrangements drawn per image at most
  int border_margin_px = 8;        ///< full silhouettes stay this far from the image border
  double depth_noise_m = 0.0015;   ///< Gaussian depth noise sigma, metres
  double color_noise = 2.0;        ///< Gaussian colour noise sigma, 8-bit levels
  double depth_scale_mm = 0.1;     ///< BOP depth_scale: millimetres per depth PNG unit
  int supersampling = 2;           ///< colour is rendered at this factor and area-downsampled
  double texture_px_per_mm = 2.5;  ///< object texture resolution
  double table_size_m = 3.0;       ///< side of the table square
  int table_cells = 60;            ///< table tessellation per side
  double table_tile_m = 0.6;       ///< period of the table texture
  /// Sequence mode; when enabled, max_tries counts whole candidates (arrangement, camera
  /// path and jump), each checked in every image.
  SampleSequenceOptions sequence;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Ground truth of one object in one image.
struct SampleInstance {
  int obj_id = 0;
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();  ///< metres
  int px_count_all = 0;      ///< silhouette pixels (all inside the image by construction)
  int px_count_visib = 0;    ///< pixels where this object is the nearest surface
  double visib_fract = 0.0;  ///< px_count_visib / px_count_all
  cv::Rect bbox_obj;         ///< box of the full silhouette
  cv::Rect bbox_visib;       ///< box of the visible pixels
};

/// One rendered image of the sequence.
struct SampleFrame {
  Eigen::Isometry3d cam_from_world = Eigen::Isometry3d::Identity();  ///< world = table frame
  std::vector<SampleInstance> instances;  ///< in object order (gt_idx = index)
  cv::Mat rgb;                            ///< CV_8UC3, RGB order
  cv::Mat depth_m;                        ///< CV_32F metres with noise; 0 where nothing is in range
  std::vector<cv::Mat> masks;             ///< CV_8U 0/255 full silhouettes, per instance
  std::vector<cv::Mat> masks_visib;       ///< CV_8U 0/255 visible masks, per instance
  int tries = 0;                          ///< arrangements drawn for this image
};

/// The geometry of a sequence (SampleSequenceOptions): where the objects rest and where
/// the camera is in every image. World = table frame, metres.
struct SampleSequencePlan {
  std::vector<Eigen::Isometry3d> world_from_object;  ///< per object, before the jump
  int abrupt_frame = -1;                             ///< as in the options; -1 = no jump
  int abrupt_object = -1;                            ///< object index that jumps; -1 = none
  /// The displaced object from abrupt_frame on.
  Eigen::Isometry3d jumped_world_from_object = Eigen::Isometry3d::Identity();
  double jump_m = 0.0;         ///< its translation, metres
  double jump_turn_deg = 0.0;  ///< its rotation about the table normal, degrees (signed)
  std::vector<Eigen::Isometry3d> cam_from_world;  ///< per image
  double sweep_deg = 0.0;                         ///< azimuth swept, after any slow-down (signed)
  double max_step_m = 0.0;       ///< largest camera centre move between consecutive images
  double max_step_deg = 0.0;     ///< largest camera rotation between consecutive images
  double min_visib_fract = 1.0;  ///< least visible object over the sequence (objects only)
  bool occluded = false;         ///< some image has an object below occlusion_below_fraction
  int tries = 0;                 ///< candidates drawn

  /// world_from_object of object k in image `im_id`.
  Eigen::Isometry3d WorldFromObject(int im_id, int k) const;
};

/// Draws the sequence for options.sequence (enabled or not) from options.seed: one
/// arrangement of `objects` (as in every image of the classic sample), a camera path and
/// the jump, redrawn until every object is inside the image with the border margin and at
/// least min_visible_fraction visible in every image, preferring a candidate with mutual
/// occlusion in some image (among at most sequence.max_valid_candidates valid ones; a
/// single object takes the first valid one). Throws g6d::Error on bad options or when no valid
/// candidate is found within options.max_tries.
SampleSequencePlan PlanSampleSequence(const SampleOptions& options,
                                      const std::vector<SampleObject>& objects);

/// Progress callback: a human-readable line per step.
using SampleProgressCallback = std::function<void(const std::string&)>;

/// What WriteSampleDataset() wrote.
struct SampleReport {
  bool success = false;
  std::string message = "not run";
  std::vector<SampleObject> objects;  ///< meshes as written and read back (LoadMesh)
  std::vector<double> diameters_m;    ///< per object
  int frames_written = 0;
  int instances_written = 0;
  int occluded_instances = 0;  ///< instances with visib_fract < 0.98
  double min_visib_fract = 1.0;
  double mean_visib_fract = 0.0;
  double seconds = 0.0;
  /// Sequence mode only (options.sequence.enabled): the plan rendered.
  SampleSequencePlan sequence;
};

/// The composed view of `meshes` at `cam_from_object` poses (and the table at
/// `cam_from_world`, when `table` is not null): per pixel the index of the nearest surface
/// (0..n-1 objects, n = table, -1 = nothing; ties keep the lower index) and its depth,
/// from the exact CPU rasterizer at pixel centres. This is the z-buffer that defines
/// mask_visib and the depth of the sample; tests recompute it independently.
void ComposeSampleDepth(const std::vector<const Mesh*>& meshes,
                        const std::vector<Eigen::Isometry3d>& cam_from_object, const Mesh* table,
                        const Eigen::Isometry3d& cam_from_world, const Camera& camera,
                        cv::Mat* nearest_index, cv::Mat* depth_m);

/// Writes the sample dataset under `root` (created; existing sample files replaced):
///   camera.json, test_targets_bop19.json (every instance with visib_fract >= 0.1),
///   models/models_info.json and per object obj_XXXXXX.obj/.mtl/.png (metres; the info
///   file records `mesh` and `units` = "m", `diameter` and the box in mm, no symmetries:
///   the prints break every geometric symmetry),
///   test/000001/{rgb,depth,mask,mask_visib}/, scene_gt.json, scene_camera.json (also
///   cam_R_w2c / cam_t_w2c of the table frame), scene_gt_info.json.
/// Images are 000000.png ... in sequence order. With options.sequence enabled the images
/// follow PlanSampleSequence() (one arrangement, a camera path, one jump); otherwise every
/// image has its own arrangement and camera. The meshes used for rendering are the
/// written files read back with LoadMesh(), i.e. exactly what every other tool sees.
/// Throws g6d::Error on bad options, on a write failure (naming the file), or when no
/// valid arrangement (or sequence) is found within max_tries.
SampleReport WriteSampleDataset(const SampleOptions& options, const std::string& root,
                                const SampleProgressCallback& progress = nullptr);

/// Renders one image of the sequence without writing anything (what WriteSampleDataset
/// does per image). `objects` are the meshes to place, `table` the table mesh, `frame_seed`
/// seeds this image's arrangement and noise. Throws g6d::Error when no valid arrangement
/// is found within options.max_tries.
SampleFrame RenderSampleFrame(const SampleOptions& options,
                              const std::vector<SampleObject>& objects, const Mesh& table,
                              uint64_t frame_seed);

/// The table mesh WriteSampleDataset() renders for these options (regenerated from the
/// seed; it is not written to the dataset).
Mesh SampleTableFor(const SampleOptions& options);

/// What WriteSampleCache() built.
struct SampleCacheEntry {
  std::string object_id;  ///< "obj_000001"
  std::string path;       ///< the cache file
  int templates = 0;
  size_t keypoints = 0;
  int64_t bytes = 0;
  double seconds = 0.0;
};

/// Builds the template cache of one object of a BOP dataset (`object` from
/// LoadBopDataset()) at `cache_path`, as g6d-build-templates would from the mesh that
/// models_info.json names: same content hash, units and options. Views fan out over
/// `executor`.
///
/// Use a fresh thread pool per call (or one whose threads never rendered): GlRenderer
/// contexts that BuildTemplateBank() creates on pool threads are destroyed on the calling
/// thread, and OSMesa crashes when such a thread later makes a new context current
/// (seen with Mesa 22.3; reported, lib/templates).
/// Throws g6d::Error on bad options or unreadable / unwritable files.
SampleCacheEntry WriteSampleCache(const TemplateBuildOptions& options, const BopObjectInfo& object,
                                  const std::string& cache_path, Executor* executor);

}  // namespace g6d
