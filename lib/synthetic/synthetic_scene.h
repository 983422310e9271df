#pragma once
/// @file synthetic_scene.h
/// A synthetic scene generator for tests and benchmarks (like COLMAP's SynthesizeDataset): a
/// procedurally textured box, random poses in front of a camera, RGB-D rendered with the
/// project's own renderers, depth noise and an optional occluder. Fixed seeds only.

#include <cmath>
#include <random>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera.h"
#include "core/se3.h"
#include "mesh/mesh.h"
#include "render/gl_renderer.h"
#include "render/raster.h"

namespace g6d::synthetic {

/// A box of size (sx, sy, sz) metres centred at the origin, one texture tile per face,
/// the texture made of random coloured shapes (plenty of ORB corners).
inline Mesh MakeTexturedBox(double sx, double sy, double sz, uint64_t seed) {
  Mesh mesh;
  const int tile = 256;
  mesh.texture = cv::Mat(tile * 2, tile * 3, CV_8UC3, cv::Scalar(200, 200, 200));
  cv::RNG rng(seed);
  for (int i = 0; i < 360; ++i) {
    const cv::Scalar color(rng.uniform(0, 256), rng.uniform(0, 256), rng.uniform(0, 256));
    const cv::Point centre(rng.uniform(0, mesh.texture.cols), rng.uniform(0, mesh.texture.rows));
    const int size = rng.uniform(4, 28);
    if (i % 3 == 0) {
      cv::circle(mesh.texture, centre, size, color, cv::FILLED, cv::LINE_AA);
    } else if (i % 3 == 1) {
      cv::rectangle(mesh.texture, centre, centre + cv::Point(size, size * 2 / 3), color, cv::FILLED);
    } else {
      cv::line(mesh.texture, centre, centre + cv::Point(size * 2, -size), color, 3, cv::LINE_AA);
    }
  }
  const Eigen::Vector3f half(static_cast<float>(sx / 2), static_cast<float>(sy / 2), static_cast<float>(sz / 2));
  // Each face: outward normal axis and sign; corners counter-clockwise seen from outside.
  const int axes[6] = {0, 0, 1, 1, 2, 2};
  const float signs[6] = {1, -1, 1, -1, 1, -1};
  for (int f = 0; f < 6; ++f) {
    const int a = axes[f];
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    Eigen::Vector3f corners[4];
    const float su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
    for (int k = 0; k < 4; ++k) {
      Eigen::Vector3f p;
      p[a] = signs[f] * half[a];
      p[b] = su[k] * half[b] * signs[f];
      p[c] = sv[k] * half[c];
      corners[k] = p;
    }
    const int base = static_cast<int>(mesh.vertices.size());
    const float u0 = static_cast<float>(f % 3) / 3.0f, v0 = static_cast<float>(f / 3) / 2.0f;
    const float uv_u[4] = {0, 1, 1, 0}, uv_v[4] = {0, 0, 1, 1};
    for (int k = 0; k < 4; ++k) {
      mesh.vertices.push_back(corners[k]);
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[a] = signs[f];
      mesh.normals.push_back(normal);
      // Texture v runs up (OBJ convention); tiles are laid out in a 3 x 2 atlas.
      mesh.uvs.emplace_back(u0 + uv_u[k] / 3.0f * 0.98f + 0.003f, 1.0f - (v0 + (1 - uv_v[k]) / 2.0f * 0.98f + 0.003f));
    }
    // Make the winding counter-clockwise as seen from outside (normal direction).
    const Eigen::Vector3f n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
    if (n[a] * signs[f] > 0) {
      mesh.faces.emplace_back(base, base + 1, base + 2);
      mesh.faces.emplace_back(base, base + 2, base + 3);
    } else {
      mesh.faces.emplace_back(base, base + 2, base + 1);
      mesh.faces.emplace_back(base, base + 3, base + 2);
    }
  }
  return mesh;
}

/// A random cam_from_object: object centre at distance [z_min, z_max] metres, within
/// the central part of the image, uniformly random rotation.
inline Eigen::Isometry3d RandomPose(const Camera& camera, double z_min, double z_max, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  // Uniform rotation from three uniforms (Shoemake).
  const double u1 = uniform(*rng), u2 = uniform(*rng), u3 = uniform(*rng);
  const Eigen::Quaterniond rotation(std::sqrt(u1) * std::cos(2 * M_PI * u3), std::sqrt(1 - u1) * std::sin(2 * M_PI * u2),
                                    std::sqrt(1 - u1) * std::cos(2 * M_PI * u2), std::sqrt(u1) * std::sin(2 * M_PI * u3));
  const double z = z_min + (z_max - z_min) * uniform(*rng);
  const double u = camera.width * (0.3 + 0.4 * uniform(*rng));
  const double v = camera.height * (0.3 + 0.4 * uniform(*rng));
  return MakePose(rotation.normalized().toRotationMatrix(), camera.Backproject({u, v}, z));
}

/// One rendered observation.
struct SyntheticView {
  Eigen::Isometry3d cam_from_object;
  cv::Mat rgb;    ///< CV_8UC3
  cv::Mat depth;  ///< CV_32F metres, noisy
  cv::Mat mask;   ///< CV_8U visible mask
};

/// Options of RenderSyntheticView().
struct SyntheticOptions {
  double depth_noise_m = 0.001;  ///< Gaussian depth noise sigma, metres
  double occlusion = 0.0;        ///< fraction of the mask box width covered by an occluder
  uint64_t seed = 1;
};

/// Renders mesh at pose with a grey background, noise and an occluding bar from the left.
inline SyntheticView RenderSyntheticView(GlRenderer* renderer, const Mesh& mesh, const Camera& camera,
                                         const Eigen::Isometry3d& pose, const SyntheticOptions& options) {
  SyntheticView view;
  view.cam_from_object = pose;
  const GlImage image = renderer->Render(camera, pose);
  view.rgb = cv::Mat(camera.height, camera.width, CV_8UC3, cv::Scalar(90, 100, 110));
  image.rgb.copyTo(view.rgb, image.mask);
  view.depth = image.depth.clone();
  view.mask = image.mask.clone();
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<float> noise(0.0f, static_cast<float>(options.depth_noise_m));
  for (int v = 0; v < view.depth.rows; ++v) {
    for (int u = 0; u < view.depth.cols; ++u) {
      float& z = view.depth.at<float>(v, u);
      if (z > 0.0f) z += noise(rng);
    }
  }
  if (options.occlusion > 0.0) {
    const cv::Rect box = cv::boundingRect(view.mask);
    const cv::Rect bar(box.x, box.y, static_cast<int>(box.width * options.occlusion), box.height);
    view.rgb(bar).setTo(cv::Scalar(30, 160, 60));
    view.mask(bar).setTo(0);
    cv::Mat occluder_depth = view.depth(bar);
    occluder_depth.setTo(static_cast<float>(pose.translation().z() - 0.1));  // 10 cm in front
  }
  return view;
}

}  // namespace g6d::synthetic
