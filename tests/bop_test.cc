#include "eval/bop.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>
#include <vector>

#include "core/error.h"
#include "eval/metrics.h"
#include "mesh/mesh.h"
#include "test_util.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;

void WriteText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// The message of the g6d::Error thrown by `function` (fails the test if none is thrown).
template <typename Function>
std::string ErrorOf(Function function) {
  try {
    function();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected g6d::Error";
  return "";
}

// A minimal BOP dataset in a temp folder: one object, scene 1 with image 7 (one GT
// instance, 4x3 images), no camera.json.
struct TinyDataset {
  std::string root;
  fs::path scene;

  explicit TinyDataset(const std::string& name) : root(test::TempDir(name)) {
    scene = fs::path(root) / "test" / "000001";
    WriteText(fs::path(root) / "models" / "models_info.json",
              R"({"3": {"diameter": 100.0, "symmetries_continuous": )"
              R"([{"axis": [0, 0, 1], "offset": [0, 0, 10]}]}})");
    WriteText(scene / "scene_camera.json",
              R"({"7": {"cam_K": [500, 0, 2, 0, 510, 1.5, 0, 0, 1], "depth_scale": 0.1}})");
    WriteText(scene / "scene_gt.json", R"({"7": [{"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], )"
                                       R"("cam_t_m2c": [10, -20, 500], "obj_id": 3}]})");
    cv::Mat depth(3, 4, CV_16UC1, cv::Scalar(0));
    depth.at<uint16_t>(1, 2) = 1234;
    depth.at<uint16_t>(2, 3) = 65535;
    fs::create_directories(scene / "depth");
    cv::imwrite((scene / "depth" / "000007.png").string(), depth);
    cv::Mat bgr(3, 4, CV_8UC3, cv::Scalar(255, 0, 0));  // blue in OpenCV's BGR order
    fs::create_directories(scene / "rgb");
    cv::imwrite((scene / "rgb" / "000007.png").string(), bgr);
    cv::Mat mask(3, 4, CV_8UC1, cv::Scalar(0));
    mask.at<uint8_t>(0, 1) = 255;
    fs::create_directories(scene / "mask_visib");
    cv::imwrite((scene / "mask_visib" / "000007_000000.png").string(), mask);
  }
  ~TinyDataset() { fs::remove_all(root); }
};

TEST(BopObjectName, FormatsAndParses) {
  EXPECT_EQ(BopObjectName(5), "obj_000005");
  EXPECT_EQ(ParseBopObjectName("obj_000012"), 12);
  EXPECT_THROW(BopObjectName(-1), Error);
  EXPECT_THROW(ParseBopObjectName("obj_12"), Error);
  EXPECT_THROW(ParseBopObjectName("000012"), Error);
  EXPECT_THROW(ParseBopObjectName("obj_00001x"), Error);
}

TEST(TargetGtIndices, TheMostVisibleInstancesInSceneGtOrder) {
  // Object 7 three times (visible 0.0, 0.6, 0.9), object 3 once without gt_info.
  BopFrame frame;
  for (const auto& [obj_id, visib] : std::vector<std::pair<int, double>>{{7, 0.0}, {3, -1.0}, {7, 0.6}, {7, 0.9}}) {
    BopGtInstance gt;
    gt.obj_id = obj_id;
    if (visib >= 0.0) {
      gt.info = BopGtInfo();
      gt.info->visib_fract = visib;
    }
    frame.gt.push_back(gt);
  }
  // A target of one instance is the most visible one, not the first (hidden) one in the file.
  EXPECT_EQ(TargetGtIndices(frame, 7, 1), (std::vector<int>{3}));
  EXPECT_EQ(TargetGtIndices(frame, 7, 2), (std::vector<int>{2, 3}));
  EXPECT_EQ(TargetGtIndices(frame, 7, 5), (std::vector<int>{0, 2, 3}));
  EXPECT_EQ(TargetGtIndices(frame, 3, 1), (std::vector<int>{1}));  // no gt_info: counts as seen
  EXPECT_TRUE(TargetGtIndices(frame, 9, 1).empty());
  EXPECT_TRUE(TargetGtIndices(frame, 7, 0).empty());
}

