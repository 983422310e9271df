// The embedded sample (tools/sample/sample_scene.h and g6d-make-sample): objects, the BOP
// folder it writes (read back with lib/eval's reader and checked against an independent
// re-rasterization), determinism, the template caches and the LCM log.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/hash.h"
#include "core/se3.h"
#include "eval/bop.h"
#include "frame_log.h"
#include "process_util.h"
#include "render/gl_renderer.h"
#include "render/raster.h"
#include "sample/sample_scene.h"
#include "sample_test_util.h"
#include "wire/frame_codec.h"
#include "templates/cache.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using Json = nlohmann::json;

const std::string kMakeSample = test::BinaryDir() + "/tools/g6d-make-sample";

// A small sample: 3 images, written once for the tests that only read it.
SampleOptions SmallOptions() {
  SampleOptions options;
  options.num_frames = 3;
  options.seed = 7;
  return options;
}

const std::string& SmallSampleRoot() {
  static const std::string root = [] {
    const std::string dir = test::ScratchDirs::Make("make_sample_small");
    WriteSampleDataset(SmallOptions(), dir);
    return dir;
  }();
  return root;
}

Json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  return Json::parse(in);
}

// cam_from_world of an image from scene_camera.json's cam_R_w2c / cam_t_w2c (mm).
Eigen::Isometry3d CamFromWorld(const std::string& root, int im_id) {
  const Json camera =
      ReadJson(fs::path(root) / "test" / "000001" / "scene_camera.json")[std::to_string(im_id)];
  Eigen::Matrix3d rotation;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) rotation(r, c) = camera["cam_R_w2c"][3 * r + c].get<double>();
  }
  Eigen::Vector3d translation;
  for (int i = 0; i < 3; ++i) translation[i] = camera["cam_t_w2c"][i].get<double>() / 1000.0;
  return MakePose(rotation, translation);
}

// The z-buffer of the GT objects and the table, computed here independently of the
// library: per pixel the nearest surface (object index, n = table, -1 = none) and its depth.
void ReferenceZBuffer(const std::vector<Mesh>& meshes, const std::vector<Eigen::Isometry3d>& poses,
                      const Mesh& table, const Eigen::Isometry3d& cam_from_world,
                      const Camera& camera, cv::Mat* nearest, cv::Mat* depth_m,
                      std::vector<cv::Mat>* full_masks) {
  *nearest = cv::Mat(camera.height, camera.width, CV_32S, cv::Scalar(-1));
  *depth_m = cv::Mat::zeros(camera.height, camera.width, CV_32F);
  full_masks->clear();
  RasterImage raster;
  for (size_t k = 0; k <= meshes.size(); ++k) {
    const bool is_table = k == meshes.size();
    Rasterize(is_table ? table : meshes[k], camera, is_table ? cam_from_world : poses[k],
              RasterOptions{}, &raster);
    if (!is_table) full_masks->push_back(raster.Mask());
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const float z = raster.depth.at<float>(v, u);
        if (z > 0.0f && (nearest->at<int>(v, u) < 0 || z < depth_m->at<float>(v, u))) {
          nearest->at<int>(v, u) = static_cast<int>(k);
          depth_m->at<float>(v, u) = z;
        }
      }
    }
  }
}

// All regular files under `root`, relative path -> FNV-1a hash of the bytes.
std::map<std::string, uint64_t> HashTree(const fs::path& root) {
  std::map<std::string, uint64_t> hashes;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(root)) {
    if (entry.is_regular_file())
      hashes[fs::relative(entry.path(), root).string()] = HashFile(entry.path().string());
  }
  return hashes;
}

TEST(MakeSampleObjects, TexturedClosedRobotSizedAndRichInCorners) {
  const std::vector<SampleObject> objects = MakeSampleObjects(3, 5);
  ASSERT_EQ(objects.size(), 3u);
  const Camera camera{615.0, 615.0, 320.0, 240.0, 640, 480};
  for (const SampleObject& object : objects) {
    SCOPED_TRACE(object.name + " " + object.dimensions);
    EXPECT_TRUE(object.mesh.HasTexture());
    EXPECT_EQ(object.mesh.normals.size(), object.mesh.vertices.size());
    EXPECT_TRUE(IsClosedAndOriented(object.mesh));
    EXPECT_FALSE(object.rests.empty());
    const double diameter = ComputeDiameter(object.mesh);
    EXPECT_GT(diameter, 0.05);
    EXPECT_LT(diameter, 0.20);
    // Bounding box centred on the origin.
    EXPECT_LT(ComputeBoundingBox(object.mesh).center().norm(), 1e-6);
    // Seen at 0.5 m from an oblique direction, the print gives ORB plenty of corners.
    GlRenderer renderer(object.mesh);
    const Eigen::Isometry3d pose =
        LookAt({0.3, -0.25, 0.32}, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
    const GlImage image = renderer.Render(camera, pose);
    cv::Mat gray;
    cv::cvtColor(image.rgb, gray, cv::COLOR_RGB2GRAY);
    std::vector<cv::KeyPoint> keypoints;
    cv::ORB::create(500)->detect(gray, keypoints, image.mask);
    EXPECT_GE(keypoints.size(), 150u);
  }
  EXPECT_EQ(objects[0].name, "obj_000001");
  EXPECT_EQ(objects[2].obj_id, 3);
}

TEST(MakeSampleObjects, DeterministicForASeedAndPrefixStable) {
  const std::vector<SampleObject> a = MakeSampleObjects(3, 11);
  const std::vector<SampleObject> b = MakeSampleObjects(3, 11);
  const std::vector<SampleObject> c = MakeSampleObjects(3, 12);
  const std::vector<SampleObject> one = MakeSampleObjects(1, 11);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(cv::norm(a[k].mesh.texture, b[k].mesh.texture, cv::NORM_INF), 0.0);
    EXPECT_GT(cv::norm(a[k].mesh.texture, c[k].mesh.texture, cv::NORM_L1), 0.0);
  }
  EXPECT_EQ(cv::norm(a[0].mesh.texture, one[0].mesh.texture, cv::NORM_INF), 0.0);
  EXPECT_THROW(MakeSampleObjects(4, 1), Error);
}

