// Silhouette codes (templates/silhouette.h) and poses from the mask's outline
// (solver/silhouette_poses.h): the code's invariances, the pose of a template's own view, and
// the pose of an untextured part found from its outline alone.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/executor.h"
#include "render/raster.h"
#include "solver/silhouette_poses.h"
#include "templates/silhouette.h"
#include "templates/template_bank.h"
#include "test_bank.h"
#include "test_meshes.h"

namespace g6d {
namespace {

using test::AxisAngle;
using test::LmoCamera;
using test::MakeCube;

// An L-shaped outline (no symmetry) centred near (cx, cy), `size` px long.
cv::Mat LMask(int width, int height, double cx, double cy, double size, double angle_rad) {
  const std::vector<Eigen::Vector2d> corners = {{0, 0}, {1, 0}, {1, 0.25}, {0.3, 0.25}, {0.3, 0.7}, {0, 0.7}};
  std::vector<cv::Point> polygon;
  const Eigen::Rotation2Dd turn(angle_rad);
  for (const Eigen::Vector2d& c : corners) {
    const Eigen::Vector2d p = Eigen::Vector2d(cx, cy) + turn * ((c - Eigen::Vector2d(0.4, 0.3)) * size);
    polygon.emplace_back(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y())));
  }
  cv::Mat mask = cv::Mat::zeros(height, width, CV_8U);
  cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{polygon}, cv::Scalar(255));
  return mask;
}

TEST(EncodeSilhouette, SameCodeWhereverTheOutlineIsHowBigAndHowTurned) {
  const cv::Mat base = LMask(400, 300, 120, 100, 80, 0.0);
  const SilhouetteBits code = EncodeSilhouette(base, MomentsOfMask(base), 0.0);
  // Moved, twice as large, turned by 50 degrees: read at 50 degrees it is the same code.
  const double angle = 50.0 * M_PI / 180.0;
  const cv::Mat other = LMask(400, 300, 250, 170, 160, angle);
  const MaskMoments moments = MomentsOfMask(other);
  EXPECT_NEAR(moments.area_px, 4.0 * MomentsOfMask(base).area_px, 0.05 * moments.area_px);
  EXPECT_GT(SilhouetteIou(code, EncodeSilhouette(other, moments, angle)), 0.9);
  // Read at the wrong angle, or mirrored, it is not.
  EXPECT_LT(SilhouetteIou(code, EncodeSilhouette(other, moments, 0.0)), 0.7);
  cv::Mat mirrored;
  cv::flip(base, mirrored, 1);
  EXPECT_LT(SilhouetteIou(code, EncodeSilhouette(mirrored, MomentsOfMask(mirrored), 0.0)), 0.8);
  // Nothing in, nothing out.
  const cv::Mat empty = cv::Mat::zeros(10, 10, CV_8U);
  EXPECT_EQ(MomentsOfMask(empty).area_px, 0.0);
  EXPECT_EQ(SilhouetteIou(EncodeSilhouette(empty, MomentsOfMask(empty), 0.0), SilhouetteBits{}), 0.0);
}

// Two boxes joined off-centre, untextured: 60 x 30 x 20 mm and a 20 mm cube beside it.
Mesh MakeBracket() {
  Mesh mesh = MakeCube(0.5);
  for (Eigen::Vector3f& v : mesh.vertices) v = v.cwiseProduct(Eigen::Vector3f(0.06f, 0.03f, 0.02f));
  Mesh small = MakeCube(0.01);
  const int offset = static_cast<int>(mesh.vertices.size());
  for (const Eigen::Vector3f& v : small.vertices) mesh.vertices.push_back(v + Eigen::Vector3f(0.02f, 0.025f, 0.0f));
  for (const Eigen::Vector3i& f : small.faces) mesh.faces.push_back(f + Eigen::Vector3i::Constant(offset));
  return mesh;
}

class SilhouettePosesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ThreadPool pool(2);
    TemplateBuildOptions options;
    options.build_ppf = false;
    options.sample_appearance = false;
    options.find_symmetries = false;
    bank_ = new TemplateBank(test::SharedTestBank("bracket-outline", MakeBracket(), "bracket", options, &pool));
  }
  static void TearDownTestSuite() {
    delete bank_;
    bank_ = nullptr;
  }
  static cv::Mat Render(const Eigen::Isometry3d& cam_from_object, const Camera& camera) {
    RasterImage raster;
    Rasterize(bank_->online_mesh, camera, cam_from_object, RasterOptions{}, &raster);
    return raster.Mask();
  }
  static double RotationDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
    return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * 180.0 / M_PI;
  }
  static TemplateBank* bank_;
};
TemplateBank* SilhouettePosesTest::bank_ = nullptr;

