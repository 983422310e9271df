#include "solver/pnp.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "solver/icp.h"

namespace g6d {

std::string PnpOptions::Check() const {
  std::ostringstream out;
  if (!(tau_fraction > 0.0)) out << "PnpOptions.tau_fraction must be > 0 (got " << tau_fraction << ")";
  else if (!(tau_min_px > 0.0 && tau_max_px >= tau_min_px)) out << "PnpOptions.tau_min_px/tau_max_px must satisfy 0 < min <= max (got " << tau_min_px << ", " << tau_max_px << ")";
  else if (max_iterations < 1) out << "PnpOptions.max_iterations must be >= 1 (got " << max_iterations << ")";
  else if (!(confidence > 0.0 && confidence < 1.0)) out << "PnpOptions.confidence must be in (0, 1) (got " << confidence << ")";
  else if (min_inliers < 4) out << "PnpOptions.min_inliers must be >= 4 (got " << min_inliers << ")";
  else if (!std::isfinite(max_centre_depth_error)) out << "PnpOptions.max_centre_depth_error must be finite (got " << max_centre_depth_error << ")";
  return out.str();
}

double PnpThreshold(const PnpOptions& options, double projected_size_px) {
  return std::clamp(options.tau_fraction * projected_size_px, options.tau_min_px, options.tau_max_px);
}

bool RefinePoseByReprojection(const Camera& camera, const std::vector<Eigen::Vector3d>& object_points,
                              const std::vector<Eigen::Vector2d>& image_points, const std::vector<int>& indices,
                              Eigen::Isometry3d* cam_from_object) {
  if (indices.size() < 4) return false;
  const double fx = camera.fx, fy = camera.fy;
  // The cost at a pose; +infinity when a point is not in front of the camera.
  auto cost_at = [&](const Eigen::Isometry3d& at) {
    double cost = 0.0;
    for (int i : indices) {
      const Eigen::Vector3d p = at * object_points[static_cast<size_t>(i)];
      if (!(p.z() > 1e-9)) return std::numeric_limits<double>::infinity();
      cost += (camera.Project(p) - image_points[static_cast<size_t>(i)]).squaredNorm();
    }
    return cost;
  };
  Eigen::Isometry3d current = *cam_from_object;
  double cost = cost_at(current);
  if (!std::isfinite(cost)) return false;
  double lambda = 1e-3;
  bool converged = false;
  for (int iteration = 0; iteration < 20 && !converged; ++iteration) {
    Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> gradient = Eigen::Matrix<double, 6, 1>::Zero();
    for (int i : indices) {
      const Eigen::Vector3d p = current * object_points[static_cast<size_t>(i)];
      const double inverse_z = 1.0 / p.z();
      const Eigen::Vector2d residual = camera.Project(p) - image_points[static_cast<size_t>(i)];
      Eigen::Matrix<double, 2, 3> projection;
      projection << fx * inverse_z, 0.0, -fx * p.x() * inverse_z * inverse_z,
                    0.0, fy * inverse_z, -fy * p.y() * inverse_z * inverse_z;
      Eigen::Matrix<double, 3, 6> motion;  // d(point) / d(w, v) at 0: [-[p]x | I]
      motion << 0.0, p.z(), -p.y(), 1.0, 0.0, 0.0,
                -p.z(), 0.0, p.x(), 0.0, 1.0, 0.0,
                p.y(), -p.x(), 0.0, 0.0, 0.0, 1.0;
      const Eigen::Matrix<double, 2, 6> jacobian = projection * motion;
      normal.noalias() += jacobian.transpose() * jacobian;
      gradient.noalias() += jacobian.transpose() * residual;
    }
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      Eigen::Matrix<double, 6, 6> damped = normal;
      damped.diagonal() += lambda * normal.diagonal().cwiseMax(1e-12);
      const Eigen::Matrix<double, 6, 1> step = damped.ldlt().solve(-gradient);
      if (!step.allFinite()) return false;
      const Eigen::Vector3d w = step.head<3>();
      Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
      if (w.norm() > 0.0) moved.linear() = Eigen::AngleAxisd(w.norm(), w / w.norm()).toRotationMatrix();
      moved.translation() = step.tail<3>();
      const Eigen::Isometry3d candidate = moved * current;
      const double candidate_cost = cost_at(candidate);
      if (candidate_cost < cost) {
        const double decrease = cost - candidate_cost;
        current = candidate;
        cost = candidate_cost;
        lambda = std::max(1e-9, lambda * 0.1);
        improved = true;
        // Converged: the step or the decrease is at the level of rounding.
        converged = step.norm() < 1e-9 * (1.0 + current.translation().norm()) || decrease <= 1e-12 * (1.0 + cost);
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  if (!current.matrix().allFinite()) return false;
  *cam_from_object = current;
  return true;
}

std::vector<Eigen::Vector3d> BackprojectKeypoints(const Camera& camera, const cv::Mat& depth, const cv::Mat& mask,
                                                  const std::vector<Eigen::Vector2d>& image_points) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Eigen::Vector3d> points(image_points.size(), Eigen::Vector3d::Constant(nan));
  for (size_t i = 0; i < image_points.size(); ++i) {
    const int u = static_cast<int>(std::floor(image_points[i].x()));
    const int v = static_cast<int>(std::floor(image_points[i].y()));
    float values[9];
    int count = 0;
    for (int dv = -1; dv <= 1; ++dv) {
      for (int du = -1; du <= 1; ++du) {
        const int x = u + du, y = v + dv;
        if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows) continue;
        if (!mask.empty() && !mask.at<uint8_t>(y, x)) continue;
        const float z = depth.at<float>(y, x);
        if (z > 0.0f && std::isfinite(z)) values[count++] = z;
      }
    }
    if (count < 3) continue;
    std::nth_element(values, values + count / 2, values + count);
    points[i] = camera.Backproject(image_points[i], values[count / 2]);
  }
  return points;
}

namespace {

// OpenCV's (rvec, tvec) as cam_from_object.
Eigen::Isometry3d PoseFromRvecTvec(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat rotation_cv;
  cv::Rodrigues(rvec, rotation_cv);
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  cv::cv2eigen(rotation_cv, rotation);
  cv::cv2eigen(tvec, translation);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  return pose;
}

// The data of one MSAC run. Scores follow eq. (5): Σ min(r², τ²).
class MsacProblem {
 public:
  MsacProblem(const PnpOptions& options, const CorrespondenceSet& set, const Camera& camera, const PnpPrior& prior,
              double tau_px)
      : options_(options), set_(set), camera_(camera), prior_(prior), tau2_(tau_px * tau_px) {}