TEST(WriteTexturedObj, LoadsBackAsTheSameTexturedMesh) {
  const std::string dir = test::ScratchDirs::Make("sample_obj");
  const SampleObject object = MakeSampleObjects(2, 3)[1];  // the cylinder: smooth sides, a seam
  const std::string path = dir + "/can.obj";
  WriteTexturedObj(object.mesh, path);
  ASSERT_TRUE(fs::exists(dir + "/can.mtl"));
  ASSERT_TRUE(fs::exists(dir + "/can.png"));
  const Mesh loaded = LoadMesh(path, Units::kMetres);
  EXPECT_EQ(loaded.faces.size(), object.mesh.faces.size());
  EXPECT_NEAR(ComputeDiameter(loaded), ComputeDiameter(object.mesh), 1e-6);
  ASSERT_TRUE(loaded.HasTexture());
  EXPECT_EQ(cv::norm(loaded.texture, object.mesh.texture, cv::NORM_INF), 0.0);
  // Rendered the same (texture coordinates and orientation survive the file).
  const Camera camera{600.0, 600.0, 160.0, 120.0, 320, 240};
  const Eigen::Isometry3d pose =
      LookAt({0.25, 0.1, 0.15}, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  GlRenderer original(object.mesh), reloaded(loaded);
  const GlImage a = original.Render(camera, pose), b = reloaded.Render(camera, pose);
  cv::Mat difference;
  cv::absdiff(a.rgb, b.rgb, difference);
  EXPECT_LT(cv::mean(difference, a.mask)[0], 1.0);
  EXPECT_THROW(WriteTexturedObj(Mesh{}, dir + "/empty.obj"), Error);
}

TEST(WriteSampleDataset, LoadsWithTheBopReader) {
  const std::string& root = SmallSampleRoot();
  const BopDataset dataset = LoadBopDataset(root);
  ASSERT_TRUE(dataset.camera.has_value());
  EXPECT_EQ(dataset.camera->width, 640);
  EXPECT_DOUBLE_EQ(dataset.camera_depth_scale, 0.1);
  ASSERT_EQ(dataset.objects.size(), 3u);
  for (const auto& [obj_id, info] : dataset.objects) {
    EXPECT_EQ(info.mesh_units, Units::kMetres);
    EXPECT_EQ(fs::path(info.mesh_path).extension(), ".obj");
    EXPECT_FALSE(info.IsSymmetric());
    EXPECT_NEAR(info.diameter_m, ComputeDiameter(LoadMesh(info.mesh_path, info.mesh_units)), 1e-6);
  }
  EXPECT_EQ(dataset.scene_ids, std::vector<int>({1}));
  ASSERT_TRUE(dataset.has_targets);
  const BopScene scene = LoadBopScene(root, 1);
  ASSERT_EQ(scene.frames.size(), 3u);
  EXPECT_EQ(scene.InstanceCount(), 9);
  EXPECT_EQ(dataset.targets.size(), 9u);  // every instance is at least 10% visible
  for (const BopFrame& frame : scene.frames) {
    ASSERT_EQ(frame.gt.size(), 3u);
    EXPECT_DOUBLE_EQ(frame.depth_scale, 0.1);
    EXPECT_EQ(LoadBopRgb(scene, frame.im_id).size(), cv::Size(640, 480));
    EXPECT_EQ(LoadBopDepth(scene, frame.im_id).type(), CV_32F);
    for (size_t k = 0; k < frame.gt.size(); ++k) {
      const BopGtInstance& gt = frame.gt[k];
      EXPECT_EQ(gt.obj_id, static_cast<int>(k) + 1);
      ASSERT_TRUE(gt.info.has_value());
      const cv::Mat visible = LoadBopMaskVisib(scene, frame.im_id, static_cast<int>(k));
      const cv::Mat full = LoadBopMask(scene, frame.im_id, static_cast<int>(k));
      EXPECT_EQ(gt.info->px_count_visib, cv::countNonZero(visible));
      EXPECT_EQ(gt.info->px_count_all, cv::countNonZero(full));
      EXPECT_EQ(gt.info->px_count_valid, gt.info->px_count_all);  // depth everywhere on objects
      EXPECT_NEAR(gt.info->visib_fract, double(gt.info->px_count_visib) / gt.info->px_count_all,
                  1e-12);
      EXPECT_GE(gt.info->visib_fract, SmallOptions().min_visible_fraction);
      // Visible pixels are a subset of the silhouette.
      EXPECT_EQ(cv::countNonZero(visible & ~full), 0);
      const cv::Rect box = cv::boundingRect(full);
      EXPECT_EQ(gt.info->bbox_obj, (std::array<int, 4>{box.x, box.y, box.width, box.height}));
      // Inside the image with a margin (the solver refuses masks touching the border).
      EXPECT_GE(box.x, SmallOptions().border_margin_px);
      EXPECT_LE(box.x + box.width, 640 - SmallOptions().border_margin_px);
      // A proper rotation (written to 17 digits).
      EXPECT_NEAR(gt.cam_from_object.linear().determinant(), 1.0, 1e-9);
    }
  }
}

TEST(WriteSampleDataset, MasksEqualAnIndependentRasterizationOfTheGroundTruth) {
  const std::string& root = SmallSampleRoot();
  const BopDataset dataset = LoadBopDataset(root);
  const BopScene scene = LoadBopScene(root, 1);
  std::vector<Mesh> meshes;
  for (const auto& [obj_id, info] : dataset.objects)
    meshes.push_back(LoadMesh(info.mesh_path, info.mesh_units));
  const Mesh table = SampleTableFor(SmallOptions());
  for (const BopFrame& frame : scene.frames) {
    SCOPED_TRACE("image " + std::to_string(frame.im_id));
    std::vector<Eigen::Isometry3d> poses;
    for (const BopGtInstance& gt : frame.gt) poses.push_back(gt.cam_from_object);
    cv::Mat nearest, depth;
    std::vector<cv::Mat> full;
    ReferenceZBuffer(meshes, poses, table, CamFromWorld(root, frame.im_id), frame.camera, &nearest,
                     &depth, &full);
    for (int k = 0; k < static_cast<int>(frame.gt.size()); ++k) {
      const cv::Mat expected_visible = nearest == k;
      EXPECT_EQ(cv::countNonZero(expected_visible != LoadBopMaskVisib(scene, frame.im_id, k)), 0)
          << "object " << k;
      EXPECT_EQ(cv::countNonZero(full[k] != LoadBopMask(scene, frame.im_id, k)), 0)
          << "object " << k;
    }
  }
}

TEST(WriteSampleDataset, GroundTruthRerendersToTheWrittenDepthWithinTheNoise) {
  const std::string& root = SmallSampleRoot();
  const SampleOptions options = SmallOptions();
  const BopDataset dataset = LoadBopDataset(root);
  const BopScene scene = LoadBopScene(root, 1);
  std::vector<Mesh> meshes;
  for (const auto& [obj_id, info] : dataset.objects)
    meshes.push_back(LoadMesh(info.mesh_path, info.mesh_units));
  const Mesh table = SampleTableFor(options);
  const double quantization_m = options.depth_scale_mm / 1000.0;
  for (const BopFrame& frame : scene.frames) {
    SCOPED_TRACE("image " + std::to_string(frame.im_id));
    std::vector<Eigen::Isometry3d> poses;
    for (const BopGtInstance& gt : frame.gt) poses.push_back(gt.cam_from_object);
    cv::Mat nearest, expected;
    std::vector<cv::Mat> full;
    ReferenceZBuffer(meshes, poses, table, CamFromWorld(root, frame.im_id), frame.camera, &nearest,
                     &expected, &full);
    const cv::Mat written = LoadBopDepth(scene, frame.im_id);
    double sum = 0.0, sum_squares = 0.0, largest = 0.0;
    int count = 0, valid_mismatch = 0;
    for (int v = 0; v < written.rows; ++v) {
      for (int u = 0; u < written.cols; ++u) {
        const float z = written.at<float>(v, u), reference = expected.at<float>(v, u);
        valid_mismatch += (z > 0.0f) != (reference > 0.0f);
        if (z <= 0.0f || reference <= 0.0f) continue;
        const double residual = z - reference;
        sum += residual;
        sum_squares += residual * residual;
        largest = std::max(largest, std::abs(residual));
        ++count;
      }
    }
    ASSERT_GT(count, 100000);
    EXPECT_EQ(valid_mismatch, 0);
    const double mean = sum / count, sigma = std::sqrt(sum_squares / count - mean * mean);
    EXPECT_LT(std::abs(mean), 0.05 * options.depth_noise_m);
    EXPECT_NEAR(sigma, options.depth_noise_m, 0.05 * options.depth_noise_m);
    EXPECT_LT(largest, 6.5 * options.depth_noise_m + quantization_m);
  }
}

TEST(WriteSampleDataset, SequenceShowsMutualOcclusionOfEveryObjectKind) {
  SampleOptions options;
  options.num_frames = 6;
  const std::string root = test::ScratchDirs::Make("make_sample_occlusion");
  const SampleReport report = WriteSampleDataset(options, root);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_EQ(report.frames_written, 6);
  EXPECT_EQ(report.instances_written, 18);
  EXPECT_GE(report.occluded_instances, 4);
  EXPECT_GE(report.min_visib_fract, options.min_visible_fraction);
  EXPECT_LT(report.min_visib_fract, 0.85);
  EXPECT_LT(report.mean_visib_fract, 0.97);
}

TEST(WriteSampleDataset, DeterministicForASeed) {
  SampleOptions options = SmallOptions();
  options.num_frames = 2;
  const std::string a = test::ScratchDirs::Make("make_sample_seed_a"),
                    b = test::ScratchDirs::Make("make_sample_seed_b");
  WriteSampleDataset(options, a);
  WriteSampleDataset(options, b);
  const auto hashes_a = HashTree(a), hashes_b = HashTree(b);
  // camera.json and the targets; models: 3 x (obj, mtl, png) + info; the scene: 2 rgb,
  // 2 depth, 6 mask, 6 mask_visib, 3 json.
  EXPECT_EQ(hashes_a.size(), 2u + 10u + 19u);
  EXPECT_EQ(hashes_a, hashes_b);
  options.seed += 1;
  const std::string c = test::ScratchDirs::Make("make_sample_seed_c");
  WriteSampleDataset(options, c);
  EXPECT_NE(HashFile(a + "/test/000001/rgb/000000.png"),
            HashFile(c + "/test/000001/rgb/000000.png"));
}

TEST(SampleOptions, CheckNamesTheBadField) {
  EXPECT_EQ(SampleOptions{}.Check(), "");
  SampleOptions options;
  options.num_objects = 4;
  EXPECT_THAT(options.Check(), HasSubstr("num_objects"));
  options = SampleOptions{};
  options.max_distance_m = 0.1;
  EXPECT_THAT(options.Check(), HasSubstr("max_distance_m"));
  options = SampleOptions{};
  options.depth_noise_m = -1;
  EXPECT_THAT(options.Check(), HasSubstr("depth_noise_m"));
  EXPECT_THROW(WriteSampleDataset(options, test::ScratchDirs::Make("make_sample_bad")), Error);
}

TEST(RenderSampleFrame, ImpossibleVisibilityIsAnErrorNamingTheOption) {
  SampleOptions options;
  options.min_visible_fraction = 1.0;
  options.cluster_radius_m = 0.001;  // objects cannot be placed apart
  options.max_tries = 5;
  const std::vector<SampleObject> objects = MakeSampleObjects(3, 1);
  try {
    RenderSampleFrame(options, objects, SampleTableFor(options), 1);
    FAIL() << "expected g6d::Error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("min_visible_fraction"));
  }
}

// The tool: everything in one folder, caches valid for the written meshes, the log decoding
// back to the BOP images, --reuse, and byte-identical output for a seed.
class MakeSampleTool : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_TRUE(fs::exists(kMakeSample)) << kMakeSample << " is not built";
    root_ = new std::string(test::ScratchDirs::Make("make_sample_tool") + "/sample");
    const test::CommandResult run =
        test::RunCommand(kMakeSample + " --out " + *root_ +
                         " --frames 2 --seed 3 --views 12 --inplane 1 --threads 2");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    output_ = new std::string(run.output);
  }
  static void TearDownTestSuite() {
    delete root_;
    delete output_;
  }
  static std::string* root_;
  static std::string* output_;
};
std::string* MakeSampleTool::root_ = nullptr;
std::string* MakeSampleTool::output_ = nullptr;

