// The embedded sample's files: the textured OBJ meshes, the BOP dataset (images, masks,
// ground truth, camera, targets) and the template caches. One of the four files of
// g6d_sample (sample_texture, sample_layout, sample_render, sample_writers).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/hash.h"
#include "core/timer.h"
#include "eval/bop.h"
#include "sample/sample_internal.h"
#include "sample/sample_scene.h"
#include "templates/cache.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using sample_internal::DerivedSeed;
using sample_internal::kFramePartBase;
using sample_internal::kObjectsPart;
using sample_internal::RenderFrameWith;
using sample_internal::RenderPlannedFrame;
using sample_internal::SampleRenderers;

// Objects count as occluded in the report below this visible fraction.
constexpr double kOccludedReportFraction = 0.98;
// BOP'19 targets: instances at least this visible.
constexpr double kBopTargetMinVisibFract = 0.1;

std::string ImageName(int im_id, const char* suffix = ".png") {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d%s", im_id, suffix);
  return name;
}

std::string MaskName(int im_id, int gt_idx) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d_%06d.png", im_id, gt_idx);
  return name;
}

void WriteImage(const fs::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image)) G6D_THROW("cannot write image '" << path.string() << "'");
}

void WriteJson(const fs::path& path, const Json& json) {
  std::ofstream out(path);
  out << json.dump(1) << "\n";
  out.close();
  if (!out) G6D_THROW("cannot write '" << path.string() << "'");
}

Json BoxJson(const cv::Rect& box) {
  if (box.area() == 0) return Json::array({-1, -1, -1, -1});
  return Json::array({box.x, box.y, box.width, box.height});
}

Json RotationJson(const Eigen::Matrix3d& r) {
  return Json::array(
      {r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1), r(2, 2)});
}

Json TranslationMmJson(const Eigen::Vector3d& t_m) {
  return Json::array({t_m.x() * 1000.0, t_m.y() * 1000.0, t_m.z() * 1000.0});
}
}  // namespace

void WriteTexturedObj(const Mesh& mesh, const std::string& obj_path) {
  if (!mesh.HasTexture())
    G6D_THROW("WriteTexturedObj: the mesh for '" << obj_path << "' has no texture");
  const fs::path path(obj_path);
  const std::string stem = path.stem().string();
  const fs::path mtl_path = path.parent_path() / (stem + ".mtl");
  const fs::path png_path = path.parent_path() / (stem + ".png");
  cv::Mat bgr;
  cv::cvtColor(mesh.texture, bgr, cv::COLOR_RGB2BGR);
  WriteImage(png_path, bgr);
  {
    std::ofstream mtl(mtl_path);
    mtl << "# g6d-make-sample: procedural print\nnewmtl print\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nd "
           "1\nillum 1\n"
        << "map_Kd " << png_path.filename().string() << "\n";
    mtl.close();
    if (!mtl) G6D_THROW("cannot write '" << mtl_path.string() << "'");
  }
  std::ofstream obj(path);
  obj << "# g6d-make-sample: procedurally textured object, units: metres\n"
      << "mtllib " << mtl_path.filename().string() << "\no " << stem << "\n";
  char line[160];
  for (const Eigen::Vector3f& v : mesh.vertices) {
    std::snprintf(line, sizeof(line), "v %.7f %.7f %.7f\n", v.x(), v.y(), v.z());
    obj << line;
  }
  for (const Eigen::Vector2f& uv : mesh.uvs) {
    std::snprintf(line, sizeof(line), "vt %.7f %.7f\n", uv.x(), uv.y());
    obj << line;
  }
  for (const Eigen::Vector3f& n : mesh.normals) {
    std::snprintf(line, sizeof(line), "vn %.6f %.6f %.6f\n", n.x(), n.y(), n.z());
    obj << line;
  }
  obj << "usemtl print\n";
  const bool has_normals = mesh.normals.size() == mesh.vertices.size();
  for (const Eigen::Vector3i& f : mesh.faces) {
    obj << "f";
    for (int k = 0; k < 3; ++k) {
      const int i = f[k] + 1;  // OBJ indices are 1-based
      obj << " " << i << "/" << i;
      if (has_normals) obj << "/" << i;
    }
    obj << "\n";
  }
  obj.close();
  if (!obj) G6D_THROW("cannot write '" << obj_path << "'");
}

