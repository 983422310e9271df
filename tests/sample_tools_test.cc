// The tools around the demo, run on a small embedded sample: g6d-overlay, g6d-eval
// --per-instance, g6d-solve without a mask (--find, --find-all), and the per-estimate JSON
// lines of g6d-replay (EstimatesJsonLines).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <regex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/se3.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "eval/metrics.h"
#include "mesh/mesh.h"
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
const std::string kSolve = test::BinaryDir() + "/tools/g6d-solve";

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

// A sample whose caches are fine enough to solve with (the fixture above has 12 views per
// object, enough to draw with, too few to solve with), and g6d-solve's arguments for its
// image 3 without a mask (seed 1: the three objects apart on the table; on the 12-image
// sample all 36 objects are found within 0.1 d).
struct SolveFixture {
  std::string root;
  BopDataset dataset;
  BopFrame frame;
  std::string command;  // g6d-solve --cache ... --rgb ... --depth ... --depth-scale ... --K ...

  SolveFixture() {
    root = test::ScratchDirs::Make("sample_tools_solve") + "/sample";
    const test::CommandResult made =
        test::RunCommand(kMakeSample + " --out " + root + " --frames 4 --seed 1 --no-log --threads 2");
    EXPECT_EQ(made.exit_code, 0) << made.output;
    dataset = LoadBopDataset(root);
    frame = LoadBopScene(root, 1).Frame(3);
    char image[16];
    std::snprintf(image, sizeof(image), "%06d.png", frame.im_id);
    std::ostringstream k;
    k.precision(10);
    k << frame.camera.fx << "," << frame.camera.fy << "," << frame.camera.cx << "," << frame.camera.cy;
    std::ostringstream scale;
    scale << frame.depth_scale;
    command = kSolve + " --cache " + root + "/caches --rgb " + root + "/test/000001/rgb/" + image + " --depth " + root +
              "/test/000001/depth/" + image + " --depth-scale " + scale.str() + " --K " + k.str() + " --threads 2";
  }

  std::string RgbPath() const {
    char image[16];
    std::snprintf(image, sizeof(image), "%06d.png", frame.im_id);
    return root + "/test/000001/rgb/" + image;
  }
};

const SolveFixture& SharedSolveFixture() {
  static const SolveFixture fixture;
  return fixture;
}

// ADD(-S) of an answer to the nearest ground-truth instance of its object, in diameters.
double ErrorInDiameters(const BopDataset& dataset, const BopFrame& frame, int obj_id,
                        const Eigen::Isometry3d& cam_from_object) {
  const BopObjectInfo& info = dataset.objects.at(obj_id);
  const Mesh mesh = LoadMesh(info.mesh_path, info.mesh_units);
  std::vector<Eigen::Vector3f> points;
  const size_t step = std::max<size_t>(1, mesh.vertices.size() / 2000);
  for (size_t i = 0; i < mesh.vertices.size(); i += step) points.push_back(mesh.vertices[i]);
  double best = std::numeric_limits<double>::infinity();
  for (const BopGtInstance& gt : frame.gt) {
    if (gt.obj_id != obj_id) continue;
    best = std::min(best, info.IsSymmetric() ? ComputeAdds(cam_from_object, gt.cam_from_object, points)
                                             : ComputeAdd(cam_from_object, gt.cam_from_object, points));
  }
  return best / info.diameter_m;
}