TEST(LoadBopDataset, ReadsLmo) {
  G6D_REQUIRE_SHARED_DATA("lmo");
  const BopDataset dataset = LoadBopDataset(test::SharedDataPath("lmo"));
  ASSERT_TRUE(dataset.camera.has_value());
  EXPECT_DOUBLE_EQ(dataset.camera->fx, 572.4114);
  EXPECT_EQ(dataset.camera->width, 640);
  EXPECT_EQ(dataset.camera->height, 480);
  EXPECT_DOUBLE_EQ(dataset.camera_depth_scale, 1.0);

  ASSERT_EQ(dataset.objects.size(), 8u);
  const std::set<int> ids = {1, 5, 6, 8, 9, 10, 11, 12};
  for (const auto& [obj_id, info] : dataset.objects) {
    EXPECT_TRUE(ids.count(obj_id)) << obj_id;
    EXPECT_EQ(info.name, BopObjectName(obj_id));
    EXPECT_EQ(fs::path(info.mesh_path).filename().string(), info.name + ".ply");
    EXPECT_TRUE(fs::exists(info.mesh_path)) << info.mesh_path;
    EXPECT_EQ(info.mesh_units, Units::kMillimetres);
    EXPECT_EQ(info.IsSymmetric(), obj_id == 10 || obj_id == 11) << obj_id;
  }
  const BopObjectInfo& ape = dataset.Object(1);
  EXPECT_NEAR(ape.diameter_m, 0.102099, 1e-12);
  EXPECT_NEAR(ape.box_m.min().x(), -0.0379343, 1e-12);
  EXPECT_NEAR(ape.box_m.sizes().z(), 0.091769, 1e-12);

  // Eggbox: one discrete symmetry, translation converted from mm.
  const BopObjectInfo& eggbox = dataset.Object(10);
  ASSERT_EQ(eggbox.symmetries_discrete.size(), 1u);
  EXPECT_NEAR(eggbox.symmetries_discrete[0].linear()(0, 0), -0.999964, 1e-12);
  EXPECT_NEAR(eggbox.symmetries_discrete[0].translation().y(), 0.000694388, 1e-12);
  EXPECT_EQ(eggbox.Symmetries().size(), 2u);
  EXPECT_THROW(dataset.Object(2), Error);

  EXPECT_TRUE(dataset.has_targets);
  EXPECT_EQ(dataset.targets.size(), 449u);
  EXPECT_EQ(dataset.targets[0].scene_id, 2);
  EXPECT_EQ(dataset.targets[0].im_id, 8);
  EXPECT_EQ(dataset.targets[0].inst_count, 1);
  EXPECT_EQ(dataset.scene_ids, std::vector<int>({2}));
}