TEST_F(MakeSampleTool, WritesTheBopFolderCachesLogAndManifest) {
  EXPECT_THAT(*output_, HasSubstr("g6d-make-sample: wrote"));
  EXPECT_THAT(*output_, HasSubstr("image 2/2"));
  const Json manifest = ReadJson(*root_ + "/sample.json");
  EXPECT_EQ(manifest["frames"], 2);
  EXPECT_EQ(manifest["instances"], 6);
  EXPECT_EQ(manifest["objects"].size(), 3u);
  const BopDataset dataset = LoadBopDataset(*root_);
  for (const auto& [obj_id, info] : dataset.objects) {
    const std::string cache = *root_ + "/caches/" + info.name + ".g6dcache";
    // Not stale: the cache records the hash of the very mesh file models_info.json names.
    const TemplateBank bank = ReadTemplateCacheChecked(cache, info.mesh_path);
    EXPECT_EQ(bank.object_id, info.name);
    EXPECT_EQ(bank.templates.size(), 12u);
    EXPECT_NEAR(bank.diameter_m, info.diameter_m, 1e-6);
    EXPECT_GT(bank.NumKeypoints(), 12u * 50);
  }
}

TEST_F(MakeSampleTool, LogDecodesBackToTheBopImages) {
  const BopScene scene = LoadBopScene(*root_, 1);
  FrameLogReader reader(*root_ + "/sample.lcmlog", "G6D_RGBD");
  FrameEvent event;
  int frames = 0;
  while (reader.Next(&event)) {
    SCOPED_TRACE("frame " + std::to_string(frames));
    const DecodedFrame decoded = DecodeFrame(event.frame);
    EXPECT_EQ(event.frame.scene_id, 1);
    ASSERT_EQ(event.frame.image_id, frames);
    const BopFrame& bop = scene.Frame(event.frame.image_id);
    EXPECT_DOUBLE_EQ(decoded.frame.camera.fx, bop.camera.fx);
    EXPECT_DOUBLE_EQ(event.frame.depth_scale_m, 0.0001);
    EXPECT_EQ(cv::norm(decoded.frame.rgb, LoadBopRgb(scene, bop.im_id), cv::NORM_INF), 0.0);
    EXPECT_LT(cv::norm(decoded.frame.depth, LoadBopDepth(scene, bop.im_id), cv::NORM_INF), 1e-6);
    ASSERT_EQ(decoded.instances.size(), 3u);
    for (const DecodedInstance& instance : decoded.instances) {
      EXPECT_EQ(instance.object_id, BopObjectName(bop.gt[instance.gt_index].obj_id));
      EXPECT_EQ(
          cv::countNonZero(instance.mask != LoadBopMaskVisib(scene, bop.im_id, instance.gt_index)),
          0);
    }
    ++frames;
  }
  EXPECT_EQ(frames, 2);
  EXPECT_TRUE(reader.stats().Problems().empty());
}

