#include "solver/mhpo.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

#include <ceres/cubic_interpolation.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "render/raster.h"

namespace g6d {

std::string MhpoOptions::Check() const {
  std::ostringstream out;
  if (!(lambda_d >= 0.0)) out << "MhpoOptions.lambda_d must be >= 0 (got " << lambda_d << ")";
  else if (!(huber_beta > 0.0)) out << "MhpoOptions.huber_beta must be > 0 (got " << huber_beta << ")";
  else if (!(silhouette_robust_px > 0.0)) out << "MhpoOptions.silhouette_robust_px must be > 0 (got " << silhouette_robust_px << ")";
  else if (max_rounds < 0) out << "MhpoOptions.max_rounds must be >= 0 (got " << max_rounds << ")";
  else if (lm_iterations < 1) out << "MhpoOptions.lm_iterations must be >= 1 (got " << lm_iterations << ")";
  else if (max_contour_points < 1 || max_depth_points < 0) out << "MhpoOptions.max_contour_points must be >= 1 and max_depth_points >= 0";
  else if (patience < 1) out << "MhpoOptions.patience must be >= 1 (got " << patience << ")";
  else if (min_rounds < 0) out << "MhpoOptions.min_rounds must be >= 0 (got " << min_rounds << ")";
  return out.str();
}

namespace {

using Grid = ceres::Grid2D<float, 1>;
using Interpolator = ceres::BiCubicInterpolator<Grid>;

// Bicubic views of the signed distance and the observed depth of a target.
struct TargetInterpolators {
  explicit TargetInterpolators(const MhpoTarget& target)
      : sdf_grid(target.signed_distance.ptr<float>(), 0, target.signed_distance.rows, 0,
                 target.signed_distance.cols),
        depth_grid(target.filled_depth.ptr<float>(), 0, target.filled_depth.rows, 0,
                   target.filled_depth.cols),
        sdf(sdf_grid),
        depth(depth_grid) {}
  Grid sdf_grid;
  Grid depth_grid;
  Interpolator sdf;
  Interpolator depth;
};

// The grid camera's projection of `point` (camera frame) in the coordinates of ceres::Grid2D
// (integer values on pixel centres: the continuous coordinates minus 0.5), and the
// derivatives of (row, col) with respect to the point. A point at or behind z = 1e-6 is
// projected as if at 1e-6, which does not move with it.
struct GridProjection {
  double row = 0.0, col = 0.0;
  Eigen::Vector3d d_row = Eigen::Vector3d::Zero(), d_col = Eigen::Vector3d::Zero();
};

GridProjection ProjectToGrid(const Camera& camera, const Eigen::Vector3d& point) {
  GridProjection projection;
  const bool in_front = point.z() > 1e-6;
  const double z = in_front ? point.z() : 1e-6;
  projection.col = camera.fx * point.x() / z + camera.cx - 0.5;
  projection.row = camera.fy * point.y() / z + camera.cy - 0.5;
  projection.d_col = Eigen::Vector3d(camera.fx / z, 0.0, in_front ? -camera.fx * point.x() / (z * z) : 0.0);
  projection.d_row = Eigen::Vector3d(0.0, camera.fy / z, in_front ? -camera.fy * point.y() / (z * z) : 0.0);
  return projection;
}

// The derivative of a residual with respect to the left increment (rho, phi) at zero,
// p' = R(phi) p + rho, from its derivative with respect to the point p: d/d rho = d/dp,
// d/d phi = p x d/dp (R(phi) p = p + phi x p to first order).
void IncrementJacobian(const Eigen::Vector3d& point, const Eigen::Vector3d& d_point, double jacobian[6]) {
  const Eigen::Vector3d d_phi = point.cross(d_point);
  for (int i = 0; i < 3; ++i) {
    jacobian[i] = d_point[i];
    jacobian[3 + i] = d_phi[i];
  }
}

// (a) silhouette: the signed distance of the projected contour point to the observed boundary.
double SilhouetteResidual(const Camera& camera, const Interpolator& sdf, const Eigen::Vector3d& point,
                          double jacobian[6]) {
  const GridProjection at = ProjectToGrid(camera, point);
  double value = 0.0, d_row = 0.0, d_col = 0.0;
  sdf.Evaluate(at.row, at.col, &value, &d_row, &d_col);
  if (jacobian != nullptr) IncrementJacobian(point, d_row * at.d_row + d_col * at.d_col, jacobian);
  return value;
}

// (b) depth: (rendered - observed depth) / z_M at the projected surface point.
double DepthResidual(const Camera& camera, const Interpolator& depth, const Eigen::Vector3d& point, double z_m,
                     double jacobian[6]) {
  const GridProjection at = ProjectToGrid(camera, point);
  double observed = 0.0, d_row = 0.0, d_col = 0.0;
  depth.Evaluate(at.row, at.col, &observed, &d_row, &d_col);
  if (jacobian != nullptr) {
    IncrementJacobian(point, (Eigen::Vector3d::UnitZ() - d_row * at.d_row - d_col * at.d_col) / z_m, jacobian);
  }
  return (point.z() - observed) / z_m;
}

// One round's least-squares problem: each term a mean, as in eqs. (10) and (13) (weights
// 1/N inside the squares), each residual under a Huber penalty.
struct RoundProblem {
  const Camera* camera = nullptr;
  const TargetInterpolators* interpolators = nullptr;
  double z_m = 0.0;
  std::vector<Eigen::Vector3d> contour, surface;  // camera frame, at the round's start
  double contour_weight = 0.0, contour_huber = 0.0;
  double surface_weight = 0.0, surface_huber = 0.0;
};

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Half the sum of the Huber penalties rho(r^2) of the residuals with the points moved by
// (rotation, translation). With `normal` and `gradient`, also the Gauss-Newton system of
// the left increment at zero: each residual and its Jacobian scaled by sqrt(rho'(r^2))
// (Triggs' correction without its second-order part, which is how Ceres treats Huber).
double EvaluateRound(const RoundProblem& problem, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                     Matrix6d* normal, Vector6d* gradient) {
  const bool linearize = normal != nullptr;
  if (linearize) {
    normal->setZero();
    gradient->setZero();
  }
  double cost = 0.0;
  double jacobian[6];
  auto add = [&](double residual, double huber) {
    const double s = residual * residual, threshold = huber * huber;
    const double rho = s <= threshold ? s : 2.0 * huber * std::sqrt(s) - threshold;
    cost += 0.5 * rho;
    if (!linearize) return;
    const double rho1 = s <= threshold ? 1.0 : huber / std::sqrt(s);
    const Eigen::Map<const Vector6d> j(jacobian);
    normal->selfadjointView<Eigen::Lower>().rankUpdate(j, rho1);
    *gradient += (rho1 * residual) * j;
  };
  for (const Eigen::Vector3d& point : problem.contour) {
    const double value = SilhouetteResidual(*problem.camera, problem.interpolators->sdf, rotation * point + translation,
                                            linearize ? jacobian : nullptr);
    if (linearize) for (double& d : jacobian) d *= problem.contour_weight;
    add(problem.contour_weight * value, problem.contour_huber);
  }
  for (const Eigen::Vector3d& point : problem.surface) {
    const double value = DepthResidual(*problem.camera, problem.interpolators->depth, rotation * point + translation,
                                       problem.z_m, linearize ? jacobian : nullptr);
    if (linearize) for (double& d : jacobian) d *= problem.surface_weight;
    add(problem.surface_weight * value, problem.surface_huber);
  }
  if (linearize) *normal = normal->selfadjointView<Eigen::Lower>();
  return cost;
}

// R(phi) for the rotation vector phi.
Eigen::Matrix3d RotationOf(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix();
}

// Levenberg-Marquardt on the round's problem over a left increment of the points, at most
// `iterations` steps (successful or not). Every accepted step is composed into (rotation,
// translation) and the next one linearized at zero again. The trust-region rules are
// Ceres' defaults for its LEVENBERG_MARQUARDT strategy, which this replaces (one dense 6x6
// system instead of a problem of hundreds of residual blocks built per round): the
// damping diag(J^T J) clamped to [1e-6, 1e32] over the radius, first 1e4; a step is taken
// when it achieves more than 1e-3 of the decrease its model predicts, the radius then
// grows by 1 / max(1/3, 1 - (2 ratio - 1)^3) and otherwise shrinks by a factor that
// doubles with each failure; the loop ends when the cost changes by less than 1e-6 of
// itself or the gradient vanishes.
void SolveRound(const RoundProblem& problem, int iterations, Eigen::Matrix3d* rotation, Eigen::Vector3d* translation) {
  Matrix6d normal;
  Vector6d gradient;
  double cost = EvaluateRound(problem, *rotation, *translation, &normal, &gradient);
  double radius = 1e4, decrease = 2.0;
  for (int iteration = 0; iteration < iterations; ++iteration) {
    if (!(gradient.lpNorm<Eigen::Infinity>() > 1e-10)) return;
    Matrix6d damped = normal;
    damped.diagonal() += normal.diagonal().cwiseMax(1e-6).cwiseMin(1e32) / radius;
    const Vector6d step = damped.ldlt().solve(-gradient);
    const double model_decrease = -(gradient.dot(step) + 0.5 * step.dot(normal * step));
    if (!step.allFinite() || !(model_decrease > 0.0)) {
      radius /= decrease;
      decrease *= 2.0;
      continue;
    }
    const Eigen::Matrix3d turn = RotationOf(step.tail<3>());
    const Eigen::Matrix3d next_rotation = turn * *rotation;
    const Eigen::Vector3d next_translation = turn * *translation + step.head<3>();
    const double next_cost = EvaluateRound(problem, next_rotation, next_translation, nullptr, nullptr);
    const double ratio = (cost - next_cost) / model_decrease;
    const bool converged = std::abs(cost - next_cost) <= 1e-6 * cost;
    if (!(ratio > 1e-3)) {
      if (converged) return;
      radius /= decrease;
      decrease *= 2.0;
      continue;
    }
    *rotation = next_rotation;
    *translation = next_translation;
    if (converged || iteration + 1 == iterations) return;
    radius = std::min(1e16, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * ratio - 1.0, 3)));
    decrease = 2.0;
    cost = EvaluateRound(problem, *rotation, *translation, &normal, &gradient);
  }
}

