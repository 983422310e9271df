// g6d-bench-dataset as a user runs it: a BOP folder written by the test, caches built by
// the real g6d-build-templates, a targets file of the user's own (--targets), the GT-score
// diagnostic (--score-gt) and the per-instance records CSV.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "eval/bop.h"
#include "process_util.h"
#include "synthetic_bop.h"
#include "test_paths.h"
#include "test_util.h"

namespace g6d {
namespace {

const std::string kBench = test::BinaryDir() + "/bench/g6d-bench-dataset";
const std::string kBuildTemplates = test::BinaryDir() + "/tools/g6d-build-templates";

std::vector<std::vector<std::string>> ReadCsv(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream stream(line);
    std::string field;
    while (std::getline(stream, field, ',')) fields.push_back(field);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    rows.push_back(fields);
  }
  return rows;
}

class BenchDatasetTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(test::TempDir("bench_dataset"));
    const test::SyntheticBop dataset = test::WriteSyntheticBopDataset(*dir_ + "/tiny", {});
    std::filesystem::create_directories(*dir_ + "/caches");
    for (int obj_id : dataset.obj_ids) {
      const std::string name = BopObjectName(obj_id);
      // 72 templates keep the test fast.
      const test::CommandResult build =
          test::RunCommand(kBuildTemplates + " --mesh " + *dir_ + "/tiny/models/" + name + ".ply --units mm --object-id " +
                           name + " --out " + *dir_ + "/caches/" + name + ".g6dcache --views 72 --threads 2");
      ASSERT_EQ(build.exit_code, 0) << build.output;
    }
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string* dir_;
};
std::string* BenchDatasetTest::dir_ = nullptr;

TEST_F(BenchDatasetTest, OwnTargetsFileScoreGtAndRecords) {
  ASSERT_TRUE(std::filesystem::exists(kBench)) << kBench;
  // Only object 2 of image 0 (the dataset's own targets also hold object 1 and image 2).
  const std::string targets = *dir_ + "/targets.json";
  std::ofstream(targets) << R"([{"scene_id": 1, "im_id": 0, "obj_id": 2, "inst_count": 1}])";
  const std::string records = *dir_ + "/records.csv";
  const test::CommandResult run =
      test::RunCommand(kBench + " --dataset " + *dir_ + "/tiny --caches " + *dir_ + "/caches --targets " + targets +
                       " --score-gt --records " + records + " --hypotheses 4");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("misses by cause"), std::string::npos) << run.output;
  const std::vector<std::vector<std::string>> rows = ReadCsv(records);
  ASSERT_EQ(rows.size(), 2u) << "one header and one instance";
  const std::vector<std::string>& header = rows[0];
  auto column = [&](const std::string& name) {
    for (size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return i;
    }
    ADD_FAILURE() << "no column " << name;
    return size_t{0};
  };
  ASSERT_EQ(rows[1].size(), header.size());
  EXPECT_EQ(rows[1][column("obj_id")], "2");
  EXPECT_EQ(rows[1][column("im_id")], "0");
  EXPECT_EQ(rows[1][column("success")], "1");
  // The GT pose of a rendered scene fits its own mask and depth almost perfectly.
  const double gt_score = std::stod(rows[1][column("gt_score")]);
  const double gt_iou = std::stod(rows[1][column("gt_iou")]);
  EXPECT_GT(gt_iou, 0.9);
  EXPECT_LT(gt_score, 0.2);
  EXPECT_EQ(rows[1][column("truncated")], "0");
}

TEST_F(BenchDatasetTest, BadTargetsFileAndContradictingFlagsAreErrors) {
  ASSERT_TRUE(std::filesystem::exists(kBench)) << kBench;
  const test::CommandResult missing =
      test::RunCommand(kBench + " --dataset " + *dir_ + "/tiny --caches " + *dir_ + "/caches --targets " + *dir_ +
                       "/absent.json");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.output.find("absent.json"), std::string::npos) << missing.output;
  const test::CommandResult both = test::RunCommand(kBench + " --dataset " + *dir_ + "/tiny --caches " + *dir_ +
                                                    "/caches --allow-border-masks --reject-border-masks");
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.output.find("contradict"), std::string::npos) << both.output;
  // Detection's confidence takes 11 weights (an old list: the free band's weight 0) or 12.
  for (const char* weights : {"1,2,3", "1,2,3,4,5,6,7,8,9,10,11,12,13"}) {
    const test::CommandResult wrong = test::RunCommand(kBench + " --dataset " + *dir_ + "/tiny --caches " + *dir_ +
                                                       "/caches --masks none --detect-confidence " + weights);
    EXPECT_NE(wrong.exit_code, 0) << weights;
    EXPECT_NE(wrong.output.find("--detect-confidence"), std::string::npos) << wrong.output;
  }
}

