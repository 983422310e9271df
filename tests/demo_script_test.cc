// scripts/demo.sh (the README's first command, without the package/build step) on the
// embedded sample and on a BOP folder, and docs/tools.md's g6d-make-sample / g6d-overlay
// examples run as written (build/ and out/ mapped to this build and a temporary folder).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "process_util.h"
#include "sample_test_util.h"
#include "synthetic_bop.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using Json = nlohmann::json;

// Runs scripts/demo.sh with the binaries of this build and no setup step.
test::CommandResult RunDemo(const std::string& environment) {
  return test::RunCommand("cd " + test::SourceDir() + " && G6D_SKIP_BUILD=1 BUILD_DIR=" +
                          test::BinaryDir() + " " + environment + " bash scripts/demo.sh");
}

int CountLinesWith(const std::string& text, const std::regex& pattern) {
  std::istringstream lines(text);
  std::string line;
  int count = 0;
  while (std::getline(lines, line)) count += std::regex_search(line, pattern);
  return count;
}

int CountFiles(const fs::path& dir, const std::string& extension) {
  int count = 0;
  if (!fs::is_directory(dir)) return 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir))
    count += entry.path().extension() == extension;
  return count;
}

TEST(DemoScript, RunsTheEmbeddedSampleThroughTheService) {
  const std::string out = test::ScratchDirs::Make("demo_script_sample");
  const test::CommandResult run = RunDemo("OUT=" + out + " FRAMES=3 SEED=1 SEQUENCE_FRAMES=12");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // One line per instance: image, object, S_A, confidence, ms, error, verdict.
  const std::regex instance_line(
      R"(^\s+\d+\s+obj_00000\d\s+\d+\.\d{3}\s+\d\.\d\d\s+\d+\s+\d+\.\d\s+\d\.\d{3}\s+(yes|NO)$)");
  EXPECT_EQ(CountLinesWith(run.output, instance_line), 9) << run.output;
  EXPECT_THAT(run.output, HasSubstr("ADD(-S)@0.1d recall:"));
  EXPECT_THAT(run.output, HasSubstr("p50"));
  // The same images without masks: the service found the objects from ids and counts.
  EXPECT_THAT(run.output, HasSubstr("Without masks (object ids and counts only; the service finds the objects): "
                                    "ADD(-S)@0.1d "));
  const Json no_masks = Json::parse(std::ifstream(out + "/no_masks/eval.json"));
  EXPECT_EQ(no_masks["overall"]["targets"], 9);
  EXPECT_GE(no_masks["overall"]["targets_with_estimate"].get<int>(), 6) << run.output;
  EXPECT_THAT(run.output, HasSubstr("p95"));
  EXPECT_THAT(run.output, HasSubstr("overlays (estimate green, ground truth blue): " + out +
                                    "/overlays/ (3 PNGs)"));
  EXPECT_EQ(CountFiles(out + "/overlays", ".png"), 3);
  const Json evaluation = Json::parse(std::ifstream(out + "/eval.json"));
  EXPECT_EQ(evaluation["overall"]["targets"], 9);
  EXPECT_GE(evaluation["overall"]["add_recall"].get<double>(), 0.75);
  // The service was stopped cleanly (its log ends with the shutdown).
  std::ifstream log(out + "/service.log");
  const std::string service_log((std::istreambuf_iterator<char>(log)),
                                std::istreambuf_iterator<char>());
  EXPECT_THAT(service_log, HasSubstr("SIGTERM"));
  // The tracking part: the 12-frame sequence through the service in real time, a
  // timeline row per object (D first: a new track is detected), counts and accuracy.
  EXPECT_THAT(run.output, HasSubstr("Tracking: the moving-camera sequence (12 frames at 30 Hz"));
  EXPECT_EQ(CountLinesWith(run.output, std::regex(R"(^  obj_00000\d D[D.Rx_]{11}$)")), 3) << run.output;
  EXPECT_THAT(run.output, HasSubstr("ADD(-S)@0.1d of the answers:"));
  const Json sequence = Json::parse(std::ifstream(out + "/tracking/summary.json"));
  EXPECT_EQ(sequence["sent"], 12);
  EXPECT_GE(sequence["answered"].get<int>(), 1);
  std::ifstream tracking_log(out + "/tracking/service.log");
  const std::string tracking_service_log((std::istreambuf_iterator<char>(tracking_log)),
                                         std::istreambuf_iterator<char>());
  EXPECT_THAT(tracking_service_log, HasSubstr("tracking on"));

  // Again: the sample is current and kept.
  const test::CommandResult again = RunDemo("OUT=" + out + " FRAMES=3 SEED=1 SEQUENCE_FRAMES=12");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_THAT(again.output, HasSubstr("is up to date"));
  EXPECT_EQ(CountLinesWith(again.output, instance_line), 9);
}