Eigen::Isometry3d PoseOf(const Json& answer) {
  const Json& p = answer.at("position_m");
  const Json& q = answer.at("orientation_wxyz");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Quaterniond(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>())
                      .normalized()
                      .toRotationMatrix();
  pose.translation() = Eigen::Vector3d(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
  return pose;
}

// No mask, no box: every cache's object is found in the frame, each within 0.1 d of its
// ground truth; the report and the JSON show how (support, segments, ranked and solved
// candidates, stage times), and the overlay is the detection picture.
TEST(G6dSolve, FindAllFindsEverySampleObjectWithoutAMask) {
  ASSERT_TRUE(fs::exists(kSolve)) << kSolve << " is not built";
  const SolveFixture& f = SharedSolveFixture();
  ASSERT_EQ(f.frame.gt.size(), f.dataset.objects.size());  // one instance of each object
  const std::string out = test::ScratchDirs::Make("sample_tools_find_all");
  const test::CommandResult run =
      test::RunCommand(f.command + " --find-all --overlay " + out + "/find.png --json " + out + "/find.json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const char* line : {"mode        find (no mask):", "support     ", "regions     ", "answer 1    obj_",
                           "region      #", "S_A         ", "candidates  obj_000001: asked 1, found 1",
                           "time (ms)   support "}) {
    EXPECT_THAT(run.output, HasSubstr(line));
  }
  std::ifstream json_file(out + "/find.json");
  const Json j = Json::parse(json_file);
  EXPECT_EQ(j.at("mode"), "find");
  EXPECT_TRUE(j.at("success").get<bool>());
  const Json& answers = j.at("answers");
  ASSERT_EQ(answers.size(), f.dataset.objects.size()) << run.output;
  std::set<std::string> found;
  for (const Json& answer : answers) {
    const std::string id = answer.at("object_id");
    found.insert(id);
    const double error_d = ErrorInDiameters(f.dataset, f.frame, ParseBopObjectName(id), PoseOf(answer));
    std::printf("%s: S_A %.4f, confidence %.3f, ADD(-S) %.4f d\n", id.c_str(), answer.at("score").get<double>(),
                answer.at("confidence").get<double>(), error_d);
    EXPECT_LT(error_d, 0.1) << id << "\n" << run.output;
    EXPECT_TRUE(answer.at("success").get<bool>());
    const Json& region = answer.at("region");
    EXPECT_EQ(region.at("box").size(), 4u);
    EXPECT_GT(region.at("pixels").get<int>(), 0);
  }
  EXPECT_EQ(found.size(), f.dataset.objects.size());
  const Json& detection = j.at("detection");
  EXPECT_GE(detection.at("support_planes").get<int>(), 1);  // the table
  EXPECT_GT(detection.at("segments").get<int>(), 0);
  EXPECT_GE(detection.at("solves").get<int>(), 3);
  EXPECT_EQ(detection.at("answers").get<int>(), 3);
  ASSERT_EQ(j.at("objects").size(), f.dataset.objects.size());
  for (const Json& object : j.at("objects")) {
    EXPECT_EQ(object.at("count"), 1);
    EXPECT_EQ(object.at("found"), 1);
    int answered = 0;
    for (const Json& candidate : object.at("candidates")) {
      answered += candidate.value("verdict", "").rfind("answer", 0) == 0;
    }
    EXPECT_EQ(answered, 1) << object.at("object_id");
  }
  for (const char* stage : {"support", "segment", "propose", "rank", "solve", "select", "total"}) {
    EXPECT_GE(j.at("time_ms").at(stage).get<double>(), 0.0) << stage;
  }
  // The detection picture: the frame's size, not the plain image (support darkened,
  // segments and regions outlined, the answers drawn).
  const cv::Mat picture = cv::imread(out + "/find.png");
  const cv::Mat plain = cv::imread(f.RgbPath());
  ASSERT_FALSE(picture.empty());
  ASSERT_EQ(picture.size(), plain.size());
  cv::Mat difference;
  cv::absdiff(picture, plain, difference);
  cv::cvtColor(difference, difference, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(difference > 30), picture.total() / 10);
  EXPECT_GT(CountColour(picture, cv::Vec3b(40, 255, 40), 40), 300);  // the answers' green contours
}

// --find OBJ:COUNT asks for one object only: the answer is of that object, and the one can
// in the frame is one answer although two were allowed.
TEST(G6dSolve, FindOneObjectWithACount) {
  const SolveFixture& f = SharedSolveFixture();
  const std::string out = test::ScratchDirs::Make("sample_tools_find_one");
  const test::CommandResult run = test::RunCommand(f.command + " --find obj_000002:2 --json " + out + "/find.json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("find (no mask): obj_000002 x2"));
  EXPECT_THAT(run.output, HasSubstr("candidates  obj_000002: asked 2, found 1;"));
  std::ifstream json_file(out + "/find.json");
  const Json j = Json::parse(json_file);
  ASSERT_EQ(j.at("answers").size(), 1u) << run.output;
  ASSERT_EQ(j.at("objects").size(), 1u);
  EXPECT_EQ(j.at("objects")[0].at("found"), 1);
  EXPECT_EQ(j.at("answers")[0].at("object_id"), "obj_000002");
  const double error_d = ErrorInDiameters(f.dataset, f.frame, 2, PoseOf(j.at("answers")[0]));
  EXPECT_LT(error_d, 0.1) << run.output;
}

// Contradictions and bad values: a clear message and exit code 2, before any solve.
TEST(G6dSolve, FindArgumentErrors) {
  const SolveFixture& f = SharedSolveFixture();
  const std::string mask = f.root + "/test/000001/mask_visib/000003_000000.png";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {" --find obj_000001 --mask " + mask, "--find finds the objects without a mask: --mask cannot be given with it"},
      {" --find-all --candidates all", "--find-all finds the objects without a mask: --candidates cannot be given"},
      {" --find obj_000001 --find-all", "--find and --find-all contradict each other"},
      {" --find obj_000001:0", "--find obj_000001:0: the count must be >= 1 (got 0)"},
      {" --find obj_000001:two", "the count 'two' is not a whole number"},
      {" --find obj_000099", "no cache given for object 'obj_000099' (the caches hold: obj_000001, obj_000002"},
      {" --find obj_000001 --find obj_000001:2", "object 'obj_000001' is given twice"},
      {" --find-all --detect-colour-weight 2", "--detect-colour-weight must be in [0, 1] (got 2)"},
      {" --find-all --detect-extra -1", "--detect-extra must be >= 0 (got -1)"},
      {"", "no mask: give --mask FILE (the object's pixels), or --find OBJ[:COUNT] / --find-all"},
      {" --mask " + mask + " --candidates all --detect-extra 3", "--detect-extra needs --find or --find-all"},
  };
  for (const auto& [arguments, message] : cases) {
    const test::CommandResult run = test::RunCommand(f.command + arguments);
    EXPECT_EQ(run.exit_code, 2) << arguments << "\n" << run.output;
    EXPECT_THAT(run.output, HasSubstr(message)) << arguments;
    EXPECT_THAT(run.output, HasSubstr("g6d-solve: error: ")) << arguments;
  }
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