TEST_F(MakeSampleTool, ReuseKeepsACurrentFolderAndRedoesAChangedOne) {
  const std::string dir = test::ScratchDirs::Make("make_sample_reuse") + "/sample";
  const std::string base =
      kMakeSample + " --out " + dir + " --frames 1 --views 6 --inplane 1 --no-log";
  ASSERT_EQ(test::RunCommand(base).exit_code, 0);
  const test::CommandResult again = test::RunCommand(base + " --reuse");
  EXPECT_EQ(again.exit_code, 0);
  EXPECT_THAT(again.output, HasSubstr("up to date"));
  // A missing file or other options mean work again.
  fs::remove(dir + "/caches/obj_000002.g6dcache");
  EXPECT_THAT(test::RunCommand(base + " --reuse").output, HasSubstr("g6d-make-sample: wrote"));
  EXPECT_TRUE(fs::exists(dir + "/caches/obj_000002.g6dcache"));
  EXPECT_THAT(test::RunCommand(base + " --reuse --seed 2").output,
              HasSubstr("g6d-make-sample: wrote"));
  EXPECT_THAT(test::RunCommand(base + " --reuse").output, HasSubstr("g6d-make-sample: wrote"));
}

TEST_F(MakeSampleTool, SameSeedGivesTheSameFiles) {
  // Same folder name: the log records it as the frames' source.
  const std::string other = test::ScratchDirs::Make("make_sample_tool_again") + "/sample";
  ASSERT_EQ(test::RunCommand(kMakeSample + " --out " + other +
                             " --frames 2 --seed 3 --views 12 --inplane 1 --threads 1")
                .exit_code,
            0);
  std::map<std::string, uint64_t> a = HashTree(*root_), b = HashTree(other);
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [file, hash] : a) {
    if (fs::path(file).extension() == ".g6dcache") {
      // Caches record their mesh's path, which differs; their contents must not.
      const TemplateBank x = ReadTemplateCache(*root_ + "/" + file),
                         y = ReadTemplateCache(other + "/" + file);
      ASSERT_EQ(x.templates.size(), y.templates.size());
      EXPECT_EQ(x.mesh_hash, y.mesh_hash);
      for (size_t t = 0; t < x.templates.size(); ++t)
        EXPECT_EQ(x.templates[t].descriptors, y.templates[t].descriptors);
    } else if (file != "sample.json") {
      EXPECT_EQ(hash, b[file]) << file;
    }
  }
  // The manifest differs only where the options differ (none here but --threads).
  EXPECT_EQ(ReadJson(*root_ + "/sample.json")["options"],
            ReadJson(other + "/sample.json")["options"]);
}

