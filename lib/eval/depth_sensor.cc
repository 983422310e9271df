#include "eval/depth_sensor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/hash.h"

namespace g6d {

namespace {

// Uniform in [0, 1) from the generator's raw 64 bits (the same with every standard library,
// unlike std::uniform_real_distribution).
double Uniform01(std::mt19937_64* rng) { return static_cast<double>((*rng)() >> 11) * 0x1.0p-53; }

// A standard normal by Box-Muller, from Uniform01 (repeatable across standard libraries).
double Normal01(std::mt19937_64* rng) {
  const double u1 = 1.0 - Uniform01(rng);  // (0, 1]
  const double u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace

std::string DepthSensorModel::Check() const {
  std::ostringstream out;
  if (!(baseline_m > 0.0 && std::isfinite(baseline_m))) out << "DepthSensorModel.baseline_m must be > 0 (got " << baseline_m << ")";
  else if (!(disparity_step_px > 0.0 && std::isfinite(disparity_step_px))) out << "DepthSensorModel.disparity_step_px must be > 0 (got " << disparity_step_px << ")";
  else if (!(noise_at_1m_m >= 0.0 && std::isfinite(noise_at_1m_m))) out << "DepthSensorModel.noise_at_1m_m must be >= 0 (got " << noise_at_1m_m << ")";
  else if (!(max_incidence_deg > 0.0 && max_incidence_deg <= 90.0)) out << "DepthSensorModel.max_incidence_deg must be in (0, 90] (got " << max_incidence_deg << ")";
  else if (!(edge_step_m >= 0.0 && std::isfinite(edge_step_m))) out << "DepthSensorModel.edge_step_m must be >= 0 (got " << edge_step_m << ")";
  else if (!(edge_relative >= 0.0 && std::isfinite(edge_relative))) out << "DepthSensorModel.edge_relative must be >= 0 (got " << edge_relative << ")";
  else if (!(edge_drop >= 0.0 && edge_drop <= 1.0)) out << "DepthSensorModel.edge_drop must be in [0, 1] (got " << edge_drop << ")";
  else if (!(dark_drop >= 0.0 && dark_drop <= 1.0)) out << "DepthSensorModel.dark_drop must be in [0, 1] (got " << dark_drop << ")";
  else if (!(bright_drop >= 0.0 && bright_drop <= 1.0)) out << "DepthSensorModel.bright_drop must be in [0, 1] (got " << bright_drop << ")";
  else if (dark_grey < 0 || dark_grey > 256) out << "DepthSensorModel.dark_grey must be in [0, 256] (got " << dark_grey << ")";
  else if (bright_grey < 0 || bright_grey > 256) out << "DepthSensorModel.bright_grey must be in [0, 256] (got " << bright_grey << ")";
  else if (blob_px < 1) out << "DepthSensorModel.blob_px must be >= 1 (got " << blob_px << ")";
  else if (!(dropout >= 0.0 && dropout <= 1.0)) out << "DepthSensorModel.dropout must be in [0, 1] (got " << dropout << ")";
  return out.str();
}

DepthSensorModel WithoutSensorEffects(DepthSensorModel model, const std::string& names) {
  std::stringstream list(names);
  std::string name;
  while (std::getline(list, name, ',')) {
    if (name.empty()) continue;
    if (name == "shadows") model.shadows = false;
    else if (name == "grazing") model.max_incidence_deg = 90.0;
    else if (name == "edges") model.edges = false;
    else if (name == "noise") model.noise_at_1m_m = 0.0;
    else if (name == "dark") model.dark_drop = 0.0;
    else if (name == "bright") model.bright_drop = 0.0;
    else if (name == "speckle") model.dropout = 0.0;
    else G6D_THROW("unknown depth sensor effect '" << name << "' (valid: shadows, grazing, edges, noise, dark, bright, speckle)");
  }
  return model;
}

bool ParseDepthSensorName(const std::string& name) {
  if (name == "none") return false;
  if (name == "structured-light") return true;
  G6D_THROW("unknown depth sensor '" << name << "' (valid: none, structured-light)");
}

cv::Mat SimulateDepthSensor(const cv::Mat& depth_m, const cv::Mat& rgb, const Camera& camera,
                            const DepthSensorModel& model, uint64_t frame_key) {
  if (const std::string bad = model.Check(); !bad.empty()) G6D_THROW("SimulateDepthSensor: " << bad);
  if (depth_m.type() != CV_32F || depth_m.cols != camera.width || depth_m.rows != camera.height) {
    G6D_THROW("SimulateDepthSensor: the depth must be CV_32F of the camera's size " << camera.width << "x" << camera.height
                                                                                     << " (got " << depth_m.cols << "x"
                                                                                     << depth_m.rows << ", type " << depth_m.type() << ")");
  }
  if (!rgb.empty() && (rgb.type() != CV_8UC3 || rgb.size() != depth_m.size())) {
    G6D_THROW("SimulateDepthSensor: the colour image must be empty or CV_8UC3 of the depth's size (got "
              << rgb.cols << "x" << rgb.rows << ", type " << rgb.type() << ")");
  }
  const int width = depth_m.cols, height = depth_m.rows;
  const double focal_baseline = camera.fx * model.baseline_m;  // disparity (px) = this / z
  cv::Mat out = depth_m.clone();
  auto z_at = [&](int u, int v) { return depth_m.at<float>(v, u); };

  // 1. Projector shadows, row by row from the right: a point whose projector column
  // u - d(u) is not left of every projector column to its right is behind a closer surface.
  for (int v = 0; v < height && model.shadows; ++v) {
    double leftmost = std::numeric_limits<double>::infinity();
    for (int u = width - 1; u >= 0; --u) {
      const float z = z_at(u, v);
      if (!(z > 0.0f)) continue;
      const double projector_u = u - focal_baseline / z;
      if (projector_u >= leftmost) out.at<float>(v, u) = 0.0f;
      leftmost = std::min(leftmost, projector_u);
    }
  }

  // 2. Grazing surfaces: the normal from the 3D neighbours against the ray.
  const double min_cos = std::cos(model.max_incidence_deg * M_PI / 180.0);
  auto point = [&](int u, int v) {
    const double z = z_at(u, v);
    return Eigen::Vector3d((u - camera.cx) * z / camera.fx, (v - camera.cy) * z / camera.fy, z);
  };
  auto edge_limit = [&](double z) { return std::max(model.edge_step_m, model.edge_relative * z); };
  cv::Mat edge = cv::Mat::zeros(height, width, CV_8U);
  cv::Mat far_side(height, width, CV_32F, cv::Scalar(0.0f));
  for (int v = 1; v + 1 < height; ++v) {
    for (int u = 1; u + 1 < width; ++u) {
      const float z = z_at(u, v);
      if (!(z > 0.0f)) continue;
      // 3. (marked here) a depth step to a neighbour, or to no depth at all.
      float farthest = 0.0f;
      bool step = false;
      for (const auto& [du, dv] : {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
        const float n = z_at(u + du, v + dv);
        if (!(n > 0.0f) || std::abs(n - z) > edge_limit(z)) step = true;
        if (n > farthest) farthest = n;
      }
      if (step) {
        edge.at<uint8_t>(v, u) = 255;
        far_side.at<float>(v, u) = farthest;
        continue;  // no reliable normal across a step
      }
      const Eigen::Vector3d du = point(u + 1, v) - point(u - 1, v), dv = point(u, v + 1) - point(u, v - 1);
      const Eigen::Vector3d normal = du.cross(dv);
      const Eigen::Vector3d ray = point(u, v);
      if (normal.norm() > 0.0 && std::abs(normal.dot(ray)) < min_cos * normal.norm() * ray.norm()) {
        out.at<float>(v, u) = 0.0f;
      }
    }
  }

  std::mt19937_64 rng(SplitMix64(SplitMix64(model.seed) ^ frame_key));
  // 5. (the field) dark and shining pixels lose their depth where a smooth random field,
  // uniform in [0, 1) over the image (ranks of coarse noise upsampled), is below the rate.
  cv::Mat grey;
  cv::Mat field;
  if (!rgb.empty()) {
    cv::cvtColor(rgb, grey, cv::COLOR_BGR2GRAY);  // symmetric in R and B up to their weights
    const int cells_x = width / model.blob_px + 2, cells_y = height / model.blob_px + 2;
    cv::Mat coarse(cells_y, cells_x, CV_32F);
    for (int v = 0; v < cells_y; ++v) {
      for (int u = 0; u < cells_x; ++u) coarse.at<float>(v, u) = static_cast<float>(Uniform01(&rng));
    }
    cv::Mat fine;
    cv::resize(coarse, fine, cv::Size(cells_x * model.blob_px, cells_y * model.blob_px), 0, 0, cv::INTER_LINEAR);
    fine = fine(cv::Rect(0, 0, width, height));
    std::vector<std::pair<float, int>> order;
    order.reserve(static_cast<size_t>(width) * height);
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) order.emplace_back(fine.at<float>(v, u), v * width + u);
    }
    std::sort(order.begin(), order.end());
    field.create(height, width, CV_32F);
    for (size_t k = 0; k < order.size(); ++k) {
      field.at<float>(order[k].second / width, order[k].second % width) = static_cast<float>(k) / order.size();
    }
  }
  const double disparity_sigma = model.noise_at_1m_m * focal_baseline;  // sigma_z = this * z^2 / (f b)
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      float& z = out.at<float>(v, u);
      if (!(z > 0.0f)) continue;
      if (model.edges && edge.at<uint8_t>(v, u)) {
        if (Uniform01(&rng) < model.edge_drop) {
          z = 0.0f;
          continue;
        }
        const float far = far_side.at<float>(v, u);
        if (far > z) z = static_cast<float>(z + Uniform01(&rng) * (far - z));  // a flying pixel
      }
      // 4. Noise and quantisation in disparity.
      double disparity = focal_baseline / z + disparity_sigma * Normal01(&rng);
      disparity = std::round(disparity / model.disparity_step_px) * model.disparity_step_px;
      z = disparity > 0.0 ? static_cast<float>(focal_baseline / disparity) : 0.0f;
      // 5. Dark and shining surfaces, in blobs.
      if (!grey.empty()) {
        const int g = grey.at<uint8_t>(v, u);
        const double rate = g < model.dark_grey ? model.dark_drop : g >= model.bright_grey ? model.bright_drop : 0.0;
        if (field.at<float>(v, u) < rate) z = 0.0f;
      }
      // 6. Speckle.
      if (model.dropout > 0.0 && Uniform01(&rng) < model.dropout) z = 0.0f;
    }
  }
  return out;
}

}  // namespace g6d
