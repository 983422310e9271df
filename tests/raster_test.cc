// Tests of the CPU rasterizer: analytic depth (face-on cube, tilted plane), sphere
// silhouette area, face ids, cropped/scaled cameras, watertightness, LM-O GT masks.

#include "render/raster.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/se3.h"
#include "test_meshes.h"
#include "test_util.h"

namespace g6d {
namespace {

using test::AxisAngle;
using test::LmoCamera;
using test::MakeCube;
using test::MakeUvSphere;
using test::MaskIoU;

// Square [-half, half]^2 in the plane z = 0 split into n x n cells of two triangles,
// normal +z. `jitter` moves interior vertices in the plane by up to that fraction of a cell.
Mesh MakeGrid(double half_size_m, int n, double jitter = 0.0, uint64_t seed = 7) {
  Mesh mesh;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const double cell = 2.0 * half_size_m / n;
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= n; ++j) {
      double x = -half_size_m + j * cell;
      double y = -half_size_m + i * cell;
      if (i > 0 && i < n && j > 0 && j < n) {
        x += jitter * cell * uniform(rng);
        y += jitter * cell * uniform(rng);
      }
      mesh.vertices.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.0f);
    }
  }
  auto index = [&](int i, int j) { return i * (n + 1) + j; };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      // Alternate the diagonal so edges in both diagonal directions are exercised.
      if ((i + j) % 2 == 0) {
        mesh.faces.emplace_back(index(i, j), index(i, j + 1), index(i + 1, j + 1));
        mesh.faces.emplace_back(index(i, j), index(i + 1, j + 1), index(i + 1, j));
      } else {
        mesh.faces.emplace_back(index(i, j), index(i, j + 1), index(i + 1, j));
        mesh.faces.emplace_back(index(i, j + 1), index(i + 1, j + 1), index(i + 1, j));
      }
    }
  }
  return mesh;
}

// z of the camera-frame plane (normal n through point p) on the ray through pixel (u, v).
double RayPlaneDepth(const Camera& camera, int u, int v, const Eigen::Vector3d& normal,
                     const Eigen::Vector3d& point) {
  const Eigen::Vector3d ray = camera.Ray(PixelCentre(u, v));
  return normal.dot(point) / normal.dot(ray);
}

TEST(Rasterize, CubeFaceOnDepthIsExactlyThePlane) {
  const Camera camera = LmoCamera();
  const double half = 0.05;
  const Eigen::Vector3d t(0.0123, -0.0071, 0.5);
  RasterImage image;
  Rasterize(MakeCube(half), camera, MakePose(Eigen::Matrix3d::Identity(), t), {}, &image);

  // The face z = t.z - half is seen face-on; count the pixel centres inside its projection.
  const double z_front = t.z() - half;
  int expected = 0;
  double max_error = 0.0;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const Eigen::Vector3d p = camera.Backproject(PixelCentre(u, v), z_front);
      const bool inside = std::abs(p.x() - t.x()) < half && std::abs(p.y() - t.y()) < half;
      expected += inside ? 1 : 0;
      const float depth = image.depth.at<float>(v, u);
      EXPECT_EQ(inside, depth > 0.0f) << "pixel " << u << "," << v;
      if (depth > 0.0f) max_error = std::max(max_error, std::abs(depth - z_front));
    }
  }
  EXPECT_EQ(image.pixel_count, expected);
  EXPECT_LT(max_error, 1e-5);
}

TEST(Rasterize, TiltedPlaneDepthMatchesRayPlaneIntersection) {
  const Camera camera = LmoCamera();
  const Eigen::Matrix3d rotation = AxisAngle(0.9, Eigen::Vector3d(1.0, 0.4, 0.2));
  const Eigen::Vector3d t(-0.02, 0.015, 0.8);
  RasterImage image;
  Rasterize(MakeGrid(0.1, 4), camera, MakePose(rotation, t), {}, &image);
  ASSERT_GT(image.pixel_count, 1000);

  const Eigen::Vector3d normal = rotation.col(2);
  double max_error = 0.0;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const float depth = image.depth.at<float>(v, u);
      if (depth <= 0.0f) continue;
      max_error = std::max(max_error, std::abs(depth - RayPlaneDepth(camera, u, v, normal, t)));
    }
  }
  EXPECT_LT(max_error, 1e-5);
}

