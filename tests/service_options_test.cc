// ServiceOptions: defaults, Check() and the YAML file format.
#include "service/service_options.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <string>

#include "core/error.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;

ServiceOptions Valid() {
  ServiceOptions options;
  options.templates_dir = "/tmp";
  return options;
}

TEST(ServiceOptions, DefaultsAreValidOnceTemplatesAreSet) {
  EXPECT_NE(ServiceOptions().Check().find("templates_dir"), std::string::npos);
  EXPECT_EQ(Valid().Check(), "");
  EXPECT_EQ(Valid().input_channel, "G6D_RGBD");
  EXPECT_EQ(Valid().output_channel, "G6D_POSES");
  EXPECT_EQ(Valid().status_channel, "G6D_STATUS");
}

TEST(ServiceOptions, CheckNamesTheBadField) {
  ServiceOptions options = Valid();
  options.workers = 0;
  EXPECT_NE(options.Check().find("workers"), std::string::npos);
  options = Valid();
  options.output_channel = options.input_channel;
  EXPECT_NE(options.Check().find("channels must differ"), std::string::npos);
  options = Valid();
  options.max_age_ms = -1;
  EXPECT_NE(options.Check().find("max_age_ms"), std::string::npos);
  options = Valid();
  options.solver.num_hypotheses = 0;
  EXPECT_NE(options.Check().find("solver."), std::string::npos);
  options = Valid();
  options.limits.max_width = 0;
  EXPECT_NE(options.Check().find("limits.max_width"), std::string::npos);
}

TEST(ParseServiceOptionsYaml, ReadsEveryKey) {
  ServiceOptions options;
  ParseServiceOptionsYaml(R"(
name: cam1
templates: /data/caches
input: CAM1_RGBD
output: CAM1_POSES
status: CAM1_STATUS
lcm_url: udpm://239.255.76.67:7667?ttl=1
workers: 3
hypotheses: 6
max_age_ms: 250
subscription_queue: 3
status_period_s: 0.5
latency_window: 50
shutdown_timeout_s: 1.0
limits: {max_width: 2000, max_height: 1500, max_raw_bytes: 100000000, max_instances: 8}
solver:
  max_sets: 64
  hamming_threshold: 60
  min_correspondences: 8
  query_features: 400
  run_icp: false
  run_mhpo: true
  mhpo_max_rounds: 3
  early_stop_score: 0.05
  reject_border_masks: false
  min_valid_depth_pixels: 50
)",
                          "test.yaml", &options);
  EXPECT_EQ(options.name, "cam1");
  EXPECT_EQ(options.templates_dir, "/data/caches");
  EXPECT_EQ(options.input_channel, "CAM1_RGBD");
  EXPECT_EQ(options.output_channel, "CAM1_POSES");
  EXPECT_EQ(options.status_channel, "CAM1_STATUS");
  EXPECT_EQ(options.lcm_url, "udpm://239.255.76.67:7667?ttl=1");
  EXPECT_EQ(options.workers, 3);
  EXPECT_EQ(options.solver.num_hypotheses, 6);
  EXPECT_EQ(options.max_age_ms, 250);
  EXPECT_EQ(options.subscription_queue, 3);
  EXPECT_EQ(options.status_period_s, 0.5);
  EXPECT_EQ(options.latency_window, 50);
  EXPECT_EQ(options.shutdown_timeout_s, 1.0);
  EXPECT_EQ(options.limits.max_width, 2000);
  EXPECT_EQ(options.limits.max_raw_bytes, 100000000);
  EXPECT_EQ(options.limits.max_instances, 8);
  EXPECT_EQ(options.solver.match.max_sets, 64);
  EXPECT_EQ(options.solver.match.hamming_threshold, 60);
  EXPECT_EQ(options.solver.match.min_correspondences, 8);
  EXPECT_EQ(options.solver.query_orb.max_features, 400);
  EXPECT_FALSE(options.solver.run_icp);
  EXPECT_EQ(options.solver.mhpo.max_rounds, 3);
  EXPECT_EQ(options.solver.mhpo.early_stop_score, 0.05);
  EXPECT_FALSE(options.solver.reject_border_masks);
  EXPECT_EQ(options.solver.min_valid_depth_pixels, 50);
  EXPECT_EQ(options.Check(), "");
}

TEST(ParseServiceOptionsYaml, KeysNotGivenKeepTheirValues) {
  ServiceOptions options = Valid();
  ParseServiceOptionsYaml("workers: 1\n", "test.yaml", &options);
  EXPECT_EQ(options.workers, 1);
  EXPECT_EQ(options.templates_dir, "/tmp");
  ParseServiceOptionsYaml("", "empty.yaml", &options);
  EXPECT_EQ(options.workers, 1);
}

