#pragma once
/// @file bop_eval_scene.h
/// A synthetic BOP dataset on disk for the evaluation tests: meshes written as PLY (mm),
/// models_info.json, one scene whose depth images are rendered from the GT poses with the
/// g6d rasterizer (so the test depth is exact), scene_gt(_info).json and a targets file.

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "core/camera.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "mesh/mesh.h"
#include "render/raster.h"
#include "test_util.h"

namespace g6d::test {

/// Closed cylinder of `radius_m` about the z axis, z in [-half_height_m, half_height_m],
/// `facets` side quads, counter-clockwise faces seen from outside. A rotation about z by a
/// multiple of 2*pi / facets maps it onto itself.
inline Mesh MakeCylinder(double radius_m, double half_height_m, int facets) {
  Mesh mesh;
  for (int ring = 0; ring < 2; ++ring) {
    const float z = static_cast<float>(ring == 0 ? -half_height_m : half_height_m);
    for (int i = 0; i < facets; ++i) {
      const double angle = 2.0 * M_PI * i / facets;
      mesh.vertices.emplace_back(static_cast<float>(radius_m * std::cos(angle)),
                                 static_cast<float>(radius_m * std::sin(angle)), z);
    }
  }
  const int bottom_centre = static_cast<int>(mesh.vertices.size());
  mesh.vertices.emplace_back(0.0f, 0.0f, static_cast<float>(-half_height_m));
  const int top_centre = bottom_centre + 1;
  mesh.vertices.emplace_back(0.0f, 0.0f, static_cast<float>(half_height_m));
  for (int i = 0; i < facets; ++i) {
    const int j = (i + 1) % facets;
    mesh.faces.emplace_back(i, j, facets + j);
    mesh.faces.emplace_back(i, facets + j, facets + i);
    mesh.faces.emplace_back(bottom_centre, j, i);
    mesh.faces.emplace_back(top_centre, facets + i, facets + j);
  }
  return mesh;
}

/// A pose from a rotation and a translation in metres.
inline Eigen::Isometry3d MakePose(const Eigen::Matrix3d& rotation,
                                  const Eigen::Vector3d& translation_m) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = translation_m;
  return pose;
}

/// Writes `mesh` (metres) as an ASCII PLY in millimetres.
inline void WritePlyMillimetres(const std::string& path, const Mesh& mesh) {
  std::ofstream out(path);
  out << "ply\nformat ascii 1.0\nelement vertex " << mesh.vertices.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face "
      << mesh.faces.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  out.precision(9);
  for (const Eigen::Vector3f& v : mesh.vertices) {
    out << v.x() * 1000.0 << " " << v.y() * 1000.0 << " " << v.z() * 1000.0 << "\n";
  }
  for (const Eigen::Vector3i& f : mesh.faces)
    out << "3 " << f[0] << " " << f[1] << " " << f[2] << "\n";
}

/// One object of the synthetic dataset.
struct SyntheticObject {
  int obj_id = 0;
  Mesh mesh;                           ///< metres
  double diameter_m = 0.0;             ///< written to models_info.json
  bool continuous_z_symmetry = false;  ///< writes symmetries_continuous: axis z, offset 0
};

/// One GT instance of the synthetic dataset.
struct SyntheticInstance {
  int obj_id = 0;
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();
  double visib_fract = 1.0;  ///< written to scene_gt_info.json
};