TEST_F(SilhouettePosesTest, ATemplatesOwnOutlineGivesItsOwnPose) {
  ASSERT_EQ(bank_->silhouettes.size(), bank_->templates.size());
  for (int view : {0, 7, 100, static_cast<int>(bank_->templates.size()) - 1}) {
    const MaskMoments& moments = bank_->silhouettes[static_cast<size_t>(view)].moments;
    const Eigen::Isometry3d pose =
        PoseFromSilhouette(*bank_, view, 0.0, moments.centroid_px, moments.area_px, bank_->template_camera);
    const Eigen::Isometry3d& truth = bank_->templates[static_cast<size_t>(view)].cam_from_object;
    EXPECT_LT(RotationDeg(pose, truth), 1e-6) << "view " << view;
    EXPECT_LT((pose.translation() - truth.translation()).norm(), 1e-9) << "view " << view;
  }
}

TEST_F(SilhouettePosesTest, ThePoseCastsTheOutlineItWasMadeFrom) {
  // A template turned by 70 degrees, placed off the optical axis and smaller: rendered, its
  // outline has the centroid and area it was made from.
  const Camera camera = LmoCamera();
  const int view = 40;
  const double angle = 70.0 * M_PI / 180.0;
  const Eigen::Vector2d centroid(420.0, 150.0);
  const double area = 0.35 * bank_->silhouettes[view].moments.area_px;
  const Eigen::Isometry3d pose = PoseFromSilhouette(*bank_, view, angle, centroid, area, camera);
  const cv::Mat mask = Render(pose, camera);
  const MaskMoments rendered = MomentsOfMask(mask);
  EXPECT_NEAR(rendered.area_px, area, 0.08 * area);
  // Off the axis the view is the template's seen along another ray: the image of it is the
  // template's under a homography, not a similarity, so the centroid moves a little.
  EXPECT_LT((rendered.centroid_px - centroid).norm(), 0.1 * std::sqrt(area));
  // And its code is the template's turned by the angle.
  EXPECT_GT(SilhouetteIou(bank_->silhouettes[view].bits, EncodeSilhouette(mask, rendered, angle)), 0.85);
}

TEST_F(SilhouettePosesTest, FindsAnUntexturedPartFromItsOutlineAlone) {
  const Camera camera = LmoCamera();
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = AxisAngle(2.1, Eigen::Vector3d(0.3, -0.8, 0.5).normalized());
  truth.translation() = Eigen::Vector3d(0.06, -0.04, 0.55);
  const cv::Mat mask = Render(truth, camera);
  const SamePose same = [](const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
    return RotationDeg(a, b) < 10.0 && (a.translation() - b.translation()).norm() < 0.01;
  };
  SilhouetteOptions options;
  const std::vector<SilhouettePose> poses = SilhouettePoses(*bank_, camera, mask, options, same);
  ASSERT_FALSE(poses.empty());
  EXPECT_LE(static_cast<int>(poses.size()), options.candidates);
  for (size_t k = 1; k < poses.size(); ++k) EXPECT_LE(poses[k].iou, poses[k - 1].iou);
  // The views are ~20 degrees apart and the angles 10: some candidate is within a view's
  // reach of the truth, at about its distance (from the area alone: no depth was given).
  double best_deg = 180.0, best_mm = 1e9;
  for (const SilhouettePose& pose : poses) {
    if (RotationDeg(pose.cam_from_object, truth) < best_deg) {
      best_deg = RotationDeg(pose.cam_from_object, truth);
      best_mm = 1000.0 * (pose.cam_from_object.translation() - truth.translation()).norm();
    }
  }
  EXPECT_LT(best_deg, 20.0);
  EXPECT_LT(best_mm, 40.0);
  // The best candidate's own outline covers most of the mask.
  EXPECT_GT(test::MaskIoU(Render(poses.front().cam_from_object, camera), mask), 0.6);
  // A mask too small to say anything gives nothing.
  options.min_mask_pixels = 1 << 20;
  EXPECT_TRUE(SilhouettePoses(*bank_, camera, mask, options, same).empty());
}

TEST(SilhouetteOptions, CheckNamesTheBadField) {
  SilhouetteOptions options;
  EXPECT_EQ(options.Check(), "");
  options.rotations = 0;
  EXPECT_NE(options.Check().find("SilhouetteOptions.rotations"), std::string::npos);
  options = SilhouetteOptions();
  options.min_iou = 1.5;
  EXPECT_NE(options.Check().find("SilhouetteOptions.min_iou"), std::string::npos);
}

}  // namespace
}  // namespace g6d
