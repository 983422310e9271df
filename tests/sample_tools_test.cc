// The tools around the demo, run on a small embedded sample: g6d-overlay, g6d-eval
// --per-instance, and the per-estimate JSON lines of g6d-replay (EstimatesJsonLines).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/se3.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "process_util.h"
#include "replay.h"
#include "sample_test_util.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using Json = nlohmann::json;

const std::string kMakeSample = test::BinaryDir() + "/tools/g6d-make-sample";
const std::string kOverlay = test::BinaryDir() + "/tools/g6d-overlay";
const std::string kEval = test::BinaryDir() + "/tools/g6d-eval";

// A 2-image sample and a results CSV holding its ground truth, except that the box of
// image 1 is 5 cm off.
struct Fixture {
  std::string root;
  std::string results;

  Fixture() {
    root = test::ScratchDirs::Make("sample_tools") + "/sample";
    const test::CommandResult made = test::RunCommand(
        kMakeSample + " --out " + root + " --frames 2 --views 12 --inplane 1 --no-log");
    EXPECT_EQ(made.exit_code, 0) << made.output;
    const BopScene scene = LoadBopScene(root, 1);
    std::vector<BopEstimate> estimates;
    for (const BopFrame& frame : scene.frames) {
      for (const BopGtInstance& gt : frame.gt) {
        BopEstimate e;
        e.scene_id = 1;
        e.im_id = frame.im_id;
        e.obj_id = gt.obj_id;
        e.score = 0.9;
        e.cam_from_object = gt.cam_from_object;
        if (frame.im_id == 1 && gt.obj_id == 1) e.cam_from_object.translation().x() += 0.05;
        e.time_s = 0.25;
        estimates.push_back(e);
      }
    }
    results = root + "/../results.csv";
    WriteBopCsv(results, estimates);
  }
};

const Fixture& SharedFixture() {
  static const Fixture fixture;
  return fixture;
}

int CountColour(const cv::Mat& bgr, const cv::Vec3b& colour, int tolerance) {
  int count = 0;
  for (int v = 0; v < bgr.rows; ++v) {
    for (int u = 0; u < bgr.cols; ++u) {
      const cv::Vec3b p = bgr.at<cv::Vec3b>(v, u);
      count += std::abs(p[0] - colour[0]) <= tolerance && std::abs(p[1] - colour[1]) <= tolerance &&
               std::abs(p[2] - colour[2]) <= tolerance;
    }
  }
  return count;
}

TEST(G6dOverlay, WritesOneImagePerImageWithContoursAndVerdicts) {
  ASSERT_TRUE(fs::exists(kOverlay)) << kOverlay << " is not built";
  const Fixture& f = SharedFixture();
  const std::string out = test::ScratchDirs::Make("sample_tools_overlay");
  const test::CommandResult run =
      test::RunCommand(kOverlay + " --dataset " + f.root + " --results " + f.results + " --out " +
                       out + " --caches " + f.root + "/caches");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("wrote 2 image(s)"));
  EXPECT_THAT(run.output, HasSubstr("5 of 6 estimates within ADD(-S) 0.1 d"));
  for (const char* name : {"000001_000000.png", "000001_000001.png"}) {
    const cv::Mat image = cv::imread(out + "/" + name);
    ASSERT_FALSE(image.empty()) << name;
    EXPECT_EQ(image.size(), cv::Size(640, 480));
    // Estimated contours in green (BGR 40, 255, 40), at least a few hundred pixels.
    EXPECT_GT(CountColour(image, cv::Vec3b(40, 255, 40), 40), 300) << name;
  }
  // The displaced box's contour lies off the ground truth's: blue GT pixels remain visible.
  const cv::Mat shifted = cv::imread(out + "/000001_000001.png");
  EXPECT_GT(CountColour(shifted, cv::Vec3b(255, 110, 60), 60), 50);
}

TEST(G6dOverlay, DrawsWithTheDatasetMeshesWithoutCaches) {
  const Fixture& f = SharedFixture();
  const std::string out = test::ScratchDirs::Make("sample_tools_overlay_meshes");
  const test::CommandResult run =
      test::RunCommand(kOverlay + " --dataset " + f.root + " --results " + f.results + " --out " +
                       out + " --max-images 1");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("wrote 1 image(s)"));
  EXPECT_TRUE(fs::exists(out + "/000001_000000.png"));
}

