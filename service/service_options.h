#pragma once
/// @file service_options.h
/// Everything g6d-service can be told: channels, transport, threads, K, limits and the
/// solver knobs worth changing at run time. Set from a YAML file and/or command-line flags
/// (flags win).

#include <string>

#include "service/debug_images.h"
#include "solver/detect.h"
#include "solver/pipeline.h"
#include "track/tracker.h"
#include "wire/frame_codec.h"
#include "wire/input_adapters.h"

namespace g6d {

/// Options of one g6d-service (one camera).
struct ServiceOptions {
  /// Name reported in service_status_t.service_name; empty = the input channel name.
  std::string name;
  /// Directory holding the template caches (every regular file in it is tried).
  std::string templates_dir;
  std::string input_channel = "G6D_RGBD";     ///< frames in (of input_type)
  std::string output_channel = "G6D_POSES";   ///< g6d_pose_array_t out, one per frame
  std::string status_channel = "G6D_STATUS";  ///< g6d_service_status_t out, every status_period_s
  /// LCM provider URL, e.g. "udpm://239.255.76.67:7667?ttl=1&recv_buf_size=8388608";
  /// empty = LCM's default ($LCM_DEFAULT_URL, else udpm://239.255.76.67:7667?ttl=0).
  std::string lcm_url;
  /// Total solver parallelism: the scheduler thread plus workers - 1 pool threads. Both
  /// the instances of a frame and the hypotheses of each instance fan out over them.
  int workers = 2;
  /// Frames whose capture utime is more than this older than the wall clock on arrival
  /// (or when the scheduler takes them) are dropped and counted as stale, milliseconds;
  /// 0 = no age limit (e.g. for replayed logs with old timestamps).
  double max_age_ms = 0.0;
  /// LCM's per-subscription queue capacity for the input channel, messages: about one
  /// second at 30 Hz. LCM drops a message silently (counted nowhere) when its subscription
  /// queue is full, which happened with a capacity of 2 when decoding on a loaded machine
  /// took longer than two frame periods (soak benchmark). Freshness is the mailbox's job:
  /// it keeps only the latest decoded frame and counts the ones it replaces.
  int subscription_queue = 30;
  double status_period_s = 1.0;  ///< period of service_status_t, seconds
  int latency_window = 300;      ///< frames in the latency p50/p95 of the status
  /// On SIGINT/SIGTERM, how long to let the solver calls in flight finish before the
  /// process exits without joining them, seconds (a solver call cannot be interrupted;
  /// instances not yet started are abandoned at once).
  double shutdown_timeout_s = 1.5;
  DecodeLimits limits;  ///< bounds on declared image sizes and instance counts
  /// Message type of the input channel: g6d (g6d.rgbd_frame_t), drake
  /// (drake.lcmt_image_array) or bot_core (bot_core.images_t); wire/input_adapters.h.
  InputType input_type = InputType::kG6d;
  /// Intrinsics, label map and camera id of a drake / bot_core input (unused for g6d).
  AdapterOptions adapter;
  /// Also publish every OK estimate's cam_from_object as bot_core.rigid_transform_t on
  /// rigid_transform_prefix + object id (e.g. G6D_POSE_obj_000005).
  bool publish_rigid_transforms = false;
  std::string rigid_transform_prefix = "G6D_POSE_";  ///< channel prefix of those transforms
  /// Debug pictures (--debug-images CHANNEL): the frame with each answer drawn on it,
  /// JPEG, at most debug_images.max_rate_hz; off (no channel) by default.
  DebugImageOptions debug_images;
  /// Load caches added to, changed in or removed from templates_dir while running
  /// (README, "Adding objects while it runs"): inotify, a rescan every
  /// reload_scan_period_s, and SIGHUP. Off: the caches loaded at start are served until
  /// the end.
  bool reload = true;
  /// Period of the fallback rescan of templates_dir, seconds (events can be lost, e.g. on
  /// a network file system); 0 = inotify events and SIGHUP only.
  double reload_scan_period_s = 2.0;
  /// Solver options; `solver.num_hypotheses` is K (--hypotheses). The solver's own
  /// defaults, K = 18 included: since issue 13 a K = 18 solve costs less than K = 4 did
  /// before (README, "The service"), so the service no longer trades accuracy for speed by
  /// default; --hypotheses and --budget-ms bound the time per instance where needed.
  SolverOptions solver;
  /// Detection requests (instances with neither mask nor box): the proposals, their ranking
  /// and the acceptance of DetectObjects (solver/detect.h); its solves use `solver`.
  DetectOptions detect;
  /// Tracking (README, "Tracking"): on by default; `tracking.enabled` false (--tracking
  /// off) answers every instance with the full solver, exactly as without a tracker.
  /// Periodic re-detections run in the background by default (a thread of their own at a
  /// lower priority, BackgroundDetector): the frame is answered by tracking at once.
  TrackerOptions tracking = [] {
    TrackerOptions tracking;
    tracking.background_redetect = true;
    return tracking;
  }();

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Reads a YAML options file into `options` (keys not in the file keep their values).
/// Keys: name, templates, input, output, status, lcm_url, workers, hypotheses, max_age_ms,
/// input_type (g6d|drake|bot_core), camera (a mapping as in a camera YAML, see
/// ParseCameraYaml) or camera_file, labels (label value -> object id) or label_map_file,
/// camera_id, publish_rigid_transforms, rigid_transform_prefix, debug_images (a channel),
/// debug_images_hz, debug_images_type (bot_core|g6d), debug_images_jpeg_quality,
/// subscription_queue, status_period_s, latency_window, shutdown_timeout_s, reload,
/// reload_scan_period_s,
/// limits: {max_width, max_height, max_raw_bytes, max_instances},
/// solver: {max_sets, hamming_threshold, min_correspondences, query_features, run_icp,
/// run_mhpo, mhpo_max_rounds, early_stop_score, reject_border_masks,
/// min_valid_depth_pixels},
/// tracking: {enabled, max_age_s, min_overlap, loss_score, min_iou, appearance_drop, redetect_every,
/// max_periodic_per_frame, constant_velocity, background_redetect}. Throws g6d::Error naming the file and key on an
/// unknown key, a value of the wrong type or a file that does not parse.
void LoadServiceOptionsYaml(const std::string& path, ServiceOptions* options);

/// The same from YAML text (`name` is used in error messages).
void ParseServiceOptionsYaml(const std::string& text, const std::string& name,
                             ServiceOptions* options);

}  // namespace g6d
