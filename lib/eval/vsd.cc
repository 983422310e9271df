#include "eval/vsd.h"

#include <cmath>

#include "core/error.h"
#include "render/raster.h"

namespace g6d {
namespace {

// The per-pixel ray length factor of bop_toolkit's depth_im_to_dist_im_fast: distance =
// depth * sqrt(1 + x^2 + y^2) with x = (u - cx) / fx, y = (v - cy) / fy. BOP takes the
// integer pixel index u (np.arange(width)), not the pixel centre u + 0.5 at which its
// renderer (and ours) samples depth. We keep BOP's choice so the numbers agree with the
// toolkit; the half-pixel shift scales every distance of a pixel by the same factor
// (relative change below 1e-3 at 640x480), so test, GT and estimate stay consistent.
class RayLength {
 public:
  explicit RayLength(const Camera& camera) : camera_(camera) {}
  double Factor(int u, int v) const {
    const double x = (u - camera_.cx) / camera_.fx;
    const double y = (v - camera_.cy) / camera_.fy;
    return std::sqrt(1.0 + x * x + y * y);
  }

 private:
  Camera camera_;
};

// bop_toolkit visibility._estimate_visib_mask, "bop19" mode: the model surface at a pixel
// is visible when it is not more than delta behind the measured surface, and also where
// the sensor measured nothing (shiny or dark surfaces: BOP'19 counts them visible).
inline bool IsVisible(double model_distance, double test_distance, double delta) {
  return model_distance > 0.0 && (test_distance == 0.0 || model_distance - test_distance <= delta);
}

void CheckDepthImage(const cv::Mat& image, const char* name, const cv::Size& size,
                     const char* function) {
  if (image.type() != CV_32FC1) {
    G6D_THROW(function << ": " << name << " must be CV_32FC1 (metres), got OpenCV type "
                       << image.type());
  }
  if (image.size() != size) {
    G6D_THROW(function << ": " << name << " is " << image.cols << "x" << image.rows << ", expected "
                       << size.width << "x" << size.height);
  }
}

void CheckFocal(const Camera& camera, const char* function) {
  if (!(camera.fx > 0.0 && camera.fy > 0.0) || !std::isfinite(camera.fx) ||
      !std::isfinite(camera.fy) || !std::isfinite(camera.cx) || !std::isfinite(camera.cy)) {
    G6D_THROW(function << ": camera needs finite positive focal lengths and a finite principal "
                          "point (fx "
                       << camera.fx << ", fy " << camera.fy << ", cx " << camera.cx << ", cy "
                       << camera.cy << ")");
  }
}

}  // namespace

std::vector<double> BopVsdTaus() {
  // np.arange(0.05, 0.51, 0.05) evaluates start + i * step.
  std::vector<double> taus;
  for (int i = 0; i < 10; ++i) taus.push_back(0.05 + i * 0.05);
  return taus;
}

std::string VsdOptions::Check() const {
  if (!std::isfinite(delta_m) || delta_m < 0.0) {
    return "VsdOptions.delta_m must be finite and >= 0 (got " + std::to_string(delta_m) + ")";
  }
  if (taus.empty()) return "VsdOptions.taus is empty";
  for (size_t i = 0; i < taus.size(); ++i) {
    if (!std::isfinite(taus[i]) || taus[i] <= 0.0) {
      return "VsdOptions.taus[" + std::to_string(i) + "] must be finite and > 0 (got " +
             std::to_string(taus[i]) + ")";
    }
  }
  return "";
}

cv::Mat DepthToDistance(const cv::Mat& depth_m, const Camera& camera) {
  if (depth_m.type() != CV_32FC1) {
    G6D_THROW("DepthToDistance: depth_m must be CV_32FC1 (metres), got OpenCV type "
              << depth_m.type());
  }
  CheckFocal(camera, "DepthToDistance");
  const RayLength ray(camera);
  cv::Mat distance(depth_m.size(), CV_32FC1);
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* depth_row = depth_m.ptr<float>(v);
    float* distance_row = distance.ptr<float>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      distance_row[u] = static_cast<float>(depth_row[u] * ray.Factor(u, v));
    }
  }
  return distance;
}

cv::Mat EstimateVisibilityMaskGt(const cv::Mat& test_distance_m, const cv::Mat& gt_distance_m,
                                 double delta_m) {
  const char* kFunction = "EstimateVisibilityMaskGt";
  CheckDepthImage(test_distance_m, "test_distance_m", test_distance_m.size(), kFunction);
  CheckDepthImage(gt_distance_m, "gt_distance_m", test_distance_m.size(), kFunction);
  cv::Mat visible(test_distance_m.size(), CV_8UC1);
  for (int v = 0; v < visible.rows; ++v) {
    const float* test = test_distance_m.ptr<float>(v);
    const float* gt = gt_distance_m.ptr<float>(v);
    uint8_t* out = visible.ptr<uint8_t>(v);
    for (int u = 0; u < visible.cols; ++u) out[u] = IsVisible(gt[u], test[u], delta_m) ? 255 : 0;
  }
  return visible;
}