/// Writes the dataset: camera 640x480, fx = fy = 500, cx = 320, cy = 240; scene 1 with
/// one image per entry of `images` (im_id = key); the depth image of each is the nearest
/// surface of its GT instances (mm, depth_scale 1, 0 = background), and the targets list
/// asks for every GT instance (inst_count = number of instances of the object).
/// Returns the dataset root.
inline std::string WriteSyntheticBopDataset(
    const std::string& name, const std::vector<SyntheticObject>& objects,
    const std::map<int, std::vector<SyntheticInstance>>& images) {
  namespace fs = std::filesystem;
  using Json = nlohmann::json;
  const std::string root = TempDir(name);
  const Camera camera{500.0, 500.0, 320.0, 240.0, 640, 480};
  fs::create_directories(fs::path(root) / "models");
  const fs::path scene = fs::path(root) / "test" / "000001";
  fs::create_directories(scene / "depth");

  Json camera_json = {{"fx", camera.fx},   {"fy", camera.fy},       {"cx", camera.cx},
                      {"cy", camera.cy},   {"width", camera.width}, {"height", camera.height},
                      {"depth_scale", 1.0}};
  std::ofstream(fs::path(root) / "camera.json") << camera_json.dump(1);

  Json info = Json::object();
  std::map<int, const SyntheticObject*> by_id;
  for (const SyntheticObject& object : objects) {
    char file[32];
    std::snprintf(file, sizeof(file), "obj_%06d.ply", object.obj_id);
    WritePlyMillimetres((fs::path(root) / "models" / file).string(), object.mesh);
    Json entry = {{"diameter", object.diameter_m * 1000.0}};
    if (object.continuous_z_symmetry) {
      entry["symmetries_continuous"] = {{{"axis", {0, 0, 1}}, {"offset", {0, 0, 0}}}};
    }
    info[std::to_string(object.obj_id)] = entry;
    by_id[object.obj_id] = &object;
  }
  std::ofstream(fs::path(root) / "models" / "models_info.json") << info.dump(1);

  Json scene_camera = Json::object(), scene_gt = Json::object(), scene_gt_info = Json::object();
  Json targets = Json::array();
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  for (const auto& [im_id, instances] : images) {
    const std::string key = std::to_string(im_id);
    scene_camera[key] = {{"cam_K", {camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1}},
                         {"depth_scale", 1.0}};
    Json gt_list = Json::array(), info_list = Json::array();
    cv::Mat depth_m(camera.height, camera.width, CV_32F, cv::Scalar(0));
    std::map<int, int> counts;
    for (const SyntheticInstance& instance : instances) {
      const Eigen::Matrix3d& r = instance.cam_from_object.linear();
      const Eigen::Vector3d t_mm = instance.cam_from_object.translation() * 1000.0;
      gt_list.push_back(
          {{"obj_id", instance.obj_id},
           {"cam_R_m2c",
            {r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1), r(2, 2)}},
           {"cam_t_m2c", {t_mm.x(), t_mm.y(), t_mm.z()}}});
      info_list.push_back({{"visib_fract", instance.visib_fract}});
      ++counts[instance.obj_id];
      RasterImage render;
      Rasterize(by_id.at(instance.obj_id)->mesh, camera, instance.cam_from_object, raster_options,
                &render);
      for (int v = 0; v < camera.height; ++v) {
        for (int u = 0; u < camera.width; ++u) {
          const float z = render.depth.at<float>(v, u);
          float& scene_z = depth_m.at<float>(v, u);
          if (z > 0.0f && (scene_z == 0.0f || z < scene_z)) scene_z = z;
        }
      }
    }
    scene_gt[key] = gt_list;
    scene_gt_info[key] = info_list;
    for (const auto& [obj_id, count] : counts) {
      targets.push_back(
          {{"scene_id", 1}, {"im_id", im_id}, {"obj_id", obj_id}, {"inst_count", count}});
    }
    cv::Mat depth_mm;
    depth_m.convertTo(depth_mm, CV_16U, 1000.0);
    char file[32];
    std::snprintf(file, sizeof(file), "%06d.png", im_id);
    cv::imwrite((scene / "depth" / file).string(), depth_mm);
  }
  std::ofstream(scene / "scene_camera.json") << scene_camera.dump(1);
  std::ofstream(scene / "scene_gt.json") << scene_gt.dump(1);
  std::ofstream(scene / "scene_gt_info.json") << scene_gt_info.dump(1);
  std::ofstream(fs::path(root) / "test_targets_bop19.json") << targets.dump(1);
  return root;
}

/// One estimate of scene 1.
inline BopEstimate MakeEstimate(int im_id, int obj_id, double score,
                                const Eigen::Isometry3d& cam_from_object) {
  BopEstimate estimate;
  estimate.scene_id = 1;
  estimate.im_id = im_id;
  estimate.obj_id = obj_id;
  estimate.score = score;
  estimate.cam_from_object = cam_from_object;
  return estimate;
}

/// Every GT instance of `dataset` as an estimate with score 1.
inline std::vector<BopEstimate> GroundTruthEstimates(const BopDataset& dataset) {
  std::vector<BopEstimate> estimates;
  for (int scene_id : dataset.scene_ids) {
    const BopScene scene = LoadBopScene(dataset.root, scene_id, dataset.split);
    for (const BopFrame& frame : scene.frames) {
      for (const BopGtInstance& gt : frame.gt) {
        BopEstimate estimate;
        estimate.scene_id = scene_id;
        estimate.im_id = frame.im_id;
        estimate.obj_id = gt.obj_id;
        estimate.score = 1.0;
        estimate.cam_from_object = gt.cam_from_object;
        estimates.push_back(estimate);
      }
    }
  }
  return estimates;
}

}  // namespace g6d::test
