#pragma once
/// @file score.h
/// Mask and depth consistency of a pose: coverage C and IoU J (eq. 6), observable error
/// E_obs (eq. 7) and the physical consistency score S (eq. 12).

#include <cmath>
#include <string>

#include <Eigen/Geometry>

#include "mesh/mesh.h"
#include "render/raster.h"
#include "solver/observation.h"

namespace g6d {

/// Weights of the scores.
struct ScoreOptions {
  double omega_c = 0.70;   ///< ω_C: weight of (1 − coverage) in E_obs (eq. 7)
  double lambda_s = 10.0;  ///< λ_S: weight of the normalized depth residual in S (eq. 12)
  /// Occlusion reasoning (not in the paper, which assumes the mask covers every occluder):
  /// a rendered pixel outside the observed mask whose observed depth is closer than the
  /// rendered depth by more than this margin (metres) is hidden by something no mask
  /// covers, so it does not count against the pose in J or S. Pixels outside the image are
  /// never on the grid, so truncation by the border never counts either. <= 0 disables it.
  double occlusion_margin_m = 0.01;
  /// Rasterize with back faces culled. Only for a closed mesh oriented outwards (the
  /// pipeline sets it per mesh, TemplateBank::online_mesh_closed): it then changes no
  /// rendering and skips about half of the triangles.
  bool cull_backfaces = false;
  /// Masks as evidence (MaskTrust::kDepth, region.h): a rendered pixel outside the observed
  /// mask whose observed depth lies within `surface_tolerance_m` of the rendered depth, and
  /// not on the support plane (EvaluationGrid::support), is object the mask missed: it
  /// counts as observed in C, J and the depth residual. Off: the mask alone decides (the
  /// paper). The pipeline sets both per instance (ObservedRegion::surface_tolerance_m).
  bool depth_evidence = false;
  double surface_tolerance_m = 0.0;
  /// Segment ownership (a mask of two depth segments or more, EvaluationGrid::segment: a
  /// merged or boxed mask, segments.h): a pose owns the segments it covers at least this fraction of;
  /// the mask pixels of the segments it does not own are another object's and count neither
  /// for nor against it. A pose that covers part of a segment must explain all of it.
  /// 0 = every mask pixel counts (as without segments).
  double segment_own_fraction = 0.25;
  /// ... but only a segment that the object could not reach is another object's: one that
  /// spans more than this together with the segments the pose owns (Spans::Extent; the
  /// pipeline sets it per instance: the diameter plus the depth noise at both ends). A
  /// segment within reach (a handle behind a depth step, a part seen past an occluder) must
  /// be explained. 0 = no such limit.
  double max_object_extent_m = 0.0;
  /// On: a rendered pixel outside the mask where the sensor saw no depth counts neither for
  /// nor against the pose, as a hidden one: the depth cannot say whether an occluder hides
  /// it (bare metal that reflects the pattern away, a projector's shadow). Off (default, the
  /// paper): it counts against the pose. Measured (bench/RESULTS.md, "Poses from the
  /// outline"): on synth_dev's simulated sensor, 30%-cut masks 72.1% -> 79.1%, GT masks
  /// 92.7% -> 93.2%, but on the real Xtion frames the masks' BOP AR falls (YCB-V clutter
  /// 0.766 -> 0.736, foam brick 0.530 -> 0.417; without masks 0.824 -> 0.738): real depth
  /// drops out along every object's edge, and a pose may then spill over it unpunished.
  bool unseen_is_hidden = false;
  /// ... but only where the sensor sees a background: where more than this share of the
  /// grid outside the mask has no depth (EvaluationGrid::unseen_background), a missing depth
  /// says nothing of occluders and unseen pixels count against the pose.
  double max_unseen_background = 0.5;

