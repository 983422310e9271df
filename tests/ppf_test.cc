// Point-pair features: the model's geometry helpers, the table, and the vote on rendered
// depth (templates/ppf_model.h, solver/ppf.h).
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/executor.h"
#include "render/raster.h"
#include "solver/ppf.h"
#include "templates/ppf_model.h"
#include "test_meshes.h"

namespace g6d {
namespace {

using test::AxisAngle;
using test::LmoCamera;
using test::MakeCube;

// Two boxes joined off-centre: an object with no symmetry, 50 + 30 mm long.
Mesh MakeLShape() {
  Mesh mesh = MakeCube(0.025);
  Mesh small = MakeCube(0.015);
  const int offset = static_cast<int>(mesh.vertices.size());
  for (Eigen::Vector3f v : small.vertices) mesh.vertices.push_back(v + Eigen::Vector3f(0.035f, 0.012f, -0.01f));
  for (const Eigen::Vector3i& f : small.faces) mesh.faces.push_back(f + Eigen::Vector3i::Constant(offset));
  return mesh;
}

constexpr double kLShapeDiameter = 0.1;  // a bound, as ComputeDiameter would give about 0.09

// Fraction of the pixels of `truth` (depth, metres) where the mesh at `pose` has depth
// within `tolerance_m`: equal for poses that look the same (symmetries included).
double DepthAgreement(const Mesh& mesh, const Camera& camera, const Eigen::Isometry3d& pose, const cv::Mat& truth,
                      double tolerance_m) {
  RasterImage raster;
  Rasterize(mesh, camera, pose, RasterOptions{}, &raster);
  int pixels = 0, agree = 0;
  for (int v = 0; v < truth.rows; ++v) {
    for (int u = 0; u < truth.cols; ++u) {
      const float z = truth.at<float>(v, u);
      if (!(z > 0.0f)) continue;
      ++pixels;
      agree += std::abs(raster.depth.at<float>(v, u) - z) < tolerance_m;
    }
  }
  return pixels > 0 ? static_cast<double>(agree) / pixels : 0.0;
}

TEST(PpfReferenceFrame, TakesThePointToTheOriginAndTheNormalOntoX) {
  std::mt19937 random(3);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3f p(normal(random), normal(random), normal(random));
    Eigen::Vector3f n(normal(random), normal(random), normal(random));
    if (trial == 0) n = -Eigen::Vector3f::UnitX();  // the degenerate axis
    n.normalize();
    const Eigen::Isometry3f frame = PpfReferenceFrame(p, n);
    EXPECT_LT((frame * p).norm(), 1e-5f);
    EXPECT_LT((frame.linear() * n - Eigen::Vector3f::UnitX()).norm(), 1e-5f);
    EXPECT_NEAR(frame.linear().determinant(), 1.0f, 1e-5f);
    // Alpha turns any point about +x into the half-plane z = 0, y > 0.
    const Eigen::Vector3f q = frame * Eigen::Vector3f(normal(random), normal(random), normal(random));
    const Eigen::Vector3f turned = Eigen::AngleAxisf(PpfAlpha(q), Eigen::Vector3f::UnitX()) * q;
    EXPECT_NEAR(turned.z(), 0.0f, 1e-5f);
    EXPECT_GE(turned.y(), 0.0f);
  }
}

TEST(PpfAngleUnits, WrapsAndDifferencesWrap) {
  EXPECT_EQ(PpfAngleUnits(0.0f), 0);
  EXPECT_EQ(PpfAngleUnits(static_cast<float>(M_PI / 2)), 16384);
  EXPECT_EQ(PpfAngleUnits(static_cast<float>(-M_PI / 2)), -16384);
  EXPECT_EQ(PpfAngleUnits(static_cast<float>(2.5 * M_PI)), 16384);
  // 170 - (-170) degrees is -20 degrees once wrapped.
  const int16_t difference = static_cast<int16_t>(PpfAngleUnits(static_cast<float>(170 * M_PI / 180)) -
                                                  PpfAngleUnits(static_cast<float>(-170 * M_PI / 180)));
  EXPECT_NEAR(difference * 360.0 / 65536.0, -20.0, 0.01);
}

TEST(BuildPpfModel, SamplesTheSurfaceWithOutwardNormalsAndFillsTheTable) {
  const Mesh cube = MakeCube(0.05);
  PpfModelOptions options;
  const PpfModel model = BuildPpfModel(cube, 0.1 * std::sqrt(3.0), options);
  ASSERT_GT(model.points.size(), 100u);
  ASSERT_LE(static_cast<int>(model.points.size()), options.max_points);
  for (size_t i = 0; i < model.points.size(); ++i) {
    // On the surface (one coordinate at +-5 cm) with the normal pointing out of it.
    EXPECT_NEAR(model.points[i].cwiseAbs().maxCoeff(), 0.05f, 1e-3f);
    EXPECT_NEAR(model.normals[i].norm(), 1.0f, 1e-4f);
    EXPECT_GT(model.normals[i].dot(model.points[i]), 0.0f);
  }
  // Every ordered pair closer than the table's reach is in it once.
  const size_t n = model.points.size();
  EXPECT_EQ(model.entries.size(), n * (n - 1));
  EXPECT_EQ(model.offsets.back(), model.entries.size());
  EXPECT_EQ(model.alpha_bins, 30);
}

TEST(BuildPpfModel, KeepsTheTwoSidesOfAThinSheetApart) {
  // A 2 mm plate: both faces fall in the same voxels, with opposite normals.
  Mesh plate = MakeCube(0.5);
  for (Eigen::Vector3f& v : plate.vertices) v = Eigen::Vector3f(v.x() * 0.1f, v.y() * 0.1f, v.z() * 0.002f);
  const PpfModel model = BuildPpfModel(plate, 0.15, PpfModelOptions{});
  int up = 0, down = 0;
  for (const Eigen::Vector3f& normal : model.normals) {
    up += normal.z() > 0.9f;
    down += normal.z() < -0.9f;
  }
  EXPECT_GT(up, 20);
  EXPECT_NEAR(up, down, 0.2 * up);
}

TEST(BuildPpfModel, RefusesBadOptions) {
  PpfModelOptions options;
  options.step_fraction = 0.0;
  EXPECT_THROW(BuildPpfModel(MakeCube(0.05), 0.17, options), Error);
  EXPECT_NE(options.Check().find("ppf.step_fraction"), std::string::npos);
}

class PpfVote : public ::testing::TestWithParam<int> {};

TEST_P(PpfVote, FindsAnAsymmetricObjectInRenderedDepth) {
  const Mesh mesh = MakeLShape();
  const PpfModel model = BuildPpfModel(mesh, kLShapeDiameter, PpfModelOptions{});
  const Camera camera = LmoCamera();
  std::mt19937 random(static_cast<uint32_t>(GetParam()));
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = AxisAngle(angle(random), Eigen::Vector3d(angle(random), angle(random), angle(random)));
  truth.translation() = Eigen::Vector3d(0.03, -0.02, 0.7);
  RasterImage raster;
  Rasterize(mesh, camera, truth, RasterOptions{}, &raster);
  // Sensor-like noise: sigma 1.5 mm at 0.7 m.
  cv::Mat depth = raster.depth.clone();
  std::normal_distribution<float> noise(0.0f, 0.0015f);
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      if (depth.at<float>(v, u) > 0.0f) depth.at<float>(v, u) += noise(random);
    }
  }
  const PpfSearchOptions options;
  const PpfScene scene = MakePpfScene(camera, depth, raster.Mask(), model.step_m, model.options.normal_cluster_deg, options);
  ASSERT_GT(scene.points.size(), 30u);
  for (size_t i = 0; i < scene.points.size(); ++i) EXPECT_LT(scene.normals[i].dot(scene.points[i]), 0.0f);
  PpfReport report;
  InlineExecutor inline_executor;
  const std::vector<PpfPose> poses = VotePpfPoses(model, scene, kLShapeDiameter, options, &inline_executor, &report);
  ASSERT_FALSE(poses.empty());
  EXPECT_GT(report.votes, 0);
  // The best of the first three explains the depth (before any refinement: within about
  // one sampling step).
  double best_agreement = 0.0;
  for (size_t k = 0; k < std::min<size_t>(3, poses.size()); ++k) {
    best_agreement = std::max(best_agreement, DepthAgreement(mesh, camera, poses[k].cam_from_object, raster.depth, 0.008));
  }
  EXPECT_GT(best_agreement, 0.6) << "report: scene " << report.scene_points << " refs " << report.reference_points
                                 << " clusters " << report.clusters;
  // Any thread count gives the same poses.
  ThreadPool pool(2);
  const std::vector<PpfPose> pooled = VotePpfPoses(model, scene, kLShapeDiameter, options, &pool, nullptr);
  ASSERT_EQ(pooled.size(), poses.size());
  for (size_t k = 0; k < poses.size(); ++k) {
    EXPECT_TRUE(pooled[k].cam_from_object.isApprox(poses[k].cam_from_object));
    EXPECT_EQ(pooled[k].votes, poses[k].votes);
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, PpfVote, ::testing::Values(1, 2, 3, 4, 5));