// True when the observed depth in the 4x4 bicubic support around (u, v) is all valid.
bool DepthSupportValid(const cv::Mat& depth, int u, int v) {
  for (int dv = -1; dv <= 2; ++dv) {
    for (int du = -1; du <= 2; ++du) {
      const int uu = u + du, vv = v + dv;
      if (uu < 0 || vv < 0 || uu >= depth.cols || vv >= depth.rows) return false;
      if (!(depth.at<float>(vv, uu) > 0.0f)) return false;
    }
  }
  return true;
}

struct HypothesisState {
  Eigen::Isometry3d current;
  Eigen::Isometry3d best;
  PoseScore best_score;
  int rounds_without_gain = 0;
  bool active = true;
  MhpoHypothesisReport report;
  RasterImage raster;
};

// True when the rendered edge at (u, v), inside the mask, borders a mask pixel of another
// depth segment (EvaluationGrid::segment): the mask goes on into another object there, so
// the observed boundary that the contour should lie on is the depth edge, which the mask's
// distance field does not know. Such contour points pull nowhere.
// The same where the mask goes on into pixels the depth cannot judge (EvaluationGrid::
// unsure): the mask's edge there says nothing of the object's.
bool CrossesIntoAnotherSegment(const EvaluationGrid& grid, const cv::Mat& rendered, int u, int v) {
  const bool unsure = !grid.unsure.empty();
  if (grid.segment.empty() && !unsure) return false;
  const int own = grid.segment.empty() ? 0 : grid.segment.at<int>(v, u);
  const int du[4] = {-1, 1, 0, 0}, dv[4] = {0, 0, -1, 1};
  for (int k = 0; k < 4; ++k) {
    const int uu = u + du[k], vv = v + dv[k];
    if (rendered.at<float>(vv, uu) > 0.0f || !grid.mask.at<uint8_t>(vv, uu)) continue;
    if (unsure && grid.unsure.at<uint8_t>(vv, uu)) return true;
    const int other = grid.segment.empty() ? 0 : grid.segment.at<int>(vv, uu);
    if (other > 0 && other != own) return true;
  }
  return false;
}