// Area in pixels of the ellipse that is the image of a sphere (centre in camera frame,
// radius): the tangent cone x^T (c c^T - cos^2(alpha) I) x = 0 mapped through K^-1.
double ProjectedSphereArea(const Camera& camera, const Eigen::Vector3d& centre, double radius) {
  const Eigen::Vector3d c = centre.normalized();
  const double cos2 = 1.0 - radius * radius / centre.squaredNorm();
  const Eigen::Matrix3d cone = c * c.transpose() - cos2 * Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d k_inv = camera.K().inverse();
  const Eigen::Matrix3d conic = k_inv.transpose() * cone * k_inv;
  const double det_2x2 = conic.topLeftCorner<2, 2>().determinant();
  return M_PI * std::abs(conic.determinant()) / std::pow(det_2x2, 1.5);
}

TEST(Rasterize, SphereSilhouetteAreaMatchesProjectedEllipse) {
  const Camera camera = LmoCamera();
  const double radius = 0.05;
  const Mesh sphere = MakeUvSphere(radius, 96, 192);
  RasterImage image;
  for (const Eigen::Vector3d& centre :
       {Eigen::Vector3d(0.0, 0.0, 0.6), Eigen::Vector3d(0.18, -0.12, 0.55),
        Eigen::Vector3d(-0.3, 0.2, 0.9)}) {
    Rasterize(sphere, camera, MakePose(AxisAngle(0.3, Eigen::Vector3d(1, 2, 3)), centre), {}, &image);
    const double expected = ProjectedSphereArea(camera, centre, radius);
    EXPECT_NEAR(image.pixel_count / expected, 1.0, 0.01)
        << "centre " << centre.transpose() << ": " << image.pixel_count << " px vs " << expected;
  }
}

TEST(Rasterize, FaceIdsAreValidAndMatchTheirPlanes) {
  const Camera camera = LmoCamera();
  const Mesh sphere = MakeUvSphere(0.06, 24, 48);
  const Eigen::Isometry3d pose =
      MakePose(AxisAngle(1.1, Eigen::Vector3d(0.3, -1, 0.5)), Eigen::Vector3d(0.03, 0.02, 0.7));
  RasterImage image;
  Rasterize(sphere, camera, pose, {}, &image);
  ASSERT_EQ(image.face_id.type(), CV_32S);
  ASSERT_GT(image.pixel_count, 1000);
  int checked = 0;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const int face = image.face_id.at<int>(v, u);
      const float depth = image.depth.at<float>(v, u);
      if (depth == 0.0f) {
        EXPECT_EQ(face, -1);
        continue;
      }
      ASSERT_GE(face, 0);
      ASSERT_LT(face, static_cast<int>(sphere.faces.size()));
      const Eigen::Vector3i& f = sphere.faces[face];
      const Eigen::Vector3d a = pose * sphere.vertices[f[0]].cast<double>();
      const Eigen::Vector3d b = pose * sphere.vertices[f[1]].cast<double>();
      const Eigen::Vector3d c = pose * sphere.vertices[f[2]].cast<double>();
      const Eigen::Vector3d normal = (b - a).cross(c - a).normalized();
      // The visible face of a convex mesh faces the camera.
      EXPECT_LT(normal.dot(a), 0.0);
      EXPECT_NEAR(depth, RayPlaneDepth(camera, u, v, normal, a), 1e-5);
      ++checked;
    }
  }
  EXPECT_EQ(checked, image.pixel_count);
}

TEST(Rasterize, CroppedCameraEqualsCropOfFullRender) {
  const Camera camera = LmoCamera();
  const Mesh sphere = MakeUvSphere(0.05, 32, 64);
  const Eigen::Isometry3d pose =
      MakePose(AxisAngle(0.7, Eigen::Vector3d(1, 1, 0)), Eigen::Vector3d(0.04, -0.03, 0.65));
  RasterImage full, crop;
  Rasterize(sphere, camera, pose, {}, &full);
  const cv::Rect roi(300, 170, 128, 128);
  Rasterize(sphere, camera.Cropped(roi.x, roi.y, roi.width, roi.height), pose, {}, &crop);
  ASSERT_EQ(crop.depth.size(), roi.size());
  EXPECT_EQ(cv::countNonZero(full.Mask()(roi) != crop.Mask()), 0);
  EXPECT_EQ(cv::countNonZero(full.face_id(roi) != crop.face_id), 0);
  EXPECT_LT(cv::norm(full.depth(roi), crop.depth, cv::NORM_INF), 1e-6);
}

