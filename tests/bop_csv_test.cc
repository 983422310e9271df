#include "eval/bop_csv.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/se3.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;

// Estimates with awkward numbers (many digits, tiny and negative values), fixed seed.
std::vector<BopEstimate> MakeEstimates() {
  std::mt19937 generator(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<BopEstimate> estimates;
  for (int im_id : {3, 8}) {
    const double time_s = im_id == 3 ? 0.123456789012345678 : -1.0;
    for (int obj_id : {1, 5, 12}) {
      BopEstimate estimate;
      estimate.scene_id = 2;
      estimate.im_id = im_id;
      estimate.obj_id = obj_id;
      estimate.score = 1.0 / (3.0 + obj_id) * (obj_id == 12 ? 1e-20 : 1.0);
      Vector6d xi;
      for (int k = 0; k < 6; ++k) xi[k] = normal(generator);
      estimate.cam_from_object = ExpSE3(xi);
      estimate.cam_from_object.translation().z() += 1.0 / 3.0;
      estimate.time_s = time_s;
      estimates.push_back(estimate);
    }
  }
  return estimates;
}

std::string ToCsv(const std::vector<BopEstimate>& estimates) {
  std::ostringstream out;
  WriteBopCsv(estimates, &out);
  return out.str();
}

std::vector<BopEstimate> FromCsv(const std::string& text) {
  std::istringstream in(text);
  return ReadBopCsv(in, "results.csv");
}

// The message of the g6d::Error thrown by reading `text` (empty if nothing was thrown).
std::string ReadError(const std::string& text) {
  try {
    FromCsv(text);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(WriteBopCsv, WritesHeaderAndBopUnits) {
  BopEstimate estimate;
  estimate.scene_id = 2;
  estimate.im_id = 8;
  estimate.obj_id = 5;
  estimate.score = 0.5;
  estimate.cam_from_object.translation() = Eigen::Vector3d(0.25, -0.125, 1.5);
  estimate.time_s = 0.25;
  EXPECT_EQ(ToCsv({estimate}),
            "scene_id,im_id,obj_id,score,R,t,time\n"
            "2,8,5,0.5,1 0 0 0 1 0 0 0 1,250 -125 1500,0.25\n");
}

TEST(WriteBopCsv, RoundTripIsExact) {
  const std::vector<BopEstimate> estimates = MakeEstimates();
  const std::string text = ToCsv(estimates);
  const std::vector<BopEstimate> read = FromCsv(text);
  ASSERT_EQ(read.size(), estimates.size());
  for (size_t i = 0; i < read.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(read[i].scene_id, estimates[i].scene_id);
    EXPECT_EQ(read[i].im_id, estimates[i].im_id);
    EXPECT_EQ(read[i].obj_id, estimates[i].obj_id);
    EXPECT_EQ(read[i].score, estimates[i].score);
    EXPECT_EQ(read[i].time_s, estimates[i].time_s);
    // R is printed with 17 significant digits: bit-exact.
    EXPECT_EQ(read[i].cam_from_object.linear(), estimates[i].cam_from_object.linear());
    // t passes through one m -> mm -> m conversion.
    for (int k = 0; k < 3; ++k) {
      EXPECT_DOUBLE_EQ(read[i].cam_from_object.translation()[k],
                       estimates[i].cam_from_object.translation()[k]);
    }
  }
  // Writing what was read gives the same text: for a t_mm that was written from metres,
  // t_mm / 1000 * 1000 gives t_mm back (not so for arbitrary mm text, off by an ulp).
  EXPECT_EQ(ToCsv(read), text);
}

TEST(WriteBopCsv, FileRoundTrip) {
  const std::string dir = test::TempDir("bop_csv_file");
  const std::string path = dir + "/results.csv";
  const std::vector<BopEstimate> estimates = MakeEstimates();
  WriteBopCsv(path, estimates);
  const std::vector<BopEstimate> read = ReadBopCsv(path);
  ASSERT_EQ(read.size(), estimates.size());
  EXPECT_EQ(read.back().cam_from_object.linear(), estimates.back().cam_from_object.linear());
  std::filesystem::remove_all(dir);
}

TEST(WriteBopCsv, DifferentTimesInOneImageThrow) {
  std::vector<BopEstimate> estimates = MakeEstimates();
  estimates[1].time_s = 2.0;
  try {
    ToCsv(estimates);
    FAIL() << "expected g6d::Error";
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("one time per image"));
  }
}

TEST(WriteBopCsv, NonFiniteThrows) {
  std::vector<BopEstimate> estimates = MakeEstimates();
  estimates[2].score = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ToCsv(estimates), Error);
}

TEST(WriteBopCsv, UnwritablePathThrows) {
  EXPECT_THROW(WriteBopCsv("/nonexistent_dir_g6d/results.csv", MakeEstimates()), Error);
}

TEST(ReadBopCsv, AcceptsCrlfBlankLinesNoHeaderAndScientificNumbers) {
  const std::vector<BopEstimate> read = FromCsv(
      "\r\n2,8,5,1e-1,1 0 0 0 1 0 0 0 1,1.5e3 0 -2,  -1\r\n\n"
      "2,8,6,0.3,1 0 0 0 1 0 0 0 1,0 0 1000,-1\n");
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].obj_id, 5);
  EXPECT_DOUBLE_EQ(read[0].score, 0.1);
  EXPECT_DOUBLE_EQ(read[0].cam_from_object.translation().x(), 1.5);
  EXPECT_DOUBLE_EQ(read[0].cam_from_object.translation().z(), -0.002);
  EXPECT_EQ(read[0].time_s, -1.0);
  EXPECT_DOUBLE_EQ(read[1].cam_from_object.translation().z(), 1.0);
}