TEST(PpfReferenceSupport, IsHigherOnTheObjectThanOnACylinderBesideIt) {
  const Mesh mesh = MakeLShape();
  const PpfModel model = BuildPpfModel(mesh, kLShapeDiameter, PpfModelOptions{});
  const Camera camera = LmoCamera();
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = AxisAngle(0.7, Eigen::Vector3d(1.0, 2.0, 0.5));
  truth.translation() = Eigen::Vector3d(0.05, 0.0, 0.7);
  RasterImage raster;
  Rasterize(mesh, camera, truth, RasterOptions{}, &raster);
  // A lying cylinder (radius 4 cm, axis along the image's rows) left of the object: a surface
  // of the object's size but not of its shape.
  cv::Mat depth = raster.depth.clone();
  const cv::Rect object_box = cv::boundingRect(raster.Mask());
  const int cylinder_right = object_box.x - 10;
  ASSERT_GT(cylinder_right, 150);
  const double radius = 0.04, axis_z = 0.72, focal = camera.fx;
  for (int v = 140; v < 340; ++v) {
    for (int u = cylinder_right - 100; u < cylinder_right; ++u) {
      // Across the cylinder: x in the camera frame at its front, about (u - centre) z / f.
      const double x = (u - (cylinder_right - 50)) * (axis_z - radius) / focal;
      if (std::abs(x) >= radius) continue;
      depth.at<float>(v, u) = static_cast<float>(axis_z - std::sqrt(radius * radius - x * x));
    }
  }
  const PpfSearchOptions options;
  const PpfScene scene = MakePpfScene(camera, depth, cv::Mat(), model.step_m, model.options.normal_cluster_deg, options);
  std::vector<int> on_object, on_cylinder;
  for (size_t i = 0; i < scene.points.size(); ++i) {
    const Eigen::Vector2d uv = camera.Project(scene.points[i].cast<double>());
    (uv.x() < cylinder_right ? on_cylinder : on_object).push_back(static_cast<int>(i));
  }
  ASSERT_GT(on_object.size(), 20u);
  ASSERT_GT(on_cylinder.size(), 20u);
  InlineExecutor executor;
  auto median = [&](const std::vector<int>& references) {
    std::vector<float> support = PpfReferenceSupport(model, scene, references, options, &executor);
    std::nth_element(support.begin(), support.begin() + static_cast<long>(support.size() / 2), support.end());
    return support[support.size() / 2];
  };
  const float object_support = median(on_object), cylinder_support = median(on_cylinder);
  EXPECT_GT(object_support, 1.3f * cylinder_support) << "object " << object_support << ", cylinder " << cylinder_support;
  // Any thread count gives the same support; a reference out of range has none.
  ThreadPool pool(2);
  std::vector<int> references = on_object;
  references.push_back(-1);
  const std::vector<float> inline_support = PpfReferenceSupport(model, scene, references, options, &executor);
  EXPECT_EQ(PpfReferenceSupport(model, scene, references, options, &pool), inline_support);
  EXPECT_EQ(inline_support.back(), 0.0f);
}

TEST(VotePpfPoses, GivesNothingForAnEmptyScene) {
  const PpfModel model = BuildPpfModel(MakeCube(0.05), 0.17, PpfModelOptions{});
  InlineExecutor executor;
  PpfReport report;
  EXPECT_TRUE(VotePpfPoses(model, PpfScene{}, 0.17, PpfSearchOptions{}, &executor, &report).empty());
  EXPECT_EQ(report.scene_points, 0);
}

}  // namespace
}  // namespace g6d
