// The include layering of DESIGN.md, read from the source tree: lib/ includes nothing
// above it, wire/ nothing of the apps or tests, service/ and replay/ are peers (neither
// includes the other), and bench/ and tools/ never include from tests/. Inside lib/solver/
// the stages keep one order (kSolverOrder): a stage's header includes only the headers of
// the stages it calls, never one of a stage that calls it.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "test_paths.h"
#include "test_util.h"

namespace g6d {
namespace {

namespace fs = std::filesystem;

// lib/ folders are included as "core/...", "solver/...": they all belong to layer "lib".
const std::set<std::string> kLibFolders = {"core",   "mesh", "render",    "templates",
                                           "solver", "eval", "synthetic", "track"};
const std::vector<std::string> kLayers = {"lib",   "wire",  "service", "replay",
                                          "tools", "bench", "tests"};

// The forbidden (from layer, to layer) pairs.
const std::set<std::pair<std::string, std::string>> kForbidden = {
    {"lib", "wire"},       {"lib", "service"},   {"lib", "replay"},   {"lib", "tools"},
    {"lib", "bench"},      {"lib", "tests"},     {"wire", "service"}, {"wire", "replay"},
    {"wire", "tools"},     {"wire", "bench"},    {"wire", "tests"},   {"replay", "service"},
    {"service", "replay"}, {"service", "tests"}, {"replay", "tests"}, {"bench", "tests"},
    {"tools", "tests"}};

// The layer (top-level folder) of a file below `root`; empty when it is in none.
std::string LayerOf(const fs::path& root, const fs::path& file) {
  const std::string top = *fs::relative(file, root).begin();
  for (const std::string& layer : kLayers)
    if (top == layer) return layer;
  return "";
}

// The layer a quoted include of `file` resolves to, as the build's include paths do: the
// including file's folder first, then the checkout root ("wire/...", "service/..."), lib/
// ("core/..."), and the folders the targets add (tests/, replay/, tools/, bench/).
std::string IncludedLayer(const fs::path& root, const fs::path& file, const std::string& include) {
  if (fs::exists(file.parent_path() / include)) return LayerOf(root, file.parent_path() / include);
  const std::string first = include.substr(0, include.find('/'));
  if (include.find('/') != std::string::npos) {
    if (kLibFolders.count(first) != 0) return "lib";
    for (const std::string& layer : kLayers)
      if (first == layer) return layer;
  }
  for (const char* layer : {"tests", "replay", "tools", "bench"})
    if (fs::exists(root / layer / include)) return layer;
  return "";  // a generated header ("g6d/image_t.hpp") or a system one
}

// "from -> to: file includes \"x\"" for every forbidden include below `root`.
std::vector<std::string> FindLayerViolations(const fs::path& root) {
  const std::regex include_line(R"(^\s*#\s*include\s*"([^"]+)\")");
  std::vector<std::string> violations;
  for (const std::string& layer : kLayers) {
    if (!fs::exists(root / layer)) continue;
    for (const auto& entry : fs::recursive_directory_iterator(root / layer)) {
      const std::string extension = entry.path().extension().string();
      if (!entry.is_regular_file() || (extension != ".h" && extension != ".cc")) continue;
      std::ifstream in(entry.path());
      std::string line;
      std::smatch match;
      while (std::getline(in, line)) {
        if (!std::regex_search(line, match, include_line)) continue;
        const std::string to = IncludedLayer(root, entry.path(), match[1]);
        if (kForbidden.count({layer, to}) != 0) {
          violations.push_back(layer + " -> " + to + ": " +
                               fs::relative(entry.path(), root).string() + " includes \"" +
                               match[1].str() + "\"");
        }
      }
    }
  }
  return violations;
}

void WriteFile(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

TEST(FindLayerViolations, FindsEveryForbiddenKindInATree) {
  const fs::path root = test::TempDir("layering_tree");
  WriteFile(root / "service/service.h", "#pragma once\n");
  WriteFile(root / "tests/helper.h", "#pragma once\n");
  WriteFile(root / "wire/lcm_loop.h", "#pragma once\n");
  WriteFile(root / "replay/replay.cc", "#include \"service/service.h\"\n#include \"core/se3.h\"\n");
  WriteFile(root / "bench/bench.cc", "#include \"helper.h\"\n#include <vector>\n");
  WriteFile(root / "lib/solver/pipeline.cc", "  #  include \"wire/lcm_loop.h\"\n");
  WriteFile(root / "tools/tool.cc", "#include \"wire/lcm_loop.h\"\n#include \"g6d/image_t.hpp\"\n");
  EXPECT_THAT(FindLayerViolations(root),
              testing::UnorderedElementsAre(
                  "replay -> service: replay/replay.cc includes \"service/service.h\"",
                  "bench -> tests: bench/bench.cc includes \"helper.h\"",
                  "lib -> wire: lib/solver/pipeline.cc includes \"wire/lcm_loop.h\""));
}

// lib/solver/'s headers from the bottom up, in the order the stages call each other (as
// pipeline.h describes it): a header may include only the headers before it; a .cc file only
// its own header and those before it. A new header must be given its place here.
const std::vector<std::string> kSolverOrder = {
    // the algorithms
    "segments", "plane", "observation", "region", "score", "match", "point_tree", "icp", "pnp", "mhpo", "ppf",
    "silhouette_poses", "frame_check",
    // what every stage shares: the options, the result, the depth's candidate regions
    "solver_options", "result", "detect_options", "proposals",
    // the solve on a mask, stage by stage
    "mask_stage", "solve_context", "track_pose", "mask_refine", "finalists", "stages", "mask_solve",
    // above the solve on a mask: detection solves its regions with it, the depth's regions use
    // detection, EstimatePose composes the two, the neighbours pass and the identity search
    // call EstimatePose
    "detect", "depth_regions", "pipeline", "neighbours", "identify"};

// .cc files that implement a header of another name.
const std::map<std::string, std::string> kSolverSourceOf = {{"detect_picture", "detect"}};

// "file includes \"solver/x.h\" (above it)" for every include in `root`/lib/solver/ that goes
// up kSolverOrder, and "file is not in the order" for a header it does not list.
std::vector<std::string> FindSolverOrderViolations(const fs::path& root) {
  const std::regex include_line(R"(^\s*#\s*include\s*"solver/([^"/]+)\.h")");
  std::map<std::string, size_t> rank;
  for (size_t i = 0; i < kSolverOrder.size(); ++i) rank[kSolverOrder[i]] = i;
  std::vector<std::string> violations;
  for (const auto& entry : fs::directory_iterator(root / "lib/solver")) {
    const std::string extension = entry.path().extension().string();
    if (!entry.is_regular_file() || (extension != ".h" && extension != ".cc")) continue;
    std::string stem = entry.path().stem().string();
    if (kSolverSourceOf.count(stem) != 0) stem = kSolverSourceOf.at(stem);
    const std::string name = "lib/solver/" + entry.path().filename().string();
    if (rank.count(stem) == 0) {
      if (extension == ".h") violations.push_back(name + " is not in the order");
      continue;
    }
    std::ifstream in(entry.path());
    std::string line;
    std::smatch match;
    while (std::getline(in, line)) {
      if (!std::regex_search(line, match, include_line)) continue;
      const std::string included = match[1];
      const bool allowed = rank.count(included) != 0 &&
                           (rank[included] < rank[stem] || (extension == ".cc" && included == stem));
      if (!allowed) violations.push_back(name + " includes \"solver/" + included + ".h\" (above it)");
    }
  }
  return violations;
}

TEST(FindSolverOrderViolations, FindsAnUpwardInclude) {
  const fs::path root = test::TempDir("solver_order_tree");
  WriteFile(root / "lib/solver/mask_stage.h", "#pragma once\n#include \"solver/pipeline.h\"\n");
  WriteFile(root / "lib/solver/pipeline.h", "#pragma once\n#include \"solver/mask_stage.h\"\n");
  WriteFile(root / "lib/solver/pipeline.cc", "#include \"solver/pipeline.h\"\n#include \"solver/neighbours.h\"\n");
  WriteFile(root / "lib/solver/detect_picture.cc", "#include \"solver/detect.h\"\n#include \"solver/identify.h\"\n");
  WriteFile(root / "lib/solver/stages.h", "#pragma once\n#include \"solver/stages.h\"\n");
  WriteFile(root / "lib/solver/helpers.h", "#pragma once\n#include \"core/frame.h\"\n");
  EXPECT_THAT(FindSolverOrderViolations(root),
              testing::UnorderedElementsAre("lib/solver/mask_stage.h includes \"solver/pipeline.h\" (above it)",
                                            "lib/solver/pipeline.cc includes \"solver/neighbours.h\" (above it)",
                                            "lib/solver/detect_picture.cc includes \"solver/identify.h\" (above it)",
                                            "lib/solver/stages.h includes \"solver/stages.h\" (above it)",
                                            "lib/solver/helpers.h is not in the order"));
}

TEST(FindSolverOrderViolations, TheCheckoutHasNone) {
  const fs::path root = test::SourceDir();
  ASSERT_TRUE(fs::exists(root / "lib/solver/pipeline.h")) << root << " has no lib/solver/pipeline.h";
  EXPECT_THAT(FindSolverOrderViolations(root), testing::IsEmpty());
}

TEST(FindLayerViolations, TheCheckoutHasNone) {
  const fs::path root = test::SourceDir();
  ASSERT_TRUE(fs::exists(root / "wire")) << root << " has no wire/ folder";
  EXPECT_THAT(FindLayerViolations(root), testing::IsEmpty());
}

}  // namespace
}  // namespace g6d