  double Score(const Eigen::Isometry3d& pose, int* inliers) const {
    double cost = 0.0;
    int count = 0;
    const Eigen::Matrix3d rotation = pose.linear();
    const Eigen::Vector3d translation = pose.translation();
    for (size_t i = 0; i < set_.object_points.size(); ++i) {
      const Eigen::Vector3d p = rotation * set_.object_points[i] + translation;
      double r2 = tau2_;
      if (p.z() > 0.0) r2 = std::min(r2, (camera_.Project(p) - set_.image_points[i]).squaredNorm());
      cost += r2;
      count += r2 < tau2_;
    }
    if (inliers) *inliers = count;
    return cost;
  }

  // Inliers of `pose` among the correspondences `indices`.
  int CountInliers(const Eigen::Isometry3d& pose, const std::vector<int>& indices) const {
    int count = 0;
    for (int i : indices) {
      const Eigen::Vector3d p = pose * set_.object_points[static_cast<size_t>(i)];
      count += p.z() > 0.0 && (camera_.Project(p) - set_.image_points[static_cast<size_t>(i)]).squaredNorm() < tau2_;
    }
    return count;
  }

  std::vector<int> Inliers(const Eigen::Isometry3d& pose) const {
    std::vector<int> inliers;
    for (size_t i = 0; i < set_.object_points.size(); ++i) {
      const Eigen::Vector3d p = pose * set_.object_points[i];
      if (p.z() > 0.0 && (camera_.Project(p) - set_.image_points[i]).squaredNorm() < tau2_) {
        inliers.push_back(static_cast<int>(i));
      }
    }
    return inliers;
  }

