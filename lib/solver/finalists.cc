#include "solver/finalists.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/timer.h"
#include "render/raster.h"

namespace g6d {

void ResolveFinalists(const SolverOptions& options, const TemplateBank& bank, const Frame& frame, const cv::Mat& mask,
                      const MeshSymmetries& symmetries, const std::vector<Eigen::Vector3d>& distance_points,
                      std::vector<Finalist> finalists, PoseResult* result) {
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
      if (appearance[k].valid && appearance[k].agreement > appearance[chosen].agreement + options.appearance_min_gain) {
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
  // Runner-up: the best distinct finalist by S that is not the answer moved by a
  // symmetry of the shape (a printed box's flip that appearance cannot tell apart is the
  // same shape: a symmetry, reported at build time, not an ambiguity).
  const MeshSymmetries shape_symmetries = ShapeSymmetries(bank);
  for (size_t k = 0; k < distinct.size(); ++k) {
    if (k == chosen) continue;
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
    ResolveFinalists(c.options, c.bank, c.frame, c.observation.mask, c.comparer.symmetries(), c.comparer.points(),
                     std::move(finalists), result);
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