TEST(LoadBopScene, ReadsLmoScene) {
  G6D_REQUIRE_SHARED_DATA("lmo");
  const BopScene scene = LoadBopScene(test::SharedDataPath("lmo"), 2);
  EXPECT_EQ(scene.scene_id, 2);
  EXPECT_EQ(scene.frames.size(), 62u);
  EXPECT_EQ(scene.InstanceCount(), 484);
  EXPECT_TRUE(
      std::is_sorted(scene.frames.begin(), scene.frames.end(),
                     [](const BopFrame& a, const BopFrame& b) { return a.im_id < b.im_id; }));

  std::set<int> objects;
  int with_info = 0;
  for (const BopFrame& frame : scene.frames) {
    EXPECT_DOUBLE_EQ(frame.depth_scale, 1.0);
    EXPECT_TRUE(frame.camera.Check().empty()) << frame.camera.Check();
    for (const BopGtInstance& gt : frame.gt) {
      objects.insert(gt.obj_id);
      with_info += gt.info.has_value();
    }
  }
  EXPECT_EQ(objects.size(), 8u);
  EXPECT_EQ(with_info, 484);

  const BopFrame& frame = scene.Frame(8);
  EXPECT_DOUBLE_EQ(frame.camera.fy, 573.57043);
  EXPECT_DOUBLE_EQ(frame.camera.cy, 242.04899);
  ASSERT_EQ(frame.gt.size(), 8u);
  const BopGtInstance& ape = frame.gt[0];
  EXPECT_EQ(ape.obj_id, 1);
  // Rotation kept as given (row-major), translation mm -> m.
  EXPECT_DOUBLE_EQ(ape.cam_from_object.linear()(0, 1), 0.43540977);
  EXPECT_DOUBLE_EQ(ape.cam_from_object.linear()(1, 0), 0.43772791);
  EXPECT_NEAR(ape.cam_from_object.translation().z(), 1.09718626032, 1e-12);
  ASSERT_TRUE(ape.info.has_value());
  EXPECT_EQ(ape.info->bbox_obj, (std::array<int, 4>{292, 218, 33, 39}));
  EXPECT_EQ(ape.info->px_count_visib, 716);
  EXPECT_NEAR(ape.info->visib_fract, 0.6806083650190115, 1e-15);
  EXPECT_THROW(scene.Frame(3), Error);  // held out

  // The GT object origin projects inside the silhouette box of every instance; instances
  // entirely outside the image (bbox_obj -1, BOP's convention) project outside it.
  int outside = 0;
  for (const BopFrame& f : scene.frames) {
    for (const BopGtInstance& gt : f.gt) {
      const Eigen::Vector2d uv = f.camera.Project(gt.cam_from_object.translation());
      const auto& box = gt.info->bbox_obj;
      if (box[0] == -1) {
        ++outside;
        EXPECT_TRUE(uv.x() < 0 || uv.y() < 0 || uv.x() > 640 || uv.y() > 480) << uv.transpose();
        continue;
      }
      EXPECT_GE(uv.x(), box[0]);
      EXPECT_LE(uv.x(), box[0] + box[2] + 1);
      EXPECT_GE(uv.y(), box[1]);
      EXPECT_LE(uv.y(), box[1] + box[3] + 1);
    }
  }
  EXPECT_LE(outside, 5);
}

TEST(LoadBopDepth, LmoDepthMatchesGroundTruthInsideMask) {
  G6D_REQUIRE_SHARED_DATA("lmo");
  const std::string root = test::SharedDataPath("lmo");
  const BopDataset dataset = LoadBopDataset(root);
  const BopScene scene = LoadBopScene(root, 2);
  const BopFrame& frame = scene.Frame(8);
  const cv::Mat depth = LoadBopDepth(scene, 8);
  ASSERT_EQ(depth.type(), CV_32FC1);
  EXPECT_EQ(depth.cols, 640);
  EXPECT_EQ(depth.rows, 480);
  const cv::Mat rgb = LoadBopRgb(scene, 8);
  EXPECT_EQ(rgb.type(), CV_8UC3);
  EXPECT_EQ(rgb.size(), depth.size());

  for (size_t i = 0; i < frame.gt.size(); ++i) {
    const BopGtInstance& gt = frame.gt[i];
    const cv::Mat mask = LoadBopMaskVisib(scene, 8, static_cast<int>(i));
    ASSERT_EQ(mask.type(), CV_8UC1);
    EXPECT_EQ(cv::countNonZero(mask), gt.info->px_count_visib);
    // Every valid depth inside the visible mask lies within one radius of the centre depth.
    const double centre_z = gt.cam_from_object.translation().z();
    const double radius = dataset.Object(gt.obj_id).diameter_m / 2.0;
    int valid = 0;
    for (int v = 0; v < mask.rows; ++v) {
      for (int u = 0; u < mask.cols; ++u) {
        const float z = depth.at<float>(v, u);
        if (mask.at<uint8_t>(v, u) == 0 || z == 0.0f) continue;
        ++valid;
        EXPECT_NEAR(z, centre_z, radius + 0.01) << "obj " << gt.obj_id << " at " << u << "," << v;
      }
    }
    EXPECT_GT(valid, gt.info->px_count_visib / 2);
  }
  EXPECT_THROW(LoadBopMaskVisib(scene, 8, 8), Error);
}

