// DetectObjects on synthetic tabletop scenes: textured objects standing on a tilted table
// plane (depth of the table ray-cast, 1 mm noise), no masks given.
#include "solver/detect.h"

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "eval/metrics.h"
#include "mesh/mesh.h"
#include "render/gl_renderer.h"
#include "solver/neighbours.h"
#include "synthetic_scene.h"
#include "test_bank.h"

namespace g6d {
namespace {

const Camera kCamera{572.4, 573.6, 325.3, 242.0, 640, 480};

// The table: the plane through kTableCentre with unit normal kUp (towards the camera side:
// the camera looks down at it at about 50 degrees).
const Eigen::Vector3d kTableCentre(0.0, 0.06, 0.55);
const Eigen::Vector3d kUp = Eigen::Vector3d(0.0, -1.0, -0.85).normalized();

struct TestObject {
  std::string id;
  Mesh mesh;
  Eigen::Vector3d size;
  TemplateBank bank;
};

// A pose standing on the table: the object's z axis along kUp, turned by `yaw` about it,
// its centre `along` metres across the table (x of the image) from kTableCentre.
Eigen::Isometry3d OnTable(const TestObject& object, double along_m, double yaw_rad) {
  const Eigen::Vector3d x_axis = (Eigen::Vector3d::UnitX() - kUp * kUp.x()).normalized();
  Eigen::Matrix3d table_from_up;  // columns: x, y, z (= up) of the table frame
  table_from_up.col(0) = x_axis;
  table_from_up.col(1) = kUp.cross(x_axis);
  table_from_up.col(2) = kUp;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = table_from_up * Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = kTableCentre + along_m * x_axis + kUp * (0.5 * object.size.z() + 0.0005);
  return pose;
}

struct Scene {
  Frame frame;
  std::vector<Eigen::Isometry3d> poses;  // per placed object
};

// Renders the placed objects over the table (nearest surface wins), 1 mm depth noise.
Scene RenderScene(const std::vector<const TestObject*>& objects, const std::vector<Eigen::Isometry3d>& poses,
                  uint64_t seed) {
  Scene scene;
  scene.poses = poses;
  scene.frame.camera = kCamera;
  cv::Mat rgb(kCamera.height, kCamera.width, CV_8UC3);
  cv::Mat depth = cv::Mat::zeros(kCamera.height, kCamera.width, CV_32F);
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> speckle(-12, 12);
  const double offset = -kUp.dot(kTableCentre);
  for (int v = 0; v < kCamera.height; ++v) {
    for (int u = 0; u < kCamera.width; ++u) {
      const Eigen::Vector3d ray = kCamera.Backproject(PixelCentre(u, v), 1.0);
      const double t = -offset / kUp.dot(ray);
      const Eigen::Vector3d p = t * ray;
      // A 1.2 m table; beyond it nothing returns (depth 0).
      if (t > 0.0 && (p - kTableCentre).norm() < 0.6) depth.at<float>(v, u) = static_cast<float>(t);
      const int grey = 140 + speckle(rng);
      rgb.at<cv::Vec3b>(v, u) = cv::Vec3b(grey, grey - 5, grey - 15);
    }
  }
  for (size_t k = 0; k < objects.size(); ++k) {
    GlRenderer renderer(objects[k]->mesh);
    const GlImage image = renderer.Render(kCamera, poses[k]);
    for (int v = 0; v < kCamera.height; ++v) {
      for (int u = 0; u < kCamera.width; ++u) {
        if (!image.mask.at<uint8_t>(v, u)) continue;
        const float z = image.depth.at<float>(v, u);
        float& scene_z = depth.at<float>(v, u);
        if (scene_z > 0.0f && scene_z <= z) continue;
        scene_z = z;
        rgb.at<cv::Vec3b>(v, u) = image.rgb.at<cv::Vec3b>(v, u);
      }
    }
  }
  std::normal_distribution<float> noise(0.0f, 0.001f);
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      if (depth.at<float>(v, u) > 0.0f) depth.at<float>(v, u) += noise(rng);
    }
  }
  scene.frame.rgb = rgb;
  scene.frame.depth = depth;
  return scene;
}

SolverOptions QuickSolver() {
  SolverOptions options;
  options.num_hypotheses = 8;
  return options;
}

class DetectTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    objects_ = new std::vector<TestObject>();
    ThreadPool pool(2);
    TemplateBuildOptions templates;
    templates.views.num_directions = 60;
    templates.views.num_inplane = 3;
    const struct {
      const char* id;
      double sx, sy, sz;
      uint64_t seed;
    } specs[] = {{"box", 0.10, 0.07, 0.05, 21}, {"bar", 0.18, 0.035, 0.03, 9}};
    for (const auto& spec : specs) {
      TestObject object;
      object.id = spec.id;
      object.size = Eigen::Vector3d(spec.sx, spec.sy, spec.sz);
      object.mesh = test::MakeTexturedBox(spec.sx, spec.sy, spec.sz, spec.seed);
      object.bank = test::SharedTestBank(std::string("identify-") + spec.id, object.mesh, spec.id, templates, &pool);
      objects_->push_back(std::move(object));
    }
  }
  static void TearDownTestSuite() { delete objects_; }

  static const TestObject& Box() { return objects_->at(0); }
  static const TestObject& Bar() { return objects_->at(1); }

  static std::vector<TestObject>* objects_;
};
std::vector<TestObject>* DetectTest::objects_ = nullptr;

double AddOf(const Detection& detection, const TestObject& object, const Eigen::Isometry3d& truth) {
  return ComputeAdd(detection.result.cam_from_object, truth, object.mesh.vertices);
}

