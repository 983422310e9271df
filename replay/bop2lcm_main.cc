// g6d-bop2lcm: one scene of a BOP dataset -> a standard LCM event log of g6d_rgbd_frame_t
// (one event per image) for g6d-replay or lcm-logplayer.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "bop_to_lcm.h"
#include "foreign_log.h"
#include "core/error.h"

int main(int argc, char** argv) {
  CLI::App app{
      "g6d-bop2lcm: a BOP scene (rgb/, depth/, mask_visib/, scene_gt.json, scene_camera.json) "
      "-> an LCM log of g6d_rgbd_frame_t, one event per image"};
  std::string dataset_dir, frames_text, targets_file, color = "png", out, as = "g6d";
  std::string instances = "label", identity = "given";
  int scene_id = -1;
  bool all_instances = false;
  g6d::BopToLcmOptions options;
  app.add_option("--dataset", dataset_dir, "BOP dataset folder (models/, test/, ...)")->required();
  app.add_option("--scene", scene_id, "scene id (the <split>/NNNNNN folder)")->required();
  app.add_option("--frames", frames_text, "image ids to include, e.g. 8,10-20 (default: all)");
  app.add_option("--targets", targets_file,
                 "BOP'19 targets json: only its images and objects (default: "
                 "<dataset>/test_targets_bop19.json when present)");
  app.add_flag("--all-instances", all_instances,
               "ignore any targets file: every image, every GT instance");
  app.add_option("--channel", options.channel, "LCM channel of the events")->capture_default_str();
  app.add_option("--color", color, "colour storage: jpeg, png, zstd or raw")->capture_default_str();
  app.add_option("--fps", options.fps, "event rate of the log timestamps, Hz")
      ->capture_default_str();
  app.add_option("--start-utime", options.start_utime, "timestamp of the first event, microseconds")
      ->capture_default_str();
  app.add_option("--camera-id", options.camera_id, "camera_id of the frames")
      ->capture_default_str();
  app.add_option("--split", options.split, "split folder holding the scenes")
      ->capture_default_str();
  app.add_option("--out", out, "LCM log file to write (overwritten)")->required();
  app.add_option("--as", as,
                 "message type: g6d (g6d_rgbd_frame_t), drake (lcmt_image_array) or bot_core "
                 "(images_t; MJPEG colour with --color jpeg, else raw RGB). Also writes "
                 "<out>.yaml, the g6d-service options for the log, and for drake/bot_core "
                 "<out>.ids.csv, the frames' scene/image ids for g6d-replay")
      ->capture_default_str();
  app.add_option("--instances", instances,
                 "where each instance is: label (its GT visible mask in the label image) or box "
                 "(only the bounding box of that mask grown by --box-margin-px and clipped to the "
                 "image, no label image: g6d-bench-dataset --degrade-masks box's masks) or none "
                 "(one detection request per object, no mask and no box, count = its target "
                 "instances: the service finds them itself; needs --identity given)")
      ->capture_default_str();
  app.add_option("--box-margin-px", options.box_margin_px,
                 "--instances box: margin around the mask's bounding box, pixels (as "
                 "g6d-bench-dataset --degrade-px)")
      ->capture_default_str();
  app.add_option("--identity", identity,
                 "given (object ids in the frames) or unknown (object ids left empty: the service "
                 "chooses among every loaded object)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  try {
    options.color = g6d::ParseColorEncoding(color);
    if (!frames_text.empty()) options.frames = g6d::ParseFrameList(frames_text);
    options.targets_file = targets_file;
    options.use_targets = !all_instances;
    options.instances = g6d::ParseInstanceInput(instances);
    options.identity = g6d::ParseIdentityInput(identity);
    const g6d::InputType type = g6d::ParseInputType(as);
    if (type != g6d::InputType::kG6d && (options.instances != g6d::InstanceInput::kLabel ||
                                         options.identity != g6d::IdentityInput::kGiven)) {
      G6D_THROW("--instances box or none and --identity unknown need --as g6d (" << as
                                                                       << " frames carry only a label image "
                                                                          "and a label -> object map)");
    }
    // Foreign types: the g6d log first, then rewritten message by message.
    const std::string g6d_log = type == g6d::InputType::kG6d ? out : out + ".g6d.tmp";
    const g6d::BopToLcmReport report =
        g6d::WriteBopSceneLog(options, dataset_dir, scene_id, g6d_log);
    g6d::ForeignLogReport foreign;
    if (type != g6d::InputType::kG6d) {
      g6d::ForeignLogOptions foreign_options;
      foreign_options.type = type;
      foreign_options.bot_core_mjpeg = options.color == g6d::ColorEncoding::kJpeg;
      foreign_options.jpeg_quality = options.encode.jpeg_quality;
      foreign = g6d::ConvertFrameLog(g6d_log, options.channel, foreign_options, out);
      std::filesystem::remove(g6d_log);
      g6d::WriteForeignFrameIds(out + ".ids.csv", foreign.ids);
      if (foreign.dropped_instances > 0) {
        std::fprintf(stderr,
                     "g6d-bop2lcm: warning: %d instance(s) dropped: %s labels name objects, and "
                     "their object was already in the frame\n",
                     foreign.dropped_instances, as.c_str());
      }
    }
    {
      std::ofstream yaml(out + ".yaml");
      yaml << g6d::ServiceOptionsYamlFor(options.channel, type, foreign);
      if (!yaml) G6D_THROW("cannot write " << out << ".yaml");
    }
    if (report.missing_instances > 0) {
      std::fprintf(stderr,
                   "g6d-bop2lcm: warning: %d target instance(s) have no GT entry of their object\n",
                   report.missing_instances);
    }
    if (report.overlap_pixels > 0) {
      std::fprintf(
          stderr,
          "g6d-bop2lcm: warning: %lld mask_visib pixel(s) belong to two instances; the later "
          "instance keeps them\n",
          static_cast<long long>(report.overlap_pixels));
    }
    if (report.empty_masks > 0) {
      std::fprintf(stderr,
                   "g6d-bop2lcm: warning: %d instance(s) left out: no visible pixel, so no box\n",
                   report.empty_masks);
    }
    if (!report.success) {
      std::fprintf(stderr, "g6d-bop2lcm: %s\n", report.message.c_str());
      return 1;
    }
    const std::string selection =
        report.targets_file.empty() ? "all GT instances" : "targets of " + report.targets_file;
    std::printf(
        "g6d-bop2lcm: %s scene %d: %d of %d images, %d instances (%s, identity %s) -> %s (%.1f "
        "MB, %s colour, channel %s, as %s; service options %s.yaml) in %.1f s; %s\n",
        report.source.c_str(), scene_id, report.frames_written, report.images_in_scene,
        report.instances_written, instances == "box" ? "boxes" : instances == "none" ? "detection requests" : "labels", identity.c_str(),
        out.c_str(),
        static_cast<double>(std::filesystem::file_size(out)) / 1e6, color.c_str(),
        options.channel.c_str(), as.c_str(), out.c_str(), report.seconds, selection.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-bop2lcm: error: %s\n", e.what());
    return 2;
  }
}