cv::Mat EstimateVisibilityMaskEstimate(const cv::Mat& test_distance_m,
                                       const cv::Mat& estimate_distance_m, const cv::Mat& visib_gt,
                                       double delta_m) {
  const char* kFunction = "EstimateVisibilityMaskEstimate";
  CheckDepthImage(test_distance_m, "test_distance_m", test_distance_m.size(), kFunction);
  CheckDepthImage(estimate_distance_m, "estimate_distance_m", test_distance_m.size(), kFunction);
  if (visib_gt.type() != CV_8UC1 || visib_gt.size() != test_distance_m.size()) {
    G6D_THROW(kFunction << ": visib_gt must be CV_8UC1 of the test image size");
  }
  cv::Mat visible(test_distance_m.size(), CV_8UC1);
  for (int v = 0; v < visible.rows; ++v) {
    const float* test = test_distance_m.ptr<float>(v);
    const float* estimate = estimate_distance_m.ptr<float>(v);
    const uint8_t* gt = visib_gt.ptr<uint8_t>(v);
    uint8_t* out = visible.ptr<uint8_t>(v);
    for (int u = 0; u < visible.cols; ++u) {
      const bool own = IsVisible(estimate[u], test[u], delta_m);
      out[u] = (own || (gt[u] != 0 && estimate[u] > 0.0f)) ? 255 : 0;
    }
  }
  return visible;
}

std::vector<double> ComputeVsdFromDepth(const cv::Mat& estimate_depth_m, const cv::Mat& gt_depth_m,
                                        const cv::Mat& test_depth_m, const Camera& camera,
                                        double diameter_m, const VsdOptions& options) {
  const char* kFunction = "ComputeVsdFromDepth";
  const std::string problem = options.Check();
  if (!problem.empty()) G6D_THROW(kFunction << ": " << problem);
  if (!(diameter_m > 0.0) || !std::isfinite(diameter_m)) {
    G6D_THROW(kFunction << ": diameter_m must be finite and > 0 (got " << diameter_m << ")");
  }
  CheckFocal(camera, kFunction);
  const cv::Size size = test_depth_m.size();
  CheckDepthImage(test_depth_m, "test_depth_m", size, kFunction);
  CheckDepthImage(estimate_depth_m, "estimate_depth_m", size, kFunction);
  CheckDepthImage(gt_depth_m, "gt_depth_m", size, kFunction);

  // One pass over the image doing what pose_error.vsd does with whole-image arrays:
  // distance images, V_gt, V_est, their union and intersection, and the pixel distances
  // on the intersection. Pixels where neither model has a surface are in neither mask.
  const RayLength ray(camera);
  const double normalizer = options.normalized_by_diameter ? diameter_m : 1.0;
  long union_count = 0;
  long intersection_count = 0;
  std::vector<double> distances;  // |D_gt - D_est| / normalizer on V_gt ∩ V_est
  for (int v = 0; v < size.height; ++v) {
    const float* estimate_row = estimate_depth_m.ptr<float>(v);
    const float* gt_row = gt_depth_m.ptr<float>(v);
    const float* test_row = test_depth_m.ptr<float>(v);
    for (int u = 0; u < size.width; ++u) {
      if (!(estimate_row[u] > 0.0f) && !(gt_row[u] > 0.0f)) continue;
      const double factor = ray.Factor(u, v);
      const double estimate = estimate_row[u] * factor;
      const double gt = gt_row[u] * factor;
      const double test = test_row[u] * factor;
      const bool visible_gt = IsVisible(gt, test, options.delta_m);
      const bool visible_estimate =
          IsVisible(estimate, test, options.delta_m) || (visible_gt && estimate > 0.0);
      if (visible_gt || visible_estimate) ++union_count;
      if (visible_gt && visible_estimate) {
        ++intersection_count;
        distances.push_back(std::abs(gt - estimate) / normalizer);
      }
    }
  }

  std::vector<double> errors(options.taus.size(), 1.0);
  if (union_count == 0) return errors;
  const long complement_count = union_count - intersection_count;
  for (size_t k = 0; k < options.taus.size(); ++k) {
    // "step" cost: a pixel of the intersection costs 1 when its distance reaches tau.
    long cost = 0;
    for (double distance : distances) cost += distance >= options.taus[k] ? 1 : 0;
    errors[k] = static_cast<double>(cost + complement_count) / static_cast<double>(union_count);
  }
  return errors;
}

std::vector<double> ComputeVsd(const Eigen::Isometry3d& estimate_cam_from_object,
                               const Eigen::Isometry3d& gt_cam_from_object,
                               const cv::Mat& test_depth_m, const Camera& camera, const Mesh& mesh,
                               double diameter_m, const VsdOptions& options) {
  const std::string camera_problem = camera.Check();
  if (!camera_problem.empty()) G6D_THROW("ComputeVsd: " << camera_problem);
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  RasterImage estimate, gt;
  Rasterize(mesh, camera, estimate_cam_from_object, raster_options, &estimate);
  Rasterize(mesh, camera, gt_cam_from_object, raster_options, &gt);
  return ComputeVsdFromDepth(estimate.depth, gt.depth, test_depth_m, camera, diameter_m, options);
}

bool SphereProjectionsOverlap(double radius_m, const Eigen::Vector3d& centre1_in_cam,
                              const Eigen::Vector3d& centre2_in_cam) {
  if (centre1_in_cam.z() == 0.0 || centre2_in_cam.z() == 0.0) return false;
  const Eigen::Vector2d projection1 = centre1_in_cam.head<2>() / centre1_in_cam.z();
  const Eigen::Vector2d projection2 = centre2_in_cam.head<2>() / centre2_in_cam.z();
  const double threshold = radius_m * (1.0 / centre1_in_cam.z() + 1.0 / centre2_in_cam.z());
  return (projection1 - projection2).norm() < threshold;
}

}  // namespace g6d