  // The object must be in front of the camera and, when the depth is known, its centre
  // near the observed surface depth.
  bool Plausible(const Eigen::Isometry3d& pose) const {
    if (!pose.matrix().allFinite()) return false;
    const double centre_z = (pose * prior_.centre_in_object).z();
    if (!(centre_z > 0.0)) return false;
    if (prior_.z_m <= 0.0 || options_.max_centre_depth_error <= 0.0 || prior_.diameter_m <= 0.0) return true;
    return std::abs(centre_z - prior_.z_m) < options_.max_centre_depth_error * prior_.diameter_m;
  }

  // Levenberg-Marquardt on the reprojection error of `indices`, from `pose`.
  bool RefineLm(const std::vector<int>& indices, Eigen::Isometry3d* pose) const {
    return RefinePoseByReprojection(camera_, set_.object_points, set_.image_points, indices, pose);
  }

  // Minimal models from three correspondences.
  void SolveP3p(const int sample[3], std::vector<Eigen::Isometry3d>* models) const {
    models->clear();
    cv::Mat object_points(3, 3, CV_64F), image_points(3, 2, CV_64F);
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d& x = set_.object_points[static_cast<size_t>(sample[k])];
      const Eigen::Vector2d& u = set_.image_points[static_cast<size_t>(sample[k])];
      for (int c = 0; c < 3; ++c) object_points.at<double>(k, c) = x[c];
      image_points.at<double>(k, 0) = u.x();
      image_points.at<double>(k, 1) = u.y();
    }
    cv::Mat k;
    cv::eigen2cv(camera_.K(), k);
    std::vector<cv::Mat> rvecs, tvecs;
    try {
      cv::solveP3P(object_points, image_points, k, cv::noArray(), rvecs, tvecs, cv::SOLVEPNP_AP3P);
    } catch (const cv::Exception&) {
      return;
    }
    for (size_t s = 0; s < rvecs.size(); ++s) models->push_back(PoseFromRvecTvec(rvecs[s], tvecs[s]));
  }

  // 3D-3D: the sample's object points onto their observed camera-frame points. Rejects
  // samples whose pairwise distances disagree (a wrong match or a depth edge).
  bool SolveRigid(const int sample[3], Eigen::Isometry3d* model) const {
    std::vector<Eigen::Vector3d> source(3), target(3);
    for (int k = 0; k < 3; ++k) {
      source[static_cast<size_t>(k)] = set_.object_points[static_cast<size_t>(sample[k])];
      target[static_cast<size_t>(k)] = Observed(sample[k]);
    }
    const double tolerance = std::max(0.005, 0.1 * prior_.diameter_m);
    for (int a = 0; a < 3; ++a) {
      const int b = (a + 1) % 3;
      const double d_source = (source[static_cast<size_t>(a)] - source[static_cast<size_t>(b)]).norm();
      const double d_target = (target[static_cast<size_t>(a)] - target[static_cast<size_t>(b)]).norm();
      if (std::abs(d_source - d_target) > tolerance) return false;
    }
    *model = AlignRigid(source, target);
    return true;
  }

  // Kabsch on every inlier with depth (LO for the rigid solver).
  bool FitRigid(const std::vector<int>& indices, Eigen::Isometry3d* model) const {
    std::vector<Eigen::Vector3d> source, target;
    for (int i : indices) {
      if (!HasObserved(i)) continue;
      source.push_back(set_.object_points[static_cast<size_t>(i)]);
      target.push_back(Observed(i));
    }
    if (source.size() < 3) return false;
    *model = AlignRigid(source, target);
    return true;
  }

  bool HasObserved(int i) const {
    if (!prior_.query_points_in_cam || set_.query_indices.size() != set_.object_points.size()) return false;
    const int q = set_.query_indices[static_cast<size_t>(i)];
    return q >= 0 && static_cast<size_t>(q) < prior_.query_points_in_cam->size() &&
           std::isfinite((*prior_.query_points_in_cam)[static_cast<size_t>(q)].z());
  }
  const Eigen::Vector3d& Observed(int i) const {
    return (*prior_.query_points_in_cam)[static_cast<size_t>(set_.query_indices[static_cast<size_t>(i)])];
  }

