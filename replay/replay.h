#pragma once
/// @file replay.h
/// Feeding the frames of an LCM log to a running g6d-service and collecting its answers.
///
/// Frames go out on the frame channel with `utime` re-stamped to the send time (so a
/// service with a maximum frame age accepts them); everything else is sent as recorded.
/// An answer (g6d_pose_array_t on the results channel) belongs to a sent frame when its
/// `source` and `seq` match and its `source_utime` equals the stamp that frame was sent
/// with, so a late answer to an earlier replay of the same log is never mistaken for one
/// of this run. Answers are collected by one LCM handle thread; senders wait on a
/// condition variable, never by polling.

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/stats.h"
#include "eval/bop_csv.h"
#include "g6d/pose_array_t.hpp"
#include "g6d/rgbd_frame_t.hpp"
#include "g6d/service_status_t.hpp"
#include "wire/input_adapters.h"
#include "wire/names.h"  // EstimateStatusName() names the statuses in reports

namespace lcm {
class LCM;
}

namespace g6d {

class FrameLogReader;
struct FrameLogStats;

/// When the next frame goes out.
enum class ReplayMode {
  kWait,      ///< after the answer to the previous frame (or its timeout): deterministic
  kRealtime,  ///< at the recorded log timestamps
  kRate,      ///< at a fixed rate (ReplayOptions::rate_hz)
};

/// Options of RunReplay().
struct ReplayOptions {
  std::string channel = "G6D_RGBD";           ///< frame channel (in the log and on the bus)
  std::string results_channel = "G6D_POSES";  ///< channel of the service's answers
  ReplayMode mode = ReplayMode::kWait;
  double rate_hz = 10.0;  ///< send rate of ReplayMode::kRate, Hz
  /// How long to wait for the answer to a frame after sending it, milliseconds. In wait
  /// mode the next frame goes out after this; in the timed modes it bounds the final wait.
  int timeout_ms = 30000;
  /// Message type of the log's frames: g6d frames are re-stamped and matched by source,
  /// seq and utime; drake / bot_core messages are sent as logged and matched by utime.
  InputType input_type = InputType::kG6d;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Parses "wait", "realtime" or "rate:HZ" into options->mode (and options->rate_hz).
/// Throws g6d::Error naming the text when it is none of these or HZ is not a positive number.
void ParseReplayMode(const std::string& text, ReplayOptions* options);

/// "wait", "realtime" or "rate:<hz>".
std::string ReplayModeName(const ReplayOptions& options);

/// What happened to one sent frame.
struct ReplayedFrame {
  int64_t seq = 0;
  std::string source;
  int32_t scene_id = -1;
  int32_t image_id = -1;
  int32_t instances = 0;   ///< instances requested
  int64_t sent_utime = 0;  ///< utime stamped into the sent frame, microseconds
  bool answered = false;   ///< an answer arrived before the end of the run
  bool timed_out = false;  ///< no answer within timeout_ms of sending (late or lost)
  double latency_s = 0.0;  ///< send -> answer received, seconds (when answered)
  pose_array_t answer;     ///< the answer (when answered)
};

/// Counts and percentiles of a replay run.
struct ReplayReport {
  bool success = false;
  std::string message = "not run";
  int64_t sent = 0;               ///< frames published
  int64_t answered = 0;           ///< frames with an answer
  int64_t lost = 0;               ///< frames never answered
  int64_t timed_out = 0;          ///< frames not answered within the timeout (lost or late)
  int64_t late = 0;               ///< frames answered, but after the timeout
  int64_t rejected = 0;           ///< answers with frame status BAD_FRAME
  int64_t unmatched_answers = 0;  ///< answers on the results channel for no frame of this run
  int64_t duplicate_answers = 0;  ///< second answers to an already answered frame
  int64_t estimates = 0;          ///< estimates in the answers
  /// Estimates per status name ("ok", "no_solution", "bad_input", "unknown_object",
  /// "internal_error", "unknown(<code>)").
  std::map<std::string, int64_t> estimates_by_status;
  /// OK estimates per mode name ("detected", "tracked", "redetected"; EstimateModeName).
  std::map<std::string, int64_t> estimates_by_mode;
  double latency_p50_s = 0.0;  ///< round trip send -> answer, over answered frames
  double latency_p95_s = 0.0;
  double latency_max_s = 0.0;
  double service_p50_s = 0.0;  ///< the service's own end-to-end total_s over answers
  double service_p95_s = 0.0;
  double service_max_s = 0.0;
  double wall_s = 0.0;                ///< whole run
  std::vector<ReplayedFrame> frames;  ///< in send order
};

/// Called after every frame is settled (answered or timed out) in wait mode, and after
/// each send and each answer in the timed modes; `done` frames of `total` (total may be 0
/// when unknown).
struct ReplayProgress {
  int64_t sent = 0;
  int64_t answered = 0;
  int64_t timed_out = 0;
  int64_t total = 0;
  const ReplayedFrame* last = nullptr;  ///< the frame this update is about, or null
};
using ReplayProgressCallback = std::function<void(const ReplayProgress&)>;

/// Publishes every frame of `reader` on `lcm` and collects the answers. Starts (and joins
/// before returning) one thread that handles `lcm`; the caller must not handle `lcm`
/// itself meanwhile, but may have subscribed its own handlers (they run on that thread).
/// `total_frames` (0 if unknown) is only for progress. Throws g6d::Error on bad options
/// or when publishing fails; a silent service is a report with lost frames, not an error.
/// success is true when every sent frame was answered.
ReplayReport RunReplay(const ReplayOptions& options, FrameLogReader* reader, lcm::LCM* lcm,
                       int64_t total_frames = 0, const ReplayProgressCallback& progress = {});

/// Waits until a g6d_service_status_t arrives on `status_channel` from a service whose
/// input channel is `input_channel` (any service when empty), at most `timeout_ms`; then
/// *status (optional) holds it. False on timeout. Runs its own handle thread on `lcm` for
/// the wait, like RunReplay(). Use it before a replay so the first frame does not go out
/// before the service listens.
bool WaitForService(lcm::LCM* lcm, const std::string& status_channel,
                    const std::string& input_channel, int timeout_ms,
                    service_status_t* status = nullptr);

/// Writes the answers of the answered frames, in send order, as an LCM event log (the
/// lcm-logger format, readable by lcm-logplayer and examples/print_poses.py): one event
/// per answer on `channel`, timestamped with the answer's publication utime. Throws
/// g6d::Error when the file cannot be written.
void WriteAnswersLog(const std::string& path, const std::string& channel,
                     const std::vector<ReplayedFrame>& frames);

/// The BOP results rows of the answered frames: one row per estimate with status OK and a
/// BOP object id ("obj_000005" -> 5), scene_id and im_id from the answer, score = the
/// confidence (BOP's greedy matching prefers high scores; S_A is lower-is-better and not
/// comparable across objects), R from the quaternion, t = position, time = the answer's
/// total_s (the same for all estimates of an image). `skipped_ids` (optional) receives the
/// number of OK estimates whose object id is not a BOP stem.
std::vector<BopEstimate> AnswersToBopEstimates(const std::vector<ReplayedFrame>& frames,
                                               int64_t* skipped_ids = nullptr);

/// The summary of a run as pretty-printed JSON: the log's counts (events, frames, foreign
/// and undecodable events, truncation), the options, sent / answered / lost / timed_out /
/// late / rejected frames, estimates ok and failed by status, ok estimates by mode
/// (by_mode: detected / tracked / redetected), latency_s and
/// service_total_s percentiles (p50, p95, max), the verdict, and one entry per sent frame
/// (ids, answered, latency_s, service_total_s, and per estimate object_id, gt_index,
/// status, mode, track_id, solve_time_s, and the message of a failure) so runs can be
/// merged exactly.
std::string ReplaySummaryJson(const ReplayOptions& options, const FrameLogStats& log,
                              const ReplayReport& report);

/// Every estimate of the answered frames as JSON lines (one object per line, in send
/// order), for per-instance analysis: scene_id, image_id, seq, source, object_id, label,
/// gt_index, status (EstimateStatusName), message, score (S_A, lower is better),
/// confidence, iou, depth_residual, truncated, ambiguous (booleans), runner_up_score (S of
/// the runner-up; null without one), appearance_agreement (ZNCC in [-1, 1]; null when not
/// valid), hypotheses, solve_time_s, mode ("detected", "tracked", "redetected"), track_id
/// (-1: no track), frames_since_detection, mask_iou (the answer's mask vs the request's),
/// identity_searched (the request had no object id; object_id is then the chosen one),
/// runner_up_object_id and runner_up_object_score (the runner-up identity and its S; null
/// without one), candidates_tried, request_index (the instance it answers),
/// found_without_mask, region_box ([x, y, width, height] px) and region_pixels (the region
/// a detection request's answer was solved on; zeros otherwise), position (m) and orientation (w, x, y, z) of
/// cam_from_object, and the frame's latency_s and service total_s. Failed estimates are
/// included; frames rejected as a whole or never answered give no line.
std::string EstimatesJsonLines(const std::vector<ReplayedFrame>& frames);

}  // namespace g6d
