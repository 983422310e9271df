#include "solver/finalists.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/timer.h"
#include "render/raster.h"

namespace g6d {

double DepthBehindSupport(const ObservedRegion& region, const Mesh& mesh, const Eigen::Isometry3d& cam_from_object) {
  if (!region.has_limit_plane) return 0.0;
  // The plane's normal points to the camera's side: n · p + offset < 0 lies behind it.
  const Eigen::Vector3d normal_in_object = cam_from_object.linear().transpose() * region.limit_plane_normal;
  const double offset = region.limit_plane_offset_m + region.limit_plane_normal.dot(cam_from_object.translation());
  double deepest = 0.0;
  for (const Eigen::Vector3f& vertex : mesh.vertices) {
    deepest = std::max(deepest, -(normal_in_object.dot(vertex.cast<double>()) + offset));
  }
  return deepest;
}

void ResolveFinalists(const SolverOptions& options, const TemplateBank& bank, const Frame& frame, const cv::Mat& mask,
                      const ObservedRegion& region, const MeshSymmetries& symmetries,
                      const std::vector<Eigen::Vector3d>& distance_points, std::vector<Finalist> finalists,
                      PoseResult* result) {
  StageReport& stages = result->stages;
  std::stable_sort(finalists.begin(), finalists.end(),
                   [](const Finalist& a, const Finalist& b) { return a.score.s < b.score.s; });
  const double same_m = options.ambiguity_distance_fraction * bank.diameter_m;
  std::vector<Finalist> distinct;
  for (const Finalist& f : finalists) {
    bool is_new = true;
    for (size_t k = 0; k < distinct.size() && is_new; ++k) {
      is_new = SymmetricPoseDistance(symmetries, distance_points, f.cam_from_object, distinct[k].cam_from_object) > same_m;
    }
    if (is_new) distinct.push_back(f);
  }
  stages.distinct_finalists = static_cast<int>(distinct.size());
  // The support: a finalist reaching behind it is impossible; the best possible one within
  // support_margin of the best S moves to the front (the others keep their order).
  std::vector<double> behind(distinct.size(), 0.0);
  std::vector<bool> impossible(distinct.size(), false);
  if (options.support_penetration_fraction > 0.0 && region.has_limit_plane) {
    const double limit_m = options.support_penetration_fraction * bank.diameter_m + region.surface_tolerance_m;
    for (size_t k = 0; k < distinct.size(); ++k) {
      behind[k] = DepthBehindSupport(region, bank.online_mesh, distinct[k].cam_from_object);
      impossible[k] = behind[k] > limit_m;
      stages.finalists_behind_support += impossible[k] ? 1 : 0;
    }
    for (size_t k = 1; k < distinct.size() && impossible[0]; ++k) {
      if (impossible[k] || distinct[k].score.s > distinct[0].score.s + options.support_margin) continue;
      const auto to_front = [k](auto& v) {
        std::rotate(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.begin() + static_cast<std::ptrdiff_t>(k) + 1);
      };
      to_front(distinct);
      to_front(behind);
      to_front(impossible);
      stages.support_changed = true;
    }
  }
  // A finalist behind the support is no rival of one in front of it.
  auto rival = [&](size_t k, size_t of) { return !impossible[k] || impossible[of]; };
  size_t chosen = 0;
  std::vector<AppearanceScore> appearance(distinct.size());
  if (options.appearance_tiebreak && !bank.appearance.Empty()) {
    for (size_t k = 0; k < distinct.size(); ++k) {
      if (distinct[k].score.s > distinct[0].score.s + options.appearance_margin) break;
      appearance[k] = ScoreAppearance(options.appearance, bank.appearance, bank.online_mesh, frame.camera, frame.rgb, mask,
                                      distinct[k].cam_from_object);
      ++stages.appearance_compared;
    }
    // Only a valid comparison can overrule S: a pose whose visible model colours are
    // uniform (invalid score) is neither better nor worse in appearance.
    for (size_t k = 1; k < distinct.size() && appearance[0].valid; ++k) {
      if (rival(k, 0) && appearance[k].valid &&
          appearance[k].agreement > appearance[chosen].agreement + options.appearance_min_gain) {
        chosen = k;
      }
    }
  }
  if (chosen != 0) stages.appearance_changed = true;
  result->cam_from_object = distinct[chosen].cam_from_object;
  result->details = distinct[chosen].score;
  stages.answer_hypothesis = distinct[chosen].hypothesis;
  result->appearance_valid = appearance[chosen].valid;
  result->appearance_agreement = appearance[chosen].agreement;
  stages.support_penetration_m = behind[chosen];
  stages.answer_behind_support = impossible[chosen];
  // Runner-up: the best distinct finalist by S that is not the answer moved by a
  // symmetry of the shape (a printed box's flip that appearance cannot tell apart is the
  // same shape: a symmetry, reported at build time, not an ambiguity).
  const MeshSymmetries shape_symmetries = ShapeSymmetries(bank);
  for (size_t k = 0; k < distinct.size(); ++k) {
    if (k == chosen || !rival(k, chosen)) continue;
    if (SymmetricPoseDistance(shape_symmetries, distance_points, distinct[k].cam_from_object, distinct[chosen].cam_from_object) <=
        same_m) {
      continue;
    }
    result->has_runner_up = true;
    result->runner_up_cam_from_object = distinct[k].cam_from_object;
    result->runner_up_score = distinct[k].score.s;
    result->runner_up_appearance_valid = appearance[k].valid;
    result->runner_up_appearance_agreement = appearance[k].agreement;
    const bool appearance_separates = appearance[chosen].valid && appearance[k].valid &&
                                      appearance[chosen].agreement > appearance[k].agreement + options.appearance_min_gain;
    result->ambiguous = distinct[k].score.s < distinct[chosen].score.s + options.ambiguity_margin && !appearance_separates;
    break;
  }
}

namespace {

// T_A's 180-degree turns about the bounding box's three axes through its centre, each
// refined by ICP and MHPO on `target` (SolverOptions::check_flips).
std::vector<Finalist> FlippedFinalists(const SolveContext& c, const MhpoTarget& target, const Eigen::Isometry3d& answer) {
  const SolverOptions& options = c.options;
  std::vector<Eigen::Isometry3d> flips = BoxFlips(answer, c.bank);
  c.executor->ParallelFor(static_cast<int>(flips.size()), [&](int k) {
    RasterImage scratch;
    if (options.run_icp) {
      RunIcpFrom(options, c.bank.online_mesh, c.observation.refine_grid, c.online_score, *c.observation.observed,
                 c.bank.diameter_m, options.max_source_points, options.icp.max_iterations, &scratch,
                 &flips[static_cast<size_t>(k)]);
    }
  });
  std::vector<Finalist> out;
  if (options.run_mhpo) {
    Eigen::Isometry3d best;
    MhpoReport report;
    RefineByMhpo(options.mhpo, c.online_score, target, c.bank.online_mesh, flips, c.executor, &best, &report);
    if (!report.success) return out;
    for (const MhpoHypothesisReport& h : report.hypotheses) out.push_back(Finalist{h.best_cam_from_object, h.best_score, -1});
  } else {
    for (const Eigen::Isometry3d& flip : flips) {
      RasterImage scratch;
      out.push_back(Finalist{flip, ScorePose(*target.grid, c.bank.online_mesh, flip, target.z_m, c.online_score, &scratch), -1});
    }
  }
  return out;
}

}  // namespace

void RunFinalistStage(const SolveContext& c, const MhpoTarget& target, std::vector<Finalist> finalists,
                      const std::vector<Hypothesis>& kept, const std::vector<CorrespondenceSet>& sets, PoseResult* result) {
  StageReport& stages = *c.stages;
  const Stopwatch watch;
  finalists.push_back(Finalist{result->cam_from_object, result->details, stages.answer_hypothesis});
  const Eigen::Isometry3d first = result->cam_from_object;
  const bool texture_agrees = c.options.silhouette_skip_agreement > 0 && stages.pnp_agreement >= c.options.silhouette_skip_agreement;
  if (c.options.check_flips && !texture_agrees && result->details.s <= c.options.check_flips_max_score &&
      !c.clock->OutOfTime()) {
    for (Finalist& flip : FlippedFinalists(c, target, first)) {
      finalists.push_back(std::move(flip));
      ++stages.flips_checked;
    }
  }
  if (!c.clock->OutOfTime()) {
    ResolveFinalists(c.options, c.bank, c.frame, c.observation.mask, c.observation.region, c.comparer.symmetries(),
                     c.comparer.points(), std::move(finalists), result);
  }
  stages.flip_answer = stages.flips_checked > 0 && !result->cam_from_object.isApprox(first);
  stages.finalists_ms = watch.ElapsedMs();
  if (stages.answer_hypothesis >= 0) {
    const int rank = kept[static_cast<size_t>(stages.answer_hypothesis)].set_rank;
    stages.answer_from_ppf = rank == kPpfSource;
    stages.answer_from_silhouette = rank == kSilhouetteSource;
    if (rank >= 0) {
      stages.answer_set_rank = rank;
      stages.answer_quality_ratio = sets[static_cast<size_t>(rank)].quality / sets.front().quality;
    }
  }
}

}  // namespace g6d