TEST_F(DetectTest, FindsEachObjectOnTheTableWithoutAMask) {
  const Scene scene = RenderScene({&Box(), &Bar()}, {OnTable(Box(), -0.09, 0.4), OnTable(Bar(), 0.08, -0.7)}, 3);
  ThreadPool pool(2);
  DetectionReport report;
  const std::vector<Detection> detections =
      DetectObjects(scene.frame, {{&Box().bank, 1}, {&Bar().bank, 1}}, QuickSolver(), DetectOptions(), &pool, &report);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_EQ(report.support_planes, 1) << report.message;
  ASSERT_EQ(detections.size(), 2u) << report.message;
  for (const Detection& detection : detections) {
    const bool is_box = detection.object_id == Box().id;
    const TestObject& object = is_box ? Box() : Bar();
    const Eigen::Isometry3d& truth = scene.poses[is_box ? 0 : 1];
    const double add = AddOf(detection, object, truth);
    EXPECT_LT(add, 0.1 * object.bank.diameter_m) << detection.object_id << ": ADD " << add * 1000 << " mm, S "
                                                 << detection.result.score;
    // The region it came from lies on the object: most of it inside the true silhouette's box.
    ASSERT_GE(detection.proposal, 0);
    EXPECT_FALSE(detection.region.empty());
    EXPECT_GT(cv::countNonZero(detection.region), 500);
    // A whole object's region covers about one of its silhouettes (DetectOptions::area_weight):
    // the ratio to the median silhouette at its depth is near 1, its agreement high.
    int ranked = 0;
    for (const CandidateTrial& trial : report.trials) {
      if (trial.proposal != detection.proposal || trial.request != detection.request) continue;
      ++ranked;
      EXPECT_GT(trial.area_ratio, 0.5) << detection.object_id;
      EXPECT_LT(trial.area_ratio, 2.0) << detection.object_id;
      EXPECT_GT(trial.area_term, 0.7) << detection.object_id;
    }
    EXPECT_GE(ranked, 1) << detection.object_id << ": its region was never ranked";
  }
  EXPECT_NE(detections[0].object_id, detections[1].object_id);
  // Answers come best first and every stage reported its time.
  EXPECT_LE(detections[0].result.score, detections[1].result.score);
  EXPECT_GT(report.solves, 0);
  EXPECT_GE(report.total_ms, report.solve_ms);

  // The picture for a person: the support darkened, each answer's contour in green.
  const cv::Mat picture =
      DrawDetectionPicture(scene.frame, {{&Box().bank, 1}, {&Bar().bank, 1}}, report, detections);
  ASSERT_EQ(picture.size(), scene.frame.rgb.size());
  cv::Mat grey_picture, grey_frame;
  cv::cvtColor(picture, grey_picture, cv::COLOR_RGB2GRAY);
  cv::cvtColor(scene.frame.rgb, grey_frame, cv::COLOR_RGB2GRAY);
  EXPECT_LT(cv::mean(grey_picture, report.support)[0], 0.5 * cv::mean(grey_frame, report.support)[0]);
  cv::Mat green;
  cv::inRange(picture, cv::Scalar(55, 250, 55), cv::Scalar(65, 255, 65), green);
  EXPECT_GT(cv::countNonZero(green), 200);
}

// The silhouette of an object at a pose (every pixel it covers, occlusion ignored).
cv::Mat Silhouette(const TestObject& object, const Eigen::Isometry3d& pose) {
  GlRenderer renderer(object.mesh);
  return renderer.Render(kCamera, pose).mask > 0;
}

TEST_F(DetectTest, WithinKeepsTheCandidatesInsideTheGivenArea) {
  // Two boxes; the request says where one of them is: that one is the answer, whichever
  // would rank first over the whole frame.
  const Scene scene = RenderScene({&Box(), &Box()}, {OnTable(Box(), -0.10, 0.3), OnTable(Box(), 0.10, -0.9)}, 11);
  ThreadPool pool(2);
  for (size_t k = 0; k < 2; ++k) {
    DetectRequest request{&Box().bank, 1};
    cv::Mat within = cv::Mat::zeros(kCamera.height, kCamera.width, CV_8U);
    within(cv::boundingRect(Silhouette(Box(), scene.poses[k]))).setTo(255);  // a box detector's box
    request.within = within;
    const std::vector<Detection> found = DetectObjects(scene.frame, {request}, QuickSolver(), DetectOptions(), &pool, nullptr);
    ASSERT_EQ(found.size(), 1u) << "box " << k;
    EXPECT_LT(AddOf(found[0], Box(), scene.poses[k]), 0.1 * Box().bank.diameter_m) << "box " << k;
  }
  // A `within` of the wrong type or size is a bad argument, named.
  DetectRequest bad{&Box().bank, 1};
  bad.within = cv::Mat::zeros(10, 10, CV_8U);
  try {
    DetectObjects(scene.frame, {bad}, QuickSolver(), DetectOptions(), &pool, nullptr);
    ADD_FAILURE() << "no error for a 10x10 `within`";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("within"), std::string::npos) << e.what();
  }
}

TEST_F(DetectTest, AMaskOverTwoTouchingObjectsIsSolvedOnTheObjectsOwnRegion) {
  // Two boxes stand side by side, touching: a segmenter's mask that merged them is one
  // region wider than a box can be. EstimatePose solves the depth's own regions inside it
  // (depth_regions.h) beside the mask, keeps the lowest S_A, and answers one box's pose,
  // with the mask it implies (about half of the merged one). Segment ownership leaves the
  // other box's segment out of the mask's own answer too, so the two answers nearly tie:
  // which one wins is no property; that the better one is kept is.
  const Eigen::Isometry3d left = OnTable(Box(), -0.05, 0.0);
  const Eigen::Isometry3d right = OnTable(Box(), -0.05 + Box().size.x() + 0.001, 0.0);
  const Scene scene = RenderScene({&Box(), &Box()}, {left, right}, 13);
  const cv::Mat merged = Silhouette(Box(), left) | Silhouette(Box(), right);
  ThreadPool pool(2);
  const PoseResult result = EstimatePose(scene.frame, {Box().id, merged}, Box().bank, QuickSolver(), &pool);
  ASSERT_TRUE(result.success) << result.message;
  EXPECT_TRUE(result.stages.mask_wider_than_object);
  EXPECT_GT(result.stages.depth_regions_solved, 0);
  EXPECT_GT(result.stages.depth_regions_ms, 0.0);
  EXPECT_LE(result.score, result.stages.mask_answer_score) << "S " << result.score << ", on the mask " << result.stages.mask_answer_score;
  if (result.stages.depth_region_chosen) {
    EXPECT_LT(result.score, result.stages.mask_answer_score);
  }
  const double add = std::min(ComputeAdd(result.cam_from_object, left, Box().mesh.vertices),
                              ComputeAdd(result.cam_from_object, right, Box().mesh.vertices));
  EXPECT_LT(add, 0.1 * Box().bank.diameter_m) << "ADD " << add * 1000 << " mm, S " << result.score;
  EXPECT_GT(result.mask_iou, 0.3);
  EXPECT_LT(result.mask_iou, 0.7);

  // Off, the solve reads the merged mask alone: no region, and no better answer than with them.
  SolverOptions off = QuickSolver();
  off.region_candidates = 0;
  const PoseResult on_mask = EstimatePose(scene.frame, {Box().id, merged}, Box().bank, off, &pool);
  EXPECT_EQ(on_mask.stages.depth_regions_solved, 0);
  EXPECT_FALSE(on_mask.stages.depth_region_chosen);
  EXPECT_GE(on_mask.score, result.score);
}