TEST(MakeSampleToolOptions, BadOptionsFailWithAMessage) {
  ASSERT_TRUE(fs::exists(kMakeSample));
  const std::string dir = test::ScratchDirs::Make("make_sample_bad_options");
  const test::CommandResult views =
      test::RunCommand(kMakeSample + " --out " + dir + " --views 10 --inplane 3");
  EXPECT_NE(views.exit_code, 0);
  EXPECT_THAT(views.output, HasSubstr("--views 10 must be a positive multiple of --inplane 3"));
  const test::CommandResult objects =
      test::RunCommand(kMakeSample + " --out " + dir + " --objects 5");
  EXPECT_NE(objects.exit_code, 0);
  EXPECT_THAT(objects.output, HasSubstr("--objects"));
  const test::CommandResult noise =
      test::RunCommand(kMakeSample + " --out " + dir + " --depth-noise-mm -2");
  EXPECT_NE(noise.exit_code, 0);
  EXPECT_THAT(noise.output, HasSubstr("depth_noise_m"));
}

// Sequence mode (issue 14, item 4): one arrangement, a smooth camera path, one jump.

// world_from_object of every instance of every image of a written scene, per image then
// object order.
std::vector<std::vector<Eigen::Isometry3d>> WorldFromObjects(const std::string& root) {
  const BopScene scene = LoadBopScene(root, 1);
  std::vector<std::vector<Eigen::Isometry3d>> poses;
  for (const BopFrame& frame : scene.frames) {
    const Eigen::Isometry3d world_from_cam = CamFromWorld(root, frame.im_id).inverse();
    poses.emplace_back();
    for (const BopGtInstance& gt : frame.gt)
      poses.back().push_back(world_from_cam * gt.cam_from_object);
  }
  return poses;
}

