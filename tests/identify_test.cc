// EstimatePoseOfUnknownObject on synthetic scenes: three textured objects of clearly
// different sizes and shapes (a box, a small box, a long bar), rendered views of each, and
// every object a candidate.
#include "solver/identify.h"

#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "eval/metrics.h"
#include "mesh/mesh.h"
#include "synthetic_scene.h"
#include "test_bank.h"

namespace g6d {
namespace {

const Camera kCamera{572.4, 573.6, 325.3, 242.0, 640, 480};

struct TestObject {
  std::string id;
  Mesh mesh;
  TemplateBank bank;
};

// 60 x 3 template views and K = 4: enough for textured boxes, cheap under sanitizers.
TemplateBuildOptions QuickTemplates() {
  TemplateBuildOptions options;
  options.views.num_directions = 60;
  options.views.num_inplane = 3;
  return options;
}

SolverOptions QuickSolver() {
  SolverOptions options;
  options.num_hypotheses = 4;
  return options;
}

Frame MakeFrame(const test::SyntheticView& view) {
  Frame frame;
  frame.camera = kCamera;
  frame.rgb = view.rgb;
  frame.depth = view.depth;
  return frame;
}

class IdentifyTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    objects_ = new std::vector<std::unique_ptr<TestObject>>();
    ThreadPool pool(2);
    const struct {
      const char* id;
      double sx, sy, sz;
      uint64_t seed;
    } specs[] = {{"box", 0.10, 0.07, 0.05, 21}, {"small_box", 0.05, 0.04, 0.03, 5}, {"bar", 0.18, 0.035, 0.03, 9}};
    for (const auto& spec : specs) {
      auto object = std::make_unique<TestObject>();
      object->id = spec.id;
      object->mesh = test::MakeTexturedBox(spec.sx, spec.sy, spec.sz, spec.seed);
      object->bank = test::SharedTestBank(std::string("identify-") + spec.id, object->mesh, spec.id,
                                          QuickTemplates(), &pool);
      objects_->push_back(std::move(object));
    }
  }
  static void TearDownTestSuite() { delete objects_; }

  static std::vector<const TemplateBank*> AllBanks() {
    std::vector<const TemplateBank*> banks;
    for (const auto& object : *objects_) banks.push_back(&object->bank);
    return banks;
  }

  // `count` views of object `index` at random poses 0.5-0.7 m away.
  static std::vector<test::SyntheticView> Views(size_t index, int count, uint64_t seed) {
    const TestObject& object = *objects_->at(index);
    GlRenderer renderer(object.mesh);
    std::mt19937_64 rng(seed);
    std::vector<test::SyntheticView> views;
    for (int i = 0; i < count; ++i) {
      test::SyntheticOptions options;
      options.seed = seed + static_cast<uint64_t>(i);
      views.push_back(test::RenderSyntheticView(&renderer, object.mesh, kCamera,
                                                test::RandomPose(kCamera, 0.5, 0.7, &rng), options));
    }
    return views;
  }

  static std::vector<std::unique_ptr<TestObject>>* objects_;
};
std::vector<std::unique_ptr<TestObject>>* IdentifyTest::objects_ = nullptr;

