#pragma once
/// @file template_bank.h
/// The per-object template bank B (paper eq. 3): for each template j its pose T_j,
/// mask M_j, crop affine A_j, and keypoints with ORB descriptors d_ji and object-frame
/// 3D points X_ji; plus the decimated mesh used for online rendering.

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/executor.h"
#include "mesh/mesh.h"
#include "mesh/symmetry.h"
#include "templates/appearance.h"
#include "templates/crop.h"
#include "templates/features.h"
#include "templates/ppf_model.h"
#include "templates/silhouette.h"
#include "templates/views.h"

namespace g6d {

/// Everything that determines a bank's contents; stored in the cache header.
struct TemplateBuildOptions {
  ViewSamplingOptions views;
  CropOptions crop;
  OrbOptions orb;
  /// Side of the square template render, pixels. With fill_fraction 0.8 the mask box is
  /// at most ~256 px, so the crop (S = 256) samples the render at about its resolution;
  /// rendering larger only costs time (OSMesa is most of the build).
  int render_size_px = 320;
  double render_focal_px = 400;  ///< focal length of the template camera, pixels
  int online_mesh_faces = 4000;  ///< face budget of the decimated online mesh
  /// Keypoints whose surface is seen at a grazing angle beyond this are dropped, degrees.
  double max_view_angle_deg = 80.0;
  /// Side of the grey thumbnail of each normalized crop kept for inspection, pixels
  /// (0 = none). Not used by the solver. 48 px costs ~0.3 MB per 324-template cache
  /// (64 px: ~0.48 MB, which pushed textured objects over the 3 MB budget).
  int thumbnail_size_px = 48;

  /// The mesh's own geometric symmetries are searched at build time with these options
  /// (stored in the bank; the solver merges hypotheses that differ by one).
  bool find_symmetries = true;
  SymmetryOptions symmetry;
  /// Coloured surface samples for the solver's appearance tie-break are taken at build
  /// time (the online mesh has no colour); only the sampling fields of `appearance`
  /// (sample_points, seed, min_color_std, texture_max_side_px) are used and stored.
  bool sample_appearance = true;
  AppearanceOptions appearance;
  /// The point-pair-feature model (templates/ppf_model.h), the hypothesis source that needs
  /// no texture, is sampled at build time (off: the bank has none and the solver uses ORB
  /// alone).
  bool build_ppf = true;
  PpfModelOptions ppf;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// One template j.
struct Template {
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();  ///< T_j^r
  /// Crop affine A_j: template image px (OpenCV) = scale * crop px + offset.
  double crop_scale = 1.0;
  Eigen::Vector2d crop_offset = Eigen::Vector2d::Zero();
  cv::Mat mask;  ///< CV_8U S x S normalized-crop mask, 0/255
  /// v_ji, template image px (OpenCV convention), rounded to 1/64 px.
  std::vector<Eigen::Vector2f> keypoints;
  std::vector<std::array<uint8_t, 32>> descriptors;  ///< d_ji
  /// X_ji, object frame, metres, rounded to 2^-16 m (15 um) so the cache compresses.
  std::vector<Eigen::Vector3f> points;
  /// CV_8U thumbnail_size_px square: the normalized grey crop, downscaled (may be empty).
  /// Area-resampled, so in OpenCV pixel coordinates
  /// thumbnail = (crop + 0.5) * thumbnail side / S - 0.5.
  cv::Mat thumbnail;
};

/// A complete bank for one object. Plain data plus a few derived lookups.
struct TemplateBank {
  std::string object_id;   ///< e.g. "obj_000005"
  uint64_t mesh_hash = 0;  ///< FNV-1a 64 of the source mesh file bytes
  std::string mesh_path;   ///< source mesh path at build time (informational)
  Units mesh_units = Units::kMetres;
  TemplateBuildOptions options;
  Camera template_camera;  ///< intrinsics and size of every template render
  double diameter_m = 0.0;
  Eigen::AlignedBox3d bounding_box;  ///< metres, object frame
  /// Symmetry transforms given by the user (BOP models_info.json; object_from_object),
  /// identity excluded; empty = none given.
  std::vector<Eigen::Isometry3d> symmetries;
  /// The mesh's own geometric symmetries, found at build time (FindSymmetries); empty when
  /// options.find_symmetries is false or there are none. Shape only: a printed box has
  /// the box's flips here although its print tells them apart.
  MeshSymmetries geometric_symmetries;
  /// Coloured surface samples of the full mesh for the appearance tie-break; empty for an
  /// untextured, uncoloured or uniformly coloured mesh.
  AppearanceModel appearance;
  /// Oriented surface points for point-pair-feature voting; empty when the build had
  /// options.build_ppf off. Its table is derived when a bank is built or read.
  PpfModel ppf;
  Mesh online_mesh;  ///< decimated geometry for online rasterization
  std::vector<Template> templates;

  // Derived from online_mesh when a bank is built or read (DeriveOnlineMeshes), never
  // stored in the cache.
  /// A coarser copy of online_mesh for small silhouettes (observable selection renders
  /// 96 px); empty = use online_mesh.
  Mesh selection_mesh;
  /// online_mesh / selection_mesh is closed and oriented outwards: seen from outside, its
  /// nearest surface is always front-facing, so back faces can be culled without changing
  /// a rendering.
  bool online_mesh_closed = false;
  bool selection_mesh_closed = false;
  /// Each template's silhouette code (templates[j]'s mask, silhouette.h), for the solver's
  /// hypotheses from the outline alone.
  std::vector<TemplateSilhouette> silhouettes;

  /// Total number of keypoints over all templates.
  size_t NumKeypoints() const;
};

/// Faces of TemplateBank::selection_mesh: at the 96-160 px of the online silhouettes a
/// triangle of the 4000-face online mesh covers about one pixel; a quarter of them keeps
/// the silhouette within a pixel (the selection's recall is unchanged: bench/RESULTS.md, issue 13).
constexpr int kSelectionMeshFaces = 1000;

/// Fills the derived fields of *bank: from bank->online_mesh the selection mesh
/// (kSelectionMeshFaces) and whether each mesh may be rendered with back faces culled; from
/// the templates' masks their silhouette codes.
void DeriveOnlineMeshes(TemplateBank* bank);

/// Progress callback: (templates done, templates total).
using ProgressCallback = std::function<void(int, int)>;

/// Renders and processes all template views of `mesh` (paper Sec. III-B). Views fan out
/// over `executor`; each worker thread uses its own OSMesa context. The result is the
/// same for any number of threads. `progress` is called after each view, serialized
/// (never concurrently), with a done count that increases by one per call.
/// Fills everything except the provenance fields `mesh_hash`, `mesh_path` and
/// `mesh_units`, which the caller (who read the file) sets. Throws g6d::Error on bad
/// options, an empty mesh or a renderer failure.
TemplateBank BuildTemplateBank(const Mesh& mesh, const std::string& object_id,
                               const TemplateBuildOptions& options, Executor* executor,
                               const ProgressCallback& progress = nullptr);

}  // namespace g6d
