#include "solver/pnp.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace g6d {

std::string PnpOptions::Check() const {
  std::ostringstream out;
  if (!(tau_fraction > 0.0)) out << "PnpOptions.tau_fraction must be > 0 (got " << tau_fraction << ")";
  else if (!(tau_min_px > 0.0 && tau_max_px >= tau_min_px)) out << "PnpOptions.tau_min_px/tau_max_px must satisfy 0 < min <= max (got " << tau_min_px << ", " << tau_max_px << ")";
  else if (max_iterations < 1) out << "PnpOptions.max_iterations must be >= 1 (got " << max_iterations << ")";
  else if (!(confidence > 0.0 && confidence < 1.0)) out << "PnpOptions.confidence must be in (0, 1) (got " << confidence << ")";
  else if (min_inliers < 4) out << "PnpOptions.min_inliers must be >= 4 (got " << min_inliers << ")";
  return out.str();
}

double PnpThreshold(const PnpOptions& options, double projected_size_px) {
  return std::clamp(options.tau_fraction * projected_size_px, options.tau_min_px, options.tau_max_px);
}

void EstimatePnp(const PnpOptions& options, const CorrespondenceSet& set, const Camera& camera,
                 double projected_size_px, PnpResult* result) {
  *result = PnpResult();
  const std::string bad = options.Check();
  if (!bad.empty()) {
    result->message = bad;
    return;
  }
  const size_t n = set.image_points.size();
  if (n < static_cast<size_t>(options.min_inliers)) {
    result->message = "too few correspondences (" + std::to_string(n) + ")";
    return;
  }
  std::vector<cv::Point3d> object_points(n);
  std::vector<cv::Point2d> image_points(n);
  for (size_t i = 0; i < n; ++i) {
    object_points[i] = {set.object_points[i].x(), set.object_points[i].y(), set.object_points[i].z()};
    image_points[i] = {set.image_points[i].x(), set.image_points[i].y()};
  }
  cv::Mat k;
  cv::eigen2cv(camera.K(), k);
  const double tau = PnpThreshold(options, projected_size_px);
  result->tau_px = tau;

  // USAC with MSAC scoring (eq. 5) and inner local optimization; the RNG state is
  // derived from the template index so every set is reproducible on any thread.
  cv::UsacParams params;
  params.confidence = options.confidence;
  params.maxIterations = options.max_iterations;
  params.threshold = tau;
  params.score = cv::SCORE_METHOD_MSAC;
  params.loMethod = cv::LOCAL_OPTIM_INNER_LO;
  params.sampler = cv::SAMPLING_UNIFORM;
  params.isParallel = false;
  params.randomGeneratorState = static_cast<int>((options.seed + static_cast<uint64_t>(set.template_index)) & 0x7fffffff);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  bool found = false;
  try {
    found = cv::solvePnPRansac(object_points, image_points, k, cv::noArray(), rvec, tvec, inliers, params);
  } catch (const cv::Exception& e) {
    result->message = std::string("solvePnPRansac failed: ") + e.what();
    return;
  }
  if (!found || inliers.size() < static_cast<size_t>(options.min_inliers)) {
    result->message = "no PnP solution with " + std::to_string(options.min_inliers) + " inliers";
    return;
  }
  // Local refinement on the MSAC inliers (Levenberg-Marquardt on reprojection error).
  std::vector<cv::Point3d> inlier_object;
  std::vector<cv::Point2d> inlier_image;
  for (int i : inliers) {
    inlier_object.push_back(object_points[static_cast<size_t>(i)]);
    inlier_image.push_back(image_points[static_cast<size_t>(i)]);
  }
  cv::solvePnPRefineLM(inlier_object, inlier_image, k, cv::noArray(), rvec, tvec);
  cv::Mat rotation_cv;
  cv::Rodrigues(rvec, rotation_cv);
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  cv::cv2eigen(rotation_cv, rotation);
  cv::cv2eigen(tvec, translation);
  if (!rotation.allFinite() || !translation.allFinite() || translation.z() <= 0.0) {
    result->message = "PnP pose is not finite or behind the camera";
    return;
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  double cost = 0.0;
  int count = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = pose * set.object_points[i];
    double r2 = tau * tau;
    if (p.z() > 0.0) r2 = std::min(r2, (camera.Project(p) - set.image_points[i]).squaredNorm());
    cost += r2;
    count += r2 < tau * tau;
  }
  result->cam_from_object = pose;
  result->inliers = count;
  result->msac_cost = cost;
  if (count < options.min_inliers) {
    result->message = "refined pose has only " + std::to_string(count) + " inliers";
    return;
  }
  result->success = true;
  result->message = "ok";
}

}  // namespace g6d