TEST(ParseServiceOptionsYaml, RefusesUnknownKeysWrongTypesAndBadYaml) {
  ServiceOptions options;
  auto expect_error = [&](const std::string& text, const std::string& words) {
    try {
      ParseServiceOptionsYaml(text, "bad.yaml", &options);
      ADD_FAILURE() << "no error for: " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
    }
  };
  expect_error("wrokers: 2\n", "unknown key 'wrokers'");
  expect_error("solver: {max_set: 2}\n", "unknown key 'solver.max_set'");
  expect_error("workers: many\n", "'workers' has a value of the wrong type");
  expect_error("solver: 3\n", "'solver' must be a mapping");
  expect_error("workers: [1, 2\n", "not valid YAML");
}

// Tracking (issue 14): on by default, a `tracking` section, TrackerOptions::Check().
TEST(ServiceOptions, TrackingIsOnByDefaultAndCheckNamesItsBadField) {
  EXPECT_TRUE(Valid().tracking.enabled);
  ServiceOptions options = Valid();
  options.tracking.loss_score = -1.0;
  EXPECT_THAT(options.Check(), HasSubstr("tracking: TrackerOptions.loss_score must be > 0"));
  options = Valid();
  options.tracking.min_overlap = 1.5;
  EXPECT_THAT(options.Check(), HasSubstr("TrackerOptions.min_overlap must be in [0, 1]"));
  options = Valid();
  options.tracking.redetect_every = -2;
  EXPECT_THAT(options.Check(), HasSubstr("TrackerOptions.redetect_every must be >= 0 (got -2)"));
  options = Valid();
  options.tracking.solve.icp_iterations = -1;
  EXPECT_THAT(options.Check(), HasSubstr("tracking: "));
  // Off with otherwise bad thresholds is still refused: the options are one set.
  options.tracking.enabled = false;
  EXPECT_NE(options.Check(), "");
}

TEST(ParseServiceOptionsYaml, ReadsTheTrackingSection) {
  ServiceOptions options = Valid();
  ParseServiceOptionsYaml(R"(
tracking:
  enabled: false
  max_age_s: 0.5
  min_overlap: 0.4
  loss_score: 0.2
  min_iou: 0.7
  redetect_every: 10
  max_periodic_per_frame: 2
  constant_velocity: false
)",
                          "tracking.yaml", &options);
  EXPECT_FALSE(options.tracking.enabled);
  EXPECT_EQ(options.tracking.max_age_s, 0.5);
  EXPECT_EQ(options.tracking.min_overlap, 0.4);
  EXPECT_EQ(options.tracking.loss_score, 0.2);
  EXPECT_EQ(options.tracking.min_iou, 0.7);
  EXPECT_EQ(options.tracking.redetect_every, 10);
  EXPECT_EQ(options.tracking.max_periodic_per_frame, 2);
  EXPECT_FALSE(options.tracking.constant_velocity);
  EXPECT_EQ(options.Check(), "");
  // Keys not given keep their values.
  ParseServiceOptionsYaml("tracking: {enabled: true}\n", "tracking.yaml", &options);
  EXPECT_TRUE(options.tracking.enabled);
  EXPECT_EQ(options.tracking.redetect_every, 10);
}

TEST(ParseServiceOptionsYaml, RefusesBadTrackingKeysAndValues) {
  ServiceOptions options = Valid();
  auto expect_error = [&](const std::string& text, const std::string& words) {
    try {
      ParseServiceOptionsYaml(text, "bad.yaml", &options);
      ADD_FAILURE() << "no error for: " << text;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(words));
      EXPECT_THAT(e.what(), HasSubstr("bad.yaml"));
    }
  };
  expect_error("tracking: {max_age: 2}\n", "unknown key 'tracking.max_age'");
  expect_error("tracking: {enabled: maybe}\n", "'tracking.enabled' has a value of the wrong type");
  expect_error("tracking: {redetect_every: 1.5}\n",
               "'tracking.redetect_every' has a value of the wrong type");
  expect_error("tracking: on\n", "'tracking' must be a mapping");
  // A value of the right type but out of range parses, and Check() names it.
  ParseServiceOptionsYaml("tracking: {max_age_s: 0}\n", "range.yaml", &options);
  EXPECT_THAT(options.Check(), HasSubstr("TrackerOptions.max_age_s must be > 0 (got 0)"));
}