// Two masks merged over the same two touching boxes (a bin's parts, a segmenter that merged
// them twice): both solves answer on one box. Two requests are two instances: the answer of
// higher S_A (here the later one, on a tie) is solved again without its twin's pixels, and
// lands on the other box.
TEST_F(DetectTest, TwoAnswersOnOneInstanceAreToldApart) {
  const Eigen::Isometry3d left = OnTable(Box(), -0.05, 0.0);
  const Eigen::Isometry3d right = OnTable(Box(), -0.05 + Box().size.x() + 0.001, 0.0);
  const Scene scene = RenderScene({&Box(), &Box()}, {left, right}, 13);
  const cv::Mat merged = Silhouette(Box(), left) | Silhouette(Box(), right);
  const std::vector<Instance> instances{{Box().id, merged}, {Box().id, merged.clone()}};
  const std::vector<const TemplateBank*> banks{&Box().bank, &Box().bank};
  const SolverOptions options = QuickSolver();
  ThreadPool pool(2);
  std::vector<PoseResult> answers;
  for (size_t k = 0; k < 2; ++k) answers.push_back(EstimatePose(scene.frame, instances[k], *banks[k], options, &pool));
  ASSERT_TRUE(answers[0].success && answers[1].success) << answers[0].message << " / " << answers[1].message;
  ASSERT_TRUE(SamePlace(answers[0], answers[1], Box().bank));
  EXPECT_EQ(DuplicateAnswers(instances, banks, answers, options), (std::vector<int>{-1, 0}));
  const std::vector<PoseResult> first = answers;
  ExplainAwayNeighbours(scene.frame, instances, banks, {}, options, &pool, &answers);
  ASSERT_TRUE(answers[0].success && answers[1].success) << answers[1].message;
  EXPECT_FALSE(SamePlace(answers[0], answers[1], Box().bank));
  EXPECT_TRUE(answers[0].cam_from_object.isApprox(first[0].cam_from_object));  // the place's keeper stays
  EXPECT_TRUE(answers[1].stages.neighbour_answer_chosen);
  auto add_to = [&](const PoseResult& r, const Eigen::Isometry3d& truth) {
    return ComputeAdd(r.cam_from_object, truth, Box().mesh.vertices);
  };
  const double limit = 0.1 * Box().bank.diameter_m;
  const bool first_left = add_to(answers[0], left) < limit;
  EXPECT_TRUE(first_left || add_to(answers[0], right) < limit);
  EXPECT_LT(add_to(answers[1], first_left ? right : left), limit) << "S " << answers[1].score;
  EXPECT_TRUE(DuplicateAnswers(instances, banks, answers, options) == (std::vector<int>{-1, -1}));
  EXPECT_FALSE(answers[0].stages.duplicate_answer || answers[1].stages.duplicate_answer);
  // Two requests with one box's own mask: nothing is left for the second, whose answer stays
  // on the box, flagged, and at most 1 - the first's confidence sure.
  const std::vector<Instance> same{{Box().id, Silhouette(Box(), left)}, {Box().id, Silhouette(Box(), left)}};
  std::vector<PoseResult> twice;
  for (size_t k = 0; k < 2; ++k) twice.push_back(EstimatePose(scene.frame, same[k], *banks[k], options, &pool));
  ASSERT_TRUE(twice[0].success && twice[1].success);
  ExplainAwayNeighbours(scene.frame, same, banks, {}, options, &pool, &twice);
  ASSERT_TRUE(twice[0].success && twice[1].success);
  ASSERT_TRUE(SamePlace(twice[0], twice[1], Box().bank));
  EXPECT_FALSE(twice[0].stages.duplicate_answer);
  EXPECT_TRUE(twice[1].stages.duplicate_answer);
  EXPECT_GT(twice[0].confidence, 0.5);
  EXPECT_LE(twice[1].confidence, 1.0 - twice[0].confidence + 1e-12);
  // Off: the two answers stay on one box.
  SolverOptions off = options;
  off.resolve_duplicates = false;
  EXPECT_EQ(DuplicateAnswers(instances, banks, first, off), (std::vector<int>{-1, -1}));
  std::vector<PoseResult> kept = first;
  ExplainAwayNeighbours(scene.frame, instances, banks, {}, off, &pool, &kept);
  EXPECT_TRUE(SamePlace(kept[0], kept[1], Box().bank));
}