// The angle (degrees) of a rotation about the table normal, and how far its axis is from
// that normal (degrees; 0 for a pure turn about it).
void TurnAboutTheNormal(const Eigen::Matrix3d& rotation, double* turn_deg, double* tilt_deg) {
  const Eigen::AngleAxisd turn(rotation);
  *turn_deg = turn.angle() * 180.0 / M_PI;
  *tilt_deg = std::acos(std::min(1.0, std::abs(turn.axis().z()))) * 180.0 / M_PI;
}

SampleOptions ShortSequenceOptions() {
  SampleOptions options;
  options.num_frames = 12;
  options.seed = 2;
  options.sequence.enabled = true;
  options.sequence.abrupt_frame = 6;
  return options;
}

TEST(PlanSampleSequence, ShortSequencesAreSlowedToTheRateBounds) {
  const SampleOptions options = ShortSequenceOptions();
  const std::vector<SampleObject> objects = MakeSampleObjects(options.num_objects, 1);
  const SampleSequencePlan plan = PlanSampleSequence(options, objects);
  ASSERT_EQ(plan.cam_from_world.size(), 12u);
  const double fps = options.sequence.fps;
  EXPECT_LE(plan.max_step_m * fps, options.sequence.max_camera_speed_m_s);
  EXPECT_LE(plan.max_step_deg * fps, options.sequence.max_rotation_deg_s);
  // 0.37 s at 30 fps: far less than the 40-70 degree sweep, but a real motion.
  EXPECT_GT(std::abs(plan.sweep_deg), 3.0);
  EXPECT_LT(std::abs(plan.sweep_deg), options.sequence.min_sweep_deg);
  EXPECT_EQ(plan.abrupt_object, 1);
  EXPECT_GE(plan.min_visib_fract, options.min_visible_fraction);
  // The same seed, the same plan.
  const SampleSequencePlan again = PlanSampleSequence(options, objects);
  for (size_t i = 0; i < plan.cam_from_world.size(); ++i)
    EXPECT_TRUE(plan.cam_from_world[i].isApprox(again.cam_from_world[i], 0.0));
}

TEST(PlanSampleSequence, ALongSequenceSweepsFortyToSeventyDegrees) {
  SampleOptions options = ShortSequenceOptions();
  options.num_frames = 90;
  options.sequence.abrupt_frame = 45;
  options.num_objects = 1;  // the jump falls back to the last (only) object
  const SampleSequencePlan plan = PlanSampleSequence(options, MakeSampleObjects(1, 1));
  EXPECT_GE(std::abs(plan.sweep_deg), options.sequence.min_sweep_deg);
  EXPECT_LE(std::abs(plan.sweep_deg), options.sequence.max_sweep_deg);
  EXPECT_LE(plan.max_step_m * options.sequence.fps, options.sequence.max_camera_speed_m_s);
  EXPECT_LE(plan.max_step_deg * options.sequence.fps, options.sequence.max_rotation_deg_s);
  EXPECT_EQ(plan.abrupt_object, 0);
  EXPECT_GE(plan.jump_m, options.sequence.min_jump_m);
  EXPECT_LE(plan.jump_m, options.sequence.max_jump_m);
  EXPECT_EQ(plan.WorldFromObject(44, 0).matrix(), plan.world_from_object[0].matrix());
  EXPECT_EQ(plan.WorldFromObject(45, 0).matrix(), plan.jumped_world_from_object.matrix());
}

TEST(SampleSequenceOptions, CheckNamesTheBadField) {
  EXPECT_EQ(SampleSequenceOptions{}.Check(), "");
  SampleOptions options = ShortSequenceOptions();
  EXPECT_EQ(options.Check(), "");
  options.sequence.abrupt_frame = 12;  // past the last image
  EXPECT_THAT(options.Check(), HasSubstr("sequence.abrupt_frame"));
  options.sequence.abrupt_frame = 0;  // a jump needs an image before it
  EXPECT_THAT(options.Check(), HasSubstr("sequence.abrupt_frame"));
  options = ShortSequenceOptions();
  options.sequence.fps = 0.0;
  EXPECT_THAT(options.Check(), HasSubstr("sequence.fps"));
  options = ShortSequenceOptions();
  options.sequence.min_jump_m = 0.2;
  EXPECT_THAT(options.Check(), HasSubstr("min_jump_m"));
  options = ShortSequenceOptions();
  options.sequence.max_sweep_deg = 200.0;
  EXPECT_THAT(options.Check(), HasSubstr("max_sweep_deg"));
}