TEST(LoadBopDataset, ReadsYcbvMeshKeys) {
  G6D_REQUIRE_SHARED_DATA("ycbv_real");
  const BopDataset dataset = LoadBopDataset(test::SharedDataPath("ycbv_real"));
  ASSERT_EQ(dataset.objects.size(), 1u);
  const BopObjectInfo& brick = dataset.Object(21);
  EXPECT_EQ(brick.name, "obj_000021");
  EXPECT_EQ(brick.mesh_units, Units::kMetres);
  EXPECT_EQ(fs::path(brick.mesh_path), fs::path(test::SharedDataPath("ycbv_real")) / "models" /
                                           "061_foam_brick" / "textured.obj");
  EXPECT_NEAR(brick.diameter_m, 0.10296409535852779, 1e-12);
  EXPECT_FALSE(brick.IsSymmetric());
  ASSERT_TRUE(dataset.camera.has_value());
  EXPECT_DOUBLE_EQ(dataset.camera_depth_scale, 0.1);
  EXPECT_EQ(dataset.targets.size(), 5u);
  EXPECT_EQ(dataset.scene_ids, std::vector<int>({0}));
}

TEST(LoadBopScene, ReadsYcbvDepthScale) {
  G6D_REQUIRE_SHARED_DATA("ycbv_real");
  const std::string root = test::SharedDataPath("ycbv_real");
  const BopScene scene = LoadBopScene(root, 0);
  ASSERT_EQ(scene.frames.size(), 5u);
  EXPECT_EQ(scene.InstanceCount(), 5);
  for (const BopFrame& frame : scene.frames) {
    EXPECT_DOUBLE_EQ(frame.depth_scale, 0.1);
    EXPECT_DOUBLE_EQ(frame.camera.fx, 1066.778);
    ASSERT_EQ(frame.gt.size(), 1u);
    EXPECT_EQ(frame.gt[0].obj_id, 21);
  }
  const BopGtInstance& gt = scene.Frame(1).gt[0];
  EXPECT_NEAR(gt.cam_from_object.translation().z(), 0.5342229880488571, 1e-12);

  // Real depth: the median valid depth inside the visible mask is near the GT depth
  // (the README measures +4 mm median offset), which fails for a wrong depth_scale.
  const cv::Mat depth = LoadBopDepth(scene, 1);
  const cv::Mat mask = LoadBopMaskVisib(scene, 1, 0);
  std::vector<float> values;
  for (int v = 0; v < mask.rows; ++v) {
    for (int u = 0; u < mask.cols; ++u) {
      if (mask.at<uint8_t>(v, u) && depth.at<float>(v, u) > 0.0f)
        values.push_back(depth.at<float>(v, u));
    }
  }
  ASSERT_GT(values.size(), 1000u);
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  EXPECT_NEAR(values[values.size() / 2], gt.cam_from_object.translation().z(), 0.03);
}

// Mesh tests need LoadMesh (lib/mesh).
TEST(LoadBopDataset, YcbvMeshLoadsInMetresWithGivenDiameter) {
  G6D_REQUIRE_SHARED_DATA("ycbv_real");
  const BopDataset dataset = LoadBopDataset(test::SharedDataPath("ycbv_real"));
  const BopObjectInfo& brick = dataset.Object(21);
  const Mesh mesh = LoadMesh(brick.mesh_path, brick.mesh_units);
  EXPECT_NEAR(ComputeDiameter(mesh), brick.diameter_m, 0.001);
}

