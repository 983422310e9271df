#pragma once
/// @file appearance.h
/// Appearance agreement of a pose: how well the model's colours, seen at cam_from_object,
/// match the colours of the image inside the instance mask. Used to break ties among
/// finalist poses whose geometric scores (mask IoU, depth) are close: a printed box turned
/// by 180 degrees has the same silhouette and depth but shows the wrong print.
///
/// The measure is lighting-robust: the mean of two zero-mean normalized cross-correlations
/// (ZNCC) between model and observed colours over the visible surface samples, each
/// averaged over the channels in which the model varies:
///  - RGB: invariant to a gain and an offset per channel (exposure, white balance, ambient
///    light, the camera's colour response);
///  - chromaticity c / (R + G + B): invariant to shading that changes across the surface
///    (faces at different angles to the light), which RGB alone confuses with print.
/// Both tolerate lossy (block-compressed) textures; the texture is low-pass filtered once.
/// Chosen by measurement (tests/appearance_test.cc, GT pose against its 180-degree flips):
/// RGB alone, luminance alone or chromaticity alone each fail somewhere (RGB: LM-O's driller
/// and, without the edge margin, YCB-V's mustard bottle; chromaticity: grey objects); the
/// mean wins on YCB-V 30/30 and on 77% of LM-O pairs (RGB alone: 69%).

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "mesh/mesh.h"
#include "render/raster.h"

namespace g6d {

/// Coloured surface samples of the full-resolution mesh, made once at cache-build time
/// (the online mesh is decimated and has no colour). Object frame, metres.
/// The three arrays have the same length; all are empty for an untextured model.
struct AppearanceModel {
  std::vector<Eigen::Vector3f> points;  ///< surface points, object frame, metres
  /// Unit face normals, object frame: outward by the counter-clockwise winding, or, when
  /// the mesh has vertex normals, on their side.
  std::vector<Eigen::Vector3f> normals;
  std::vector<Eigen::Vector3f> colors;  ///< RGB albedo in [0, 1] (as stored in the mesh)

  /// True when the mesh had no usable colour (see SampleAppearance()).
  bool Empty() const { return points.empty(); }
};

/// Options of SampleAppearance() and ScoreAppearance().
struct AppearanceOptions {
  // --- SampleAppearance() ---
  /// Number of surface samples (area-weighted); about half of them face any camera.
  int sample_points = 4000;
  /// Seed of the face sampler (std::mt19937_64; the same samples on every platform).
  uint64_t seed = 1;
  /// A model whose largest per-channel standard deviation of the sampled RGB colours (in
  /// [0, 1] units) is below this counts as untextured: SampleAppearance() returns an empty
  /// model. In ScoreAppearance(), an RGB channel whose model values over the compared
  /// samples vary less than this is left out of the RGB mean (its correlation is noise).
  double min_color_std = 0.03;
  /// The texture is area-downsampled so that its longer side is at most this many pixels
  /// before it is sampled: a low-pass filter that removes the detail (and the block
  /// artefacts of lossy textures) no camera resolves at working distance.
  int texture_max_side_px = 1024;