  // A sample of three distinct correspondences (from `pool`) whose object points and
  // image points are not nearly coincident. False after too many failed draws.
  bool DrawSample(const std::vector<int>& pool, std::mt19937_64* rng, int sample[3]) const {
    std::uniform_int_distribution<size_t> pick(0, pool.size() - 1);
    const double min_object_m = 0.02 * std::max(prior_.diameter_m, 1e-3);
    for (int attempt = 0; attempt < 50; ++attempt) {
      for (int k = 0; k < 3; ++k) sample[k] = pool[pick(*rng)];
      bool ok = sample[0] != sample[1] && sample[1] != sample[2] && sample[0] != sample[2];
      for (int a = 0; ok && a < 3; ++a) {
        const size_t i = static_cast<size_t>(sample[a]), j = static_cast<size_t>(sample[(a + 1) % 3]);
        ok = (set_.object_points[i] - set_.object_points[j]).norm() > min_object_m &&
             (set_.image_points[i] - set_.image_points[j]).norm() > 1.0;
      }
      if (ok) return true;
    }
    return false;
  }

 private:
  const PnpOptions& options_;
  const CorrespondenceSet& set_;
  const Camera& camera_;
  const PnpPrior& prior_;
  const double tau2_;
};

// The original path: OpenCV USAC (P3P minimal solver, MSAC score, inner LO). Kept for
// the ablation; it has no plausibility test.
bool RunOpenCvUsac(const PnpOptions& options, const CorrespondenceSet& set, const Camera& camera, double tau,
                   Eigen::Isometry3d* pose) {
  const size_t n = set.image_points.size();
  std::vector<size_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = i;
  if (options.progressive_sampling && set.distances.size() == n) {
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return set.distances[a] < set.distances[b]; });
  }
  std::vector<cv::Point3d> object_points(n);
  std::vector<cv::Point2d> image_points(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& x = set.object_points[order[i]];
    const Eigen::Vector2d& u = set.image_points[order[i]];
    object_points[i] = {x.x(), x.y(), x.z()};
    image_points[i] = {u.x(), u.y()};
  }
  cv::Mat k;
  cv::eigen2cv(camera.K(), k);
  cv::UsacParams params;
  params.confidence = options.confidence;
  params.maxIterations = options.max_iterations;
  params.threshold = tau;
  params.score = cv::SCORE_METHOD_MSAC;
  params.loMethod = options.local_optimization ? cv::LOCAL_OPTIM_INNER_LO : cv::LOCAL_OPTIM_NULL;
  params.sampler = options.progressive_sampling ? cv::SAMPLING_PROSAC : cv::SAMPLING_UNIFORM;
  params.isParallel = false;
  params.randomGeneratorState = static_cast<int>((options.seed + static_cast<uint64_t>(set.template_index)) & 0x7fffffff);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  try {
    if (!cv::solvePnPRansac(object_points, image_points, k, cv::noArray(), rvec, tvec, inliers, params)) return false;
  } catch (const cv::Exception&) {
    return false;
  }
  *pose = PoseFromRvecTvec(rvec, tvec);
  return true;
}

}  // namespace