TEST(Rasterize, ScaledCameraApproximatesResizedFullRender) {
  const Camera camera = LmoCamera();
  const Mesh sphere = MakeUvSphere(0.05, 48, 96);
  const Eigen::Isometry3d pose = MakePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 0.6));
  RasterImage full, half;
  Rasterize(sphere, camera, pose, {}, &full);
  const Camera scaled = camera.Scaled(0.5);
  Rasterize(sphere, scaled, pose, {}, &half);
  ASSERT_EQ(half.depth.cols, 320);
  ASSERT_EQ(half.depth.rows, 240);

  // Under the pixel-centre convention a half-size pixel is exactly a 2x2 block of full ones.
  cv::Mat coverage;
  cv::resize(full.Mask(), coverage, half.depth.size(), 0, 0, cv::INTER_AREA);
  const cv::Mat resized_mask = coverage >= 128;
  EXPECT_GT(MaskIoU(resized_mask, half.Mask()), 0.97);
  EXPECT_NEAR(half.pixel_count * 4.0 / full.pixel_count, 1.0, 0.02);

  // Depth away from the silhouette: the sphere is smooth at this scale.
  cv::Mat interior;
  cv::erode(half.Mask() & resized_mask, interior, cv::Mat::ones(5, 5, CV_8U));
  cv::Mat full_depth_resized;
  cv::resize(full.depth, full_depth_resized, half.depth.size(), 0, 0, cv::INTER_AREA);
  cv::Mat difference;
  cv::absdiff(full_depth_resized, half.depth, difference);
  double max_difference = 0.0;
  cv::minMaxLoc(difference, nullptr, &max_difference, nullptr, nullptr, interior);
  EXPECT_LT(max_difference, 1e-3);
}

TEST(Rasterize, SharedEdgesThroughPixelCentresLeaveNoCracksNorOverlaps) {
  // Grid vertices land exactly on pixel centres, so every shared edge passes through
  // pixel centres: the fill rule must give each of them to exactly one triangle.
  Camera camera;
  camera.fx = camera.fy = 200.0;
  camera.cx = camera.cy = 32.5;  // vertex (x, y) at z = 1 lands on pixel centre of 32+200x
  camera.width = camera.height = 64;
  const int n = 10;
  const Mesh grid = MakeGrid(0.1, n);  // 0.02 m cells = 4 px
  const Eigen::Isometry3d pose = MakePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 1));

  RasterImage single;
  cv::Mat counts = cv::Mat::zeros(camera.height, camera.width, CV_32S);
  for (size_t f = 0; f < grid.faces.size(); ++f) {
    Mesh one;
    one.vertices = grid.vertices;
    one.faces = {grid.faces[f]};
    Rasterize(one, camera, pose, {}, &single);
    cv::Mat covered;
    single.Mask().convertTo(covered, CV_32S, 1.0 / 255.0);
    counts += covered;
  }
  // Pixel centres with x in [12.5, 52.5] map into the grid; strictly inside ones and
  // the ones on shared interior edges must be hit exactly once.
  for (int v = 13; v <= 51; ++v) {
    for (int u = 13; u <= 51; ++u) {
      EXPECT_EQ(counts.at<int>(v, u), 1) << "pixel " << u << "," << v;
    }
  }
  // Whole-mesh rendering covers the same pixels.
  RasterImage whole;
  Rasterize(grid, camera, pose, {}, &whole);
  EXPECT_EQ(cv::countNonZero(whole.Mask() != (counts > 0)), 0);
}