  // --- ScoreAppearance() ---
  /// The online mesh is rasterized (for visibility) on the mask's bounding box, downscaled
  /// so that its longer side is at most this many pixels.
  int grid_max_side_px = 160;
  /// A sample is visible when its depth is at most this far behind the rasterized online
  /// mesh at its grid pixel, metres. Covers the decimation error of the online mesh and the
  /// depth change across a grid pixel; self-occluded parts usually lie farther behind.
  double visibility_tolerance_m = 0.01;
  /// A sample is compared only when the cosine between its normal and the direction to the
  /// camera is at least this (grazing surfaces show smeared, mixed colours).
  double min_facing_cos = 0.2;
  /// Samples within this many pixels of an edge are left out: of the rendered silhouette or
  /// a rendered depth step (grid pixels), or of the mask border (image pixels). There a
  /// small pose or mask error mixes in the colour of whatever lies beside the object.
  /// 0 keeps them. (LM-O, GT beats a flip: 74% / 76% / 77% of pairs for 0 / 1 / 2.)
  int edge_margin_px = 2;
  /// A chromaticity channel whose model values over the compared samples vary less than
  /// this is left out of the chromaticity mean: on grey and white objects chromaticity is
  /// noise (0.005 on LM-O's white can and eggbox, 0.03 on the ape and duck, 0.1-0.2 on
  /// printed boxes).
  double min_chroma_std = 0.01;
  /// Fewer compared samples than this give an invalid score.
  int min_visible_points = 40;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Samples the surface of `mesh` (metres, object frame) with colours: area-weighted faces
/// (deterministic for options.seed), uniform points in each, the colour from the texture
/// (UV interpolated over the face, OBJ convention with v up, bilinear) when the mesh has
/// one, else interpolated from the three vertex colours, rounded to 8 bits per channel (the
/// cache's precision, so a saved and loaded model equals this one). Returns an empty model when the
/// mesh has neither texture nor vertex colours, or when its colours are (nearly) uniform
/// (options.min_color_std). Throws g6d::Error for invalid options, out-of-range face indices,
/// a texture that is not CV_8UC3 or a coloured mesh without any face of positive area.
AppearanceModel SampleAppearance(const Mesh& mesh, const AppearanceOptions& options);

/// Result of ScoreAppearance().
struct AppearanceScore {
  /// false: empty model or mask, too few samples, or no RGB channel varies in the model
  bool valid = false;
  std::string message = "not run";  ///< why not valid; empty when valid
  /// (rgb_zncc + chroma_zncc) / 2, or rgb_zncc when no chromaticity channel varies; in
  /// [-1, 1], higher is better; 0 when not valid.
  double agreement = 0.0;
  double rgb_zncc = 0.0;     ///< mean ZNCC over the rgb_channels used; 0 if none
  double chroma_zncc = 0.0;  ///< mean ZNCC over the chroma_channels used; 0 if none
  int rgb_channels = 0;      ///< RGB channels used (model std >= min_color_std), 0..3
  int chroma_channels = 0;   ///< chromaticity channels used (>= min_chroma_std), 0..3
  int points = 0;            ///< samples compared (facing, visible, inside the mask)
};

/// Projects the model points at cam_from_object; keeps those facing the camera
/// (options.min_facing_cos), visible (their depth within options.visibility_tolerance_m of
/// `online_mesh` rasterized at the same pose on `camera` cropped to the mask's bounding box
/// and downscaled to options.grid_max_side_px), inside `mask` and away from edges
/// (options.edge_margin_px); compares their colours with `rgb` (bilinear) by the measure of
/// this file's comment. `camera` is the camera of `rgb` (CV_8UC3, RGB order) and `mask`
/// (CV_8U, non-zero = the instance's visible pixels), both of the camera's size;
/// `online_mesh` is in metres, object frame. `scratch` (optional) is reused for the
/// rasterization, as in Rasterize(). Returns valid = false with a message when the model or
/// the mask is empty, fewer than options.min_visible_points samples remain, or no RGB
/// channel of the model varies over them (by options.min_color_std). Throws g6d::Error for invalid
/// options or camera, or images of the wrong type or size.
AppearanceScore ScoreAppearance(const AppearanceOptions& options, const AppearanceModel& model,
                                const Mesh& online_mesh, const Camera& camera, const cv::Mat& rgb,
                                const cv::Mat& mask, const Eigen::Isometry3d& cam_from_object,
                                RasterImage* scratch = nullptr);

namespace internal {
/// The model and observed colours (RGB in [0, 1]) of the samples ScoreAppearance() compares,
/// in model order, without the measure: for tests and for trying other measures. Returns
/// their number; throws as ScoreAppearance() does.
int CollectAppearancePairs(const AppearanceOptions& options, const AppearanceModel& model,
                           const Mesh& online_mesh, const Camera& camera, const cv::Mat& rgb,
                           const cv::Mat& mask, const Eigen::Isometry3d& cam_from_object,
                           std::vector<Eigen::Vector3f>* model_colors,
                           std::vector<Eigen::Vector3f>* observed_colors);
}  // namespace internal

}  // namespace g6d
