// Runs the built g6d-build-templates and g6d-inspect binaries end to end.

#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "templates/cache.h"
#include "mesh_files.h"
#include "process_util.h"
#include "test_meshes.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;

const std::string kBuildTemplates = test::BinaryDir() + "/tools/g6d-build-templates";
const std::string kInspect = test::BinaryDir() + "/tools/g6d-inspect";
const std::string kSolve = test::BinaryDir() + "/tools/g6d-solve";

using RunResult = test::CommandResult;
using test::RunCommand;

// An ASCII PLY box in millimetres (half sizes 40 x 30 x 20) with a random vertex-colour
// checker on every side.
void WriteCheckerBoxPly(const std::string& path) {
  test::WriteColouredBoxPly(path, Eigen::Vector3d(40.0, 30.0, 20.0), 10, 5);
}

TEST(Tools, BuildTemplatesThenInspect) {
  ASSERT_TRUE(std::filesystem::exists(kBuildTemplates)) << kBuildTemplates;
  ASSERT_TRUE(std::filesystem::exists(kInspect)) << kInspect;
  const std::string dir = test::TempDir("tools_build");
  const std::string mesh = dir + "/box.ply";
  WriteCheckerBoxPly(mesh);
  const std::string cache = dir + "/caches/obj_000077.g6dcache";

  const RunResult build =
      RunCommand(kBuildTemplates + " --mesh " + mesh + " --units mm --object-id obj_000077 --out " +
                 cache + " --views 12 --threads 2");
  ASSERT_EQ(build.exit_code, 0) << build.output;
  EXPECT_THAT(build.output, HasSubstr("12 templates"));
  EXPECT_THAT(build.output, HasSubstr("templates 12/12"));  // progress lines (not a terminal)
  ASSERT_TRUE(std::filesystem::exists(cache));

  const TemplateBank bank = ReadTemplateCacheChecked(cache, mesh);
  EXPECT_EQ(bank.object_id, "obj_000077");
  EXPECT_EQ(bank.templates.size(), 12u);
  EXPECT_EQ(bank.options.views.num_inplane * bank.options.views.num_directions, 12);
  EXPECT_NEAR(bank.diameter_m, 2.0 * std::sqrt(40.0 * 40 + 30 * 30 + 20 * 20) * 1e-3, 1e-6);
  EXPECT_GT(bank.NumKeypoints(), 12u * 50u);

  const std::string sheet = dir + "/sheet.png";
  const RunResult inspect = RunCommand(kInspect + " " + cache + " --sheet " + sheet + " --max 9");
  ASSERT_EQ(inspect.exit_code, 0) << inspect.output;
  EXPECT_THAT(inspect.output, HasSubstr("obj_000077"));
  EXPECT_THAT(inspect.output, HasSubstr("templates       12"));
  const cv::Mat image = cv::imread(sheet);
  ASSERT_FALSE(image.empty()) << "no contact sheet at " << sheet;
  EXPECT_EQ(image.cols, 3 * 128);
  EXPECT_EQ(image.rows, 3 * 128);
}

TEST(Tools, BuildTemplatesReadsBopSymmetries) {
  const std::string dir = test::TempDir("tools_symmetries");
  const std::string mesh = dir + "/box.ply";
  WriteCheckerBoxPly(mesh);
  // A 180 deg turn about z (6 digits, as BOP stores it; translation in mm) and a continuous
  // symmetry about x through (0, 0, 10 mm).
  std::ofstream(dir + "/models_info.json")
      << R"({"77": {"diameter": 107.7, "symmetries_discrete": [[-1, 0.000001, 0, 0.5, )"
      << R"(-0.000001, -1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]], "symmetries_continuous": )"
      << R"([{"axis": [1, 0, 0], "offset": [0, 0, 10]}]}})";
  const std::string cache = dir + "/obj_000077.g6dcache";
  const RunResult build = RunCommand(
      kBuildTemplates + " --mesh " + mesh + " --units mm --object-id obj_000077 --out " + cache +
      " --views 3 --inplane 1 --models-info " + dir + "/models_info.json --continuous-steps 4");
  ASSERT_EQ(build.exit_code, 0) << build.output;
  const TemplateBank bank = ReadTemplateCache(cache);
  ASSERT_EQ(bank.symmetries.size(), 1u + 3u);
  EXPECT_NEAR(bank.symmetries[0].translation().x(), 0.0005, 1e-12);  // mm -> m
  EXPECT_NEAR(bank.symmetries[0].linear().determinant(), 1.0, 1e-12);
  // The continuous samples keep the axis through the offset fixed.
  const Eigen::Vector3d on_axis(0.02, 0.0, 0.01);
  for (size_t i = 1; i < 4; ++i) {
    EXPECT_LT((bank.symmetries[i] * on_axis - on_axis).norm(), 1e-12);
  }
}