TEST(LoadBopDataset, LmoEggboxSymmetryMapsMeshOntoItself) {
  G6D_REQUIRE_SHARED_DATA("lmo");
  const std::string root = test::SharedDataPath("lmo");
  const BopDataset dataset = LoadBopDataset(root);
  const BopScene scene = LoadBopScene(root, 2);
  const BopObjectInfo& eggbox = dataset.Object(10);
  const Mesh mesh = LoadMesh(eggbox.mesh_path, eggbox.mesh_units);
  EXPECT_NEAR(ComputeDiameter(mesh), eggbox.diameter_m, 0.001);
  const BopGtInstance* gt = nullptr;
  for (const BopGtInstance& instance : scene.Frame(8).gt) {
    if (instance.obj_id == 10) gt = &instance;
  }
  ASSERT_NE(gt, nullptr);
  // The symmetric pose: same look (ADD-S small), different points (ADD large), MSSD 0.
  const Eigen::Isometry3d flipped = gt->cam_from_object * eggbox.symmetries_discrete[0];
  const double adds = ComputeAdds(flipped, gt->cam_from_object, mesh.vertices);
  const double add = ComputeAdd(flipped, gt->cam_from_object, mesh.vertices);
  EXPECT_LT(adds, 0.05 * eggbox.diameter_m);
  EXPECT_GT(add, 0.3 * eggbox.diameter_m);
  EXPECT_NEAR(ComputeMssd(flipped, gt->cam_from_object, mesh.vertices, eggbox.Symmetries()), 0.0,
              1e-9);
}

TEST(LoadBopScene, TinyDatasetConversions) {
  const TinyDataset tiny("bop_tiny");
  const BopDataset dataset = LoadBopDataset(tiny.root);
  EXPECT_FALSE(dataset.camera.has_value());
  EXPECT_FALSE(dataset.has_targets);
  EXPECT_EQ(dataset.scene_ids, std::vector<int>({1}));
  const BopObjectInfo& object = dataset.Object(3);
  EXPECT_NEAR(object.diameter_m, 0.1, 1e-15);
  EXPECT_TRUE(object.box_m.isEmpty());
  EXPECT_EQ(fs::path(object.mesh_path).filename().string(), "obj_000003.ply");
  ASSERT_EQ(object.symmetries_continuous.size(), 1u);
  EXPECT_NEAR(object.symmetries_continuous[0].offset_m.z(), 0.01, 1e-15);
  EXPECT_EQ(object.Symmetries().size(), 315u);

  const BopScene scene = LoadBopScene(tiny.root, 1);
  ASSERT_EQ(scene.frames.size(), 1u);
  const BopFrame& frame = scene.Frame(7);
  // No camera.json: the size comes from the RGB image.
  EXPECT_EQ(frame.camera.width, 4);
  EXPECT_EQ(frame.camera.height, 3);
  EXPECT_DOUBLE_EQ(frame.camera.fy, 510.0);
  EXPECT_DOUBLE_EQ(frame.camera.cx, 2.0);
  EXPECT_FALSE(frame.gt[0].info.has_value());
  EXPECT_TRUE(
      frame.gt[0].cam_from_object.translation().isApprox(Eigen::Vector3d(0.01, -0.02, 0.5)));

  // depth_mm = value * depth_scale (0.1), returned in metres.
  const cv::Mat depth = LoadBopDepth(scene, 7);
  EXPECT_FLOAT_EQ(depth.at<float>(1, 2), 0.1234f);
  EXPECT_FLOAT_EQ(depth.at<float>(2, 3), 6.5535f);
  EXPECT_EQ(depth.at<float>(0, 0), 0.0f);
  // RGB order.
  const cv::Mat rgb = LoadBopRgb(scene, 7);
  EXPECT_EQ(rgb.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 255));
  const cv::Mat mask = LoadBopMaskVisib(scene, 7, 0);
  EXPECT_EQ(cv::countNonZero(mask), 1);
  EXPECT_THAT(ErrorOf([&] { LoadBopMask(scene, 7, 0); }), HasSubstr("000007_000000.png"));
  EXPECT_THAT(ErrorOf([&] { LoadBopDepth(scene, 8); }), HasSubstr("image 8"));
}