TEST(LoadServiceOptionsYaml, ReadsAFileAndNamesAMissingOne) {
  const std::string dir = test::TempDir("service_options");
  std::ofstream(dir + "/service.yaml") << "hypotheses: 7\n";
  ServiceOptions options;
  LoadServiceOptionsYaml(dir + "/service.yaml", &options);
  EXPECT_EQ(options.solver.num_hypotheses, 7);
  EXPECT_THROW(LoadServiceOptionsYaml(dir + "/missing.yaml", &options), Error);
}

// Drake / bot_core input and the rigid transform output from YAML (issue 15).
TEST(ParseServiceOptionsYaml, ReadsTheDetectionKeysAndCheckNamesABadOne) {
  ServiceOptions options;
  options.templates_dir = "caches";
  ParseServiceOptionsYaml(
      "detect: {extra_candidates: 3, colour_weight: 0.25, max_score: 0.3, explain_away_passes: 0, "
      "max_planes: 2, support_extent_factor: 2.0, min_confidence: 0.5, rank_uncoloured_by_shape: false, "
      "raised_sigmas: 4.0, raised_outline_edge: 0, island_open_px: -1, area_weight: 0.5, solve_check_flips: true, identity_check_below: 0.7}\n"
      "solver: {check_flips: true}\n",
      "detect.yaml", &options);
  EXPECT_EQ(options.detect.extra_candidates, 3);
  EXPECT_EQ(options.detect.area_weight, 0.5);
  EXPECT_EQ(options.detect.identity_check_below, 0.7);
  EXPECT_TRUE(options.detect.solve_check_flips);
  EXPECT_TRUE(options.solver.check_flips);
  EXPECT_EQ(options.detect.colour_weight, 0.25);
  EXPECT_EQ(options.detect.max_score, 0.3);
  EXPECT_EQ(options.detect.explain_away_passes, 0);
  EXPECT_EQ(options.detect.max_planes, 2);
  EXPECT_EQ(options.detect.support_extent_factor, 2.0);
  EXPECT_EQ(options.detect.raised_sigmas, 4.0);
  EXPECT_EQ(options.detect.raised_outline_edge, 0.0);
  EXPECT_EQ(options.detect.island_open_px, -1);
  EXPECT_EQ(options.detect.min_confidence, 0.5);
  EXPECT_FALSE(options.detect.rank_uncoloured_by_shape);
  EXPECT_EQ(options.Check(), "");
  ParseServiceOptionsYaml("detect: {extra_candidates: -1}\n", "detect.yaml", &options);
  EXPECT_THAT(options.Check(), testing::HasSubstr("extra_candidates"));
  ParseServiceOptionsYaml("detect: {extra_candidates: 2, area_weight: 1.5}\n", "detect.yaml", &options);
  EXPECT_THAT(options.Check(), testing::HasSubstr("area_weight"));
  ParseServiceOptionsYaml("detect: {area_weight: 1, identity_check_below: 2}\n", "detect.yaml", &options);
  EXPECT_THAT(options.Check(), testing::HasSubstr("identity_check_below"));
  EXPECT_THROW(ParseServiceOptionsYaml("detect: {candidates: 3}\n", "detect.yaml", &options), Error);
}