// --identity unknown: both boxes are candidates for every instance; the summary says how
// often the right one was chosen and what a candidate costs, the records say who won.
TEST_F(BenchDatasetTest, UnknownIdentityChoosesAmongTheDatasetsObjects) {
  ASSERT_TRUE(std::filesystem::exists(kBench)) << kBench;
  const std::string records = *dir_ + "/identity.csv";
  const test::CommandResult run =
      test::RunCommand(kBench + " --dataset " + *dir_ + "/tiny --caches " + *dir_ + "/caches --identity unknown" +
                       " --records " + records + " --hypotheses 4");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("identity unknown (2 candidates; a wrong identity is a miss)"), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("| **identity** | 3 | 100.0 | | 0 (0) |"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("time per candidate (ms)"), std::string::npos) << run.output;
  const std::vector<std::vector<std::string>> rows = ReadCsv(records);
  ASSERT_EQ(rows.size(), 4u) << "one header and three instances";
  const std::vector<std::string>& header = rows[0];
  const size_t chosen = std::find(header.begin(), header.end(), "chosen_id") - header.begin();
  const size_t obj_id = std::find(header.begin(), header.end(), "obj_id") - header.begin();
  ASSERT_LT(chosen, header.size());
  for (size_t row = 1; row < rows.size(); ++row) {
    ASSERT_EQ(rows[row].size(), header.size());
    EXPECT_EQ(rows[row][chosen], BopObjectName(std::stoi(rows[row][obj_id])));
  }

  const test::CommandResult given_only = test::RunCommand(kBench + " --dataset " + *dir_ + "/tiny --caches " + *dir_ +
                                                          "/caches --no-prescreen");
  EXPECT_EQ(given_only.exit_code, 2);
  EXPECT_NE(given_only.output.find("need --identity unknown"), std::string::npos) << given_only.output;
}

// --masks none: the BOP localization task; the answers go to a BOP CSV, the summary has the
// AR columns, a picture per image is written, and mask options contradict it.
TEST_F(BenchDatasetTest, NoMasksFindsTheObjectsAndWritesTheirPoses) {
  ASSERT_TRUE(std::filesystem::exists(kBench)) << kBench;
  const std::string csv = *dir_ + "/none.csv";
  const std::string pictures = *dir_ + "/pictures";
  std::filesystem::create_directories(pictures);
  const test::CommandResult run =
      test::RunCommand(kBench + " --dataset " + *dir_ + "/tiny --caches " + *dir_ + "/caches --masks none --out " + csv +
                       " --detect-pictures " + pictures + " --hypotheses 4");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("BOP localization without masks"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("| object | targets | answered | ADD(-S)@0.1d (%) | AR |"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("| support |"), std::string::npos) << run.output;
  const std::vector<std::vector<std::string>> rows = ReadCsv(csv);
  ASSERT_GE(rows.size(), 2u) << "a header and at least one answer\n" << run.output;
  EXPECT_EQ(rows[0][0], "scene_id");
  for (size_t row = 1; row < rows.size(); ++row) {
    ASSERT_EQ(rows[row].size(), 7u);
    const int obj_id = std::stoi(rows[row][2]);
    EXPECT_TRUE(obj_id == 1 || obj_id == 2) << obj_id;
  }
  int written = 0;
  for (const auto& entry : std::filesystem::directory_iterator(pictures)) written += entry.path().extension() == ".png";
  EXPECT_GE(written, 1);

  const test::CommandResult contradiction = test::RunCommand(kBench + " --dataset " + *dir_ + "/tiny --caches " +
                                                             *dir_ + "/caches --masks none --degrade-masks erode");
  EXPECT_EQ(contradiction.exit_code, 2);
  EXPECT_NE(contradiction.output.find("--masks none takes none of"), std::string::npos) << contradiction.output;
}

}  // namespace
}  // namespace g6d