// ExplainAwayNeighbours (neighbours.h) lives here for the scenes and banks of this suite.
TEST_F(DetectTest, ANeighboursConfidentAnswerTakesItsPixelsOutOfAMergedMask) {
  // Two boxes touch; one instance's mask merged both, the other's is its own. With the
  // depth's regions off, the merged mask's solve alone answers poorly; read with its
  // neighbour's confident answer, the pixels that answer explains are taken out, and the
  // solve on the rest gives the left box's pose.
  const Eigen::Isometry3d left = OnTable(Box(), -0.05, 0.0);
  const Eigen::Isometry3d right = OnTable(Box(), -0.05 + Box().size.x() + 0.001, 0.0);
  const Scene scene = RenderScene({&Box(), &Box()}, {left, right}, 13);
  const cv::Mat own_right = Silhouette(Box(), right);
  const std::vector<Instance> instances{{Box().id, Silhouette(Box(), left) | own_right}, {Box().id, own_right}};
  const std::vector<const TemplateBank*> banks{&Box().bank, &Box().bank};
  SolverOptions options = QuickSolver();
  options.region_candidates = 0;
  // The outline's poses on every solve, as this was measured with: with them skipped where
  // the texture agrees (the default), the left box's pose is as right, at S 0.031 against
  // the merged mask's 0.025.
  options.silhouette_skip_agreement = 0;
  ThreadPool pool(2);
  std::vector<PoseResult> answers;
  for (size_t k = 0; k < 2; ++k) answers.push_back(EstimatePose(scene.frame, instances[k], *banks[k], options, &pool));
  ASSERT_TRUE(answers[1].success) << answers[1].message;
  ASSERT_FALSE(UnsureOfScore(options, answers[1].score, answers[1].ambiguous)) << "S " << answers[1].score;
  EXPECT_TRUE(answers[0].stages.mask_wider_than_object);
  const std::vector<PoseResult> first = answers;
  ExplainAwayNeighbours(scene.frame, instances, banks, {}, options, &pool, &answers);
  ASSERT_TRUE(answers[0].success) << answers[0].message;
  EXPECT_GT(answers[0].stages.neighbour_pixels, cv::countNonZero(own_right) / 2);
  EXPECT_TRUE(answers[0].stages.neighbour_answer_chosen);
  EXPECT_GT(answers[0].stages.neighbours_ms, 0.0);
  EXPECT_LT(answers[0].score, first[0].score);
  const double add = ComputeAdd(answers[0].cam_from_object, left, Box().mesh.vertices);
  EXPECT_LT(add, 0.1 * Box().bank.diameter_m) << "ADD " << add * 1000 << " mm, S " << answers[0].score;
  EXPECT_GT(answers[0].mask_iou, 0.3);  // with the merged mask the caller gave
  EXPECT_LT(answers[0].mask_iou, 0.7);
  // The confident answer is left as it was.
  EXPECT_EQ(answers[1].stages.neighbour_pixels, 0);
  EXPECT_TRUE(answers[1].cam_from_object.isApprox(first[1].cam_from_object));

  // The order of the instances does not matter.
  std::vector<PoseResult> swapped{first[1], first[0]};
  ExplainAwayNeighbours(scene.frame, {instances[1], instances[0]}, {banks[1], banks[0]}, {}, options, &pool, &swapped);
  EXPECT_TRUE(swapped[1].cam_from_object.isApprox(answers[0].cam_from_object));
  EXPECT_EQ(swapped[1].score, answers[0].score);

  // Off, or the instance not to be solved again (a tracked answer), the answers stand;
  // sizes that disagree are named.
  SolverOptions off = options;
  off.explain_neighbours = false;
  std::vector<PoseResult> kept = first;
  ExplainAwayNeighbours(scene.frame, instances, banks, {}, off, &pool, &kept);
  EXPECT_EQ(kept[0].stages.neighbour_pixels, 0);
  EXPECT_EQ(kept[0].score, first[0].score);
  kept = first;
  ExplainAwayNeighbours(scene.frame, instances, banks, {0, 1}, options, &pool, &kept);
  EXPECT_EQ(kept[0].stages.neighbour_pixels, 0);
  EXPECT_EQ(kept[0].score, first[0].score);
  std::vector<PoseResult> one{first[0]};
  try {
    ExplainAwayNeighbours(scene.frame, instances, banks, {}, options, &pool, &one);
    ADD_FAILURE() << "no error for 2 instances and 1 answer";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("1 answers"), std::string::npos) << e.what();
  }
}

TEST_F(DetectTest, AnObjectThatIsNotThereGetsNoAnswer) {
  // Only the box stands on the table; the bar is asked for too.
  const Scene scene = RenderScene({&Box()}, {OnTable(Box(), 0.0, 0.3)}, 11);
  ThreadPool pool(2);
  DetectOptions options;
  options.max_overlap = 1.0;  // the bar's pose may lie on the box's pixels: only its confidence can refuse it
  DetectionReport report;
  const std::vector<Detection> detections =
      DetectObjects(scene.frame, {{&Box().bank, 1}, {&Bar().bank, 1}}, QuickSolver(), options, &pool, &report);
  ASSERT_TRUE(report.success) << report.message;
  ASSERT_EQ(detections.size(), 1u) << report.message;
  EXPECT_EQ(detections[0].object_id, Box().id);
  EXPECT_LT(AddOf(detections[0], Box(), scene.poses[0]), 0.1 * Box().bank.diameter_m);
  EXPECT_GT(detections[0].result.confidence, 0.5);
  // Without the confidence's floor the bar's best guess is answered, and is unsure.
  options.min_confidence = 0.0;
  const std::vector<Detection> guesses =
      DetectObjects(scene.frame, {{&Box().bank, 1}, {&Bar().bank, 1}}, QuickSolver(), options, &pool, nullptr);
  for (const Detection& guess : guesses) {
    if (guess.object_id == Bar().id) {
      EXPECT_LT(guess.result.confidence, DetectOptions().min_confidence);
    }
  }
}

