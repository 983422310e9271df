#include "solver/track_pose.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <sstream>

#include "core/timer.h"
#include "render/raster.h"
#include "solver/mask_stage.h"
#include "solver/solve_context.h"

namespace g6d {

std::string TrackSolveOptions::Check() const {
  std::ostringstream out;
  if (icp_iterations < 0) out << "TrackSolveOptions.icp_iterations must be >= 0 (got " << icp_iterations << ")";
  else if (max_source_points < 10) out << "TrackSolveOptions.max_source_points must be >= 10 (got " << max_source_points << ")";
  else if (max_observed_points < 10) out << "TrackSolveOptions.max_observed_points must be >= 10 (got " << max_observed_points << ")";
  else if (mhpo_rounds < 0) out << "TrackSolveOptions.mhpo_rounds must be >= 0 (got " << mhpo_rounds << ")";
  else if (!(appearance_search_deg >= 0.0 && appearance_search_deg <= 180.0)) out << "TrackSolveOptions.appearance_search_deg must be in [0, 180] (got " << appearance_search_deg << ")";
  else if (!(appearance_step_deg > 0.0)) out << "TrackSolveOptions.appearance_step_deg must be > 0 (got " << appearance_step_deg << ")";
  return out.str();
}

namespace {

// The rotation by `angle_rad` about `axis` (unit, object frame) through `point`: a symmetry
// of a surface of revolution with that axis.
Eigen::Isometry3d TurnAbout(const Eigen::Vector3d& axis, const Eigen::Vector3d& point, double angle_rad) {
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(angle_rad, axis).toRotationMatrix();
  turn.translation() = point - turn.linear() * point;
  return turn;
}

}  // namespace

Eigen::Isometry3d KeepTurnAboutAxis(const MeshSymmetries& shape, const Eigen::Isometry3d& start,
                                    const Eigen::Isometry3d& pose) {
  if (!shape.revolution) return pose;
  // pose = start * delta (object frame); delta = swing * twist, the twist about the axis.
  const Eigen::Quaterniond delta(Eigen::Matrix3d(start.linear().transpose() * pose.linear()));
  const Eigen::Vector3d axis = shape.axis.normalized();
  const double twist = 2.0 * std::atan2(delta.vec().dot(axis), delta.w());
  return pose * TurnAbout(axis, shape.point, twist).inverse();
}

PoseResult TrackPose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                     const SolverOptions& options, const TrackSolveOptions& track_options,
                     const std::vector<Eigen::Isometry3d>& starts, Executor* executor) {
  PoseResult result;
  StageReport& stages = result.stages;
  const Stopwatch total;
  auto fail = [&](Termination termination, const std::string& message) {
    return Failed(termination, message, total, &result);
  };
  try {
    std::string bad = ValidateInputs(frame, instance, bank, options);
    if (bad.empty()) bad = track_options.Check();
    if (bad.empty() && starts.empty()) bad = "no start pose to track from";
    if (!bad.empty()) return fail(Termination::kBadInput, bad);

    Stopwatch watch;
    SolverOptions prepare_options = options;
    prepare_options.max_observed_points = track_options.max_observed_points;
    Observation observation;
    const std::string bad_observation = PrepareObservation(frame, instance, prepare_options, bank.diameter_m, &observation);
    if (!bad_observation.empty()) return fail(Termination::kBadInput, bad_observation);
    result.truncated = observation.truncated;
    ScoreOptions online_score = observation.score;
    online_score.cull_backfaces = options.cull_backfaces && bank.online_mesh_closed;
    stages.prepare_ms = watch.ElapsedMs();

    // ICP from every start, then S.
    watch.Restart();
    std::vector<Eigen::Isometry3d> poses = starts;
    std::vector<PoseScore> scores(poses.size());
    std::vector<IcpReport> reports(poses.size());
    executor->ParallelFor(static_cast<int>(poses.size()), [&](int k) {
      RasterImage scratch;
      Eigen::Isometry3d& pose = poses[static_cast<size_t>(k)];
      if (options.run_icp && track_options.icp_iterations > 0) {
        reports[static_cast<size_t>(k)] =
            RunIcpFrom(options, bank.online_mesh, observation.refine_grid, online_score, *observation.observed,
                       bank.diameter_m, track_options.max_source_points, track_options.icp_iterations, &scratch, &pose);
      }
      scores[static_cast<size_t>(k)] =
          ScorePose(observation.refine_grid, bank.online_mesh, pose, observation.z_m, online_score, &scratch);
    });
    size_t best = 0;
    for (size_t k = 0; k < poses.size(); ++k) {
      stages.icp_iterations += reports[k].iterations;
      stages.icp_converged += reports[k].success;
      if (scores[k].s < scores[best].s) best = k;
    }
    stages.kept_hypotheses = static_cast<int>(poses.size());
    stages.best_s_after_icp = scores[best].s;
    stages.icp_pose = poses[best];
    result.cam_from_object = poses[best];
    result.details = scores[best];
    stages.answer_hypothesis = static_cast<int>(best);
    stages.icp_ms = watch.ElapsedMs();

    // MHPO from the ICP results: the best state over starts and rounds.
    watch.Restart();
    result.termination = Termination::kConverged;
    if (options.run_mhpo && track_options.mhpo_rounds > 0) {
      MhpoOptions mhpo = options.mhpo;
      mhpo.max_rounds = track_options.mhpo_rounds;
      const MhpoTarget target = MakeMhpoTarget(observation.refine_grid, observation.z_m);
      Eigen::Isometry3d refined;
      RefineByMhpo(mhpo, online_score, target, bank.online_mesh, poses, executor, &refined, &stages.mhpo, nullptr,
                   &scores);
      if (stages.mhpo.success && stages.mhpo.best_score.s <= result.details.s) {
        result.cam_from_object = refined;
        result.details = stages.mhpo.best_score;
        stages.answer_hypothesis = stages.mhpo.best_hypothesis;
      }
      if (stages.mhpo.early_stopped) result.termination = Termination::kEarlyStopped;
    }
    stages.mhpo_ms = watch.ElapsedMs();

    // A surface of revolution keeps the turn about its axis of the start it came from: ICP
    // and MHPO see depth and silhouette, which do not hold that turn, and slid it by up to
    // 30 degrees in a frame (bench/RESULTS.md, "A tracked can's turn"); the appearance search
    // below is what may turn it.
    const MeshSymmetries& shape = bank.geometric_symmetries;
    if (shape.revolution) {
      const size_t from = std::min(starts.size() - 1, static_cast<size_t>(std::max(0, stages.answer_hypothesis)));
      const Eigen::Isometry3d untwisted = KeepTurnAboutAxis(shape, starts[from], result.cam_from_object);
      if (!untwisted.isApprox(result.cam_from_object)) {
        RasterImage scratch;
        result.cam_from_object = untwisted;
        result.details = ScorePose(observation.refine_grid, bank.online_mesh, untwisted, observation.z_m, online_score,
                                   &scratch);
      }
    }

    // A coloured surface of revolution: its turn about the axis, by appearance.
    if (track_options.appearance_search_deg > 0.0 && shape.revolution && !bank.appearance.Empty() &&
        options.appearance_tiebreak) {
      watch.Restart();
      RasterImage scratch;
      const int steps = static_cast<int>(std::floor(track_options.appearance_search_deg / track_options.appearance_step_deg));
      const Eigen::Isometry3d refined = result.cam_from_object;
      for (int k = -steps; k <= steps; ++k) {
        const Eigen::Isometry3d pose =
            refined * TurnAbout(shape.axis, shape.point, k * track_options.appearance_step_deg * M_PI / 180.0);
        const AppearanceScore appearance = ScoreAppearance(options.appearance, bank.appearance, bank.online_mesh, frame.camera,
                                                           frame.rgb, observation.mask, pose, &scratch);
        ++stages.appearance_compared;
        if (!appearance.valid || (result.appearance_valid && appearance.agreement <= result.appearance_agreement)) continue;
        result.appearance_valid = true;
        result.appearance_agreement = appearance.agreement;
        result.cam_from_object = pose;
      }
      if (!result.cam_from_object.isApprox(refined)) {
        stages.appearance_changed = true;
        result.details = ScorePose(observation.refine_grid, bank.online_mesh, result.cam_from_object, observation.z_m,
                                   online_score, &scratch);
      }
      stages.finalists_ms = watch.ElapsedMs();
    } else if (track_options.score_appearance && !bank.appearance.Empty() && options.appearance_tiebreak) {
      // Any other coloured mesh: the agreement of the answer, for the caller's loss test
      // (a flip onto a shape symmetry scores as well by S but not by appearance).
      watch.Restart();
      const AppearanceScore appearance = ScoreAppearance(options.appearance, bank.appearance, bank.online_mesh,
                                                         frame.camera, frame.rgb, observation.mask, result.cam_from_object);
      ++stages.appearance_compared;
      result.appearance_valid = appearance.valid;
      result.appearance_agreement = appearance.agreement;
      stages.finalists_ms = watch.ElapsedMs();
    }
    result.score = result.details.s;
    result.confidence = ConfidenceFromScore(options, result.score, false);
    result.success = true;
    result.message = "ok";
    stages.total_ms = total.ElapsedMs();
    return result;
  } catch (const std::exception& e) {
    return fail(Termination::kBadInput, std::string("internal error: ") + e.what());
  }
}

}  // namespace g6d
