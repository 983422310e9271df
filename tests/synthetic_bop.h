#pragma once
/// @file synthetic_bop.h
/// A tiny BOP dataset written by the tests themselves (for machines without ../shared):
/// two vertex-coloured boxes as PLY meshes in millimetres, a few RGB-D images rendered with
/// the project's OpenGL renderer, visible masks, GT, cameras and BOP'19 targets. Fixed
/// seeds; everything the replay tools read is there, nothing more.

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/se3.h"
#include "mesh/mesh.h"
#include "render/gl_renderer.h"
#include "test_meshes.h"

namespace g6d::test {

/// Options of WriteSyntheticBopDataset().
struct SyntheticBopOptions {
  int images = 3;            ///< images 0 .. images-1 of scene `scene_id`
  int scene_id = 1;          ///< the one scene folder
  double depth_scale = 0.5;  ///< BOP depth_scale, mm per depth PNG unit (not 1 on purpose)
  uint64_t seed = 11;        ///< poses and colours
};

/// What was written (for checks).
struct SyntheticBop {
  std::string root;
  Camera camera;
  std::vector<int> obj_ids;  ///< objects 1 and 2
  /// Per image, per GT index: the pose rendered.
  std::vector<std::vector<Eigen::Isometry3d>> cam_from_object;
};

/// Writes the dataset under `root` (created; existing files overwritten):
///   models/obj_000001.ply, obj_000002.ply, models_info.json
///   test/<scene>/rgb/, depth/ (16-bit, units of depth_scale mm), mask_visib/,
///   scene_gt.json, scene_camera.json
///   test_targets_bop19.json: both objects of image 0, object 2 of the last image, nothing
///   of the images between (so a converter must skip them).
/// Each image shows object 1 on the left and object 2 on the right at 0.45 .. 0.6 m, the
/// nearer one occluding where they overlap; mask_visib holds each object's nearest pixels.
inline SyntheticBop WriteSyntheticBopDataset(const std::string& root,
                                             const SyntheticBopOptions& options) {
  namespace fs = std::filesystem;
  using Json = nlohmann::json;
  SyntheticBop dataset;
  dataset.root = root;
  dataset.camera = Camera{572.4, 573.6, 325.3, 242.0, 640, 480};
  dataset.obj_ids = {1, 2};
  const fs::path models = fs::path(root) / "models";
  char scene_name[16];
  std::snprintf(scene_name, sizeof(scene_name), "%06d", options.scene_id);
  const fs::path scene = fs::path(root) / "test" / scene_name;
  for (const char* folder : {"rgb", "depth", "mask_visib"}) fs::create_directories(scene / folder);
  fs::create_directories(models);

  const Eigen::Vector3d halves[2] = {{45.0, 32.0, 22.0}, {35.0, 28.0, 40.0}};
  std::vector<Mesh> meshes;
  Json models_info;
  for (int k = 0; k < 2; ++k) {
    const std::string path = (models / ("obj_00000" + std::to_string(k + 1) + ".ply")).string();
    WriteColouredBoxPly(path, halves[k], 8, options.seed + 100 * k);
    meshes.push_back(LoadMesh(path, Units::kMillimetres));
    models_info[std::to_string(k + 1)] = {{"diameter", 2.0 * halves[k].norm()},
                                          {"min_x", -halves[k].x()},
                                          {"min_y", -halves[k].y()},
                                          {"min_z", -halves[k].z()},
                                          {"size_x", 2 * halves[k].x()},
                                          {"size_y", 2 * halves[k].y()},
                                          {"size_z", 2 * halves[k].z()}};
  }
  std::ofstream(models / "models_info.json") << models_info.dump(1);

  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Json scene_gt, scene_camera, targets = Json::array();
  const Camera& camera = dataset.camera;
  for (int im_id = 0; im_id < options.images; ++im_id) {
    std::vector<GlImage> renders;
    std::vector<Eigen::Isometry3d> poses;
    for (int k = 0; k < 2; ++k) {
      const Eigen::Quaterniond rotation(uniform(rng) - 0.5, uniform(rng) - 0.5, uniform(rng) - 0.5,
                                        uniform(rng) - 0.5);
      const double z = 0.45 + 0.15 * uniform(rng);
      const Eigen::Vector2d pixel(camera.width * (k == 0 ? 0.33 : 0.67),
                                  camera.height * (0.4 + 0.2 * uniform(rng)));
      poses.push_back(
          MakePose(rotation.normalized().toRotationMatrix(), camera.Backproject(pixel, z)));
      GlRenderer renderer(meshes[k]);
      renders.push_back(renderer.Render(camera, poses.back()));
    }
    cv::Mat rgb(camera.height, camera.width, CV_8UC3, cv::Scalar(90, 100, 110));
    cv::Mat depth = cv::Mat::zeros(camera.height, camera.width, CV_16UC1);
    cv::Mat visible[2] = {cv::Mat::zeros(camera.height, camera.width, CV_8UC1),
                          cv::Mat::zeros(camera.height, camera.width, CV_8UC1)};
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        int nearest = -1;
        float nearest_z = std::numeric_limits<float>::infinity();
        for (int k = 0; k < 2; ++k) {
          const float z = renders[k].depth.at<float>(v, u);
          if (renders[k].mask.at<uint8_t>(v, u) != 0 && z > 0.0f && z < nearest_z) {
            nearest = k;
            nearest_z = z;
          }
        }
        if (nearest < 0) continue;
        rgb.at<cv::Vec3b>(v, u) = renders[nearest].rgb.at<cv::Vec3b>(v, u);
        depth.at<uint16_t>(v, u) =
            static_cast<uint16_t>(std::lround(nearest_z * 1000.0 / options.depth_scale));
        visible[nearest].at<uint8_t>(v, u) = 255;
      }
    }
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.png", im_id);
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    cv::imwrite((scene / "rgb" / name).string(), bgr);
    cv::imwrite((scene / "depth" / name).string(), depth);
    Json gt_list = Json::array();
    for (int k = 0; k < 2; ++k) {
      std::snprintf(name, sizeof(name), "%06d_%06d.png", im_id, k);
      cv::imwrite((scene / "mask_visib" / name).string(), visible[k]);
      const Eigen::Matrix3d r = poses[k].linear();
      const Eigen::Vector3d t_mm = poses[k].translation() * 1000.0;
      gt_list.push_back(
          {{"cam_R_m2c",
            {r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1), r(2, 2)}},
           {"cam_t_m2c", {t_mm.x(), t_mm.y(), t_mm.z()}},
           {"obj_id", k + 1}});
    }
    scene_gt[std::to_string(im_id)] = gt_list;
    scene_camera[std::to_string(im_id)] = {
        {"cam_K", {camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0}},
        {"depth_scale", options.depth_scale}};
    dataset.cam_from_object.push_back(poses);
    if (im_id == 0) {
      for (int k = 0; k < 2; ++k) {
        targets.push_back({{"scene_id", options.scene_id},
                           {"im_id", im_id},
                           {"obj_id", k + 1},
                           {"inst_count", 1}});
      }
    } else if (im_id == options.images - 1) {
      targets.push_back(
          {{"scene_id", options.scene_id}, {"im_id", im_id}, {"obj_id", 2}, {"inst_count", 1}});
    }
  }
  std::ofstream(scene / "scene_gt.json") << scene_gt.dump(1);
  std::ofstream(scene / "scene_camera.json") << scene_camera.dump(1);
  std::ofstream(fs::path(root) / "test_targets_bop19.json") << targets.dump(1);
  return dataset;
}

}  // namespace g6d::test