TEST_F(DetectTest, AnAnswerGivesWayToAnObjectThatExplainsItsRegionBetter) {
  // Only the box stands on the table; the bar is asked for too, and without the
  // confidence's floor its best guess is answered, on the box.
  const Scene scene = RenderScene({&Box()}, {OnTable(Box(), 0.0, 0.3)}, 11);
  ThreadPool pool(2);
  const std::vector<DetectRequest> requests = {{&Box().bank, 1}, {&Bar().bank, 1}};
  DetectOptions options;
  options.max_overlap = 1.0;
  options.min_confidence = 0.0;
  options.max_score = 1e9;
  options.identity_check_below = 0.0;
  DetectionReport report;
  std::vector<Detection> detections = DetectObjects(scene.frame, requests, QuickSolver(), options, &pool, &report);
  ASSERT_EQ(detections.size(), 2u) << report.message;
  EXPECT_EQ(report.identity_checked, 0);
  // Checked, the bar's region is better explained by the box: the guess gives way, and
  // the box, which has its one instance already, takes nothing more.
  options.identity_check_below = 1.0;
  detections = DetectObjects(scene.frame, requests, QuickSolver(), options, &pool, &report);
  EXPECT_EQ(report.identity_checked, 2) << report.message;
  EXPECT_GE(report.identity_solves, 1);
  EXPECT_EQ(report.identity_dropped, 1);
  EXPECT_EQ(report.identity_replaced, 0);
  ASSERT_EQ(detections.size(), 1u) << report.message;
  EXPECT_EQ(detections[0].object_id, Box().id);
  EXPECT_LT(AddOf(detections[0], Box(), scene.poses[0]), 0.1 * Box().bank.diameter_m);
  // Asked for two boxes, the box's answer on the bar's region takes the guess's place.
  detections = DetectObjects(scene.frame, {{&Box().bank, 2}, {&Bar().bank, 1}}, QuickSolver(), options, &pool, &report);
  EXPECT_EQ(report.identity_dropped, 1) << report.message;
  EXPECT_EQ(report.identity_replaced, 1);
  for (const Detection& detection : detections) {
    EXPECT_EQ(detection.object_id, Box().id);
    EXPECT_LT(AddOf(detection, Box(), scene.poses[0]), 0.1 * Box().bank.diameter_m);
  }
}

TEST_F(DetectTest, OnlyObjectsAlreadyFoundGetTheFurtherPasses) {
  // One box on the table; two boxes and a bar asked for. The box is found and wants one
  // more: it gets the found-object passes. The bar is not there: no pass after the
  // explaining-away pass ranks a region for it.
  const Scene scene = RenderScene({&Box()}, {OnTable(Box(), 0.0, 0.3)}, 11);
  ThreadPool pool(2);
  DetectOptions options;
  options.explain_away_passes = 1;
  options.found_object_passes = 2;
  DetectionReport report;
  const std::vector<Detection> detections =
      DetectObjects(scene.frame, {{&Box().bank, 2}, {&Bar().bank, 1}}, QuickSolver(), options, &pool, &report);
  ASSERT_TRUE(report.success) << report.message;
  ASSERT_EQ(detections.size(), 1u) << report.message;
  EXPECT_EQ(detections[0].object_id, Box().id);
  EXPECT_EQ(report.explain_away_passes, 3) << report.message;
  int bar_trials = 0;
  for (const CandidateTrial& trial : report.trials) {
    if (trial.request != 1) continue;
    ++bar_trials;
    EXPECT_LE(trial.pass, options.explain_away_passes) << "the bar, never found, was ranked in a found-object pass";
  }
  EXPECT_GT(bar_trials, 0) << "the bar was never ranked: the test shows nothing";
  options.found_object_passes = 0;
  DetectObjects(scene.frame, {{&Box().bank, 2}, {&Bar().bank, 1}}, QuickSolver(), options, &pool, &report);
  EXPECT_EQ(report.explain_away_passes, 1) << report.message;
}

TEST_F(DetectTest, CandidateSolvesKeepAtMostTheirOwnK) {
  const Scene scene = RenderScene({&Box()}, {OnTable(Box(), 0.0, 0.3)}, 11);
  ThreadPool pool(2);
  SolverOptions solver = QuickSolver();
  solver.use_ppf = false;  // only the PnP poses fill the K slots
  solver.use_silhouettes = false;  // (an island's solve adds the outline's own slots)
  DetectOptions options;
  options.max_solve_hypotheses = 0;  // the solver's K (8)
  options.solve_pnp_min_quality = 0.0;  // PnP on every set: many distinct poses
  const std::vector<Detection> all = DetectObjects(scene.frame, {{&Box().bank, 1}}, solver, options, &pool, nullptr);
  ASSERT_EQ(all.size(), 1u);
  EXPECT_GT(all[0].result.stages.kept_poses.size(), 2u) << "too few PnP poses to tell the cap";
  options.max_solve_hypotheses = 2;
  const std::vector<Detection> capped = DetectObjects(scene.frame, {{&Box().bank, 1}}, solver, options, &pool, nullptr);
  ASSERT_EQ(capped.size(), 1u);
  EXPECT_LE(capped[0].result.stages.kept_poses.size(), 2u);
  EXPECT_LT(AddOf(capped[0], Box(), scene.poses[0]), 0.1 * Box().bank.diameter_m);
}

TEST_F(DetectTest, AnIslandsSolveReadsItsOutlineAndASegmentsDoesNot) {
  const Scene scene = RenderScene({&Box()}, {OnTable(Box(), 0.0, 0.3)}, 11);
  ThreadPool pool(2);
  DetectOptions options;
  options.extra_candidates = 4;  // islands and segment regions both solved
  SolverOptions solver = QuickSolver();
  solver.silhouette_skip_agreement = 0;  // outline poses even where the texture agrees on the pose
  DetectionReport report;
  const std::vector<Detection> found = DetectObjects(scene.frame, {{&Box().bank, 1}}, solver, options, &pool, &report);
  ASSERT_EQ(found.size(), 1u) << report.message;
  EXPECT_LT(AddOf(found[0], Box(), scene.poses[0]), 0.1 * Box().bank.diameter_m);
  // The answer's solve adds outline poses exactly when its region is an island.
  const Proposal& answered = report.proposals[static_cast<size_t>(found[0].proposal)];
  if (!answered.mask.empty()) {
    EXPECT_GT(found[0].result.stages.silhouette_hypotheses, 0) << "an island's solve made no pose from its outline";
  } else {
    EXPECT_EQ(found[0].result.stages.silhouette_hypotheses, 0) << "a depth segment's outline is the depth's, not the object's";
  }
  options.island_silhouettes = false;
  const std::vector<Detection> without = DetectObjects(scene.frame, {{&Box().bank, 1}}, solver, options, &pool, &report);
  ASSERT_EQ(without.size(), 1u);
  EXPECT_EQ(without[0].result.stages.silhouette_hypotheses, 0);
}