SampleReport WriteSampleDataset(const SampleOptions& options, const std::string& root,
                                const SampleProgressCallback& progress) {
  if (const std::string bad = options.Check(); !bad.empty())
    G6D_THROW("bad sample option: " << bad);
  const Stopwatch watch;
  auto say = [&](const std::string& line) {
    if (progress) progress(line);
  };
  SampleReport report;
  const fs::path models = fs::path(root) / "models";
  const fs::path scene = fs::path(root) / "test" / "000001";
  // A stale scene from a run with more frames must not survive.
  fs::remove_all(scene);
  fs::remove_all(models);
  for (const char* folder : {"rgb", "depth", "mask", "mask_visib"})
    fs::create_directories(scene / folder);
  fs::create_directories(models);

  // 1. Objects: written, then read back, so that rendering uses exactly the files.
  const std::vector<SampleObject> generated = MakeSampleObjects(
      options.num_objects, DerivedSeed(options.seed, kObjectsPart), options.texture_px_per_mm);
  Json models_info = Json::object();
  for (const SampleObject& object : generated) {
    const fs::path obj_path = models / (object.name + ".obj");
    WriteTexturedObj(object.mesh, obj_path.string());
    SampleObject loaded = object;
    loaded.mesh = LoadMesh(obj_path.string(), Units::kMetres);
    const double diameter_m = ComputeDiameter(loaded.mesh);
    const Eigen::AlignedBox3d box = ComputeBoundingBox(loaded.mesh);
    models_info[std::to_string(object.obj_id)] = {
        {"diameter", diameter_m * 1000.0},      {"min_x", box.min().x() * 1000.0},
        {"min_y", box.min().y() * 1000.0},      {"min_z", box.min().z() * 1000.0},
        {"size_x", box.sizes().x() * 1000.0},   {"size_y", box.sizes().y() * 1000.0},
        {"size_z", box.sizes().z() * 1000.0},   {"units", "m"},
        {"mesh", obj_path.filename().string()}, {"name", object.kind},
    };
    char line[200];
    std::snprintf(line, sizeof(line), "object %s: %s, diameter %.1f mm, %zu faces, texture %dx%d",
                  object.name.c_str(), object.dimensions.c_str(), diameter_m * 1000.0,
                  loaded.mesh.faces.size(), loaded.mesh.texture.cols, loaded.mesh.texture.rows);
    say(line);
    report.diameters_m.push_back(diameter_m);
    report.objects.push_back(std::move(loaded));
  }
  WriteJson(models / "models_info.json", models_info);
  const Camera& camera = options.camera;
  WriteJson(fs::path(root) / "camera.json", {{"cx", camera.cx},
                                             {"cy", camera.cy},
                                             {"depth_scale", options.depth_scale_mm},
                                             {"fx", camera.fx},
                                             {"fy", camera.fy},
                                             {"height", camera.height},
                                             {"width", camera.width}});

  // 2. Images: each its own arrangement, or the planned sequence.
  const Mesh table = SampleTableFor(options);
  SampleRenderers renderers(report.objects, table);
  const SampleSequenceOptions& sequence = options.sequence;
  if (sequence.enabled) {
    report.sequence = PlanSampleSequence(options, report.objects);
    const SampleSequencePlan& plan = report.sequence;
    char line[320];
    std::snprintf(line, sizeof(line),
                  "sequence: %d images at %.0f fps, camera sweeps %.1f deg, steps up to %.1f mm "
                  "and %.2f deg per image, objects at least %.2f visible (%d candidate%s drawn)",
                  options.num_frames, sequence.fps, plan.sweep_deg, plan.max_step_m * 1000.0,
                  plan.max_step_deg, plan.min_visib_fract, plan.tries, plan.tries == 1 ? "" : "s");
    say(line);
    if (plan.abrupt_object >= 0) {
      std::snprintf(line, sizeof(line),
                    "sequence: %s jumps at image %d by %.1f mm and %.1f deg about the table normal",
                    report.objects[plan.abrupt_object].name.c_str(), plan.abrupt_frame,
                    plan.jump_m * 1000.0, plan.jump_turn_deg);
      say(line);
    }
  }
  Json scene_gt = Json::object(), scene_camera = Json::object(), scene_gt_info = Json::object();
  Json targets = Json::array();
  double visib_sum = 0.0;
  for (int im_id = 0; im_id < options.num_frames; ++im_id) {
    const uint64_t frame_seed = DerivedSeed(options.seed, kFramePartBase + im_id);
    const SampleFrame frame =
        sequence.enabled ? RenderPlannedFrame(options, report.objects, table, report.sequence,
                                              im_id, frame_seed, &renderers)
                         : RenderFrameWith(options, report.objects, table, frame_seed, &renderers);
    cv::Mat bgr;
    cv::cvtColor(frame.rgb, bgr, cv::COLOR_RGB2BGR);
    WriteImage(scene / "rgb" / ImageName(im_id), bgr);
    cv::Mat depth_units(frame.depth_m.size(), CV_16U);
    const double units_per_m = 1000.0 / options.depth_scale_mm;
    for (int y = 0; y < depth_units.rows; ++y) {
      for (int x = 0; x < depth_units.cols; ++x) {
        depth_units.at<uint16_t>(y, x) =
            static_cast<uint16_t>(std::lround(frame.depth_m.at<float>(y, x) * units_per_m));
      }
    }
    WriteImage(scene / "depth" / ImageName(im_id), depth_units);

    Json gt_list = Json::array(), info_list = Json::array();
    std::string visib_text;
    for (size_t k = 0; k < frame.instances.size(); ++k) {
      const SampleInstance& instance = frame.instances[k];
      WriteImage(scene / "mask" / MaskName(im_id, static_cast<int>(k)), frame.masks[k]);
      WriteImage(scene / "mask_visib" / MaskName(im_id, static_cast<int>(k)), frame.masks_visib[k]);
      gt_list.push_back({{"cam_R_m2c", RotationJson(instance.cam_from_object.linear())},
                         {"cam_t_m2c", TranslationMmJson(instance.cam_from_object.translation())},
                         {"obj_id", instance.obj_id}});
      const cv::Mat has_depth = depth_units > 0;
      const cv::Mat valid = frame.masks[k] & has_depth;
      info_list.push_back({{"bbox_obj", BoxJson(instance.bbox_obj)},
                           {"bbox_visib", BoxJson(instance.bbox_visib)},
                           {"px_count_all", instance.px_count_all},
                           {"px_count_valid", cv::countNonZero(valid)},
                           {"px_count_visib", instance.px_count_visib},
                           {"visib_fract", instance.visib_fract}});
      if (instance.visib_fract >= kBopTargetMinVisibFract) {
        targets.push_back(
            {{"im_id", im_id}, {"inst_count", 1}, {"obj_id", instance.obj_id}, {"scene_id", 1}});
      }
      ++report.instances_written;
      report.occluded_instances += instance.visib_fract < kOccludedReportFraction;
      report.min_visib_fract = std::min(report.min_visib_fract, instance.visib_fract);
      visib_sum += instance.visib_fract;
      char text[16];
      std::snprintf(text, sizeof(text), " %.2f", instance.visib_fract);
      visib_text += text;
    }
    const std::string key = std::to_string(im_id);
    scene_gt[key] = gt_list;
    scene_gt_info[key] = info_list;
    scene_camera[key] = {{"cam_K", Json::array({camera.fx, 0.0, camera.cx, 0.0, camera.fy,
                                                camera.cy, 0.0, 0.0, 1.0})},
                         {"cam_R_w2c", RotationJson(frame.cam_from_world.linear())},
                         {"cam_t_w2c", TranslationMmJson(frame.cam_from_world.translation())},
                         {"depth_scale", options.depth_scale_mm}};
    ++report.frames_written;
    char line[200];
    if (sequence.enabled) {
      const SampleSequencePlan& plan = report.sequence;
      std::snprintf(
          line, sizeof(line), "image %d/%d: visible fractions%s%s%s", im_id + 1, options.num_frames,
          visib_text.c_str(), im_id == plan.abrupt_frame ? ", jumped: " : "",
          im_id == plan.abrupt_frame ? report.objects[plan.abrupt_object].name.c_str() : "");
    } else {
      std::snprintf(line, sizeof(line), "image %d/%d: visible fractions%s (%d arrangement%s drawn)",
                    im_id + 1, options.num_frames, visib_text.c_str(), frame.tries,
                    frame.tries == 1 ? "" : "s");
    }
    say(line);
  }
  WriteJson(scene / "scene_gt.json", scene_gt);
  WriteJson(scene / "scene_camera.json", scene_camera);
  WriteJson(scene / "scene_gt_info.json", scene_gt_info);
  WriteJson(fs::path(root) / "test_targets_bop19.json", targets);

  report.mean_visib_fract =
      report.instances_written > 0 ? visib_sum / report.instances_written : 0.0;
  report.seconds = watch.ElapsedMs() / 1000.0;
  report.success = true;
  report.message = "ok";
  return report;
}

SampleCacheEntry WriteSampleCache(const TemplateBuildOptions& options, const BopObjectInfo& object,
                                  const std::string& cache_path, Executor* executor) {
  if (const std::string bad = options.Check(); !bad.empty())
    G6D_THROW("bad template option: " << bad);
  const Stopwatch watch;
  const Mesh mesh = LoadMesh(object.mesh_path, object.mesh_units);
  TemplateBank bank = BuildTemplateBank(mesh, object.name, options, executor);
  // Provenance exactly as g6d-build-templates records it.
  bank.mesh_hash = HashFile(object.mesh_path);
  bank.mesh_path = object.mesh_path;
  bank.mesh_units = object.mesh_units;
  const fs::path parent = fs::path(cache_path).parent_path();
  if (!parent.empty()) fs::create_directories(parent);
  WriteTemplateCache(bank, cache_path);
  SampleCacheEntry entry;
  entry.object_id = object.name;
  entry.path = cache_path;
  entry.templates = static_cast<int>(bank.templates.size());
  entry.keypoints = bank.NumKeypoints();
  entry.bytes = static_cast<int64_t>(fs::file_size(cache_path));
  entry.seconds = watch.ElapsedMs() / 1000.0;
  return entry;
}

}  // namespace g6d