TEST(Tools, BuildTemplatesReportsErrors) {
  const std::string dir = test::TempDir("tools_errors");
  const std::string missing = dir + "/no_such_mesh.ply";
  const RunResult no_mesh = RunCommand(kBuildTemplates + " --mesh " + missing +
                                       " --units mm --object-id x --out " + dir + "/x.g6dcache");
  EXPECT_NE(no_mesh.exit_code, 0);
  EXPECT_THAT(no_mesh.output, HasSubstr(missing));
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.g6dcache"));

  const std::string mesh = dir + "/box.ply";
  WriteCheckerBoxPly(mesh);
  const RunResult bad_views =
      RunCommand(kBuildTemplates + " --mesh " + mesh + " --units mm --object-id x --out " + dir +
                 "/x.g6dcache --views 10");
  EXPECT_NE(bad_views.exit_code, 0);
  EXPECT_THAT(bad_views.output, HasSubstr("--views 10"));

  const RunResult bad_units =
      RunCommand(kBuildTemplates + " --mesh " + mesh + " --units inch --object-id x --out " + dir +
                 "/x.g6dcache");
  EXPECT_NE(bad_units.exit_code, 0);
}

// The line of `output` that starts with `prefix` ("" when none).
std::string LineStartingWith(const std::string& output, const std::string& prefix) {
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind(prefix, 0) == 0) return line;
  }
  return "";
}

// A binary PLY whose data starts with a newline byte (Debian's assimp 5.2 refused it:
// "aiMesh::mFaces[0].mNumIndices is 0") builds the same cache geometry as its ASCII twin.
TEST(Tools, BuildTemplatesReadsNewlineFirstBinaryPlyLikeItsAsciiTwin) {
  const std::string dir = test::TempDir("tools_newline_first");
  const test::CorpusBox box = test::MakeCorpusBox(/*newline_first=*/true);
  test::PlyWriteOptions options;
  options.colors = test::PlyWriteOptions::Colors::kUchar;
  test::WriteCorpusPly(dir + "/ascii.ply", box, options);
  options.encoding = test::PlyWriteOptions::Encoding::kBinaryLittleEndian;
  test::WriteCorpusPly(dir + "/binary.ply", box, options);
  std::string inspected[2];
  TemplateBank banks[2];
  const char* names[2] = {"ascii", "binary"};
  for (int i = 0; i < 2; ++i) {
    const std::string mesh = dir + "/" + names[i] + ".ply";
    const std::string cache = dir + "/" + names[i] + ".g6dcache";
    const RunResult build =
        RunCommand(kBuildTemplates + " --mesh " + mesh + " --units mm --object-id obj_000034 --out " +
                   cache + " --views 3 --inplane 1 --threads 2");
    ASSERT_EQ(build.exit_code, 0) << build.output;
    banks[i] = ReadTemplateCacheChecked(cache, mesh);
    const RunResult inspect = RunCommand(kInspect + " " + cache);
    ASSERT_EQ(inspect.exit_code, 0) << inspect.output;
    inspected[i] = inspect.output;
  }
  EXPECT_EQ(banks[1].diameter_m, banks[0].diameter_m);
  EXPECT_EQ(banks[1].bounding_box.min(), banks[0].bounding_box.min());
  EXPECT_EQ(banks[1].bounding_box.max(), banks[0].bounding_box.max());
  // The box's diagonal (its minimum x is a float step below -35 mm).
  EXPECT_NEAR(banks[1].diameter_m, 1e-3 * std::sqrt(80.0 * 80 + 60 * 60 + 40 * 40), 1e-7);
  for (const char* line : {"diameter", "bounding box"}) {
    EXPECT_NE(LineStartingWith(inspected[1], line), "") << inspected[1];
    EXPECT_EQ(LineStartingWith(inspected[1], line), LineStartingWith(inspected[0], line));
  }
}

TEST(Tools, InspectRefusesABrokenCache) {
  const std::string dir = test::TempDir("tools_inspect_broken");
  const std::string path = dir + "/broken.g6dcache";
  std::ofstream(path) << "definitely not a cache";
  const RunResult inspect = RunCommand(kInspect + " " + path);
  EXPECT_NE(inspect.exit_code, 0);
  EXPECT_THAT(inspect.output, HasSubstr("bad magic"));
}

}  // namespace
}  // namespace g6d