TEST(G6dOverlay, MissingResultsFileIsAnError) {
  const Fixture& f = SharedFixture();
  const test::CommandResult run = test::RunCommand(kOverlay + " --dataset " + f.root +
                                                   " --results /nonexistent.csv --out /tmp/unused");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.output, HasSubstr("results file '/nonexistent.csv' does not exist"));
}

TEST(G6dEval, PerInstancePrintsEveryTargetWithItsErrorAndVerdict) {
  ASSERT_TRUE(fs::exists(kEval)) << kEval << " is not built";
  const Fixture& f = SharedFixture();
  const test::CommandResult run = test::RunCommand(kEval + " --dataset " + f.root + " --results " +
                                                   f.results + " --per-instance");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("per instance"));
  std::istringstream lines(run.output);
  std::string line;
  int rows = 0, correct = 0, wrong = 0;
  while (std::getline(lines, line)) {
    // Per-instance rows start with the scene id; the per-object table's with the object.
    if (!std::regex_search(line, std::regex(R"(^\|\s+1 \|\s+\d+ \| obj_)"))) continue;
    ++rows;
    correct += line.find("| yes") != std::string::npos;
    wrong += line.find("| no ") != std::string::npos;
    EXPECT_THAT(line, HasSubstr("0.900"));  // the score
    EXPECT_THAT(line, HasSubstr("0.250"));  // the image's time
  }
  EXPECT_EQ(rows, 6);
  EXPECT_EQ(correct, 5);
  EXPECT_EQ(wrong, 1);
  // The 5 cm shift shows as 50 mm of ADD.
  EXPECT_THAT(run.output, HasSubstr("50.0"));
}

pose_estimate_t Estimate(const std::string& object_id, int8_t status, double score) {
  pose_estimate_t e{};
  e.object_id = object_id;
  e.label = 1;
  e.gt_index = 0;
  e.status = status;
  e.message = status == pose_estimate_t::STATUS_OK ? "ok" : "no pose";
  e.position[0] = 0.1;
  e.position[1] = 0.2;
  e.position[2] = 0.7;
  e.orientation[0] = 1.0;
  e.orientation[1] = e.orientation[2] = e.orientation[3] = 0.0;
  e.score = score;
  e.confidence = 0.75;
  e.iou = 0.9;
  e.depth_residual = 0.01;
  e.hypotheses = 4;
  e.solve_time_s = 0.125;
  return e;
}