TEST(LoadBopScene, MissingSceneGtNamesFile) {
  const TinyDataset tiny("bop_missing_gt");
  fs::remove(tiny.scene / "scene_gt.json");
  EXPECT_THAT(ErrorOf([&] { LoadBopScene(tiny.root, 1); }),
              AllOf(HasSubstr("scene_gt.json"), HasSubstr("missing")));
  EXPECT_THAT(ErrorOf([&] { LoadBopScene(tiny.root, 2); }), HasSubstr("000002"));
}

TEST(LoadBopScene, MalformedJsonNamesFile) {
  const TinyDataset tiny("bop_malformed");
  WriteText(tiny.scene / "scene_gt.json", R"({"7": [{"cam_R_m2c": [1, 0, )");
  EXPECT_THAT(ErrorOf([&] { LoadBopScene(tiny.root, 1); }),
              AllOf(HasSubstr("malformed JSON"), HasSubstr("scene_gt.json")));
}

TEST(LoadBopScene, BadFieldsNameFileAndField) {
  const TinyDataset tiny("bop_bad_fields");
  WriteText(
      tiny.scene / "scene_gt.json",
      R"({"7": [{"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0], "cam_t_m2c": [0, 0, 1], "obj_id": 3}]})");
  EXPECT_THAT(ErrorOf([&] { LoadBopScene(tiny.root, 1); }),
              AllOf(HasSubstr("scene_gt.json"), HasSubstr("7[0].cam_R_m2c"),
                    HasSubstr("expected a list of 9 numbers, got 8 elements")));

  WriteText(tiny.scene / "scene_gt.json",
            R"({"7": [{"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 1]}]})");
  EXPECT_THAT(ErrorOf([&] { LoadBopScene(tiny.root, 1); }), HasSubstr("7[0].obj_id' is missing"));

  WriteText(
      tiny.scene / "scene_gt.json",
      R"({"9": [{"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 1], "obj_id": 3}]})");
  EXPECT_THAT(ErrorOf([&] { LoadBopScene(tiny.root, 1); }),
              AllOf(HasSubstr("image 9"), HasSubstr("scene_camera.json")));

  WriteText(tiny.scene / "scene_camera.json", R"({"7": {"cam_K": "K", "depth_scale": 0.1}})");
  EXPECT_THAT(ErrorOf([&] { LoadBopScene(tiny.root, 1); }),
              AllOf(HasSubstr("scene_camera.json"), HasSubstr("7.cam_K")));
}

TEST(LoadBopScene, GtInfoLengthMismatchNamesFile) {
  const TinyDataset tiny("bop_info_mismatch");
  WriteText(tiny.scene / "scene_gt_info.json", R"({"7": []})");
  EXPECT_THAT(ErrorOf([&] { LoadBopScene(tiny.root, 1); }),
              AllOf(HasSubstr("scene_gt_info.json"), HasSubstr("expected a list of 1 entries")));
}