namespace g6d {
namespace {

// docs/tools.md's g6d-solve example on a real LM-O frame: the can (obj_000005) in scene 2,
// image 8, GT instance 1 (t = (-35.1, 168.3, 978.2) mm in scene_gt.json).
TEST(Tools, SolveOnAnLmoFrame) {
  G6D_REQUIRE_SHARED_DATA("lmo/test/000002/rgb/000008.png");
  ASSERT_TRUE(std::filesystem::exists(kSolve)) << kSolve;
  const std::string dir = test::TempDir("tools_solve");
  const std::string lmo = test::SharedDataPath("lmo");
  const std::string cache = dir + "/obj_000005.g6dcache";
  const RunResult build = RunCommand(kBuildTemplates + " --mesh " + lmo + "/models/obj_000005.ply --units mm" +
                                     " --object-id obj_000005 --out " + cache + " --threads 2");
  ASSERT_EQ(build.exit_code, 0) << build.output;
  const std::string scene = lmo + "/test/000002";
  const std::string common = kSolve + " --cache " + cache + " --rgb " + scene + "/rgb/000008.png --depth " + scene +
                             "/depth/000008.png --depth-scale 1 --K 572.4114,573.57043,325.2611,242.04899";
  const RunResult solve = RunCommand(common + " --mask " + scene + "/mask_visib/000008_000001.png --overlay " + dir +
                                     "/overlay.png --json " + dir + "/pose.json");
  ASSERT_EQ(solve.exit_code, 0) << solve.output;
  EXPECT_THAT(solve.output, HasSubstr("S_A"));
  EXPECT_THAT(solve.output, HasSubstr("confidence"));
  std::ifstream json_file(dir + "/pose.json");
  const nlohmann::json pose = nlohmann::json::parse(json_file);
  EXPECT_TRUE(pose.at("success").get<bool>());
  const Eigen::Vector3d t(pose.at("position_m")[0], pose.at("position_m")[1], pose.at("position_m")[2]);
  // Within a tenth of the can's diameter (201.4 mm) of the GT translation.
  EXPECT_LT((t - Eigen::Vector3d(-0.03507, 0.16831, 0.97816)).norm(), 0.02) << t.transpose();
  const cv::Mat overlay = cv::imread(dir + "/overlay.png");
  ASSERT_FALSE(overlay.empty());
  EXPECT_EQ(overlay.cols, 640);

  // An empty mask: exit code 3 and the reason.
  const cv::Mat empty = cv::Mat::zeros(480, 640, CV_8U);
  cv::imwrite(dir + "/empty.png", empty);
  const RunResult bad = RunCommand(common + " --mask " + dir + "/empty.png");
  EXPECT_EQ(bad.exit_code, 3) << bad.output;
  EXPECT_THAT(bad.output, HasSubstr("mask is empty"));
}

// The same can with its identity unknown: the ape (obj_000001) and the can are candidates;
// the can is chosen and the JSON says so, with every candidate's S and time.
TEST(Tools, SolveWithCandidatesChoosesTheObject) {
  G6D_REQUIRE_SHARED_DATA("lmo/test/000002/rgb/000008.png");
  ASSERT_TRUE(std::filesystem::exists(kSolve)) << kSolve;
  const std::string dir = test::TempDir("tools_solve_candidates");
  const std::string lmo = test::SharedDataPath("lmo");
  std::filesystem::create_directories(dir + "/caches");
  for (const char* id : {"obj_000001", "obj_000005"}) {
    const RunResult build =
        RunCommand(kBuildTemplates + " --mesh " + lmo + "/models/" + id + ".ply --units mm --object-id " + id +
                   " --out " + dir + "/caches/" + id + ".g6dcache --views 72 --threads 2");
    ASSERT_EQ(build.exit_code, 0) << build.output;
  }
  const std::string scene = lmo + "/test/000002";
  const std::string common = kSolve + " --rgb " + scene + "/rgb/000008.png --depth " + scene +
                             "/depth/000008.png --depth-scale 1 --K 572.4114,573.57043,325.2611,242.04899 --mask " +
                             scene + "/mask_visib/000008_000001.png";
  const RunResult solve = RunCommand(common + " --cache " + dir + "/caches --candidates all --json " + dir + "/pose.json");
  ASSERT_EQ(solve.exit_code, 0) << solve.output;
  EXPECT_THAT(solve.output, HasSubstr("object      obj_000005"));
  EXPECT_THAT(solve.output, HasSubstr("identity    2 candidates"));
  std::ifstream json_file(dir + "/pose.json");
  const nlohmann::json pose = nlohmann::json::parse(json_file);
  EXPECT_EQ(pose.at("object_id"), "obj_000005");
  const nlohmann::json& identity = pose.at("identity");
  EXPECT_EQ(identity.at("chosen"), "obj_000005");
  ASSERT_EQ(identity.at("candidates").size(), 2u);
  EXPECT_EQ(identity.at("candidates")[0].at("object_id"), "obj_000001");
  EXPECT_EQ(identity.at("candidates")[1].at("score").get<double>(), pose.at("score").get<double>());

  // Two caches and no --candidates, and an id without a cache: errors that say what to do.
  const RunResult two = RunCommand(common + " --cache " + dir + "/caches");
  EXPECT_EQ(two.exit_code, 2) << two.output;
  EXPECT_THAT(two.output, HasSubstr("pass --candidates"));
  const RunResult unknown = RunCommand(common + " --cache " + dir + "/caches --candidates obj_000005,obj_000009");
  EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
  EXPECT_THAT(unknown.output, HasSubstr("no cache given for object 'obj_000009'"));
}

}  // namespace
}  // namespace g6d