TEST(EstimatesJsonLines, OneLinePerEstimateOfEveryAnsweredFrame) {
  std::vector<ReplayedFrame> frames(3);
  frames[0].answered = true;
  frames[0].seq = 5;
  frames[0].latency_s = 0.5;
  frames[0].answer.status = pose_array_t::STATUS_OK;
  frames[0].answer.scene_id = 2;
  frames[0].answer.image_id = 8;
  frames[0].answer.source = "lmo";
  frames[0].answer.estimates = {Estimate("obj_000001", pose_estimate_t::STATUS_OK, 0.04),
                                Estimate("obj_000005", pose_estimate_t::STATUS_NO_SOLUTION, 2.0)};
  frames[0].answer.estimates[1].gt_index = 3;
  // The first is cut by the border, has a runner-up and a colour comparison; the failed
  // one has neither (its runner-up score and agreement are 0 on the wire: not numbers to
  // report).
  pose_estimate_t& cut = frames[0].answer.estimates[0];
  cut.truncated = 1;
  cut.ambiguous = 1;
  cut.has_runner_up = 1;
  cut.runner_up_score = 0.05;
  cut.appearance_valid = 1;
  cut.appearance_agreement = -0.5;
  // A tracked answer of track 4; the failure belongs to no track.
  cut.mode = pose_estimate_t::MODE_TRACKED;
  cut.track_id = 4;
  cut.frames_since_detection = 2;
  frames[0].answer.estimates[1].mode = pose_estimate_t::MODE_DETECTED;
  frames[0].answer.estimates[1].track_id = -1;
  // The first was asked without an object id: the identity answer; the failure was not.
  cut.mask_iou = 0.8;
  cut.identity_searched = 1;
  cut.runner_up_object_id = "obj_000005";
  cut.runner_up_object_score = 0.3;
  cut.candidates_tried = 2;
  frames[0].answer.num_estimates = 2;
  frames[1].answered = true;  // rejected as a whole: no estimates to list
  frames[1].answer.status = pose_array_t::STATUS_BAD_FRAME;
  frames[2].answered = false;  // never answered
  const std::string text = EstimatesJsonLines(frames);
  std::istringstream lines(text);
  std::vector<Json> parsed;
  std::string line;
  while (std::getline(lines, line)) parsed.push_back(Json::parse(line));
  ASSERT_EQ(parsed.size(), 2u);
  EXPECT_EQ(parsed[0]["scene_id"], 2);
  EXPECT_EQ(parsed[0]["image_id"], 8);
  EXPECT_EQ(parsed[0]["seq"], 5);
  EXPECT_EQ(parsed[0]["source"], "lmo");
  EXPECT_EQ(parsed[0]["object_id"], "obj_000001");
  EXPECT_EQ(parsed[0]["status"], "ok");
  EXPECT_DOUBLE_EQ(parsed[0]["score"].get<double>(), 0.04);
  EXPECT_DOUBLE_EQ(parsed[0]["confidence"].get<double>(), 0.75);
  EXPECT_DOUBLE_EQ(parsed[0]["solve_time_s"].get<double>(), 0.125);
  EXPECT_DOUBLE_EQ(parsed[0]["latency_s"].get<double>(), 0.5);
  EXPECT_EQ(parsed[0]["position"], Json::array({0.1, 0.2, 0.7}));
  EXPECT_EQ(parsed[0]["orientation"], Json::array({1.0, 0.0, 0.0, 0.0}));
  EXPECT_EQ(parsed[0]["truncated"], true);
  EXPECT_EQ(parsed[0]["ambiguous"], true);
  EXPECT_DOUBLE_EQ(parsed[0]["runner_up_score"].get<double>(), 0.05);
  EXPECT_DOUBLE_EQ(parsed[0]["appearance_agreement"].get<double>(), -0.5);
  EXPECT_EQ(parsed[0]["mode"], "tracked");
  EXPECT_EQ(parsed[0]["track_id"], 4);
  EXPECT_EQ(parsed[0]["frames_since_detection"], 2);
  EXPECT_EQ(parsed[1]["mode"], "detected");
  EXPECT_EQ(parsed[1]["track_id"], -1);
  EXPECT_EQ(parsed[1]["frames_since_detection"], 0);
  EXPECT_EQ(parsed[1]["truncated"], false);
  EXPECT_EQ(parsed[1]["ambiguous"], false);
  EXPECT_TRUE(parsed[1]["runner_up_score"].is_null());
  EXPECT_TRUE(parsed[1]["appearance_agreement"].is_null());
  EXPECT_EQ(parsed[1]["status"], "no_solution");
  EXPECT_EQ(parsed[1]["message"], "no pose");
  EXPECT_EQ(parsed[1]["gt_index"], 3);
  EXPECT_DOUBLE_EQ(parsed[0]["mask_iou"].get<double>(), 0.8);
  EXPECT_EQ(parsed[0]["identity_searched"], true);
  EXPECT_EQ(parsed[0]["runner_up_object_id"], "obj_000005");
  EXPECT_DOUBLE_EQ(parsed[0]["runner_up_object_score"].get<double>(), 0.3);
  EXPECT_EQ(parsed[0]["candidates_tried"], 2);
  EXPECT_DOUBLE_EQ(parsed[1]["mask_iou"].get<double>(), 0.0);
  EXPECT_EQ(parsed[1]["identity_searched"], false);
  EXPECT_TRUE(parsed[1]["runner_up_object_id"].is_null());
  EXPECT_TRUE(parsed[1]["runner_up_object_score"].is_null());
  EXPECT_EQ(parsed[1]["candidates_tried"], 0);
  EXPECT_EQ(EstimatesJsonLines({}), "");
}

}  // namespace
}  // namespace g6d