TEST(Rasterize, FinelyTessellatedTiltedPlaneHasNoCracks) {
  const Camera camera = LmoCamera();
  const double half = 0.15;
  const Mesh grid = MakeGrid(half, 120, 0.3);  // 28800 jittered triangles, ~1-2 px each
  const Eigen::Matrix3d rotation = AxisAngle(0.5, Eigen::Vector3d(0.2, 1, 0.1));
  const Eigen::Vector3d t(0.01, -0.02, 0.9);
  RasterImage image;
  Rasterize(grid, camera, MakePose(rotation, t), {}, &image);
  // Every pixel whose ray hits the square at least 0.5 mm inside its border is covered.
  const Eigen::Vector3d normal = rotation.col(2);
  int inside = 0, holes = 0;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const double z = RayPlaneDepth(camera, u, v, normal, t);
      const Eigen::Vector3d local =
          rotation.transpose() * (camera.Backproject(PixelCentre(u, v), z) - t);
      if (std::max(std::abs(local.x()), std::abs(local.y())) > half - 5e-4) continue;
      ++inside;
      if (image.depth.at<float>(v, u) == 0.0f) ++holes;
    }
  }
  ASSERT_GT(inside, 10000);
  EXPECT_EQ(holes, 0);
}

TEST(Rasterize, BackfaceCullingKeepsTheFrontOfAClosedMesh) {
  const Camera camera = LmoCamera();
  const Mesh cube = MakeCube(0.04);
  const Eigen::Isometry3d pose =
      MakePose(AxisAngle(0.8, Eigen::Vector3d(1, -2, 0.5)), Eigen::Vector3d(0.0, 0.01, 0.5));
  RasterOptions culled;
  culled.cull_backfaces = true;
  RasterImage all, front;
  Rasterize(cube, camera, pose, {}, &all);
  Rasterize(cube, camera, pose, culled, &front);
  EXPECT_EQ(all.pixel_count, front.pixel_count);
  EXPECT_LT(cv::norm(all.depth, front.depth, cv::NORM_INF), 1e-7);

  // Inverting the winding turns the near face into a back face: with culling, the far
  // face and the sides (now front faces) remain, with the same silhouette but farther.
  Mesh inverted = cube;
  for (auto& face : inverted.faces) std::swap(face[1], face[2]);
  Rasterize(inverted, camera, pose, culled, &front);
  EXPECT_NEAR(front.pixel_count, all.pixel_count, 0.002 * all.pixel_count);
  EXPECT_GT(cv::mean(front.depth, front.Mask())[0], cv::mean(all.depth, all.Mask())[0] + 0.01);
}

TEST(Rasterize, SkipsTrianglesCrossingTheNearPlane) {
  const Camera camera = LmoCamera();
  Mesh triangle;
  triangle.vertices = {{-0.1f, -0.1f, 0.5f}, {0.1f, -0.1f, 0.5f}, {0.0f, 0.1f, 0.005f}};
  triangle.faces = {{0, 1, 2}};
  RasterImage image;
  Rasterize(triangle, camera, Eigen::Isometry3d::Identity(), {}, &image);
  EXPECT_EQ(image.pixel_count, 0);
  EXPECT_EQ(cv::countNonZero(image.depth), 0);
  triangle.vertices[2].z() = 0.5f;
  Rasterize(triangle, camera, Eigen::Isometry3d::Identity(), {}, &image);
  EXPECT_GT(image.pixel_count, 0);
}

TEST(Rasterize, ReusesOutputBuffersAndClearsThem) {
  const Camera camera = LmoCamera().Cropped(250, 170, 128, 128);
  const Mesh sphere = MakeUvSphere(0.05, 16, 32);
  RasterImage image;
  Rasterize(sphere, camera, MakePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 0.5)), {},
            &image);
  const uchar* depth_data = image.depth.data;
  const uchar* face_data = image.face_id.data;
  const int first_count = image.pixel_count;
  Rasterize(sphere, camera, MakePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 1.0)), {},
            &image);
  EXPECT_EQ(image.depth.data, depth_data);
  EXPECT_EQ(image.face_id.data, face_data);
  EXPECT_LT(image.pixel_count, first_count);
  EXPECT_EQ(cv::countNonZero(image.depth), image.pixel_count);
  EXPECT_EQ(cv::countNonZero(image.face_id >= 0), image.pixel_count);

  RasterOptions no_face_id;
  no_face_id.want_face_id = false;
  Rasterize(sphere, camera, MakePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 0.5)),
            no_face_id, &image);
  EXPECT_TRUE(image.face_id.empty());
  EXPECT_EQ(image.pixel_count, first_count);
}

