// Appearance agreement: sampling (texture convention, vertex colours, untextured models),
// which samples are compared, and the 180-degree flip of printed boxes (synthetic under
// lighting changes, real YCB-V), plus the LM-O measurement (vertex colours, mostly
// uniformly coloured objects).
#include "templates/appearance.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/se3.h"
#include "eval/bop.h"
#include "mesh/mesh.h"
#include "render/gl_renderer.h"
#include "render/raster.h"
#include "synthetic_scene.h"
#include "test_meshes.h"
#include "test_util.h"

namespace g6d {
namespace {

// cam_from_object followed by a 180-degree turn about object axis `axis` through `centre`
// (object frame, metres).
Eigen::Isometry3d Flipped(const Eigen::Isometry3d& cam_from_object, int axis,
                          const Eigen::Vector3d& centre) {
  Eigen::Isometry3d object_from_object = Eigen::Isometry3d::Identity();
  object_from_object.linear() = test::AxisAngle(M_PI, Eigen::Vector3d::Unit(axis));
  object_from_object.translation() = centre - object_from_object.linear() * centre;
  return cam_from_object * object_from_object;
}

// A box of half sizes `half_m` centred at the origin, each side split into cells x cells
// squares of random vertex colours (four vertices of their own per square), faces
// counter-clockwise seen from outside.
Mesh MakeVertexColouredBox(const Eigen::Vector3f& half_m, int cells, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> channel(15, 240);
  Mesh mesh;
  for (int axis = 0; axis < 3; ++axis) {
    for (float sign : {1.0f, -1.0f}) {
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      for (int i = 0; i < cells; ++i) {
        for (int j = 0; j < cells; ++j) {
          const Eigen::Vector3f color(channel(rng) / 255.0f, channel(rng) / 255.0f,
                                      channel(rng) / 255.0f);
          const int base = static_cast<int>(mesh.vertices.size());
          const int corner_i[4] = {0, 1, 1, 0}, corner_j[4] = {0, 0, 1, 1};
          for (int k = 0; k < 4; ++k) {
            Eigen::Vector3f point;
            point[axis] = sign * half_m[axis];
            point[a] = half_m[a] * (-1.0f + 2.0f * (i + corner_i[k]) / cells);
            point[b] = half_m[b] * (-1.0f + 2.0f * (j + corner_j[k]) / cells);
            mesh.vertices.push_back(point);
            mesh.colors.push_back(color);
          }
          // (a, b, axis) is right-handed, so a -> b is counter-clockwise seen from +axis.
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

// A camera 0.45 m away seeing three faces of a box at the origin.
Eigen::Isometry3d ObliqueView() {
  return LookAt({0.22, -0.28, 0.30}, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
}

// Renders `mesh` at `cam_from_object` with GlRenderer (Lambertian headlight: every face of
// a box has its own brightness) over a grey background. *mask receives the silhouette.
cv::Mat RenderOverGrey(const Mesh& mesh, const Camera& camera,
                       const Eigen::Isometry3d& cam_from_object, cv::Mat* mask) {
  GlRenderer renderer(mesh);
  const GlImage image = renderer.Render(camera, cam_from_object);
  cv::Mat rgb(camera.height, camera.width, CV_8UC3, cv::Scalar(90, 100, 110));
  image.rgb.copyTo(rgb, image.mask);
  *mask = image.mask.clone();
  return rgb;
}

// The agreement at `cam_from_object` beats each of the three flips about the box axes by a
// wide margin, on the rendering, with the image darkened and offset (rgb * 0.6 + 20, the
// brief's lighting change) and with a white-balance change (gain and offset per channel).
void ExpectTruePoseBeatsFlips(const Mesh& mesh, const Eigen::Isometry3d& cam_from_object) {
  const Camera camera = test::LmoCamera();
  cv::Mat mask;
  const cv::Mat rgb = RenderOverGrey(mesh, camera, cam_from_object, &mask);
  cv::Mat darker, white_balance;
  rgb.convertTo(darker, -1, 0.6, 20.0);
  cv::Mat channels[3];
  cv::split(rgb, channels);
  channels[0].convertTo(channels[0], -1, 1.1, 5.0);
  channels[1].convertTo(channels[1], -1, 0.8, 25.0);
  channels[2].convertTo(channels[2], -1, 0.5, 40.0);
  cv::merge(channels, 3, white_balance);

  const AppearanceOptions options;
  const AppearanceModel model = SampleAppearance(mesh, options);
  ASSERT_FALSE(model.Empty());
  const std::vector<std::pair<const char*, const cv::Mat*>> images = {
      {"rendered", &rgb}, {"x0.6+20", &darker}, {"white balance", &white_balance}};
  for (const auto& [name, observed] : images) {
    const AppearanceScore truth =
        ScoreAppearance(options, model, mesh, camera, *observed, mask, cam_from_object);
    ASSERT_TRUE(truth.valid) << name << ": " << truth.message;
    EXPECT_GT(truth.agreement, 0.8) << name;
    EXPECT_GT(truth.points, 500) << name;
    EXPECT_EQ(truth.rgb_channels, 3) << name;
    EXPECT_EQ(truth.chroma_channels, 3) << name;
    for (int axis = 0; axis < 3; ++axis) {
      const AppearanceScore flipped =
          ScoreAppearance(options, model, mesh, camera, *observed, mask,
                          Flipped(cam_from_object, axis, Eigen::Vector3d::Zero()));
      ASSERT_TRUE(flipped.valid) << name << " axis " << axis << ": " << flipped.message;
      std::printf("%-13s truth %.3f  flip about %c %.3f (%d points)\n", name, truth.agreement,
                  "xyz"[axis], flipped.agreement, flipped.points);
      EXPECT_LT(flipped.agreement, truth.agreement - 0.4) << name << " axis " << axis;
    }
  }
}

// ---------------------------------------------------------------------------------------
// SampleAppearance

TEST(SampleAppearance, TextureRowZeroIsVUp) {
  // A unit square in z = 0 whose uv equals its (x, y); texture top half red, bottom blue.
  Mesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  mesh.faces = {{0, 1, 2}, {0, 2, 3}};
  mesh.texture = cv::Mat(64, 64, CV_8UC3, cv::Scalar(0, 0, 255));
  mesh.texture(cv::Rect(0, 0, 64, 32)).setTo(cv::Scalar(255, 0, 0));
  AppearanceOptions options;
  options.sample_points = 500;
  const AppearanceModel model = SampleAppearance(mesh, options);
  ASSERT_EQ(model.points.size(), 500u);
  int checked = 0;
  for (size_t i = 0; i < model.points.size(); ++i) {
    EXPECT_TRUE(model.normals[i].isApprox(Eigen::Vector3f::UnitZ(), 1e-6f));
    const float y = model.points[i].y();
    if (std::abs(y - 0.5f) < 0.05f) continue;  // the bilinear blend across the boundary
    // v up: y (= v) above 0.5 is the upper half of the image, rows 0..31: red.
    const Eigen::Vector3f expected = y > 0.5f ? Eigen::Vector3f(1, 0, 0) : Eigen::Vector3f(0, 0, 1);
    EXPECT_TRUE(model.colors[i].isApprox(expected, 1e-5f))
        << "y " << y << " colour " << model.colors[i].transpose();
    ++checked;
  }
  EXPECT_GT(checked, 400);
}

TEST(SampleAppearance, VertexColoursAreInterpolatedBarycentrically) {
  // One triangle with red, green and blue corners at (0,0), (1,0), (0,1): the colour of a
  // point is its barycentric weights (1 - x - y, x, y).
  Mesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.colors = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.faces = {{0, 1, 2}};
  AppearanceOptions options;
  options.sample_points = 200;
  const AppearanceModel model = SampleAppearance(mesh, options);
  ASSERT_EQ(model.colors.size(), 200u);
  for (size_t i = 0; i < model.points.size(); ++i) {
    const Eigen::Vector3f& p = model.points[i];
    const Eigen::Vector3f expected(1 - p.x() - p.y(), p.x(), p.y());
    EXPECT_LE((model.colors[i] - expected).cwiseAbs().maxCoeff(), 0.5f / 255.0f + 1e-6f)  // 8-bit grid
        << "point " << p.transpose() << " colour " << model.colors[i].transpose();
    for (int c = 0; c < 3; ++c) {
      const float byte = model.colors[i][c] * 255.0f;
      EXPECT_EQ(byte, std::round(byte)) << "colour " << model.colors[i].transpose() << " is not on the 8-bit grid";
    }
  }
}

TEST(SampleAppearance, VertexNormalsOverrideAWrongWinding) {
  // Clockwise seen from +z, but the file's vertex normals say the outside is +z.
  Mesh mesh;
  mesh.vertices = {{0, 0, 0}, {0, 1, 0}, {1, 0, 0}};
  mesh.colors = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.faces = {{0, 1, 2}};
  AppearanceOptions options;
  options.sample_points = 10;
  for (const Eigen::Vector3f& normal : SampleAppearance(mesh, options).normals) {
    EXPECT_TRUE(normal.isApprox(-Eigen::Vector3f::UnitZ(), 1e-6f));
  }
  mesh.normals.assign(3, Eigen::Vector3f::UnitZ());
  for (const Eigen::Vector3f& normal : SampleAppearance(mesh, options).normals) {
    EXPECT_TRUE(normal.isApprox(Eigen::Vector3f::UnitZ(), 1e-6f));
  }
}

TEST(SampleAppearance, DeterministicForASeed) {
  const Mesh mesh = MakeVertexColouredBox({0.04f, 0.06f, 0.08f}, 3, 5);
  AppearanceOptions options;
  const AppearanceModel a = SampleAppearance(mesh, options);
  const AppearanceModel b = SampleAppearance(mesh, options);
  options.seed = 2;
  const AppearanceModel c = SampleAppearance(mesh, options);
  ASSERT_EQ(a.points.size(), 4000u);
  ASSERT_EQ(a.normals.size(), 4000u);
  ASSERT_EQ(a.colors.size(), 4000u);
  EXPECT_EQ(a.points, b.points);
  EXPECT_EQ(a.colors, b.colors);
  EXPECT_NE(a.points, c.points);
  for (size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_NEAR(a.normals[i].norm(), 1.0f, 1e-5f);
    // On the box surface: one coordinate at +-half, outward normal along it.
    const Eigen::Vector3f ratio = a.points[i].cwiseQuotient(Eigen::Vector3f(0.04f, 0.06f, 0.08f));
    Eigen::Index axis = 0;
    ratio.cwiseAbs().maxCoeff(&axis);
    EXPECT_NEAR(std::abs(ratio[axis]), 1.0f, 1e-5f);
    EXPECT_NEAR(a.normals[i][axis], ratio[axis] > 0 ? 1.0f : -1.0f, 1e-5f);
  }
}

TEST(SampleAppearance, UntexturedOrUniformMeshGivesEmptyModel) {
  const AppearanceOptions options;
  EXPECT_TRUE(SampleAppearance(test::MakeCube(0.05), options).Empty());
  // Vertex colours that vary by less than min_color_std: untextured as well.
  Mesh nearly_uniform = MakeVertexColouredBox({0.04f, 0.06f, 0.08f}, 2, 5);
  for (Eigen::Vector3f& color : nearly_uniform.colors) {
    color = Eigen::Vector3f(0.5f, 0.4f, 0.3f) + 0.01f * (color - Eigen::Vector3f::Constant(0.5f));
  }
  EXPECT_TRUE(SampleAppearance(nearly_uniform, options).Empty());
  // A uniform texture too.
  Mesh textured = test::MakeTexturedBox(0.08, 0.12, 0.16, 7);
  textured.texture.setTo(cv::Scalar(200, 30, 30));
  EXPECT_TRUE(SampleAppearance(textured, options).Empty());
}

TEST(SampleAppearance, ThrowsOnBadOptionsAndFaces) {
  const Mesh mesh = MakeVertexColouredBox({0.04f, 0.06f, 0.08f}, 2, 5);
  AppearanceOptions options;
  options.sample_points = 0;
  EXPECT_THROW(SampleAppearance(mesh, options), Error);
  Mesh broken = mesh;
  broken.faces.emplace_back(0, 1, static_cast<int>(mesh.vertices.size()));
  EXPECT_THROW(SampleAppearance(broken, AppearanceOptions()), Error);
  Mesh flat = mesh;
  for (Eigen::Vector3f& vertex : flat.vertices) vertex.setZero();
  EXPECT_THROW(SampleAppearance(flat, AppearanceOptions()), Error);
}

// ---------------------------------------------------------------------------------------
// AppearanceOptions

TEST(AppearanceOptions, CheckNamesTheBadField) {
  EXPECT_EQ(AppearanceOptions().Check(), "");
  const std::vector<std::pair<std::string, std::function<void(AppearanceOptions*)>>> cases = {
      {"sample_points", [](AppearanceOptions* o) { o->sample_points = 0; }},
      {"min_color_std", [](AppearanceOptions* o) { o->min_color_std = -0.1; }},
      {"texture_max_side_px", [](AppearanceOptions* o) { o->texture_max_side_px = 0; }},
      {"grid_max_side_px", [](AppearanceOptions* o) { o->grid_max_side_px = 4; }},
      {"visibility_tolerance_m", [](AppearanceOptions* o) { o->visibility_tolerance_m = 0.0; }},
      {"visibility_tolerance_m",
       [](AppearanceOptions* o) { o->visibility_tolerance_m = std::nan(""); }},
      {"min_facing_cos", [](AppearanceOptions* o) { o->min_facing_cos = 1.5; }},
      {"edge_margin_px", [](AppearanceOptions* o) { o->edge_margin_px = -1; }},
      {"min_chroma_std", [](AppearanceOptions* o) { o->min_chroma_std = -1.0; }},
      {"min_visible_points", [](AppearanceOptions* o) { o->min_visible_points = 1; }},
  };
  for (const auto& [field, spoil] : cases) {
    AppearanceOptions options;
    spoil(&options);
    EXPECT_NE(options.Check().find("AppearanceOptions." + field), std::string::npos)
        << field << ": " << options.Check();
  }
}

// ---------------------------------------------------------------------------------------
// ScoreAppearance

TEST(ScoreAppearance, TexturedBoxTruePoseBeatsFlips) {
  ExpectTruePoseBeatsFlips(test::MakeTexturedBox(0.08, 0.12, 0.16, 7), ObliqueView());
}

TEST(ScoreAppearance, VertexColouredBoxTruePoseBeatsFlips) {
  ExpectTruePoseBeatsFlips(MakeVertexColouredBox({0.04f, 0.06f, 0.08f}, 4, 3), ObliqueView());
}

TEST(ScoreAppearance, ComparesOnlyFacingVisibleSamplesInsideTheMask) {
  // A box with one colour per side, seen straight along -z: only the +z side is visible.
  Mesh mesh = MakeVertexColouredBox({0.04f, 0.06f, 0.08f}, 1, 9);
  const Camera camera = test::LmoCamera();
  const Eigen::Isometry3d cam_from_object =
      LookAt({0.0, 0.0, 0.5}, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitY());
  cv::Mat mask;
  const cv::Mat rgb = RenderOverGrey(mesh, camera, cam_from_object, &mask);
  AppearanceOptions options;
  const AppearanceModel model = SampleAppearance(mesh, options);
  Eigen::Vector3f top_colour = Eigen::Vector3f::Zero();
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (mesh.vertices[v].z() > 0.079f && mesh.normals[v].z() > 0.9f) top_colour = mesh.colors[v];
  }
  std::vector<Eigen::Vector3f> model_colors, observed_colors;
  const int count = internal::CollectAppearancePairs(
      options, model, mesh, camera, rgb, mask, cam_from_object, &model_colors, &observed_colors);
  // About a sixth of the area faces the camera (+z side: 0.08 x 0.12 of 0.0592 m^2 total).
  EXPECT_GT(count, 300);
  for (const Eigen::Vector3f& color : model_colors) {
    EXPECT_TRUE(color.isApprox(top_colour, 1e-6f)) << color.transpose();
  }
  // Observed colours are the rendered side under the headlight: one colour, no background.
  for (const Eigen::Vector3f& color : observed_colors) {
    EXPECT_TRUE(color.isApprox(observed_colors.front(), 0.02f)) << color.transpose();
  }
  // Half the mask: only samples in the kept half remain.
  cv::Mat half_mask = mask.clone();
  half_mask.colRange(0, camera.width / 2).setTo(0);
  const int half_count =
      internal::CollectAppearancePairs(options, model, mesh, camera, rgb, half_mask,
                                       cam_from_object, &model_colors, &observed_colors);
  EXPECT_GT(half_count, count / 3);
  EXPECT_LT(half_count, count * 2 / 3);
}

TEST(ScoreAppearance, InvalidForEmptyModelMaskOrTooFewSamples) {
  const Mesh mesh = MakeVertexColouredBox({0.04f, 0.06f, 0.08f}, 4, 3);
  const Camera camera = test::LmoCamera();
  cv::Mat mask;
  const cv::Mat rgb = RenderOverGrey(mesh, camera, ObliqueView(), &mask);
  const AppearanceOptions options;
  const AppearanceModel model = SampleAppearance(mesh, options);

  // Untextured: empty model, invalid score.
  const AppearanceModel empty = SampleAppearance(test::MakeCube(0.05), options);
  const AppearanceScore untextured =
      ScoreAppearance(options, empty, mesh, camera, rgb, mask, ObliqueView());
  EXPECT_FALSE(untextured.valid);
  EXPECT_EQ(untextured.agreement, 0.0);
  EXPECT_NE(untextured.message.find("empty"), std::string::npos) << untextured.message;

  const AppearanceScore no_mask = ScoreAppearance(
      options, model, mesh, camera, rgb, cv::Mat::zeros(mask.size(), CV_8U), ObliqueView());
  EXPECT_FALSE(no_mask.valid);
  EXPECT_EQ(no_mask.points, 0);
  EXPECT_NE(no_mask.message.find("too few"), std::string::npos) << no_mask.message;

  cv::Mat tiny_mask = cv::Mat::zeros(mask.size(), CV_8U);
  const cv::Rect box = cv::boundingRect(mask);
  tiny_mask(cv::Rect(box.x + box.width / 2, box.y + box.height / 2, 6, 6)).setTo(255);
  const AppearanceScore tiny =
      ScoreAppearance(options, model, mesh, camera, rgb, tiny_mask, ObliqueView());
  EXPECT_FALSE(tiny.valid);
  EXPECT_LT(tiny.points, options.min_visible_points);

  // Pointing away from the object: nothing visible inside the mask.
  const AppearanceScore away =
      ScoreAppearance(options, model, mesh, camera, rgb, mask,
                      ObliqueView() * Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, 1.0)));
  EXPECT_FALSE(away.valid);
}

TEST(ScoreAppearance, ThrowsOnBadArguments) {
  const Mesh mesh = MakeVertexColouredBox({0.04f, 0.06f, 0.08f}, 2, 3);
  const Camera camera = test::LmoCamera();
  const AppearanceModel model = SampleAppearance(mesh, AppearanceOptions());
  const cv::Mat rgb(camera.height, camera.width, CV_8UC3, cv::Scalar::all(0));
  const cv::Mat mask(camera.height, camera.width, CV_8U, cv::Scalar(255));
  AppearanceOptions bad;
  bad.min_visible_points = 0;
  EXPECT_THROW(ScoreAppearance(bad, model, mesh, camera, rgb, mask, ObliqueView()), Error);
  EXPECT_THROW(ScoreAppearance(AppearanceOptions(), model, mesh, camera,
                               cv::Mat(camera.height, camera.width, CV_8UC1), mask, ObliqueView()),
               Error);
  EXPECT_THROW(ScoreAppearance(AppearanceOptions(), model, mesh, camera, rgb,
                               cv::Mat(10, 10, CV_8U), ObliqueView()),
               Error);
  EXPECT_THROW(
      ScoreAppearance(AppearanceOptions(), model, mesh, Camera(), rgb, mask, ObliqueView()), Error);
}

// ---------------------------------------------------------------------------------------
// Real data

// Wins of the GT pose over the 180-degree flips about the bounding-box axes of one object.
struct FlipTally {
  int instances = 0;  // GT instances with a valid score
  int beats_all = 0;  // ... whose agreement beats every (valid, non-symmetry) flip
  int pairs = 0;      // (instance, flip) pairs with both scores valid
  int pair_wins = 0;  // ... where GT wins
  int tie_pairs = 0;  // pairs whose flip is a geometric tie: silhouette IoU with GT > 0.8
  int tie_wins = 0;   // ... where GT wins
  int invalid = 0;    // GT instances whose score is invalid
};

// Scores the GT pose and its three flips for the GT instances of `obj_ids` in every frame of
// a BOP scene (instances with visib_fract >= 0.1). Flips equal to one of the object's
// listed discrete symmetries (within 10 degrees) are skipped: there the print is symmetric
// too. Prints one line per instance when `verbose`.
std::map<int, FlipTally> MeasureFlips(const std::string& root, int scene_id,
                                      const std::vector<int>& obj_ids, bool verbose) {
  const BopDataset dataset = LoadBopDataset(root);
  const BopScene scene = LoadBopScene(root, scene_id);
  const AppearanceOptions options;
  std::map<int, AppearanceModel> models;
  std::map<int, Mesh> online_meshes;
  std::map<int, Eigen::Vector3d> centres;
  for (int id : obj_ids) {
    const BopObjectInfo& info = dataset.Object(id);
    const Mesh mesh = LoadMesh(info.mesh_path, info.mesh_units);
    models[id] = SampleAppearance(mesh, options);
    online_meshes[id] = Decimate(mesh, 4000);  // TemplateBankOptions::online_mesh_faces
    centres[id] = ComputeBoundingBox(mesh).center();
  }
  std::map<int, FlipTally> tallies;
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  RasterImage scratch, truth_silhouette, flip_silhouette;
  for (const BopFrame& frame : scene.frames) {
    const cv::Mat rgb = LoadBopRgb(scene, frame.im_id);
    for (size_t g = 0; g < frame.gt.size(); ++g) {
      const BopGtInstance& gt = frame.gt[g];
      if (models.count(gt.obj_id) == 0 || (gt.info && gt.info->visib_fract < 0.1)) continue;
      const AppearanceModel& model = models[gt.obj_id];
      const Mesh& online = online_meshes[gt.obj_id];
      const cv::Mat mask = LoadBopMaskVisib(scene, frame.im_id, static_cast<int>(g));
      FlipTally& tally = tallies[gt.obj_id];
      const AppearanceScore truth = ScoreAppearance(options, model, online, frame.camera, rgb, mask,
                                                    gt.cam_from_object, &scratch);
      if (!truth.valid) {
        ++tally.invalid;
        continue;
      }
      ++tally.instances;
      Rasterize(online, frame.camera, gt.cam_from_object, raster_options, &truth_silhouette);
      bool beats_all = true;
      std::string flips_text;
      for (int axis = 0; axis < 3; ++axis) {
        const Eigen::Isometry3d flip =
            Flipped(Eigen::Isometry3d::Identity(), axis, centres[gt.obj_id]);
        bool is_symmetry = false;
        for (const Eigen::Isometry3d& symmetry : dataset.Object(gt.obj_id).symmetries_discrete) {
          is_symmetry |= RotationErrorDeg(Orthonormalize(symmetry.linear()), flip.linear()) < 10.0;
        }
        if (is_symmetry) continue;
        const Eigen::Isometry3d flipped_pose = gt.cam_from_object * flip;
        const AppearanceScore flipped = ScoreAppearance(options, model, online, frame.camera, rgb,
                                                        mask, flipped_pose, &scratch);
        if (!flipped.valid) continue;
        const bool win = truth.agreement > flipped.agreement;
        beats_all &= win;
        ++tally.pairs;
        tally.pair_wins += win;
        Rasterize(online, frame.camera, flipped_pose, raster_options, &flip_silhouette);
        if (test::MaskIoU(truth_silhouette.Mask(), flip_silhouette.Mask()) > 0.8) {
          ++tally.tie_pairs;
          tally.tie_wins += win;
        }
        char text[64];
        std::snprintf(text, sizeof text, "  %c %.3f", "xyz"[axis], flipped.agreement);
        flips_text += text;
      }
      tally.beats_all += beats_all;
      if (verbose) {
        std::printf("im %3d obj %2d: GT %.3f (rgb %.3f chroma %.3f, %d points), flips%s\n",
                    frame.im_id, gt.obj_id, truth.agreement, truth.rgb_zncc, truth.chroma_zncc,
                    truth.points, flips_text.c_str());
      }
    }
  }
  return tallies;
}

void PrintTallies(const std::map<int, FlipTally>& tallies) {
  std::printf("obj  instances  invalid  GT>all flips  GT>flip (pairs)  GT>flip, geometric ties\n");
  for (const auto& [id, t] : tallies) {
    std::printf("%3d  %9d  %7d  %12.2f  %9.2f (%3d)  %9.2f (%3d)\n", id, t.instances, t.invalid,
                t.instances ? double(t.beats_all) / t.instances : 0.0,
                t.pairs ? double(t.pair_wins) / t.pairs : 0.0, t.pairs,
                t.tie_pairs ? double(t.tie_wins) / t.tie_pairs : 0.0, t.tie_pairs);
  }
}

constexpr char kYcbvClutter[] = "ycbv_clutter";
constexpr int kCrackerBox = 2, kMustardBottle = 5, kMasterChefCan = 1;

TEST(ScoreAppearance, YcbvCrackerBoxTruePoseBeatsEveryFlip) {
  G6D_REQUIRE_SHARED_DATA(std::string(kYcbvClutter) + "/models/models_info.json");
  const std::map<int, FlipTally> tallies =
      MeasureFlips(test::SharedDataPath(kYcbvClutter), 1, {kCrackerBox, kMustardBottle}, true);
  PrintTallies(tallies);
  const FlipTally& box = tallies.at(kCrackerBox);
  EXPECT_EQ(box.instances, 5);
  EXPECT_EQ(box.beats_all, 5);  // every frame, every flip
  EXPECT_EQ(box.pairs, 15);
}

TEST(SampleAppearance, YcbvUntexturedCanGivesEmptyModel) {
  G6D_REQUIRE_SHARED_DATA(std::string(kYcbvClutter) + "/models/models_info.json");
  const BopDataset dataset = LoadBopDataset(test::SharedDataPath(kYcbvClutter));
  const BopObjectInfo& can = dataset.Object(kMasterChefCan);  // its .mtl has no map_Kd
  EXPECT_TRUE(
      SampleAppearance(LoadMesh(can.mesh_path, can.mesh_units), AppearanceOptions()).Empty());
  const BopObjectInfo& box = dataset.Object(kCrackerBox);
  EXPECT_FALSE(
      SampleAppearance(LoadMesh(box.mesh_path, box.mesh_units), AppearanceOptions()).Empty());
}

// LM-O scene 2 (62 frames): vertex colours from scans, shading baked in, mostly uniformly
// coloured objects, masks that ignore the (unannotated) benchvise in front of some objects.
// A measurement more than a test: it prints the table; the bound only guards against a
// regression to chance (0.5 pairwise).
TEST(ScoreAppearance, LmoTruePoseVersusFlips) {
  G6D_REQUIRE_SHARED_DATA("lmo/models/models_info.json");
  const std::map<int, FlipTally> tallies =
      MeasureFlips(test::SharedDataPath("lmo"), 2, {1, 5, 6, 8, 9, 10, 11, 12}, false);
  PrintTallies(tallies);
  FlipTally all;
  for (const auto& [id, t] : tallies) {
    all.instances += t.instances;
    all.beats_all += t.beats_all;
    all.pairs += t.pairs;
    all.pair_wins += t.pair_wins;
  }
  std::printf("all: GT > all flips %.2f of %d instances, GT > flip %.2f of %d pairs\n",
              double(all.beats_all) / all.instances, all.instances,
              double(all.pair_wins) / all.pairs, all.pairs);
  EXPECT_GT(double(all.pair_wins) / all.pairs, 0.65);
}

}  // namespace
}  // namespace g6d