// One round for one hypothesis: rasterize, collect residuals, LM, re-score.
void RunRound(const MhpoOptions& options, const ScoreOptions& score_options, const MhpoTarget& target,
              const TargetInterpolators& interpolators, const Mesh& mesh, int round, HypothesisState* state) {
  const EvaluationGrid& grid = *target.grid;
  const Camera& camera = grid.camera;
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  raster_options.cull_backfaces = score_options.cull_backfaces;
  Rasterize(mesh, camera, state->current, raster_options, &state->raster);
  const cv::Mat& rendered = state->raster.depth;

  std::vector<Eigen::Vector3d> contour, surface;
  const int last_u = rendered.cols - 1, last_v = rendered.rows - 1;
  for (int v = 0; v < rendered.rows; ++v) {
    for (int u = 0; u < rendered.cols; ++u) {
      const float z = rendered.at<float>(v, u);
      if (!(z > 0.0f)) continue;
      const Eigen::Vector3d point = camera.Backproject(PixelCentre(u, v), z);
      const bool in_mask = grid.mask.at<uint8_t>(v, u) != 0;
      // Outside the mask, a pixel the depth puts on the rendered surface is object the mask
      // missed (ScoreOptions::depth_evidence): its depth counts, its mask edge does not.
      const bool on_support = !grid.support.empty() && grid.support.at<uint8_t>(v, u) != 0;
      const bool missed = !in_mask && (MissedByMask(z, grid.depth.at<float>(v, u), on_support, score_options) ||
                                       (!on_support && HoleOnSurface(grid, u, v, z, score_options)));
      // Inside the mask, an occluder the mask leaked onto is not the object (as in S).
      const bool leaked_occluder =
          in_mask && score_options.depth_evidence && IsOccluded(z, grid.depth.at<float>(v, u), score_options);
      if ((in_mask || missed) && !leaked_occluder && DepthSupportValid(grid.depth, u, v)) surface.push_back(point);
      // Contour points on the grid's edge are where the rendering leaves the ROI or the
      // image (a truncated object): there is no observed boundary to pull them to. Contour
      // points hidden behind an unmasked occluder have none either.
      if (u == 0 || v == 0 || u == last_u || v == last_v) continue;
      const bool edge = !(rendered.at<float>(v, u - 1) > 0.0f) || !(rendered.at<float>(v, u + 1) > 0.0f) ||
                        !(rendered.at<float>(v - 1, u) > 0.0f) || !(rendered.at<float>(v + 1, u) > 0.0f);
      if (!edge) continue;
      if (leaked_occluder || (!in_mask && (missed || IsOccluded(z, grid.depth.at<float>(v, u), score_options)))) continue;
      if (in_mask && CrossesIntoAnotherSegment(grid, rendered, u, v)) continue;
      contour.push_back(point);
    }
  }
  // With depth evidence, a silhouette wholly inside what the mask missed still has its
  // depth to align (the contour term then has nothing to say).
  const bool depth_only = score_options.depth_evidence && surface.size() >= 6;
  if (contour.size() < 6 && !depth_only) {
    state->active = false;  // the rendering left the grid: nothing to align
    return;
  }
  if (contour.size() < 6) contour.clear();
  auto subsample = [](std::vector<Eigen::Vector3d>* points, int max_count) {
    if (static_cast<int>(points->size()) <= max_count) return;
    std::vector<Eigen::Vector3d> kept;
    const double step = static_cast<double>(points->size()) / max_count;
    for (int i = 0; i < max_count; ++i) kept.push_back((*points)[static_cast<size_t>(i * step)]);
    points->swap(kept);
  };
  subsample(&contour, options.max_contour_points);
  subsample(&surface, options.max_depth_points);

  RoundProblem problem;
  problem.camera = &camera;
  problem.interpolators = &interpolators;
  problem.z_m = target.z_m;
  const double grid_side = std::max(camera.width, camera.height);
  problem.contour_weight = 1.0 / (grid_side * std::sqrt(static_cast<double>(std::max<size_t>(1, contour.size()))));
  problem.contour_huber = problem.contour_weight * options.silhouette_robust_px;
  problem.contour = std::move(contour);
  if (!surface.empty() && target.z_m > 0.0 && options.lambda_d > 0.0) {
    problem.surface_weight = std::sqrt(options.lambda_d / static_cast<double>(surface.size()));
    problem.surface_huber = problem.surface_weight * options.huber_beta;
    problem.surface = std::move(surface);
  }
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  SolveRound(problem, options.lm_iterations, &rotation, &translation);
  Eigen::Isometry3d next = Eigen::Isometry3d::Identity();
  next.linear() = rotation * state->current.linear();
  next.translation() = rotation * state->current.translation() + translation;
  state->current = next;
  state->report.rounds = round + 1;
  const PoseScore score = ScorePose(grid, mesh, next, target.z_m, score_options, &state->raster);
  if (score.s < state->best_score.s) {  // eq. (17): keep the best state ever seen
    state->best = next;
    state->best_score = score;
    state->report.best_round = round + 1;
    state->rounds_without_gain = 0;
  } else if (++state->rounds_without_gain >= options.patience) {
    state->active = false;
  }
}

}  // namespace