TEST_F(DetectTest, AnEmptyTableGivesNoAnswerAndSolvesNothing) {
  const Scene scene = RenderScene({}, {}, 5);
  ThreadPool pool(2);
  DetectionReport report;
  const std::vector<Detection> detections =
      DetectObjects(scene.frame, {{&Box().bank, 2}, {&Bar().bank, 1}}, QuickSolver(), DetectOptions(), &pool, &report);
  EXPECT_TRUE(report.success) << report.message;
  EXPECT_TRUE(detections.empty());
  EXPECT_EQ(report.solves, 0) << report.message;
  // The table is support: almost every pixel with depth was removed.
  int with_depth = 0;
  for (int v = 0; v < scene.frame.depth.rows; ++v) {
    for (int u = 0; u < scene.frame.depth.cols; ++u) with_depth += scene.frame.depth.at<float>(v, u) > 0.0f;
  }
  EXPECT_GT(cv::countNonZero(report.support), 0.97 * with_depth);
}

TEST_F(DetectTest, TheCountLimitsTheAnswersOfAnObject) {
  // Two boxes on the table, one asked for: one answer; two asked for: both, in different places.
  const Scene scene = RenderScene({&Box(), &Box()}, {OnTable(Box(), -0.10, 0.3), OnTable(Box(), 0.10, -0.9)}, 7);
  ThreadPool pool(2);
  const std::vector<Detection> one =
      DetectObjects(scene.frame, {{&Box().bank, 1}}, QuickSolver(), DetectOptions(), &pool, nullptr);
  EXPECT_EQ(one.size(), 1u);
  const std::vector<Detection> two =
      DetectObjects(scene.frame, {{&Box().bank, 2}}, QuickSolver(), DetectOptions(), &pool, nullptr);
  ASSERT_EQ(two.size(), 2u);
  for (const Detection& detection : two) {
    const double add = std::min(AddOf(detection, Box(), scene.poses[0]), AddOf(detection, Box(), scene.poses[1]));
    EXPECT_LT(add, 0.1 * Box().bank.diameter_m) << "ADD " << add * 1000 << " mm";
  }
  const double apart = (two[0].result.cam_from_object.translation() - two[1].result.cam_from_object.translation()).norm();
  EXPECT_GT(apart, 0.1);
}

TEST_F(DetectTest, ABadFrameIsReportedNotThrown) {
  Frame frame;
  frame.camera = kCamera;
  frame.rgb = cv::Mat(10, 10, CV_8UC3, cv::Scalar(0, 0, 0));
  frame.depth = cv::Mat(10, 10, CV_32F, cv::Scalar(0.5f));
  ThreadPool pool(1);
  DetectionReport report;
  const std::vector<Detection> detections =
      DetectObjects(frame, {{&Box().bank, 1}}, QuickSolver(), DetectOptions(), &pool, &report);
  EXPECT_TRUE(detections.empty());
  EXPECT_FALSE(report.success);
  EXPECT_NE(report.message.find("camera's size"), std::string::npos) << report.message;
}

