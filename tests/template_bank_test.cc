#include "templates/template_bank.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/se3.h"
#include "mesh/mesh.h"
#include "templates/cache.h"
#include "render/raster.h"
#include "test_meshes.h"
#include "test_util.h"

namespace g6d {
namespace {

// A box with a random-colour checker on every side: each side is a grid of quads with
// their own four vertices, so colours change sharply at the quad edges (ORB-friendly).
Mesh CheckerBox(const Eigen::Vector3f& half_size, int cells, uint32_t seed) {
  Mesh mesh;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> colour(0.05f, 0.95f);
  for (int axis = 0; axis < 3; ++axis) {
    for (float sign : {-1.0f, 1.0f}) {
      const int u_axis = (axis + 1) % 3;
      const int v_axis = (axis + 2) % 3;
      for (int i = 0; i < cells; ++i) {
        for (int j = 0; j < cells; ++j) {
          const Eigen::Vector3f rgb(colour(rng), colour(rng), colour(rng));
          const int base = static_cast<int>(mesh.vertices.size());
          for (int corner = 0; corner < 4; ++corner) {
            const int di = (corner == 1 || corner == 2) ? 1 : 0;
            const int dj = (corner >= 2) ? 1 : 0;
            Eigen::Vector3f p;
            p[axis] = sign * half_size[axis];
            p[u_axis] = half_size[u_axis] * (-1.0f + 2.0f * (i + di) / cells);
            p[v_axis] = half_size[v_axis] * (-1.0f + 2.0f * (j + dj) / cells);
            mesh.vertices.push_back(p);
            mesh.colors.push_back(rgb);
          }
          // Counter-clockwise seen from outside.
          if (sign > 0) {
            mesh.faces.emplace_back(base, base + 1, base + 2);
            mesh.faces.emplace_back(base, base + 2, base + 3);
          } else {
            mesh.faces.emplace_back(base, base + 2, base + 1);
            mesh.faces.emplace_back(base, base + 3, base + 2);
          }
        }
      }
    }
  }
  ComputeVertexNormals(&mesh);
  return mesh;
}

// Distance from p to triangle abc (Ericson, Real-Time Collision Detection, 5.1.5).
double PointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return (p - a).norm();
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return (p - b).norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (p - (a + d1 / (d1 - d3) * ab)).norm();
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return (p - c).norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (p - (a + d2 / (d2 - d6) * ac)).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return (p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  }
  const double denom = 1.0 / (va + vb + vc);
  return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}

double DistanceToMesh(const Mesh& mesh, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3i& f : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[f[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[f[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[f[2]].cast<double>();
    // Cheap reject by bounding sphere before the exact test.
    const Eigen::Vector3d centre = (a + b + c) / 3.0;
    const double radius = std::max({(a - centre).norm(), (b - centre).norm(), (c - centre).norm()});
    if ((p - centre).norm() - radius >= best) continue;
    best = std::min(best, PointTriangleDistance(p, a, b, c));
  }
  return best;
}

TemplateBuildOptions FewViews() {
  TemplateBuildOptions options;
  options.views.num_directions = 12;
  options.views.num_inplane = 1;
  return options;
}

// The checks every bank must pass: eq. (2) points reproject onto their keypoints and lie on
// the surface.
void ExpectGeometricallyConsistent(const TemplateBank& bank, const Mesh& mesh,
                                   size_t min_median_keypoints) {
  const Camera& camera = bank.template_camera;
  std::vector<size_t> counts;
  double worst_reprojection_px = 0.0;
  double worst_distance_m = 0.0;
  for (const Template& t : bank.templates) {
    ASSERT_EQ(t.keypoints.size(), t.descriptors.size());
    ASSERT_EQ(t.keypoints.size(), t.points.size());
    ASSERT_EQ(t.mask.rows, bank.options.crop.size_px);
    ASSERT_EQ(t.mask.cols, bank.options.crop.size_px);
    EXPECT_GT(cv::countNonZero(t.mask), 0);
    ASSERT_EQ(t.thumbnail.rows, bank.options.thumbnail_size_px);
    counts.push_back(t.keypoints.size());
    for (size_t i = 0; i < t.points.size(); ++i) {
      const Eigen::Vector3d point = t.points[i].cast<double>();
      const Eigen::Vector2d uv = camera.Project(t.cam_from_object * point);
      const Eigen::Vector2d keypoint =
          t.keypoints[i].cast<double>() + Eigen::Vector2d::Constant(kOpenCvToImage);
      worst_reprojection_px = std::max(worst_reprojection_px, (uv - keypoint).norm());
      worst_distance_m = std::max(worst_distance_m, DistanceToMesh(mesh, point));
    }
  }
  std::sort(counts.begin(), counts.end());
  EXPECT_GE(counts[counts.size() / 2], min_median_keypoints);
  EXPECT_LT(worst_reprojection_px, 1.0);
  EXPECT_LT(worst_distance_m, 0.002);
  std::printf("median keypoints %zu, worst reprojection %.4f px, worst surface distance %.4f mm\n",
              counts[counts.size() / 2], worst_reprojection_px, worst_distance_m * 1000.0);
}

std::string Encoded(const TemplateBank& bank, const std::string& name) {
  const std::string path = test::TempDir(name) + "/bank.g6dcache";
  WriteTemplateCache(bank, path);
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(BuildTemplateBank, CheckerBoxPointsLieOnTheSurfaceAndReproject) {
  const Mesh mesh = CheckerBox(Eigen::Vector3f(0.04f, 0.03f, 0.02f), 12, 1);
  InlineExecutor executor;
  std::vector<int> progress;
  const TemplateBank bank =
      BuildTemplateBank(mesh, "box", FewViews(), &executor, [&](int done, int total) {
        EXPECT_EQ(total, 12);
        progress.push_back(done);
      });
  EXPECT_EQ(bank.object_id, "box");
  EXPECT_NEAR(bank.diameter_m, 2.0 * Eigen::Vector3d(0.04, 0.03, 0.02).norm(), 1e-6);
  ASSERT_EQ(bank.templates.size(), 12u);
  EXPECT_EQ(progress, std::vector<int>({1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}));
  EXPECT_LE(bank.online_mesh.faces.size(), static_cast<size_t>(bank.options.online_mesh_faces));
  EXPECT_EQ(bank.template_camera.width, bank.options.render_size_px);
  ExpectGeometricallyConsistent(bank, mesh, 100);
}

TEST(BuildTemplateBank, SameBytesForAnyThreadCount) {
  const Mesh mesh = CheckerBox(Eigen::Vector3f(0.03f, 0.03f, 0.05f), 10, 2);
  InlineExecutor one;
  ThreadPool two(2);
  const std::string a = Encoded(BuildTemplateBank(mesh, "box", FewViews(), &one), "bank_threads_1");
  const std::string b = Encoded(BuildTemplateBank(mesh, "box", FewViews(), &two), "bank_threads_2");
  EXPECT_EQ(a.size(), b.size());
  EXPECT_TRUE(a == b) << "banks differ between 1 and 2 threads";
}

// A bank just built answers as the same bank saved and loaded: the cache keeps colours in
// 8 bits, so the build rounds them the same way (the Python module found objects with the
// built bank and g6d-solve with the loaded one; their confidences differed in the 4th digit).
TEST(BuildTemplateBank, ColoursSurviveTheCacheExactly) {
  const Mesh mesh = CheckerBox(Eigen::Vector3f(0.03f, 0.03f, 0.05f), 10, 3);
  InlineExecutor executor;
  const TemplateBank built = BuildTemplateBank(mesh, "box", FewViews(), &executor);
  const std::string path = test::TempDir("bank_colours") + "/bank.g6dcache";
  WriteTemplateCache(built, path);
  const TemplateBank loaded = ReadTemplateCache(path);
  ASSERT_FALSE(built.appearance.colors.empty()) << "the checker box should have a colour model";
  ASSERT_EQ(built.appearance.colors.size(), loaded.appearance.colors.size());
  size_t differing = 0;
  for (size_t i = 0; i < built.appearance.colors.size(); ++i) {
    if (built.appearance.colors[i] != loaded.appearance.colors[i]) ++differing;
  }
  EXPECT_EQ(differing, 0u) << "of " << built.appearance.colors.size() << " colours";
}

// Two builds on one pool: the pool's worker threads outlive the first build's GL contexts,
// so no context may stay current on a worker after the build returns (it used to, and the
// second build crashed inside OSMesaMakeCurrent on the destroyed context).
TEST(BuildTemplateBank, TwoBuildsOnOnePoolGiveTheSameBank) {
  const Mesh mesh = CheckerBox(Eigen::Vector3f(0.03f, 0.03f, 0.05f), 10, 2);
  ThreadPool pool(2);
  const std::string a = Encoded(BuildTemplateBank(mesh, "box", FewViews(), &pool), "bank_pool_a");
  const std::string b = Encoded(BuildTemplateBank(mesh, "box", FewViews(), &pool), "bank_pool_b");
  EXPECT_TRUE(a == b) << "the second build on the same pool differs";
}

TEST(BuildTemplateBank, LmoApePointsLieOnTheSurfaceAndReproject) {
  G6D_REQUIRE_SHARED_DATA("lmo/models/obj_000001.ply");
  const Mesh mesh =
      LoadMesh(test::SharedDataPath("lmo/models/obj_000001.ply"), Units::kMillimetres);
  ThreadPool pool(2);
  const TemplateBank bank = BuildTemplateBank(mesh, "obj_000001", FewViews(), &pool);
  ASSERT_EQ(bank.templates.size(), 12u);
  // The ape is concave (arms, ears): this also exercises self-occlusion handling.
  ExpectGeometricallyConsistent(bank, mesh, 60);
}

TEST(BuildTemplateBank, BadArgumentsThrow) {
  const Mesh mesh = CheckerBox(Eigen::Vector3f(0.02f, 0.02f, 0.02f), 2, 3);
  InlineExecutor executor;
  TemplateBuildOptions options = FewViews();
  options.render_size_px = 0;
  EXPECT_NE(options.Check().find("render_size_px"), std::string::npos);
  EXPECT_THROW(BuildTemplateBank(mesh, "x", options, &executor), Error);
  EXPECT_THROW(BuildTemplateBank(mesh, "x", FewViews(), nullptr), Error);
  EXPECT_THROW(BuildTemplateBank(Mesh(), "x", FewViews(), &executor), Error);
}

// The derived meshes of a bank: a coarse selection mesh that keeps the silhouette, and the
// closed-and-outward flags that make back-face culling safe.
TEST(DeriveOnlineMeshes, CoarseSilhouetteMatchesAndCullingIsExactOnClosedMeshes) {
  using test::AxisAngle;
  using test::MakeCube;
  using test::MakeUvSphere;
  using test::MaskIoU;
  TemplateBank bank;
  bank.online_mesh = MakeUvSphere(0.05, 40, 60);  // 4680 faces
  ASSERT_GT(static_cast<int>(bank.online_mesh.faces.size()), kSelectionMeshFaces);
  DeriveOnlineMeshes(&bank);
  EXPECT_TRUE(bank.online_mesh_closed);
  ASSERT_FALSE(bank.selection_mesh.faces.empty());
  EXPECT_LE(static_cast<int>(bank.selection_mesh.faces.size()), kSelectionMeshFaces);
  EXPECT_TRUE(bank.selection_mesh_closed);

  // On a 96 px grid (observable selection) the coarse silhouette is the online one within
  // a pixel's width around the rim, and culling changes no pixel of either mesh.
  const Camera camera{140.0, 140.0, 48.0, 48.0, 96, 96};
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-3.0, 3.0);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Isometry3d pose =
        MakePose(AxisAngle(angle(rng), Eigen::Vector3d(angle(rng), angle(rng), 1.0)), Eigen::Vector3d(0.0, 0.0, 0.25));
    RasterOptions culled;
    culled.cull_backfaces = true;
    RasterImage fine, fine_culled, coarse, coarse_culled;
    Rasterize(bank.online_mesh, camera, pose, {}, &fine);
    Rasterize(bank.online_mesh, camera, pose, culled, &fine_culled);
    Rasterize(bank.selection_mesh, camera, pose, {}, &coarse);
    Rasterize(bank.selection_mesh, camera, pose, culled, &coarse_culled);
    EXPECT_EQ(cv::norm(fine.depth, fine_culled.depth, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(coarse.depth, coarse_culled.depth, cv::NORM_INF), 0.0);
    EXPECT_GT(MaskIoU(fine.Mask(), coarse.Mask()), 0.97) << "trial " << trial;
  }

  // Inward faces or a hole: culling would change renderings, so it is not allowed.
  TemplateBank inverted;
  inverted.online_mesh = MakeCube(0.04);
  for (auto& face : inverted.online_mesh.faces) std::swap(face[1], face[2]);
  DeriveOnlineMeshes(&inverted);
  EXPECT_FALSE(inverted.online_mesh_closed);
  EXPECT_TRUE(inverted.selection_mesh.faces.empty());  // 12 faces: nothing to coarsen
  TemplateBank open;
  open.online_mesh = MakeCube(0.04);
  open.online_mesh.faces.pop_back();
  DeriveOnlineMeshes(&open);
  EXPECT_FALSE(open.online_mesh_closed);
  TemplateBank outward;
  outward.online_mesh = MakeCube(0.04);
  DeriveOnlineMeshes(&outward);
  EXPECT_TRUE(outward.online_mesh_closed);
}

}  // namespace
}  // namespace g6d