TEST(DemoScript, RunsOnABopFolderGivenAsDataset) {
  const std::string dataset = test::ScratchDirs::Make("demo_script_bop") + "/tiny_bop";
  test::WriteSyntheticBopDataset(dataset, {});
  const std::string out = test::ScratchDirs::Make("demo_script_bop_out");
  const test::CommandResult run = RunDemo("DATASET=" + dataset + " IMAGES=0 OUT=" + out);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("g6d on tiny_bop"));
  EXPECT_THAT(run.output, HasSubstr("ADD(-S)@0.1d recall:"));
  // Caches of both target objects were built; image 0 holds one instance of each.
  EXPECT_TRUE(fs::exists(out + "/caches/obj_000001.g6dcache"));
  EXPECT_TRUE(fs::exists(out + "/caches/obj_000002.g6dcache"));
  EXPECT_EQ(CountLinesWith(run.output, std::regex(R"(^\s+0\s+obj_00000[12]\s)")), 2) << run.output;
  EXPECT_EQ(CountFiles(out + "/overlays", ".png"), 1);
}

TEST(DemoScript, RefusesAFolderThatIsNotBop) {
  const std::string empty = test::ScratchDirs::Make("demo_script_not_bop");
  const test::CommandResult run = RunDemo("DATASET=" + empty + " OUT=" + empty + "/out");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.output, HasSubstr("models_info.json is missing"));
}

// The command lines of docs/tools.md (where the README points for the tools) that start
// with build/tools/<tool>, continuation lines joined.
std::vector<std::string> ToolsDocCommands(const std::string& tool) {
  std::ifstream readme(test::SourceDir() + "/docs/tools.md");
  std::vector<std::string> commands;
  std::string line, command;
  bool in_code = false;
  while (std::getline(readme, line)) {
    if (line.rfind("```", 0) == 0) {
      in_code = !in_code;
      continue;
    }
    if (!in_code) continue;
    if (command.empty()) {
      if (line.rfind("build/tools/" + tool + " ", 0) != 0) continue;
      command = line;
    } else {
      command += " " + line;
    }
    while (!command.empty() && command.back() == ' ') command.pop_back();
    if (!command.empty() && command.back() == '\\') {
      command.pop_back();  // continued on the next line
      continue;
    }
    commands.push_back(command);
    command.clear();
  }
  return commands;
}

// build/ -> this build, out/ -> `out_dir`/ in every word of the command.
std::string Localize(const std::string& command, const std::string& out_dir,
                     std::string* results_path, std::string* dataset_path) {
  std::istringstream words(command);
  std::string word, result, previous;
  while (words >> word) {
    if (word.rfind("build/", 0) == 0) word = test::BinaryDir() + word.substr(5);
    if (word.rfind("out/", 0) == 0) word = out_dir + word.substr(3);
    if (previous == "--results" && results_path != nullptr) *results_path = word;
    if (previous == "--dataset" && dataset_path != nullptr) *dataset_path = word;
    result += (result.empty() ? "" : " ") + word;
    previous = word;
  }
  return result;
}

TEST(ToolsDoc, SampleAndOverlayExamplesRunAsWritten) {
  const std::vector<std::string> make_sample = ToolsDocCommands("g6d-make-sample");
  const std::vector<std::string> overlay = ToolsDocCommands("g6d-overlay");
  ASSERT_FALSE(make_sample.empty()) << "docs/tools.md shows no build/tools/g6d-make-sample command";
  ASSERT_FALSE(overlay.empty()) << "docs/tools.md shows no build/tools/g6d-overlay command";
  const std::string out = test::ScratchDirs::Make("readme_sample") + "/out";
  for (const std::string& command : make_sample) {
    const test::CommandResult run = test::RunCommand(Localize(command, out, nullptr, nullptr));
    ASSERT_EQ(run.exit_code, 0) << command << "\n" << run.output;
  }
  for (const std::string& command : overlay) {
    std::string results, dataset;
    const std::string local = Localize(command, out, &results, &dataset);
    ASSERT_FALSE(results.empty()) << command;
    // The results the demo would have written: here the ground truth of the dataset.
    std::vector<BopEstimate> estimates;
    for (int scene_id : LoadBopDataset(dataset).scene_ids) {
      for (const BopFrame& frame : LoadBopScene(dataset, scene_id).frames) {
        for (const BopGtInstance& gt : frame.gt) {
          estimates.push_back({scene_id, frame.im_id, gt.obj_id, 1.0, gt.cam_from_object, 0.1});
        }
      }
    }
    fs::create_directories(fs::path(results).parent_path());
    WriteBopCsv(results, estimates);
    const test::CommandResult run = test::RunCommand(local);
    ASSERT_EQ(run.exit_code, 0) << command << "\n" << run.output;
    EXPECT_THAT(run.output, HasSubstr("g6d-overlay: wrote"));
  }
}

}  // namespace
}  // namespace g6d