TEST(ParseServiceOptionsYaml, ReadsTheInputAdapterKeys) {
  ServiceOptions options;
  options.templates_dir = "caches";
  ParseServiceOptionsYaml(R"(
input: DRAKE_RGBD
input_type: drake
camera: {fx: 600, fy: 601, cx: 320.5, cy: 240.5, width: 640, height: 480}
labels: {1: obj_000005, 4: obj_000008}
camera_id: head
publish_rigid_transforms: true
rigid_transform_prefix: POSE_
)",
                          "drake.yaml", &options);
  EXPECT_EQ(options.input_type, InputType::kDrake);
  EXPECT_EQ(options.adapter.camera.fx, 600.0);
  EXPECT_EQ(options.adapter.camera.cy, 240.5);
  EXPECT_EQ(options.adapter.camera.width, 640);
  EXPECT_EQ(options.adapter.label_objects,
            (std::map<int32_t, std::string>{{1, "obj_000005"}, {4, "obj_000008"}}));
  EXPECT_EQ(options.adapter.camera_id, "head");
  EXPECT_TRUE(options.publish_rigid_transforms);
  EXPECT_EQ(options.rigid_transform_prefix, "POSE_");
  EXPECT_EQ(options.Check(), "");

  // bot-param's pinhole layout works inline too; a missing label map is named by Check().
  ServiceOptions bot;
  bot.templates_dir = "caches";
  ParseServiceOptionsYaml(
      "input_type: bot_core\ncamera: {pinhole: [600, 601, 0, 320.5, 240.5], width: 640, "
      "height: 480}\n",
      "bot.yaml", &bot);
  EXPECT_EQ(bot.input_type, InputType::kBotCore);
  EXPECT_EQ(bot.adapter.camera.cx, 320.5);
  EXPECT_THAT(bot.Check(), testing::HasSubstr("needs a label map"));
  // ... unless it has objects to find without a mask (a stack with no segmenter).
  ParseServiceOptionsYaml("find: {obj_000005: 2, obj_000008: 1}\n", "find.yaml", &bot);
  EXPECT_EQ(bot.adapter.find_objects, (std::map<std::string, int>{{"obj_000005", 2}, {"obj_000008", 1}}));
  EXPECT_EQ(bot.Check(), "");
  ParseServiceOptionsYaml("find: {obj_000005: 0}\n", "find.yaml", &bot);
  EXPECT_THAT(bot.Check(), testing::HasSubstr("find: object obj_000005 has count 0"));
  EXPECT_THROW(ParseServiceOptionsYaml("find: [obj_000005]\n", "find.yaml", &bot), Error);

  try {
    ParseServiceOptionsYaml("input_type: ros\n", "ros.yaml", &bot);
    ADD_FAILURE() << "input_type ros accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), testing::HasSubstr("ros.yaml: key 'input_type': input type 'ros' is "
                                             "not one of g6d, drake, bot_core"));
  }
}

TEST(ParseServiceOptionsYaml, ReadsTheDebugImageKeysOffByDefault) {
  ServiceOptions options = Valid();
  EXPECT_FALSE(options.debug_images.enabled());
  EXPECT_EQ(options.debug_images.type, DebugImageType::kBotCore);
  ParseServiceOptionsYaml(
      "debug_images: G6D_DEBUG\ndebug_images_hz: 5\ndebug_images_type: "
      "g6d\ndebug_images_jpeg_quality: 60\n",
      "debug.yaml", &options);
  EXPECT_TRUE(options.debug_images.enabled());
  EXPECT_EQ(options.debug_images.channel, "G6D_DEBUG");
  EXPECT_EQ(options.debug_images.max_rate_hz, 5.0);
  EXPECT_EQ(options.debug_images.type, DebugImageType::kG6d);
  EXPECT_EQ(options.debug_images.jpeg_quality, 60);
  EXPECT_EQ(options.Check(), "");

  EXPECT_THROW(
      {
        try {
          ParseServiceOptionsYaml("debug_images_type: png\n", "bad.yaml", &options);
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("debug_images_type"));
          EXPECT_THAT(e.what(), HasSubstr("bot_core or g6d"));
          throw;
        }
      },
      Error);
}

TEST(ServiceOptions, CheckNamesBadDebugImageFields) {
  ServiceOptions options = Valid();
  options.debug_images.channel = "G6D_DEBUG";
  options.debug_images.max_rate_hz = -1.0;
  EXPECT_THAT(options.Check(), HasSubstr("debug_images_hz"));
  options.debug_images.max_rate_hz = 2.0;
  options.debug_images.jpeg_quality = 0;
  EXPECT_THAT(options.Check(), HasSubstr("debug_images_jpeg_quality"));
  options.debug_images.jpeg_quality = 80;
  options.debug_images.channel = options.output_channel;
  EXPECT_THAT(options.Check(), HasSubstr("debug_images channel"));
}

TEST(ParseServiceOptionsYaml, ReadsTheReloadKeysAndCheckNamesABadPeriod) {
  ServiceOptions options = Valid();
  EXPECT_TRUE(options.reload);
  EXPECT_GT(options.reload_scan_period_s, 0.0);
  ParseServiceOptionsYaml("reload: false\nreload_scan_period_s: 0\n", "test.yaml", &options);
  EXPECT_FALSE(options.reload);
  EXPECT_EQ(options.reload_scan_period_s, 0.0);
  EXPECT_EQ(options.Check(), "");  // 0: inotify and SIGHUP only
  options.reload_scan_period_s = -1.0;
  EXPECT_THAT(options.Check(), HasSubstr("reload_scan_period_s"));
  EXPECT_THROW(ParseServiceOptionsYaml("reload: sometimes\n", "test.yaml", &options), Error);
}

}  // namespace
}  // namespace g6d
