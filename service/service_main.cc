// g6d-service: the LCM pose service for one camera.
//
//   g6d-service --templates DIR [--input G6D_RGBD] [--output G6D_POSES] [--status G6D_STATUS]
//               [--lcm-url URL] [--workers N] [--hypotheses K] [--max-age-ms MS]
//               [--tracking on|off] [--track-* ...] [--reload on|off] [--config FILE.yaml]
//
// Options come from the YAML file first, then from the flags given on the command line.
// Caches added to, changed in or removed from --templates are loaded while it runs
// (--reload on, the default); SIGHUP rescans the folder at once.
// SIGINT/SIGTERM stop it: no new frames, the current one finishes or is abandoned within
// shutdown_timeout_s, every thread joins, exit code 0.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <condition_variable>
#include <csignal>
#include <cstdlib>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "service/service.h"
#include "service/service_options.h"
#include "service/template_store.h"

namespace {

// Runs `stop` and waits for it at most `timeout_s`; past that the process exits with 0
// without joining the solver calls still running (they cannot be interrupted).
void StopWithin(double timeout_s, const std::function<void()>& stop) {
  std::mutex mutex;
  std::condition_variable done_changed;
  bool done = false;
  std::thread watchdog([&] {
    std::unique_lock<std::mutex> lock(mutex);
    const auto timeout = std::chrono::duration<double>(timeout_s);
    if (!done_changed.wait_for(lock, timeout, [&] { return done; })) {
      spdlog::error(
          "shutdown: solver calls still running after {} s; exiting without waiting for them",
          timeout_s);
      spdlog::default_logger()->flush();
      std::_Exit(0);
    }
  });
  stop();
  {
    std::lock_guard<std::mutex> lock(mutex);
    done = true;
  }
  done_changed.notify_all();
  watchdog.join();
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("g6d-service"));
  spdlog::set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%n] [%l] %v");

  g6d::ServiceOptions defaults;
  CLI::App app(
      "g6d-service: 6D object poses for g6d_rgbd_frame_t over LCM (one service per camera)");
  std::string config_path;
  g6d::ServiceOptions flags = defaults;
  int hypotheses = defaults.solver.num_hypotheses;
  app.add_option("--config", config_path, "YAML options file (flags given here override it)")
      ->check(CLI::ExistingFile);
  auto* templates = app.add_option("--templates", flags.templates_dir,
                                   "directory of template caches (.g6dcache)");
  auto* input = app.add_option("--input", flags.input_channel, "input channel (messages of --input-type)")
                    ->capture_default_str();
  auto* output =
      app.add_option("--output", flags.output_channel, "answer channel (g6d_pose_array_t)")
          ->capture_default_str();
  auto* status =
      app.add_option("--status", flags.status_channel, "status channel (g6d_service_status_t)")
          ->capture_default_str();
  auto* url = app.add_option("--lcm-url", flags.lcm_url,
                             "LCM URL (default: $LCM_DEFAULT_URL or LCM's default)");
  auto* workers =
      app.add_option("--workers", flags.workers, "solver threads in total")->capture_default_str();
  auto* k = app.add_option("--hypotheses", hypotheses, "K = N_H, hypotheses refined per instance")
                ->capture_default_str();
  std::string mask_trust = g6d::MaskTrustName(defaults.solver.mask_trust);
  auto* trust = app.add_option("--mask-trust", mask_trust,
                               "how instance masks are read: depth (evidence checked by the depth) or exact "
                               "(the paper's: every mask pixel is object)")
                    ->check(CLI::IsMember({"depth", "exact"}))
                    ->capture_default_str();
  auto* max_age =
      app.add_option("--max-age-ms", flags.max_age_ms, "drop frames older than this (0 = never)")
          ->capture_default_str();
  auto* budget = app.add_option("--budget-ms", flags.solver.budget_ms,
                                "time budget of one instance's solve; when it runs out the best "
                                "pose so far is answered, marked cut_short (0 = none)")
                     ->capture_default_str();
  auto* name = app.add_option("--name", flags.name,
                              "service name in the status (default: the input channel)");
  auto* queue = app.add_option("--subscription-queue", flags.subscription_queue,
                               "LCM queue capacity of the input channel")
                    ->capture_default_str();
  auto* shutdown = app.add_option("--shutdown-timeout-s", flags.shutdown_timeout_s,
                                  "bound on the shutdown wait for running solver calls")
                       ->capture_default_str();
  std::string input_type = "g6d", camera_file, label_map_file;
  auto* input_type_option =
      app.add_option("--input-type", input_type,
                     "message type of --input: g6d (g6d_rgbd_frame_t), drake "
                     "(drake.lcmt_image_array) or bot_core (bot_core.images_t)")
          ->capture_default_str();
  auto* camera_option = app.add_option(
      "--camera", camera_file,
      "camera YAML for drake/bot_core input: fx fy cx cy width height (or bot-param pinhole)");
  auto* label_map_option = app.add_option(
      "--label-map", label_map_file,
      "label map YAML for drake/bot_core input: labels: {<label value>: <object id>}");
  std::vector<std::string> find_specs;
  auto* find_option = app.add_option(
      "--find", find_specs,
      "drake/bot_core input: find this object in every frame without a mask, OBJ or OBJ:COUNT "
      "(repeatable; the label image may then be absent)");
  auto* rigid = app.add_flag("--publish-rigid-transforms", flags.publish_rigid_transforms,
                             "also publish each OK pose as bot_core.rigid_transform_t on "
                             "<prefix><object id>");
  auto* rigid_prefix =
      app.add_option("--rigid-transform-prefix", flags.rigid_transform_prefix,
                     "channel prefix of those transforms")
          ->capture_default_str();
  auto* debug_images =
      app.add_option("--debug-images", flags.debug_images.channel,
                     "publish the frame with each answer drawn on it (model contour, axes, "
                     "S_A, confidence, mode; failures in red), JPEG, on this channel (off when "
                     "not given)");
  auto* debug_images_hz =
      app.add_option("--debug-images-hz", flags.debug_images.max_rate_hz,
                     "at most this many debug images per second (skipped frames are counted)")
          ->capture_default_str();
  std::string debug_images_type = g6d::DebugImageTypeName(defaults.debug_images.type);
  auto* debug_images_type_option =
      app.add_option(
             "--debug-images-type", debug_images_type,
             "message type of the debug images: bot_core (bot_core.image_t, MJPEG: bot viewers, "
             "Director) or g6d (g6d.image_t, JPEG)")
          ->check(CLI::IsMember({"bot_core", "g6d"}))
          ->capture_default_str();
  auto* debug_images_quality =
      app.add_option("--debug-images-quality", flags.debug_images.jpeg_quality,
                     "JPEG quality of the debug images, 1..100")
          ->capture_default_str();
  // Tracking (TrackerOptions). The switches take on|off, so that a YAML "tracking:
  // {enabled: false}" can be turned back on from the command line.
  std::string tracking_switch = "on", velocity_switch = "on", background_switch = "on";
  auto* tracking = app.add_option("--tracking", tracking_switch,
                                  "on|off: solve an instance that continues a track from its "
                                  "last pose (off: every instance gets the full solver)")
                       ->check(CLI::IsMember({"on", "off"}))
                       ->capture_default_str();
  auto* track_max_age = app.add_option("--track-max-age-s", flags.tracking.max_age_s,
                                       "a track without an answer for longer than this (frame "
                                       "time, seconds) is dropped")
                            ->capture_default_str();
  auto* track_min_overlap =
      app.add_option("--track-min-overlap", flags.tracking.min_overlap,
                     "an instance continues a track when its mask overlaps the track's predicted "
                     "silhouette by at least this (|M and P| / min(|M|, |P|))")
          ->capture_default_str();
  auto* track_loss_score = app.add_option("--track-loss-score", flags.tracking.loss_score,
                                          "a tracked pose with S_A above this is lost (the full "
                                          "solver runs in the same frame)")
                               ->capture_default_str();
  auto* track_min_iou = app.add_option("--track-min-iou", flags.tracking.min_iou,
                                       "... or with a silhouette/mask IoU below this")
                            ->capture_default_str();
  auto* track_appearance_drop =
      app.add_option("--track-appearance-drop", flags.tracking.appearance_drop,
                     "... or, for a coloured mesh (not a surface of revolution), with an appearance "
                     "agreement lower than the last answer's by more than this (<= 0: off)")
          ->capture_default_str();
  auto* redetect_every = app.add_option("--redetect-every", flags.tracking.redetect_every,
                                        "re-detect a track after this many tracked answers "
                                        "(0 = never)")
                             ->capture_default_str();
  auto* redetect_per_frame =
      app.add_option("--redetect-per-frame", flags.tracking.max_periodic_per_frame,
                     "periodic re-detections in one frame at most")
          ->capture_default_str();
  auto* track_velocity =
      app.add_option("--track-constant-velocity", velocity_switch,
                     "on|off: start from the constant-velocity prediction as well")
          ->check(CLI::IsMember({"on", "off"}))
          ->capture_default_str();
  auto* redetect_background =
      app.add_option("--redetect-background", background_switch,
                     "on|off: periodic re-detections on a thread of their own while tracking "
                     "answers the frame (off: in the frame)")
          ->check(CLI::IsMember({"on", "off"}))
          ->capture_default_str();
  std::string reload_switch = "on";
  auto* reload = app.add_option("--reload", reload_switch,
                                "on|off: load caches added to, changed in or removed from --templates "
                                "while running (inotify, a periodic rescan, SIGHUP)")
                     ->check(CLI::IsMember({"on", "off"}))
                     ->capture_default_str();
  auto* reload_period = app.add_option("--reload-scan-period-s", flags.reload_scan_period_s,
                                       "period of the fallback rescan of --templates, seconds (0 = "
                                       "inotify and SIGHUP only)")
                            ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  g6d::ServiceOptions options = defaults;
  try {
    if (!config_path.empty()) g6d::LoadServiceOptionsYaml(config_path, &options);
  } catch (const g6d::Error& e) {
    spdlog::critical("{}", e.what());
    return 2;
  }
  // Flags given on the command line win over the file.
  auto given = [](CLI::Option* option) { return option->count() > 0; };
  if (given(templates)) options.templates_dir = flags.templates_dir;
  if (given(input)) options.input_channel = flags.input_channel;
  if (given(output)) options.output_channel = flags.output_channel;
  if (given(status)) options.status_channel = flags.status_channel;
  if (given(url)) options.lcm_url = flags.lcm_url;
  if (given(workers)) options.workers = flags.workers;
  if (given(k)) options.solver.num_hypotheses = hypotheses;
  if (given(trust)) options.solver.mask_trust = g6d::ParseMaskTrust(mask_trust);
  if (given(max_age)) options.max_age_ms = flags.max_age_ms;
  if (given(budget)) options.solver.budget_ms = flags.solver.budget_ms;
  if (given(name)) options.name = flags.name;
  if (given(queue)) options.subscription_queue = flags.subscription_queue;
  if (given(shutdown)) options.shutdown_timeout_s = flags.shutdown_timeout_s;
  if (given(rigid)) options.publish_rigid_transforms = flags.publish_rigid_transforms;
  if (given(rigid_prefix)) options.rigid_transform_prefix = flags.rigid_transform_prefix;
  if (given(debug_images)) options.debug_images.channel = flags.debug_images.channel;
  if (given(debug_images_hz)) options.debug_images.max_rate_hz = flags.debug_images.max_rate_hz;
  if (given(debug_images_type_option))
    options.debug_images.type = g6d::ParseDebugImageType(debug_images_type);
  if (given(debug_images_quality))
    options.debug_images.jpeg_quality = flags.debug_images.jpeg_quality;
  if (given(tracking)) options.tracking.enabled = tracking_switch == "on";
  if (given(track_max_age)) options.tracking.max_age_s = flags.tracking.max_age_s;
  if (given(track_min_overlap)) options.tracking.min_overlap = flags.tracking.min_overlap;
  if (given(track_loss_score)) options.tracking.loss_score = flags.tracking.loss_score;
  if (given(track_min_iou)) options.tracking.min_iou = flags.tracking.min_iou;
  if (given(track_appearance_drop)) options.tracking.appearance_drop = flags.tracking.appearance_drop;
  if (given(redetect_every)) options.tracking.redetect_every = flags.tracking.redetect_every;
  if (given(redetect_per_frame))
    options.tracking.max_periodic_per_frame = flags.tracking.max_periodic_per_frame;
  if (given(track_velocity)) options.tracking.constant_velocity = velocity_switch == "on";
  if (given(redetect_background)) options.tracking.background_redetect = background_switch == "on";
  if (given(reload)) options.reload = reload_switch == "on";
  if (given(reload_period)) options.reload_scan_period_s = flags.reload_scan_period_s;
  try {
    if (given(input_type_option)) options.input_type = g6d::ParseInputType(input_type);
    if (given(camera_option)) options.adapter.camera = g6d::LoadCameraYaml(camera_file);
    if (given(label_map_option)) options.adapter.label_objects = g6d::LoadLabelMapYaml(label_map_file);
    if (given(find_option)) {
      options.adapter.find_objects.clear();
      for (const std::string& spec : find_specs) {
        const size_t colon = spec.rfind(':');
        const std::string id = colon == std::string::npos ? spec : spec.substr(0, colon);
        int count = 1;
        if (colon != std::string::npos) {
          try {
            size_t used = 0;
            count = std::stoi(spec.substr(colon + 1), &used);
            if (used != spec.size() - colon - 1) throw std::invalid_argument("trailing characters");
          } catch (const std::exception&) {
            G6D_THROW("--find " << spec << ": the count after ':' must be a whole number");
          }
        }
        options.adapter.find_objects[id] = count;
      }
    }
  } catch (const g6d::Error& e) {
    spdlog::critical("{}", e.what());
    return 2;
  }
  if (const std::string error = options.Check(); !error.empty()) {
    spdlog::critical("bad options: {}", error);
    return 2;
  }

  // SIGINT/SIGTERM (stop) and SIGHUP (rescan the caches) are blocked in every thread
  // (threads inherit the mask) and taken by sigwait() below: no handler runs in an
  // arbitrary thread.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  g6d::TemplateStore store;
  try {
    store = g6d::LoadTemplateStore(options.templates_dir);
  } catch (const g6d::Error& e) {
    spdlog::critical("{}", e.what());
    return 2;
  }
  for (const g6d::LoadedCache& cache : store.loaded) {
    spdlog::info("loaded '{}' from {} ({} templates, diameter {:.1f} mm, hash {})", cache.object_id,
                 cache.path, cache.num_templates, cache.diameter_m * 1e3, cache.hash);
  }
  for (const g6d::RefusedCache& cache : store.refused) {
    spdlog::warn("refused {}: {}", cache.path, cache.reason);
  }
  if (store.banks.empty()) {
    spdlog::warn(
        "no template cache loaded from '{}': every instance will be answered UNKNOWN_OBJECT{}",
        options.templates_dir, options.reload ? " until a cache is added there" : "");
  }

  lcm::LCM lcm(options.lcm_url);
  if (!lcm.good()) {
    spdlog::critical("cannot open LCM at '{}'",
                     options.lcm_url.empty() ? "<default>" : options.lcm_url);
    return 2;
  }
  try {
    g6d::Service service(options, std::move(store), &lcm);
    service.Start();
    int signal_number = 0;
    while (sigwait(&signals, &signal_number) == 0 && signal_number == SIGHUP) service.ReloadCaches();
    spdlog::info("{}: stopping", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
    StopWithin(options.shutdown_timeout_s, [&] { service.Stop(); });
  } catch (const std::exception& e) {
    spdlog::critical("{}", e.what());
    return 1;
  }
  return 0;
}