TEST_F(DetectTest, BadArgumentsThrowNamingTheProblem) {
  const Scene scene = RenderScene({}, {}, 9);
  ThreadPool pool(1);
  auto message_of = [&](const std::vector<DetectRequest>& requests, const DetectOptions& options) -> std::string {
    try {
      DetectObjects(scene.frame, requests, QuickSolver(), options, &pool, nullptr);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message_of({}, DetectOptions()).find("no objects"), std::string::npos);
  EXPECT_NE(message_of({{nullptr, 1}}, DetectOptions()).find("no template bank"), std::string::npos);
  EXPECT_NE(message_of({{&Box().bank, 0}}, DetectOptions()).find("asks for 0"), std::string::npos);
  DetectOptions bad;
  bad.max_overlap = 2.0;
  EXPECT_NE(message_of({{&Box().bank, 1}}, bad).find("max_overlap"), std::string::npos);
}

TEST(SolverOptions, TheDepthRegionOptionsAreChecked) {
  SolverOptions options;
  options.region_candidates = -1;
  EXPECT_NE(options.Check().find("region_candidates"), std::string::npos) << options.Check();
  options = SolverOptions();
  options.unsure_score = -0.1;
  EXPECT_NE(options.Check().find("unsure_score"), std::string::npos) << options.Check();
  options = SolverOptions();
  options.unsure_ambiguous_score = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(options.Check().find("unsure_ambiguous_score"), std::string::npos) << options.Check();
  options = SolverOptions();
  options.neighbour_min_fraction = 0.0;
  EXPECT_NE(options.Check().find("neighbour_min_fraction"), std::string::npos) << options.Check();
}

TEST(DetectOptions, CheckNamesTheBadField) {
  EXPECT_EQ(DetectOptions().Check(), "");
  DetectOptions options;
  options.extra_candidates = -1;
  EXPECT_NE(options.Check().find("extra_candidates"), std::string::npos);
  options = DetectOptions();
  options.segments.min_segment_pixels = 0;
  EXPECT_NE(options.Check().find("min_segment_pixels"), std::string::npos);
  options = DetectOptions();
  options.support_extent_factor = 0.5;
  EXPECT_NE(options.Check().find("support_extent_factor"), std::string::npos);
  options = DetectOptions();
  options.min_confidence = 1.5;
  EXPECT_NE(options.Check().find("min_confidence"), std::string::npos);
  options = DetectOptions();
  options.confidence_on_surface_weight = std::nan("");
  EXPECT_NE(options.Check().find("confidence_"), std::string::npos);
  options = DetectOptions();
  options.shape_references = 0;
  EXPECT_NE(options.Check().find("shape_references"), std::string::npos);
  options = DetectOptions();
  options.found_object_passes = -1;
  EXPECT_NE(options.Check().find("found_object_passes"), std::string::npos);
  options = DetectOptions();
  options.sure_first_confidence = -0.1;
  EXPECT_NE(options.Check().find("sure_first_confidence"), std::string::npos);
  options = DetectOptions();
  options.max_solve_hypotheses = -1;
  EXPECT_NE(options.Check().find("max_solve_hypotheses"), std::string::npos);
  options = DetectOptions();
  options.solve_pnp_min_quality = 1.5;
  EXPECT_NE(options.Check().find("solve_pnp_min_quality"), std::string::npos);
  options = DetectOptions();
  options.identity_check_below = -0.1;
  EXPECT_NE(options.Check().find("identity_check_below"), std::string::npos);
}

TEST(DetectionConfidence, RisesWithWhatTheFrameConfirmsAndFallsWithS) {
  const DetectOptions options;
  PoseResult result;
  result.score = 0.1;
  result.has_runner_up = true;  // a rival 0.05 behind in S: the base is neither sure nor unsure
  result.runner_up_score = 0.15;
  FrameCheck check;
  check.on_surface = 0.8;
  check.contour_support = 0.4;
  check.in_image = 1.0;
  check.oriented_edge = 0.4;
  const double base = DetectionConfidence(options, result, check, 0.8, 0.5);
  EXPECT_GT(base, 0.5);
  EXPECT_LT(base, 1.0);
  // An outline the colour image does not show (a pose laid onto a bare floor) is less sure,
  // one it shows all around surer.
  FrameCheck unseen = check;
  unseen.oriented_edge = 0.0;
  EXPECT_LT(DetectionConfidence(options, result, unseen, 0.8, 0.5), base - 0.2);
  FrameCheck outlined = check;
  outlined.oriented_edge = 1.0;
  EXPECT_GT(DetectionConfidence(options, result, outlined, 0.8, 0.5), base + 0.1);
  // A rival pose in the answer's own solve that explains the frame almost as well (a part
  // turned over) makes it less sure; one far behind, or none, surer (RunnerUpGap: S of the
  // runner-up less S_A, at most 0.25).
  PoseResult rivalled = result;
  rivalled.runner_up_score = result.score + 0.01;
  EXPECT_NEAR(RunnerUpGap(rivalled), 0.01, 1e-12);
  PoseResult unrivalled = rivalled;
  unrivalled.runner_up_score = result.score + 0.5;
  EXPECT_LT(DetectionConfidence(options, rivalled, check, 0.8, 0.5),
            DetectionConfidence(options, unrivalled, check, 0.8, 0.5) - 0.2);
  PoseResult alone = result;  // no runner-up: as one worse by the cap
  alone.has_runner_up = false;
  EXPECT_EQ(RunnerUpGap(alone), 0.25);
  EXPECT_GE(DetectionConfidence(options, alone, check, 0.8, 0.5), DetectionConfidence(options, unrivalled, check, 0.8, 0.5));
  FrameCheck worse = check;
  worse.on_surface = 0.3;  // most of the rendered model is not where the depth is
  EXPECT_LT(DetectionConfidence(options, result, worse, 0.8, 0.5), base - 0.2);
  PoseResult higher = result;
  higher.score = 0.3;
  EXPECT_LT(DetectionConfidence(options, higher, check, 0.8, 0.5), base);
  higher.score = std::numeric_limits<double>::infinity();
  EXPECT_EQ(DetectionConfidence(options, higher, check, 0.8, 0.5), 0.0);
  // A pose mostly beyond the image's border rests on the little of it inside.
  FrameCheck outside = check;
  outside.in_image = 0.2;
  EXPECT_LT(DetectionConfidence(options, result, outside, 0.8, 0.5), options.min_confidence);
  // The camera sees the table through a band 5 px wide along its outline (a model laid onto
  // a smaller object), against a pixel's rim of a right answer.
  FrameCheck seen_through = check;
  seen_through.free_space_band_px = 5.0;
  EXPECT_LT(DetectionConfidence(options, result, seen_through, 0.8, 0.5), base - 0.2);
  FrameCheck rim = check;
  rim.free_space_band_px = 1.0;
  EXPECT_LT(DetectionConfidence(options, result, seen_through, 0.8, 0.5), DetectionConfidence(options, result, rim, 0.8, 0.5));
  // An answer inside the support under it is no answer, unless that rule is off.
  PoseResult inside = result;
  inside.stages.answer_behind_support = true;
  EXPECT_EQ(DetectionConfidence(options, inside, check, 0.8, 0.5), 0.0);
  DetectOptions lenient = options;
  lenient.refuse_behind_support = false;
  EXPECT_EQ(DetectionConfidence(lenient, inside, check, 0.8, 0.5), base);
}

// A region whose colours are not the model's (an object asked for that is not there, found
// on another object's region) lowers the confidence; a model without colour (0.5) is neutral.
TEST(DetectionConfidence, FallsWhenTheRegionsColourIsNotTheModels) {
  const DetectOptions options;
  PoseResult result;
  result.score = 0.1;
  result.has_runner_up = true;  // a rival 0.05 behind in S
  result.runner_up_score = 0.15;
  FrameCheck check;  // an answer the frame half supports: neither sure nor unlikely
  check.on_surface = 0.8;
  check.contour_support = 0.5;
  check.in_image = 1.0;
  check.oriented_edge = 0.3;  // a third of the outline on an edge along it
  const double unlike = DetectionConfidence(options, result, check, 0.8, 0.0);
  const double uncoloured = DetectionConfidence(options, result, check, 0.8, 0.5);
  const double alike = DetectionConfidence(options, result, check, 0.8, 0.9);
  // By the fitted weight (DetectOptions::confidence_colour_weight, 2.0 since the fit was
  // regularized; 3.6 before): half the colour term's range is a logit of 1, 0.2 off an
  // answer at 0.8.
  EXPECT_LT(unlike, uncoloured - 0.15);
  EXPECT_GT(uncoloured, options.min_confidence);
  EXPECT_GT(alike, uncoloured);
}

// The box's region darkened to a seventh (a black object of its shape, same chromaticity):
// its lightness ratio (recorded for analysis) is far below the box's as rendered, which lies
// near 1; the chromaticity term cannot tell them apart.
TEST_F(DetectTest, TheLightnessRatioReadsARegionFarDarkerThanTheModelsAlbedo) {
  Scene scene = RenderScene({&Box()}, {OnTable(Box(), 0.0, 0.3)}, 11);
  GlRenderer renderer(Box().mesh);
  const cv::Mat box_pixels = renderer.Render(kCamera, scene.poses[0]).mask;
  Frame dark = scene.frame;
  dark.rgb = scene.frame.rgb.clone();
  for (int v = 0; v < dark.rgb.rows; ++v) {
    for (int u = 0; u < dark.rgb.cols; ++u) {
      if (box_pixels.at<uint8_t>(v, u)) dark.rgb.at<cv::Vec3b>(v, u) /= 7;
    }
  }
  ThreadPool pool(2);
  auto box_trial = [&](const Frame& frame) {
    DetectionReport report;
    DetectOptions options;
    options.min_confidence = 0.0;
    DetectObjects(frame, {{&Box().bank, 1}}, QuickSolver(), options, &pool, &report);
    EXPECT_TRUE(report.success) << report.message;
    // The trial on the box's region: the proposal whose box overlaps the box's pixels most.
    const cv::Rect truth = cv::boundingRect(box_pixels);
    CandidateTrial best;
    int best_overlap = 0;
    for (const CandidateTrial& trial : report.trials) {
      const int overlap = (report.proposals[static_cast<size_t>(trial.proposal)].box & truth).area();
      if (overlap > best_overlap) best = trial, best_overlap = overlap;
    }
    EXPECT_GT(best_overlap, truth.area() / 2);
    return best;
  };
  const CandidateTrial bright = box_trial(scene.frame);
  const CandidateTrial black = box_trial(dark);
  EXPECT_GT(bright.lightness_ratio, 0.5);
  EXPECT_LT(bright.lightness_ratio, 2.0);
  EXPECT_LT(black.lightness_ratio, 0.25);
  EXPECT_GT(bright.colour_term, 0.5);
  EXPECT_GT(black.colour_term, 0.5);
}

// Answers of one object wanted once, on different pixels: a sure one (confidence at least
// sure_first_confidence) claims the slot before an unsure one of lower S_A (a pose can fit a
// few pixels closely, e.g. one mostly beyond the image); among sure answers S_A decides. With
// sure_first_confidence above 1, S_A alone. An answer sharing most of its pixels with one
// kept, or below min_confidence, is suppressed either way.
TEST(SelectAnswers, ASureAnswerClaimsItsSlotBeforeAnUnsureOne) {
  Frame frame;
  frame.depth = cv::Mat(30, 40, CV_32F, cv::Scalar(0.8f));
  std::vector<DetectRequest> requests(2);
  requests[0].count = 1;
  requests[1].count = 2;
  auto answer = [&](int request, double score, double confidence, cv::Rect pixels) {
    Detection d;
    d.request = request;
    d.result.success = true;
    d.result.score = score;
    d.result.confidence = confidence;
    d.result.corrected_mask = cv::Mat::zeros(frame.depth.size(), CV_8U);
    d.result.corrected_mask(pixels).setTo(255);
    d.check.on_surface = 0.9;
    d.check.contour_support = 0.9;
    return d;
  };
  const std::vector<Detection> solved = {
      answer(0, 0.05, 0.70, cv::Rect(0, 0, 10, 10)),    // lowest S, unsure
      answer(0, 0.09, 0.95, cv::Rect(20, 0, 10, 10)),   // sure
      answer(0, 0.08, 0.92, cv::Rect(30, 0, 10, 10)),   // sure, lower S: this one
      answer(1, 0.06, 0.93, cv::Rect(0, 15, 10, 10)),
      answer(1, 0.07, 0.99, cv::Rect(2, 17, 10, 10)),   // most of its pixels are the one above's
      answer(1, 0.04, 0.30, cv::Rect(25, 15, 10, 10)),  // below min_confidence
  };
  DetectOptions options;
  int suppressed = -1;
  std::vector<Detection> kept = SelectAnswers(frame, requests, options, solved, &suppressed);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(suppressed, 4);
  EXPECT_EQ(kept[0].result.score, 0.06);
  EXPECT_EQ(kept[1].result.score, 0.08);
  options.sure_first_confidence = 1.5;  // S_A alone
  kept = SelectAnswers(frame, requests, options, solved, &suppressed);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(suppressed, 4);
  EXPECT_EQ(kept[0].result.score, 0.05);
  EXPECT_EQ(kept[1].result.score, 0.06);
}

// Which answers on a mask are unsure is a threshold on S_A (stricter when ambiguous), so
// that the published confidence can be refitted without changing any answer.
TEST(SolverOptions, UnsureOfScoreReadsSAndTheAmbiguityNotTheConfidence) {
  SolverOptions options;
  EXPECT_FALSE(UnsureOfScore(options, 0.23, false));
  EXPECT_TRUE(UnsureOfScore(options, 0.23, true));
  EXPECT_TRUE(UnsureOfScore(options, 0.3, false));
  EXPECT_TRUE(UnsureOfScore(options, std::numeric_limits<double>::quiet_NaN(), false));
  const bool before = UnsureOfScore(options, 0.23, false);
  options.confidence_bias = -20.0;  // a confidence of ~0 everywhere
  EXPECT_EQ(UnsureOfScore(options, 0.23, false), before);
  options.unsure_score = 2.0;  // only wide masks and boxes are searched again
  EXPECT_FALSE(UnsureOfScore(options, 1.0, false));
}

}  // namespace
}  // namespace g6d