MhpoTarget MakeMhpoTarget(const EvaluationGrid& grid, double z_m, int fill_radius_px) {
  MhpoTarget target;
  target.grid = &grid;
  target.z_m = z_m;
  // Grow valid depth into holes one ring per pass (mean of the valid 8-neighbours).
  target.filled_depth = grid.depth.clone();
  for (int pass = 0; pass < fill_radius_px; ++pass) {
    const cv::Mat previous = target.filled_depth.clone();
    bool changed = false;
    for (int v = 0; v < previous.rows; ++v) {
      for (int u = 0; u < previous.cols; ++u) {
        if (previous.at<float>(v, u) > 0.0f) continue;
        double sum = 0.0;
        int count = 0;
        for (int dv = -1; dv <= 1; ++dv) {
          for (int du = -1; du <= 1; ++du) {
            const int uu = u + du, vv = v + dv;
            if (uu < 0 || vv < 0 || uu >= previous.cols || vv >= previous.rows) continue;
            const float z = previous.at<float>(vv, uu);
            if (z > 0.0f) {
              sum += z;
              ++count;
            }
          }
        }
        if (count > 0) {
          target.filled_depth.at<float>(v, u) = static_cast<float>(sum / count);
          changed = true;
        }
      }
    }
    if (!changed) break;
  }
  cv::Mat inside_distance, outside_distance;
  const cv::Mat inside = grid.mask > 0;
  const cv::Mat outside = grid.mask == 0;
  // distanceTransform measures to the nearest zero pixel: for pixels inside the mask,
  // the nearest background pixel, and vice versa. The boundary lies half a pixel away.
  cv::distanceTransform(inside, inside_distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  cv::distanceTransform(outside, outside_distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  target.signed_distance.create(grid.mask.size(), CV_32F);
  for (int v = 0; v < grid.mask.rows; ++v) {
    for (int u = 0; u < grid.mask.cols; ++u) {
      target.signed_distance.at<float>(v, u) = grid.mask.at<uint8_t>(v, u)
                                                   ? -(inside_distance.at<float>(v, u) - 0.5f)
                                                   : outside_distance.at<float>(v, u) - 0.5f;
    }
  }
  return target;
}

double EvaluateSilhouetteResidual(const MhpoTarget& target, const Eigen::Vector3d& point_in_cam, double jacobian[6]) {
  const TargetInterpolators interpolators(target);
  return SilhouetteResidual(target.grid->camera, interpolators.sdf, point_in_cam, jacobian);
}

double EvaluateDepthResidual(const MhpoTarget& target, const Eigen::Vector3d& point_in_cam, double jacobian[6]) {
  const TargetInterpolators interpolators(target);
  return DepthResidual(target.grid->camera, interpolators.depth, point_in_cam, target.z_m, jacobian);
}

void RefineByMhpo(const MhpoOptions& options, const ScoreOptions& score_options,
                  const MhpoTarget& target, const Mesh& mesh,
                  const std::vector<Eigen::Isometry3d>& hypotheses, Executor* executor,
                  Eigen::Isometry3d* best_cam_from_object, MhpoReport* report,
                  const Deadline* deadline, const std::vector<PoseScore>* initial_scores) {
  *report = MhpoReport();
  std::string bad = options.Check();
  if (bad.empty()) bad = score_options.Check();
  if (!bad.empty()) {
    report->message = bad;
    return;
  }
  if (hypotheses.empty()) {
    report->message = "no hypotheses to refine";
    return;
  }
  G6D_CHECK(initial_scores == nullptr || initial_scores->size() == hypotheses.size());
  G6D_CHECK(target.grid != nullptr);
  const TargetInterpolators interpolators(target);
  const int n = static_cast<int>(hypotheses.size());
  std::vector<HypothesisState> states(static_cast<size_t>(n));
  executor->ParallelFor(n, [&](int k) {
    HypothesisState& state = states[static_cast<size_t>(k)];
    state.current = state.best = hypotheses[static_cast<size_t>(k)];
    state.best_score = initial_scores != nullptr ? (*initial_scores)[static_cast<size_t>(k)]
                                                 : ScorePose(*target.grid, mesh, state.current, target.z_m, score_options, &state.raster);
    state.report.initial_s = state.best_score.s;
  });
  auto global_best = [&]() {
    int best = 0;
    for (int k = 1; k < n; ++k) {
      if (states[static_cast<size_t>(k)].best_score.s < states[static_cast<size_t>(best)].best_score.s) best = k;
    }
    return best;
  };
  const bool early_stop_enabled = options.early_stop_score > 0.0;
  for (int round = 0; round < options.max_rounds; ++round) {
    if (early_stop_enabled && round >= options.min_rounds &&
        states[static_cast<size_t>(global_best())].best_score.s < options.early_stop_score) {
      report->early_stopped = true;
      break;
    }
    if (deadline != nullptr && deadline->Expired()) {
      report->cut_short = true;
      break;
    }
    std::vector<int> active;
    for (int k = 0; k < n; ++k) {
      if (states[static_cast<size_t>(k)].active) active.push_back(k);
    }
    if (active.empty()) break;
    executor->ParallelFor(static_cast<int>(active.size()), [&](int i) {
      RunRound(options, score_options, target, interpolators, mesh, round,
               &states[static_cast<size_t>(active[static_cast<size_t>(i)])]);
    });
  }
  const int best = global_best();
  *best_cam_from_object = states[static_cast<size_t>(best)].best;
  report->best_hypothesis = best;
  report->best_score = states[static_cast<size_t>(best)].best_score;
  for (HypothesisState& state : states) {
    state.report.best_s = state.best_score.s;
    state.report.best_cam_from_object = state.best;
    state.report.best_score = state.best_score;
    report->hypotheses.push_back(state.report);
  }
  report->success = true;
  report->message = "ok";
}

}  // namespace g6d