  std::string Check() const;
};

/// All consistency measures of one rendered pose against the observation.
struct PoseScore {
  double coverage = 0.0;        ///< C = |M̂ ∩ M| / |M|
  double iou = 0.0;             ///< J = |M̂ ∩ M| / |M̂ ∪ M|
  double depth_residual = 0.0;  ///< Σ w |D̂ − D| / (z_M Σ w), unitless (eq. 12's depth term)
  double e_obs = 1.0;           ///< ω_C (1 − C) + (1 − ω_C)(1 − J)
  double s = 2.0;               ///< 1 − J + λ_S · depth_residual; lower is better
  int rendered_pixels = 0;      ///< |M̂| on the grid
  int overlap_pixels = 0;       ///< Σ w: overlap with valid observed depth
  int occluded_pixels = 0;      ///< rendered pixels explained by an unmasked occluder (not counted)
  int recovered_pixels = 0;     ///< rendered pixels outside the mask that the depth puts on the object
  int foreign_pixels = 0;       ///< mask pixels of depth segments the pose does not own (not counted)
};

/// True when a rendered pixel (depth `rendered_m` > 0) outside the observed mask is hidden
/// behind an observed surface (`observed_m` > 0) closer by more than options.occlusion_margin_m.
inline bool IsOccluded(float rendered_m, float observed_m, const ScoreOptions& options) {
  return options.occlusion_margin_m > 0.0 && observed_m > 0.0f &&
         observed_m < rendered_m - options.occlusion_margin_m;
}

/// True when a rendered pixel outside the observed mask of `grid` counts for nothing: hidden
/// behind an observed surface (IsOccluded), or, with options.unseen_is_hidden, in a depthless
/// area (`in_unseen_area`: EvaluationGrid::unseen_area, or no observed depth when the grid
/// has none) where the sensor sees a background (options.max_unseen_background).
inline bool HiddenOutsideMask(float rendered_m, float observed_m, bool in_unseen_area, const EvaluationGrid& grid,
                              const ScoreOptions& options) {
  return IsOccluded(rendered_m, observed_m, options) ||
         (options.unseen_is_hidden && in_unseen_area && grid.unseen_background <= options.max_unseen_background);
}

/// True when a grid pixel outside the observed mask, rendered at `rendered_m` > 0 and seen
/// at `observed_m`, is object that the mask missed (ScoreOptions::depth_evidence): its depth
/// lies on the rendered surface and it is not on the support plane.
inline bool MissedByMask(float rendered_m, float observed_m, bool on_support, const ScoreOptions& options) {
  return options.depth_evidence && !on_support && observed_m > 0.0f &&
         std::abs(observed_m - rendered_m) <= options.surface_tolerance_m;
}

/// True when grid pixel (u, v), outside the mask and without depth, lies in a thin hole whose
/// surrounding depth all lies on the rendered surface (EvaluationGrid::hole_near, hole_far,
/// within options.surface_tolerance_m; ScoreOptions::depth_evidence): speckle on the object
/// the mask missed, not evidence against the pose.
inline bool HoleOnSurface(const EvaluationGrid& grid, int u, int v, float rendered_m, const ScoreOptions& options) {
  if (!options.depth_evidence || grid.hole_near.empty()) return false;
  const float near = grid.hole_near.at<float>(v, u);
  return near > 0.0f && std::abs(near - rendered_m) <= options.surface_tolerance_m &&
         std::abs(grid.hole_far.at<float>(v, u) - rendered_m) <= options.surface_tolerance_m;
}

/// Scores an already rendered image (on grid.camera) against the grid. `z_m` is z_M.
/// With no depth overlap the depth residual is 0 when the masks are disjoint as well
/// (S is then dominated by 1 − J = 1).
PoseScore ScoreRendering(const EvaluationGrid& grid, const RasterImage& rendered, double z_m,
                         const ScoreOptions& options);

/// Rasterizes `mesh` at cam_from_object on the grid and scores it. `scratch` is reused.
PoseScore ScorePose(const EvaluationGrid& grid, const Mesh& mesh,
                    const Eigen::Isometry3d& cam_from_object, double z_m,
                    const ScoreOptions& options, RasterImage* scratch);

}  // namespace g6d