TEST_F(IdentifyTest, ChoosesTheRenderedObjectAndReportsTheRunnerUp) {
  ThreadPool pool(2);
  const std::vector<const TemplateBank*> banks = AllBanks();
  int total_screened = 0;
  for (size_t truth = 0; truth < objects_->size(); ++truth) {
    const TestObject& object = *objects_->at(truth);
    for (const test::SyntheticView& view : Views(truth, 2, 100 + 10 * truth)) {
      const IdentifiedPose answer = EstimatePoseOfUnknownObject(MakeFrame(view), view.mask, banks, QuickSolver(), &pool);
      ASSERT_TRUE(answer.result.success) << answer.result.message;
      EXPECT_EQ(answer.object_id, object.id);
      EXPECT_LT(ComputeAdd(answer.result.cam_from_object, view.cam_from_object, object.mesh.vertices),
                0.1 * object.bank.diameter_m);
      ASSERT_EQ(answer.candidates.size(), banks.size());
      int screened = 0;
      for (size_t i = 0; i < banks.size(); ++i) {
        const IdentityCandidate& candidate = answer.candidates[i];
        EXPECT_EQ(candidate.object_id, banks[i]->object_id);  // in the order given
        EXPECT_GT(candidate.ms, 0.0);
        if (candidate.screened_out) {
          ++screened;
          EXPECT_NE(i, truth) << "the rendered object was screened out: " << candidate.message;
          EXPECT_GT(candidate.extent_m, candidate.diameter_m + candidate.extent_allowance_m);
          EXPECT_FALSE(candidate.success);
        }
      }
      EXPECT_EQ(screened, answer.screened_out);
      total_screened += screened;
      std::cout << object.id << ": chose " << answer.object_id << " S " << answer.result.score;
      for (const IdentityCandidate& candidate : answer.candidates) {
        std::cout << " | " << candidate.object_id << " S " << candidate.score << " extent "
                  << candidate.extent_m * 1000.0 << " mm" << (candidate.screened_out ? " (screened out)" : "");
      }
      std::cout << "\n";
      EXPECT_TRUE(answer.candidates[truth].success);
      EXPECT_EQ(answer.candidates[truth].score, answer.result.score);
      EXPECT_NE(answer.runner_up_id, object.id);
      if (!answer.runner_up_id.empty()) {
        EXPECT_GE(answer.runner_up_score, answer.result.score);
      }
      EXPECT_FALSE(answer.ambiguous);  // the shapes and prints differ clearly
      for (const IdentityCandidate& candidate : answer.candidates) {
        if (candidate.success) {
          EXPECT_GE(candidate.score, answer.result.score) << candidate.object_id;
        }
      }
    }
  }
  // The bar spans more than the small box's diameter (7.1 cm) in most views.
  EXPECT_GT(total_screened, 0);
}

TEST_F(IdentifyTest, WithoutThePrescreenEveryCandidateIsSolvedAndTheOtherObjectIsRunnerUp) {
  ThreadPool pool(2);
  IdentifyOptions no_screen;
  no_screen.prescreen = false;
  // The bar against the box: two candidates, so the runner-up can only be the other one.
  const std::vector<const TemplateBank*> banks = {&objects_->at(0)->bank, &objects_->at(2)->bank};
  const test::SyntheticView view = Views(2, 1, 7).front();
  const IdentifiedPose answer =
      EstimatePoseOfUnknownObject(MakeFrame(view), view.mask, banks, QuickSolver(), no_screen, &pool);
  ASSERT_TRUE(answer.result.success) << answer.result.message;
  EXPECT_EQ(answer.object_id, "bar");
  EXPECT_EQ(answer.screened_out, 0);
  for (const IdentityCandidate& candidate : answer.candidates) {
    EXPECT_FALSE(candidate.screened_out);
    EXPECT_EQ(candidate.extent_m, 0.0);  // the pre-screen did not run
  }
  if (answer.candidates[0].success) {
    EXPECT_EQ(answer.runner_up_id, "box");
    EXPECT_EQ(answer.runner_up_score, answer.candidates[0].score);
    EXPECT_GE(answer.runner_up_score, answer.result.score);
    EXPECT_EQ(answer.ambiguous, answer.runner_up_score - answer.result.score <= QuickSolver().ambiguity_margin);
  }
}

TEST_F(IdentifyTest, OneCandidateGivesExactlyEstimatePosesAnswer) {
  ThreadPool pool(2);
  const TemplateBank& bank = objects_->at(0)->bank;
  const test::SyntheticView view = Views(0, 1, 3).front();
  const Frame frame = MakeFrame(view);
  const PoseResult direct = EstimatePose(frame, {bank.object_id, view.mask}, bank, QuickSolver(), &pool);
  const IdentifiedPose answer = EstimatePoseOfUnknownObject(frame, view.mask, {&bank}, QuickSolver(), &pool);
  ASSERT_TRUE(direct.success) << direct.message;
  const PoseResult& result = answer.result;
  EXPECT_EQ(answer.object_id, bank.object_id);
  EXPECT_EQ(answer.runner_up_id, "");
  EXPECT_EQ(answer.screened_out, 0);
  EXPECT_TRUE(result.success);
  EXPECT_EQ(result.message, direct.message);
  EXPECT_EQ(result.termination, direct.termination);
  EXPECT_TRUE(result.cam_from_object.matrix() == direct.cam_from_object.matrix());
  EXPECT_EQ(result.score, direct.score);
  EXPECT_EQ(result.confidence, direct.confidence);
  EXPECT_EQ(result.has_runner_up, direct.has_runner_up);
  EXPECT_TRUE(result.runner_up_cam_from_object.matrix() == direct.runner_up_cam_from_object.matrix());
  EXPECT_EQ(result.runner_up_score, direct.runner_up_score);
  EXPECT_EQ(result.mask_iou, direct.mask_iou);
  EXPECT_EQ(cv::countNonZero(result.corrected_mask != direct.corrected_mask), 0);
  EXPECT_EQ(result.stages.pnp_hypotheses, direct.stages.pnp_hypotheses);
  EXPECT_EQ(result.stages.icp_iterations, direct.stages.icp_iterations);
  ASSERT_EQ(answer.candidates.size(), 1u);
  EXPECT_EQ(answer.candidates[0].score, direct.score);
}