// The tool in sequence mode: 12 images at the default 30 fps, the jump at the default
// image 6, no caches.
class MakeSampleSequenceTool : public ::testing::Test {
 protected:
  static constexpr int kFrames = 12;
  static constexpr double kFps = 30.0;
  static std::string Command(const std::string& out) {
    return kMakeSample + " --out " + out + " --sequence --frames 12 --seed 2 --no-caches";
  }
  static void SetUpTestSuite() {
    ASSERT_TRUE(fs::exists(kMakeSample)) << kMakeSample << " is not built";
    root_ = new std::string(test::ScratchDirs::Make("make_sample_sequence") + "/sample");
    const test::CommandResult run = test::RunCommand(Command(*root_));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    output_ = new std::string(run.output);
  }
  static void TearDownTestSuite() {
    delete root_;
    delete output_;
  }
  static std::string* root_;
  static std::string* output_;
};
std::string* MakeSampleSequenceTool::root_ = nullptr;
std::string* MakeSampleSequenceTool::output_ = nullptr;

TEST_F(MakeSampleSequenceTool, ManifestRecordsTheSequence) {
  EXPECT_THAT(*output_, HasSubstr("image 12/12"));
  EXPECT_THAT(*output_, HasSubstr("obj_000002 jumps at image 6"));
  const Json manifest = ReadJson(*root_ + "/sample.json");
  EXPECT_EQ(manifest["sequence"], true);
  EXPECT_EQ(manifest["abrupt_frame"], 6);
  EXPECT_EQ(manifest["abrupt_obj_id"], 2);
  EXPECT_EQ(manifest["frames"], kFrames);
  EXPECT_EQ(manifest["options"]["sequence"], true);
  EXPECT_EQ(manifest["options"]["abrupt_frame"], 6);
  EXPECT_EQ(manifest["options"]["fps"], kFps);
  EXPECT_EQ(manifest["options"]["frames"], kFrames);
}

TEST_F(MakeSampleSequenceTool, CameraMovesSmoothlyWithoutJumps) {
  Eigen::Isometry3d previous = CamFromWorld(*root_, 0).inverse();
  for (int im_id = 1; im_id < kFrames; ++im_id) {
    SCOPED_TRACE("image " + std::to_string(im_id));
    const Eigen::Isometry3d world_from_cam = CamFromWorld(*root_, im_id).inverse();
    const double step_m = TranslationError(previous, world_from_cam);
    const double step_deg = RotationErrorDeg(previous.linear(), world_from_cam.linear());
    // It moves, at most 0.3 m/s and 30 deg/s (and so far below 2 cm and 2 degrees).
    EXPECT_GT(step_m, 0.0005);
    EXPECT_LE(step_m, 0.3 / kFps + 1e-9);
    EXPECT_LE(step_deg, 30.0 / kFps + 1e-9);
    previous = world_from_cam;
  }
}

TEST_F(MakeSampleSequenceTool, ObjectsStayExceptOneJumpAtTheAbruptFrame) {
  const std::vector<std::vector<Eigen::Isometry3d>> poses = WorldFromObjects(*root_);
  ASSERT_EQ(poses.size(), static_cast<size_t>(kFrames));
  const Json manifest = ReadJson(*root_ + "/sample.json");
  int jumps = 0;
  for (int im_id = 1; im_id < kFrames; ++im_id) {
    for (size_t k = 0; k < poses[im_id].size(); ++k) {
      SCOPED_TRACE("image " + std::to_string(im_id) + ", object " + std::to_string(k + 1));
      const Eigen::Isometry3d& before = poses[im_id - 1][k];
      const Eigen::Isometry3d& after = poses[im_id][k];
      const double moved_m = TranslationError(before, after);
      const double turned_deg = RotationErrorDeg(before.linear(), after.linear());
      if (im_id != 6 || k != 1) {
        // Constant up to the 17 digits of the JSON files.
        EXPECT_LT(moved_m, 1e-9);
        EXPECT_LT(turned_deg, 1e-5);
        continue;
      }
      ++jumps;
      EXPECT_GE(moved_m, 0.06);
      EXPECT_LE(moved_m, 0.12);
      EXPECT_NEAR(moved_m * 1000.0, manifest["abrupt_translation_mm"].get<double>(), 1e-6);
      // Still on the table: the move is horizontal, the turn about the table normal.
      EXPECT_NEAR(after.translation().z(), before.translation().z(), 1e-9);
      double turn_deg = 0.0, tilt_deg = 0.0;
      TurnAboutTheNormal(after.linear() * before.linear().transpose(), &turn_deg, &tilt_deg);
      EXPECT_GE(turn_deg, 60.0);
      EXPECT_LE(turn_deg, 120.0);
      EXPECT_LT(tilt_deg, 1e-4);
      EXPECT_NEAR(turn_deg, std::abs(manifest["abrupt_rotation_deg"].get<double>()), 1e-6);
    }
  }
  EXPECT_EQ(jumps, 1);
}