TEST(Rasterize, ThrowsOnBadInput) {
  const Mesh cube = MakeCube(0.05);
  const Eigen::Isometry3d pose = MakePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 0.5));
  RasterImage image;
  Camera bad_camera = LmoCamera();
  bad_camera.fx = 0.0;
  EXPECT_THROW(Rasterize(cube, bad_camera, pose, {}, &image), Error);
  Mesh broken = cube;
  broken.faces.push_back({0, 1, 8});
  EXPECT_THROW(Rasterize(broken, LmoCamera(), pose, {}, &image), Error);
  RasterOptions bad_options;
  bad_options.near_m = -1.0;
  EXPECT_THROW(Rasterize(cube, LmoCamera(), pose, bad_options, &image), Error);
}

TEST(RasterOptions, CheckNamesTheBadField) {
  EXPECT_EQ(RasterOptions().Check(), "");
  RasterOptions options;
  options.near_m = 0.0;
  EXPECT_NE(options.Check().find("near_m"), std::string::npos);
}

// The LM-O masks were ray-cast from the GT poses with the same pixel-centre convention, so
// the full-silhouette mask must be reproduced almost exactly.
TEST(Rasterize, ReproducesLmoGroundTruthMasks) {
  G6D_REQUIRE_SHARED_DATA("lmo/models/obj_000001.ply");
  G6D_REQUIRE_SHARED_DATA("lmo/test/000002/scene_gt.json");
  const Camera camera = LmoCamera();
  std::ifstream stream(test::SharedDataPath("lmo/test/000002/scene_gt.json"));
  const nlohmann::json scene_gt = nlohmann::json::parse(stream);

  std::map<int, Mesh> meshes;
  std::map<int, double> worst_iou;
  std::map<int, double> sum_iou;
  std::map<int, int> count;
  RasterImage image;
  for (const auto& [im_id_text, instances] : scene_gt.items()) {
    const int im_id = std::stoi(im_id_text);
    for (size_t gt_index = 0; gt_index < instances.size(); ++gt_index) {
      const nlohmann::json& gt = instances[gt_index];
      const int obj_id = gt.at("obj_id").get<int>();
      if (meshes.count(obj_id) == 0) {
        char path[64];
        std::snprintf(path, sizeof(path), "lmo/models/obj_%06d.ply", obj_id);
        meshes[obj_id] = LoadMesh(test::SharedDataPath(path), Units::kMillimetres);
        worst_iou[obj_id] = 1.0;
      }
      const std::vector<double> r = gt.at("cam_R_m2c").get<std::vector<double>>();
      const std::vector<double> t = gt.at("cam_t_m2c").get<std::vector<double>>();
      Eigen::Matrix3d rotation;
      rotation << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
      const Eigen::Isometry3d pose =
          MakePose(rotation, Eigen::Vector3d(t[0], t[1], t[2]) * 1e-3);  // mm -> m
      Rasterize(meshes[obj_id], camera, pose, {}, &image);

      char mask_path[96];
      std::snprintf(mask_path, sizeof(mask_path), "lmo/test/000002/mask/%06d_%06zu.png", im_id,
                    gt_index);
      const cv::Mat gt_mask =
          cv::imread(test::SharedDataPath(mask_path), cv::IMREAD_GRAYSCALE) > 127;
      ASSERT_FALSE(gt_mask.empty()) << mask_path;
      const double iou = MaskIoU(gt_mask, image.Mask());
      EXPECT_GE(iou, 0.99) << mask_path << " obj " << obj_id;
      worst_iou[obj_id] = std::min(worst_iou[obj_id], iou);
      sum_iou[obj_id] += iou;
      ++count[obj_id];
    }
  }
  for (const auto& [obj_id, iou] : worst_iou) {
    std::printf("obj %2d: %3d GT masks, IoU mean %.5f, worst %.5f\n", obj_id, count[obj_id],
                sum_iou[obj_id] / count[obj_id], iou);
  }
  EXPECT_EQ(meshes.size(), 8u);
}

}  // namespace
}  // namespace g6d