void EstimatePnp(const PnpOptions& options, const CorrespondenceSet& set, const Camera& camera,
                 double projected_size_px, const PnpPrior& prior, PnpResult* result) {
  *result = PnpResult();
  const std::string bad = options.Check();
  if (!bad.empty()) {
    result->message = bad;
    return;
  }
  const size_t n = set.image_points.size();
  if (n < static_cast<size_t>(options.min_inliers) || set.object_points.size() != n) {
    result->message = "too few correspondences (" + std::to_string(n) + ")";
    return;
  }
  const double tau = PnpThreshold(options, projected_size_px);
  result->tau_px = tau;
  const MsacProblem problem(options, set, camera, prior, tau);

  Eigen::Isometry3d best = Eigen::Isometry3d::Identity();
  double best_cost = std::numeric_limits<double>::infinity();
  int best_inliers = 0;
  if (options.minimal_solver == PnpMinimalSolver::kOpenCvUsac) {
    if (RunOpenCvUsac(options, set, camera, tau, &best)) best_cost = problem.Score(best, &best_inliers);
    result->iterations = options.max_iterations;
  } else {
    // Own MSAC loop (eq. 5) with a plausibility test on every model; the RNG is seeded per
    // template so every set is reproducible on any thread.
    std::vector<int> all(n), with_depth;
    for (size_t i = 0; i < n; ++i) {
      all[i] = static_cast<int>(i);
      if (problem.HasObserved(static_cast<int>(i))) with_depth.push_back(static_cast<int>(i));
    }
    // The depth-rigid solver samples only correspondences whose keypoint has depth; with
    // fewer than min_inliers of them it cannot confirm a model, so P3P over all of them
    // runs instead. (Running P3P also after a rigid run that found nothing doubled the
    // cost of the many sets from wrong templates and found no extra correct pose.)
    const bool rigid = options.minimal_solver == PnpMinimalSolver::kDepthRigid &&
                       with_depth.size() >= static_cast<size_t>(std::max(3, options.min_inliers));
    int iteration = 0;
    {
      const std::vector<int>& pool = rigid ? with_depth : all;
      std::mt19937_64 rng(options.seed * 0x9E3779B97F4A7C15ULL + static_cast<uint64_t>(set.template_index));
      int needed = options.max_iterations;
      std::vector<Eigen::Isometry3d> models;
      for (int round_iteration = 0; round_iteration < needed; ++round_iteration, ++iteration) {
        int sample[3];
        if (!problem.DrawSample(pool, &rng, sample)) break;
        models.clear();
        if (rigid) {
          Eigen::Isometry3d model;
          if (problem.SolveRigid(sample, &model)) models.push_back(model);
        } else {
          problem.SolveP3p(sample, &models);
        }
        for (const Eigen::Isometry3d& model : models) {
          if (!problem.Plausible(model)) continue;
          int inliers = 0;
          const double cost = problem.Score(model, &inliers);
          if (cost >= best_cost) continue;
          best = model;
          best_cost = cost;
          best_inliers = inliers;
          if (options.local_optimization && inliers >= options.min_inliers) {
            // Local optimization: re-fit on the inliers while the cost improves.
            for (int round = 0; round < 3; ++round) {
              Eigen::Isometry3d refit = best;
              const std::vector<int> inlier_indices = problem.Inliers(best);
              const bool fitted = rigid ? problem.FitRigid(inlier_indices, &refit) : problem.RefineLm(inlier_indices, &refit);
              if (!fitted || !problem.Plausible(refit)) break;
              int refit_inliers = 0;
              const double refit_cost = problem.Score(refit, &refit_inliers);
              if (refit_cost >= best_cost) break;
              best = refit;
              best_cost = refit_cost;
              best_inliers = refit_inliers;
            }
          }
          // Adaptive stopping: samples needed to draw one all-inlier triple with
          // probability `confidence` at the current inlier ratio of the pool sampled
          // from (inliers among all correspondences over the with-depth pool would
          // overstate it when keypoint depth is missing, and stop too early).
          const int pool_inliers = problem.CountInliers(best, pool);
          const double ratio = std::min(1.0, static_cast<double>(pool_inliers) / static_cast<double>(pool.size()));
          const double p_good = ratio * ratio * ratio;
          if (p_good >= 1.0) {
            needed = 0;
          } else if (p_good > 0.0) {
            const double k = std::log(1.0 - options.confidence) / std::log(1.0 - p_good);
            needed = std::min(options.max_iterations, static_cast<int>(std::ceil(k)));
          }
        }
      }
    }
    result->iterations = iteration;
  }
  if (!std::isfinite(best_cost) || best_inliers < options.min_inliers) {
    result->message = "no plausible PnP solution with " + std::to_string(options.min_inliers) + " inliers";
    return;
  }
  // Final local refinement on the MSAC inliers (Levenberg-Marquardt on the reprojection
  // error); kept only when it does not worsen eq. (5) and stays plausible.
  Eigen::Isometry3d refined = best;
  if (problem.RefineLm(problem.Inliers(best), &refined) && problem.Plausible(refined)) {
    int refined_inliers = 0;
    const double refined_cost = problem.Score(refined, &refined_inliers);
    if (refined_cost <= best_cost) {
      best = refined;
      best_cost = refined_cost;
      best_inliers = refined_inliers;
    }
  }
  result->cam_from_object = best;
  result->inliers = best_inliers;
  result->msac_cost = best_cost;
  if (!problem.Plausible(best) && options.minimal_solver != PnpMinimalSolver::kOpenCvUsac) {
    result->message = "PnP pose is implausible";
    return;
  }
  if (best.translation().z() <= 0.0 || !best.matrix().allFinite()) {
    result->message = "PnP pose is not finite or behind the camera";
    return;
  }
  result->success = true;
  result->message = "ok";
}

}  // namespace g6d