TEST_F(IdentifyTest, BadInputThrowsWithAMessageAndBadMasksAreReported) {
  InlineExecutor executor;
  const test::SyntheticView view = Views(1, 1, 5).front();
  const Frame frame = MakeFrame(view);
  const TemplateBank* box = &objects_->at(0)->bank;
  const TemplateBank* small = &objects_->at(1)->bank;
  auto expect_error = [&](const std::vector<const TemplateBank*>& banks, const IdentifyOptions& options,
                          const std::string& words) {
    try {
      EstimatePoseOfUnknownObject(frame, view.mask, banks, QuickSolver(), options, &executor);
      ADD_FAILURE() << "no error; expected one saying '" << words << "'";
    } catch (const Error& error) {
      EXPECT_NE(std::string(error.what()).find(words), std::string::npos) << error.what();
    }
  };
  expect_error({}, IdentifyOptions(), "no candidate");
  expect_error({box, nullptr}, IdentifyOptions(), "candidate 1 is a null bank");
  expect_error({box, small, box}, IdentifyOptions(), "'box' is given twice (candidates 0 and 2)");
  IdentifyOptions bad_trim;
  bad_trim.extent_trim_fraction = 0.3;
  expect_error({box, small}, bad_trim, "extent_trim_fraction");

  // An empty mask is the solver's to report, for every candidate: no answer, and why.
  const IdentifiedPose empty =
      EstimatePoseOfUnknownObject(frame, cv::Mat::zeros(480, 640, CV_8U), {box, small}, QuickSolver(), &executor);
  EXPECT_FALSE(empty.result.success);
  EXPECT_EQ(empty.result.termination, Termination::kBadInput);
  EXPECT_EQ(empty.object_id, "");
  EXPECT_NE(empty.result.message.find("no candidate object was solved"), std::string::npos) << empty.result.message;
  EXPECT_NE(empty.result.message.find("small_box: the instance mask is empty"), std::string::npos)
      << empty.result.message;
}

// A fronto-parallel square patch: the extent is its diagonal (the span along the face
// diagonal direction), never more; flying pixels far behind it are trimmed away.
TEST(MaskDepthExtent, SquarePatchSpansItsDiagonal) {
  const double z = 0.6;
  cv::Mat mask = cv::Mat::zeros(480, 640, CV_8U);
  cv::Mat depth = cv::Mat::zeros(480, 640, CV_32F);
  const cv::Rect square(200, 150, 60, 60);  // 3600 points: all kept
  mask(square).setTo(255);
  depth(square).setTo(z);
  const double width = (square.width - 1) * z / kCamera.fx, height = (square.height - 1) * z / kCamera.fy;
  const double diagonal = std::hypot(width, height);
  double max_depth = 0.0;
  const double extent = MaskDepthExtent(kCamera, mask, depth, 0.0, &max_depth);
  EXPECT_NEAR(extent, (width + height) / std::sqrt(2.0), 1e-6);
  EXPECT_LE(extent, diagonal + 1e-9);
  EXPECT_EQ(max_depth, static_cast<double>(static_cast<float>(z)));

  // 20 flying pixels 0.5 m behind, on the patch's edge: 0.6% of its points.
  for (int i = 0; i < 20; ++i) depth.at<float>(square.y + 3 * i, square.x) = static_cast<float>(z + 0.5);
  EXPECT_GT(MaskDepthExtent(kCamera, mask, depth, 0.0, nullptr), 0.4);
  EXPECT_LE(MaskDepthExtent(kCamera, mask, depth, 0.02, nullptr), diagonal);

  // Fewer than two points with depth: nothing spanned.
  EXPECT_EQ(MaskDepthExtent(kCamera, cv::Mat::zeros(480, 640, CV_8U), depth, 0.02, nullptr), 0.0);
  cv::Mat one = cv::Mat::zeros(480, 640, CV_8U);
  one.at<uint8_t>(200, 250) = 255;
  EXPECT_EQ(MaskDepthExtent(kCamera, one, depth, 0.02, &max_depth), 0.0);
  EXPECT_EQ(max_depth, static_cast<double>(static_cast<float>(z)));
}

}  // namespace
}  // namespace g6d