TEST_F(MakeSampleSequenceTool, EveryObjectVisibleAndInsideInEveryImage) {
  const SampleOptions rules;
  const BopScene scene = LoadBopScene(*root_, 1);
  ASSERT_EQ(scene.frames.size(), static_cast<size_t>(kFrames));
  double least_visible = 1.0;
  for (const BopFrame& frame : scene.frames) {
    ASSERT_EQ(frame.gt.size(), 3u);
    for (size_t k = 0; k < frame.gt.size(); ++k) {
      SCOPED_TRACE("image " + std::to_string(frame.im_id) + ", object " + std::to_string(k + 1));
      const BopGtInstance& gt = frame.gt[k];
      ASSERT_TRUE(gt.info.has_value());
      EXPECT_GE(gt.info->visib_fract, rules.min_visible_fraction);
      least_visible = std::min(least_visible, gt.info->visib_fract);
      const cv::Rect box = cv::boundingRect(LoadBopMask(scene, frame.im_id, static_cast<int>(k)));
      const int m = rules.border_margin_px;
      EXPECT_GE(box.x, m);
      EXPECT_GE(box.y, m);
      EXPECT_LE(box.x + box.width, frame.camera.width - m);
      EXPECT_LE(box.y + box.height, frame.camera.height - m);
    }
  }
  // Mutual occlusion in some image.
  EXPECT_LT(least_visible, rules.occlusion_below_fraction);
}

TEST_F(MakeSampleSequenceTool, LogHasOneEventPerImageOneFrameApart) {
  FrameLogReader reader(*root_ + "/sample.lcmlog", "G6D_RGBD");
  FrameEvent event;
  std::vector<int64_t> utimes;
  while (reader.Next(&event)) {
    EXPECT_EQ(event.frame.image_id, static_cast<int>(utimes.size()));
    EXPECT_EQ(event.timestamp_us, event.frame.utime);
    utimes.push_back(event.frame.utime);
  }
  ASSERT_EQ(utimes.size(), static_cast<size_t>(kFrames));
  for (size_t i = 1; i < utimes.size(); ++i)
    EXPECT_NEAR(static_cast<double>(utimes[i] - utimes[i - 1]), 1e6 / kFps, 1.0);
  EXPECT_TRUE(reader.stats().Problems().empty());
}

TEST_F(MakeSampleSequenceTool, SameSeedGivesTheSameFilesAndReuseKeepsThem) {
  // Same folder name: the log records it as the frames' source.
  const std::string other = test::ScratchDirs::Make("make_sample_sequence_again") + "/sample";
  ASSERT_EQ(test::RunCommand(Command(other)).exit_code, 0);
  const std::map<std::string, uint64_t> a = HashTree(*root_), b = HashTree(other);
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [file, hash] : a) {
    if (file != "sample.json") {
      EXPECT_EQ(hash, b.at(file)) << file;
    }
  }
  EXPECT_EQ(ReadJson(*root_ + "/sample.json")["options"],
            ReadJson(other + "/sample.json")["options"]);
  // --reuse keeps the sequence, and redoes it as the classic sample (other options).
  EXPECT_THAT(test::RunCommand(Command(other) + " --reuse").output, HasSubstr("up to date"));
  const test::CommandResult classic = test::RunCommand(
      kMakeSample + " --out " + other + " --frames 12 --fps 30 --seed 2 --no-caches --reuse");
  EXPECT_THAT(classic.output, HasSubstr("g6d-make-sample: wrote"));
  EXPECT_FALSE(ReadJson(other + "/sample.json").contains("sequence"));
  EXPECT_NE(HashFile(other + "/test/000001/rgb/000001.png"),
            HashFile(*root_ + "/test/000001/rgb/000001.png"));
}

TEST(MakeSampleToolOptions, AbruptFrameNeedsTheSequenceAndAnImageInside) {
  ASSERT_TRUE(fs::exists(kMakeSample));
  const std::string dir = test::ScratchDirs::Make("make_sample_bad_sequence");
  const test::CommandResult alone =
      test::RunCommand(kMakeSample + " --out " + dir + " --abrupt-frame 3 --no-caches");
  EXPECT_NE(alone.exit_code, 0);
  EXPECT_THAT(alone.output, HasSubstr("--abrupt-frame needs --sequence"));
  const test::CommandResult outside = test::RunCommand(
      kMakeSample + " --out " + dir + " --sequence --frames 4 --abrupt-frame 4 --no-caches");
  EXPECT_NE(outside.exit_code, 0);
  EXPECT_THAT(outside.output, HasSubstr("abrupt_frame"));
}

}  // namespace
}  // namespace g6d