TEST(LoadBopDataset, BadModelsInfoNamesField) {
  const TinyDataset tiny("bop_bad_models");
  const fs::path info = fs::path(tiny.root) / "models" / "models_info.json";
  WriteText(info, R"({"3": {"size_x": 1}})");
  EXPECT_THAT(ErrorOf([&] { LoadBopDataset(tiny.root); }),
              AllOf(HasSubstr("models_info.json"), HasSubstr("3.diameter' is missing")));
  WriteText(info, R"({"3": {"diameter": 50, "units": "cm"}})");
  EXPECT_THAT(ErrorOf([&] { LoadBopDataset(tiny.root); }),
              AllOf(HasSubstr("models_info.json"), HasSubstr("3.units")));
  WriteText(info, R"({"3": {"diameter": 50, "symmetries_discrete": [[1, 0, 0]]}})");
  EXPECT_THAT(ErrorOf([&] { LoadBopDataset(tiny.root); }),
              HasSubstr("3.symmetries_discrete[0]': expected a list of 16 numbers"));
  WriteText(info, R"({"x3": {"diameter": 50}})");
  EXPECT_THAT(ErrorOf([&] { LoadBopDataset(tiny.root); }), HasSubstr("key 'x3'"));
  fs::remove(info);
  EXPECT_THAT(ErrorOf([&] { LoadBopDataset(tiny.root); }),
              AllOf(HasSubstr("models_info.json"), HasSubstr("missing")));
  EXPECT_THAT(ErrorOf([&] { LoadBopDataset(tiny.root + "/nope"); }), HasSubstr("nope"));
}

TEST(LoadBopDataset, MalformedTargetsNameFile) {
  const TinyDataset tiny("bop_bad_targets");
  WriteText(fs::path(tiny.root) / "test_targets_bop19.json", R"([{"scene_id": 1, "im_id": 7}])");
  EXPECT_THAT(ErrorOf([&] { LoadBopDataset(tiny.root); }),
              AllOf(HasSubstr("test_targets_bop19.json"), HasSubstr("[0].obj_id' is missing")));
}

// The text entry points name the source and field as the loaders name the file.
TEST(ParseBopSceneFrames, ParsesTextsAndNamesSources) {
  const std::string camera = R"({"8": {"cam_K": [500, 0, 320, 0, 510, 240, 0, 0, 1]},
                                 "3": {"cam_K": [500, 0, 320, 0, 510, 240, 0, 0, 1], "depth_scale": 0.1}})";
  const std::string gt =
      R"({"3": [{"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 800], "obj_id": 5}]})";
  const std::string info = R"({"3": [{"px_count_all": 10, "visib_fract": 0.5}]})";
  const std::vector<BopFrame> frames = ParseBopSceneFrames(camera, gt, info, 640, 480);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].im_id, 3);
  EXPECT_EQ(frames[0].depth_scale, 0.1);
  EXPECT_EQ(frames[0].camera.width, 640);
  EXPECT_EQ(frames[0].camera.fy, 510.0);
  ASSERT_EQ(frames[0].gt.size(), 1u);
  EXPECT_NEAR(frames[0].gt[0].cam_from_object.translation().z(), 0.8, 1e-12);
  ASSERT_TRUE(frames[0].gt[0].info.has_value());
  EXPECT_EQ(frames[0].gt[0].info->px_count_all, 10);
  EXPECT_TRUE(frames[1].gt.empty());
  BopSceneSources sources;
  sources.gt = "my_gt.json";
  EXPECT_THAT(
      ErrorOf([&] { ParseBopSceneFrames(camera, "{\"3\": 5}", std::nullopt, 0, 0, sources); }),
      AllOf(HasSubstr("my_gt.json: field '3'"), HasSubstr("expected a list")));
  EXPECT_THAT(ErrorOf([&] { ParseBopCamera(R"({"fx": 1})", "cam text"); }),
              HasSubstr("cam text: field 'fy' is missing"));
  const std::map<int, BopObjectInfo> objects =
      ParseBopModelsInfo(R"({"5": {"diameter": 120}})", "info text", "/models");
  ASSERT_EQ(objects.count(5), 1u);
  EXPECT_EQ(objects.at(5).mesh_path, "/models/obj_000005.ply");
  EXPECT_NEAR(objects.at(5).diameter_m, 0.12, 1e-12);
}

