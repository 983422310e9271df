// Runs the built g6d-eval binary end to end on a synthetic BOP dataset (and on the shared
// LM-O set when present).

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "bop_eval_scene.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "test_meshes.h"
#include "process_util.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;
using Json = nlohmann::json;

const std::string kEval = test::BinaryDir() + "/tools/g6d-eval";

using RunResult = test::CommandResult;
using test::RunCommand;

// A cube dataset with two images, and a results CSV holding the GT of image 0 only.
struct ToolFixture {
  std::string root;
  std::string csv;

  ToolFixture() {
    test::SyntheticObject cube{1, test::MakeCube(0.05), 0.1 * std::sqrt(3.0), false};
    root = test::WriteSyntheticBopDataset(
        "eval_tool", {cube},
        {{0, {{1, test::MakePose(Eigen::Matrix3d::Identity(), {0.0, 0.0, 0.6})}}},
         {1, {{1, test::MakePose(Eigen::Matrix3d::Identity(), {0.05, 0.0, 0.7})}}}});
    csv = root + "/results.csv";
    WriteBopCsv(csv, {test::MakeEstimate(
                         0, 1, 0.9, test::MakePose(Eigen::Matrix3d::Identity(), {0.0, 0.0, 0.6}))});
  }
};

TEST(G6dEval, PrintsTableWritesJsonAndPlot) {
  ASSERT_TRUE(std::filesystem::exists(kEval)) << kEval << " is not built";
  const ToolFixture fixture;
  const std::string json_path = fixture.root + "/eval.json";
  const std::string plot_path = fixture.root + "/eval.png";
  const RunResult run =
      RunCommand(kEval + " --dataset " + fixture.root + " --results " + fixture.csv + " --json " +
                 json_path + " --plot " + plot_path + " --threads 2");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("AR_VSD"));
  // One of the two targets has a (perfect) estimate: every recall is 0.5.
  EXPECT_THAT(run.output, HasSubstr("| all                  |       2 |       1 |    0.500 |  "
                                    "0.500 |   0.500 |   0.500 |  0.500 |"));

  std::ifstream json_file(json_path);
  ASSERT_TRUE(json_file.good());
  const Json json = Json::parse(json_file);
  EXPECT_EQ(json["overall"]["targets"], 2);
  EXPECT_DOUBLE_EQ(json["overall"]["ar"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(json["overall"]["add_recall"].get<double>(), 0.5);
  ASSERT_EQ(json["objects"].size(), 1u);
  EXPECT_EQ(json["objects"][0]["name"], "obj_000001");
  ASSERT_EQ(json["targets"].size(), 2u);
  EXPECT_TRUE(json["targets"][1]["best_add_mm"].is_null());  // no estimate for image 1
  EXPECT_EQ(json["overall"]["vsd_recall_by_tau_and_threshold"].size(), 10u);

  const cv::Mat plot = cv::imread(plot_path);
  ASSERT_FALSE(plot.empty());
  EXPECT_GT(plot.cols, 300);
}

TEST(G6dEval, ClearErrors) {
  ASSERT_TRUE(std::filesystem::exists(kEval)) << kEval << " is not built";
  const ToolFixture fixture;

  RunResult run = RunCommand(kEval + " --dataset /nonexistent/g6d --results " + fixture.csv);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_THAT(run.output, HasSubstr("dataset folder '/nonexistent/g6d' does not exist"));

  run = RunCommand(kEval + " --dataset " + fixture.root + " --results " + fixture.root +
                   "/missing.csv");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_THAT(run.output, HasSubstr("missing.csv' does not exist"));

  const std::string bad_csv = fixture.root + "/bad.csv";
  std::ofstream(bad_csv) << "scene_id,im_id,obj_id,score,R,t,time\n1,0,1,0.5,1 0 0,0 0 1,-1\n";
  run = RunCommand(kEval + " --dataset " + fixture.root + " --results " + bad_csv);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_THAT(run.output, HasSubstr("bad.csv:2"));

  const std::string unknown_csv = fixture.root + "/unknown.csv";
  WriteBopCsv(unknown_csv, {test::MakeEstimate(0, 7, 0.9, Eigen::Isometry3d::Identity())});
  run = RunCommand(kEval + " --dataset " + fixture.root + " --results " + unknown_csv);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_THAT(run.output, HasSubstr("object 7 is not in"));

  run = RunCommand(kEval + " --dataset " + fixture.root + " --results " + fixture.csv +
                   " --targets " + fixture.root + "/none.json");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_THAT(run.output, HasSubstr("none.json does not exist"));
}

// The LM-O GT as results: AR 1 over the 449 targets.
TEST(G6dEval, LmoGroundTruth) {
  G6D_REQUIRE_SHARED_DATA("lmo/test_targets_bop19.json");
  ASSERT_TRUE(std::filesystem::exists(kEval)) << kEval << " is not built";
  const std::string root = test::SharedDataPath("lmo");
  const std::vector<BopEstimate> estimates = test::GroundTruthEstimates(LoadBopDataset(root));
  const std::string dir = test::TempDir("eval_tool_lmo");
  WriteBopCsv(dir + "/gt.csv", estimates);
  const RunResult run = RunCommand(kEval + " --dataset " + root + " --results " + dir +
                                   "/gt.csv --json " + dir + "/eval.json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("| all                  |     449 |     449 |    1.000 |  "
                                    "1.000 |   1.000 |   1.000 |  1.000 |"));
}

}  // namespace
}  // namespace g6d
