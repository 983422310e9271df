#include "solver/score.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "core/error.h"

namespace g6d {

std::string ScoreOptions::Check() const {
  std::ostringstream out;
  if (!(omega_c >= 0.0 && omega_c <= 1.0)) out << "ScoreOptions.omega_c must be in [0, 1] (got " << omega_c << ")";
  else if (!(lambda_s >= 0.0 && std::isfinite(lambda_s))) out << "ScoreOptions.lambda_s must be finite and >= 0 (got " << lambda_s << ")";
  else if (!std::isfinite(occlusion_margin_m)) out << "ScoreOptions.occlusion_margin_m must be finite (got " << occlusion_margin_m << ")";
  else if (!(surface_tolerance_m >= 0.0 && std::isfinite(surface_tolerance_m))) out << "ScoreOptions.surface_tolerance_m must be finite and >= 0 (got " << surface_tolerance_m << ")";
  else if (!(segment_own_fraction >= 0.0 && segment_own_fraction <= 1.0)) out << "ScoreOptions.segment_own_fraction must be in [0, 1] (got " << segment_own_fraction << ")";
  else if (!(max_object_extent_m >= 0.0 && std::isfinite(max_object_extent_m))) out << "ScoreOptions.max_object_extent_m must be finite and >= 0 (got " << max_object_extent_m << ")";
  else if (!(max_unseen_background >= 0.0 && max_unseen_background <= 1.0)) out << "ScoreOptions.max_unseen_background must be in [0, 1] (got " << max_unseen_background << ")";
  return out.str();
}

PoseScore ScoreRendering(const EvaluationGrid& grid, const RasterImage& rendered, double z_m,
                         const ScoreOptions& options) {
  G6D_CHECK(rendered.depth.size() == grid.mask.size());
  PoseScore score;
  int observed = 0, intersection = 0, union_count = 0, overlap = 0;
  double residual_sum = 0.0;
  const bool has_support = options.depth_evidence && !grid.support.empty();
  // Segment ownership: first which segments the pose covers (after occlusion), then the
  // mask pixels of the others are left out of C, J and the residual.
  const bool by_segment = options.segment_own_fraction > 0.0 && !grid.segment.empty();
  std::vector<uint8_t> owned;
  if (by_segment) {
    std::vector<int> covered(grid.segment_pixels.size(), 0);
    for (int v = 0; v < grid.mask.rows; ++v) {
      const int* label = grid.segment.ptr<int>(v);
      const float* d = grid.depth.ptr<float>(v);
      const float* r = rendered.depth.ptr<float>(v);
      for (int u = 0; u < grid.mask.cols; ++u) {
        if (label[u] > 0 && r[u] > 0.0f && !(options.depth_evidence && IsOccluded(r[u], d[u], options))) {
          ++covered[static_cast<size_t>(label[u])];
        }
      }
    }
    owned.assign(covered.size(), 1);
    const bool have_spans = grid.segment_spans.size() == covered.size();
    bool any_owned = false;
    Spans owned_spans;
    for (size_t k = 1; k < covered.size(); ++k) {
      owned[k] = covered[k] >= options.segment_own_fraction * grid.segment_pixels[k];
      if (!owned[k] || grid.segment_pixels[k] == 0 || !have_spans) continue;
      owned_spans = any_owned ? owned_spans.Union(grid.segment_spans[k]) : grid.segment_spans[k];
      any_owned = true;
    }
    // A segment the object could reach from what the pose covers is the pose's to explain.
    for (size_t k = 1; k < covered.size() && options.max_object_extent_m > 0.0 && have_spans; ++k) {
      if (owned[k]) continue;
      const Spans reach = any_owned ? owned_spans.Union(grid.segment_spans[k]) : grid.segment_spans[k];
      owned[k] = reach.Extent() <= options.max_object_extent_m;
    }
  }
  for (int v = 0; v < grid.mask.rows; ++v) {
    const uint8_t* m = grid.mask.ptr<uint8_t>(v);
    const uint8_t* support = has_support ? grid.support.ptr<uint8_t>(v) : nullptr;
    const float* d = grid.depth.ptr<float>(v);
    const float* r = rendered.depth.ptr<float>(v);
    const int* label = by_segment ? grid.segment.ptr<int>(v) : nullptr;
    const uint8_t* unsure = grid.unsure.empty() ? nullptr : grid.unsure.ptr<uint8_t>(v);
    const uint8_t* unseen_area = grid.unseen_area.empty() ? nullptr : grid.unseen_area.ptr<uint8_t>(v);
    for (int u = 0; u < grid.mask.cols; ++u) {
      bool in_observed = m[u] != 0;
      bool in_rendered = r[u] > 0.0f;
      if (in_observed && label != nullptr && !owned[static_cast<size_t>(label[u])]) {
        ++score.foreign_pixels;  // another object's segment
        in_observed = false;
      }
      if (in_rendered && ((!in_observed && HiddenOutsideMask(r[u], d[u], unseen_area != nullptr ? unseen_area[u] != 0 : !(d[u] > 0.0f), grid, options)) ||
                          (in_observed && options.depth_evidence && IsOccluded(r[u], d[u], options)))) {
        // Hidden by an occluder that no mask covers: neither for nor against. Inside the
        // mask (depth evidence) the mask leaked onto an occluder, or the pose lies behind
        // the observed surface: not rendered, a miss for every pose alike, and no depth
        // residual (an occluder's is unbounded).
        ++score.occluded_pixels;
        in_rendered = false;
      } else if (in_rendered && !in_observed) {
        const bool on_support = support != nullptr && support[u] != 0;
        if (MissedByMask(r[u], d[u], on_support, options) || (!on_support && HoleOnSurface(grid, u, v, r[u], options))) {
          ++score.recovered_pixels;  // object the mask missed: the depth says so
          in_observed = true;
        }
      }
      // A mask pixel the depth cannot judge (ObservedRegion::unsure) counts only for a pose
      // that covers it.
      if (in_observed && !in_rendered && unsure != nullptr && unsure[u]) in_observed = false;
      observed += in_observed;
      score.rendered_pixels += in_rendered;
      intersection += in_observed && in_rendered;
      union_count += in_observed || in_rendered;
      if (in_observed && in_rendered && d[u] > 0.0f) {  // w_k(u) of eq. (10)
        ++overlap;
        residual_sum += std::abs(static_cast<double>(r[u]) - d[u]);
      }
    }
  }
  score.overlap_pixels = overlap;
  score.coverage = observed > 0 ? static_cast<double>(intersection) / observed : 0.0;
  score.iou = union_count > 0 ? static_cast<double>(intersection) / union_count : 0.0;
  // eq. (12): normalized weighted mean absolute depth residual; ε avoids 0/0.
  constexpr double kEpsilon = 1e-9;
  score.depth_residual = z_m > 0.0 ? residual_sum / (z_m * overlap + kEpsilon) : 0.0;
  score.e_obs = options.omega_c * (1.0 - score.coverage) + (1.0 - options.omega_c) * (1.0 - score.iou);
  score.s = 1.0 - score.iou + options.lambda_s * score.depth_residual;
  return score;
}

PoseScore ScorePose(const EvaluationGrid& grid, const Mesh& mesh,
                    const Eigen::Isometry3d& cam_from_object, double z_m,
                    const ScoreOptions& options, RasterImage* scratch) {
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  raster_options.cull_backfaces = options.cull_backfaces;
  Rasterize(mesh, grid.camera, cam_from_object, raster_options, scratch);
  return ScoreRendering(grid, *scratch, z_m, options);
}

}  // namespace g6d