// Found in review while hardening for fuzzing (input in
// tests/fuzz/regressions/bop_json/deeply-nested-value): error messages held value.dump(), which
// recurses once per nesting level, so a wrong-typed value nested 10^5 deep (which the parser
// accepts without recursing) overflowed the stack; a huge value also made a huge message. Now a
// message names only the type and size of a list or object.
TEST(ParseBopTargets, FuzzDeeplyNestedValueInErrorMessage) {
  const int depth = 200000;
  const std::string text = R"([{"im_id": 3, "inst_count": 1, "obj_id": 1, "scene_id": )" +
                           std::string(depth, '[') + std::string(depth, ']') + "}]";
  const std::string message = ErrorOf([&] { ParseBopTargets(text, "targets"); });
  EXPECT_THAT(message, HasSubstr("targets: field '[0].scene_id': expected an integer, got a list "
                                 "of 1 elements"));
  EXPECT_LT(message.size(), 200u);
  std::string long_list = "[1";
  for (int i = 1; i < 5000; ++i) long_list += ",1";
  const std::string long_mesh = R"({"1": {"diameter": 10, "mesh": )" + long_list + "]}}";
  const std::string mesh_message = ErrorOf([&] { ParseBopModelsInfo(long_mesh, "info", "m"); });
  EXPECT_THAT(mesh_message,
              HasSubstr("expected a non-empty path string, got a list of 5000 elements"));
  EXPECT_LT(mesh_message.size(), 200u);
  // A long string is cut, and cutting inside a UTF-8 sequence must not make dump() throw.
  const std::string gt_info = R"({"1": [{"bbox_obj": [1, 2, 3, ")" + std::string(39, 'x') +
                              "\u00e9" + std::string(100, 'y') + R"("]}]})";
  const std::string camera = R"({"1": {"cam_K": [1, 0, 0, 0, 1, 0, 0, 0, 1]}})";
  const std::string gt =
      R"({"1": [{"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 1], "obj_id": 1}]})";
  const std::string cut_message = ErrorOf([&] { ParseBopSceneFrames(camera, gt, gt_info, 0, 0); });
  EXPECT_THAT(cut_message, AllOf(HasSubstr("bbox_obj[3]': expected an integer, got string \""),
                                 HasSubstr("... (141 bytes)")));
}

// Found in review while hardening for fuzzing (input in
// tests/fuzz/regressions/bop_json/integer-beyond-int): get<int>() wrapped integers outside
// int silently (4294967299 became 3).
TEST(ParseBopTargets, FuzzIntegerBeyondIntIsAnError) {
  EXPECT_THAT(
      ErrorOf([&] {
        ParseBopTargets(R"([{"im_id": 4294967299, "inst_count": 1, "obj_id": 1, "scene_id": 2}])",
                        "targets");
      }),
      AllOf(HasSubstr("targets: field '[0].im_id'"), HasSubstr("4294967299 is out of range")));
  EXPECT_THAT(ErrorOf([&] {
                ParseBopTargets(
                    R"([{"im_id": -2147483649, "inst_count": 1, "obj_id": 1, "scene_id": 2}])",
                    "t");
              }),
              HasSubstr("-2147483649 is out of range"));
  EXPECT_THAT(ErrorOf([&] {
                ParseBopCamera(
                    R"({"fx": 1, "fy": 1, "cx": 0, "cy": 0, "width": 18446744073709551615,
                                   "height": 480})",
                    "camera");
              }),
              AllOf(HasSubstr("camera: field 'width'"), HasSubstr("out of range")));
  const std::vector<BopTarget> targets = ParseBopTargets(
      R"([{"im_id": 2147483647, "inst_count": 1, "obj_id": -2147483648, "scene_id": 0}])", "t");
  ASSERT_EQ(targets.size(), 1u);
  EXPECT_EQ(targets[0].im_id, 2147483647);
  EXPECT_EQ(targets[0].obj_id, -2147483648);
}

}  // namespace
}  // namespace g6d