TEST(ReadBopCsv, EmptyInputGivesNoEstimates) {
  EXPECT_TRUE(FromCsv("").empty());
  EXPECT_TRUE(FromCsv("scene_id,im_id,obj_id,score,R,t,time\n").empty());
}

TEST(ReadBopCsv, MalformedLinesNameTheLine) {
  const std::string header = "scene_id,im_id,obj_id,score,R,t,time\n";
  const std::string good = "2,8,5,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.1\n";
  // Wrong field count on line 3.
  EXPECT_THAT(ReadError(header + good + "2,8,5,0.5,1 0 0 0 1 0 0 0 1,0 0 1000\n"),
              HasSubstr("results.csv:3: expected 7 comma-separated fields"));
  // R with 8 numbers.
  EXPECT_THAT(ReadError(header + "2,8,5,0.5,1 0 0 0 1 0 0 0,0 0 1000,0.1\n"),
              HasSubstr("results.csv:2: field 'R': expected 9 numbers"));
  // t with a word in it.
  EXPECT_THAT(ReadError(header + good + good + "2,8,6,0.5,1 0 0 0 1 0 0 0 1,0 x 1000,0.1\n"),
              HasSubstr("results.csv:4: field 't'"));
  // Non-integer id.
  EXPECT_THAT(ReadError("2,8.5,5,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.1\n"),
              HasSubstr("results.csv:1: field 'im_id'"));
  // Negative id.
  EXPECT_THAT(ReadError("2,8,-5,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.1\n"),
              HasSubstr("results.csv:1: field 'obj_id'"));
  // Score not a number, and nan.
  EXPECT_THAT(ReadError("2,8,5,high,1 0 0 0 1 0 0 0 1,0 0 1000,0.1\n"),
              HasSubstr("results.csv:1: field 'score'"));
  EXPECT_THAT(ReadError("2,8,5,nan,1 0 0 0 1 0 0 0 1,0 0 1000,0.1\n"),
              HasSubstr("results.csv:1: field 'score'"));
  // A misspelt header is not silently skipped.
  EXPECT_THAT(ReadError("scene,im_id,obj_id,score,R,t,time\n" + good),
              HasSubstr("results.csv:1: field 'scene_id'"));
}

TEST(ReadBopCsv, DifferentTimesInOneImageNameBothLines) {
  const std::string text =
      "2,8,5,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.1\n"
      "2,9,5,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.7\n"
      "2,8,6,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.2\n";
  const std::string message = ReadError(text);
  EXPECT_THAT(message, HasSubstr("results.csv:3: time 0.2 differs from 0.1 on line 1"));
}

// Found in review while hardening for fuzzing (input in
// tests/fuzz/regressions/bop_csv/nul-inside-a-number): the number parsers stop at a NUL
// byte, so "0.5<NUL>junk" was read as 0.5.
TEST(ReadBopCsv, FuzzNulByteInsideAFieldIsAnError) {
  const std::string line = "2,8,5,0.5,1 0 0 0 1 0 0 0 1,0 0 1000,0.1\n";
  EXPECT_EQ(FromCsv(line).size(), 1u);
  for (size_t position : {4u, 6u, 11u, 30u, 39u}) {  // in score, R, t and time
    std::string damaged = line;
    damaged.insert(position, std::string(1, '\0') + "junk");
    EXPECT_THAT(ReadError(damaged), HasSubstr("results.csv:1: line contains a NUL byte"))
        << "NUL at " << position;
  }
}

TEST(ReadBopCsv, MissingFileThrowsNamingPath) {
  try {
    ReadBopCsv("/nonexistent_dir_g6d/results.csv");
    FAIL() << "expected g6d::Error";
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("/nonexistent_dir_g6d/results.csv"));
  }
}

}  // namespace
}  // namespace g6d
