#pragma once
/// @file tracker.h
/// Tracking (issue 14): per camera, a track per object instance keeps its last answer; an
/// instance of a new frame that continues a track is solved from the track's (predicted)
/// pose with a few ICP + MHPO iterations (TrackPose, track_pose.h) instead of the whole pipeline, and S_A
/// decides when that is not good enough and the full solver runs in the same frame.
///
/// The Tracker holds the state and makes the decisions; it runs no threads. One frame is
/// three calls, so that the caller can solve the instances in parallel:
///
///   std::vector<TrackPlan> plans = tracker.Plan(time_s, instances, banks);   // sequential
///   answers[i] = SolveWithPlan(frame, instances[i], bank, solver, tracker.options(),
///                              plans[i], executor);                          // any thread
///   tracker.Update(time_s, plans, answers);                                  // sequential
///
/// The service (one Tracker per service, i.e. per camera) and g6d-bench-dataset's tracking
/// mode run this same code. With TrackerOptions::enabled false every plan is a detection and
/// the answers are EstimatePose's, bit for bit.

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/executor.h"
#include "core/frame.h"
#include "solver/pipeline.h"
#include "templates/template_bank.h"

namespace g6d {

/// How an answer was made (pose_estimate_t::mode on the wire).
enum class AnswerMode {
  kDetected = 0,    ///< the full solver, for an instance that continued no track
  kTracked = 1,     ///< TrackPose from the track's pose, accepted
  kRedetected = 2,  ///< the track's instance, solved by the full solver: the tracked pose
                    ///< was lost (S_A or mask fit) or a periodic re-detection was due
};

/// Name of a mode as in the JSON lines and logs: "detected", "tracked", "redetected".
const char* AnswerModeName(AnswerMode mode);

/// Options of the Tracker. The thresholds are measured (bench/RESULTS.md, issue 14).
struct TrackerOptions {
  bool enabled = true;          ///< off: every instance is detected, no state is kept
  /// A track without an answer for longer than this (frame time) is dropped, seconds.
  double max_age_s = 1.0;
  /// An instance continues a track of the same object when the overlap of its mask M and
  /// the track's predicted silhouette P, |M ∩ P| / min(|M|, |P|), is at least this (an
  /// occluded object's mask lies inside its silhouette: overlap 1).
  double min_overlap = 0.3;
  /// A tracked pose is lost (the full solver runs in the same frame) when its S_A is above
  /// this ...
  double loss_score = 0.20;
  /// ... or the IoU of its rendered silhouette and the mask (J) is below this ...
  double min_iou = 0.6;
  /// ... or, for a coloured mesh that is not a surface of revolution, its appearance
  /// agreement (ZNCC) fell by more than this since the track's last answer: a flip onto a
  /// symmetry of the shape keeps S but not the print. <= 0: off.
  double appearance_drop = 0.3;
  /// Re-detect a track after this many frames without a detection, to catch a confident
  /// but wrong track; 0 = never. At most `max_periodic_per_frame` periodic re-detections
  /// run in one frame (the most overdue first), so tracks started together do not all
  /// re-detect in the same frame.
  int redetect_every = 30;
  int max_periodic_per_frame = 1;
  /// Periodic re-detections in the background: the frame is answered by tracking at once
  /// (TrackedAnswer::confirm_requested) and the caller runs the full solver on that frame
  /// elsewhere (a spare thread) and hands the result to Tracker::ApplyConfirmation. A
  /// detection that scores lower than the tracked pose by `confirm_margin` and lies
  /// elsewhere corrects the track (moved on by the motion tracked since). Off: the
  /// periodic re-detection runs in the frame, like a lost track's.
  bool background_redetect = false;
  /// A re-detection replaces a tracked pose when its S is lower by more than this, or
  /// within this of the tracked S with an appearance agreement higher by more than
  /// `confirm_appearance_gain` (a coloured surface of revolution or a flipped box: the
  /// same S either way, only the print tells).
  double confirm_margin = 0.02;
  double confirm_appearance_gain = 0.1;
  /// Start from the constant-velocity prediction (from the last two answers) as well as
  /// from the last pose.
  bool constant_velocity = true;
  TrackSolveOptions solve;

  std::string Check() const;
};

/// One track: the last answer of an object instance.
struct Track {
  int id = 0;
  std::string object_id;
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();  ///< last T_A
  double score = 2.0;                 ///< last S_A
  bool appearance_valid = false;      ///< the last answer's appearance agreement is known
  double appearance = 0.0;            ///< and is this (ZNCC, [-1, 1])
  double time_s = 0.0;                ///< frame time of the last answer
  bool has_velocity = false;          ///< the last two answers were close enough in time
  Eigen::Vector3d velocity_m_s = Eigen::Vector3d::Zero();    ///< translation per second (camera frame)
  Eigen::Vector3d angular_rad_s = Eigen::Vector3d::Zero();   ///< rotation per second (axis-angle, camera frame)
  int frames_since_detection = 0;     ///< answers since the last (re-)detection
  int answers = 0;                    ///< answers so far
  bool confirmation_pending = false;  ///< a background re-detection of this track is running
  bool corrected = false;             ///< a background re-detection moved the pose since the last answer
};

/// What to do with one instance of a frame.
struct TrackPlan {
  std::string object_id;
  int track_id = -1;              ///< -1: a new track (detect)
  bool redetect = false;          ///< run the full solver even if tracking succeeds (periodic)
  double overlap = 0.0;           ///< overlap of the mask and the predicted silhouette
  Track track;                    ///< a copy of the continued track (when track_id >= 0)
  std::vector<Eigen::Isometry3d> starts;  ///< TrackPose starts (last pose, prediction)
};

/// The answer for one instance and how it was made.
struct TrackedAnswer {
  PoseResult result;
  AnswerMode mode = AnswerMode::kDetected;
  int track_id = -1;              ///< filled by Tracker::Update (new tracks get their id there)
  int frames_since_detection = 0; ///< filled by Tracker::Update; 0 for (re-)detections
  bool lost = false;              ///< the tracked pose was refused (S_A, J or appearance)
  bool lost_by_appearance = false;  ///< ... by the appearance drop alone
  bool periodic = false;          ///< a periodic re-detection ran
  bool from_track = false;        ///< the answer is TrackPose's pose (a continuous motion)
  /// A periodic re-detection is due and TrackerOptions::background_redetect is on: run
  /// EstimatePose on this frame and instance elsewhere, then Tracker::ApplyConfirmation.
  bool confirm_requested = false;
  double track_ms = 0.0;          ///< wall time of TrackPose (0 when it did not run)
  double detect_ms = 0.0;         ///< wall time of EstimatePose (0 when it did not run)
  PoseScore tracked_score;        ///< TrackPose's S_A and parts (when it ran)
  Eigen::Isometry3d tracked_pose = Eigen::Isometry3d::Identity();  ///< TrackPose's T_A (when it ran)
};

/// The bank of an object id, or nullptr when there is none.
using BankLookup = std::function<const TemplateBank*(const std::string& object_id)>;

/// Solves one instance as `plan` says: detection for a new track; else TrackPose, and
/// the full solver when the tracked pose is lost or a periodic re-detection is due (the
/// answer is then the lower S of the two, so it is never worse than detection by S).
/// Thread-safe (reads only its arguments).
TrackedAnswer SolveWithPlan(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                            const SolverOptions& solver_options, const TrackerOptions& options,
                            const TrackPlan& plan, Executor* executor);

/// The first half of SolveWithPlan for a plan that continues a track: TrackPose from the
/// plan's starts and the loss decision (S_A, J, appearance), without the full solver. The
/// answer's `lost` says whether the tracked pose was refused; when it was not, the answer
/// is SolveWithPlan's tracked answer (mode kTracked, or kRedetected for a corrected track;
/// confirm_requested for a periodic check in the background). `needs_detection` is set
/// when the caller must run a detector of its own before answering: the pose was lost, or
/// a periodic re-detection is due in the frame (plan.redetect without background checks);
/// `result` then holds TrackPose's answer (possibly failed). Throws g6d::Error for a plan
/// without a track. Thread-safe (reads only its arguments).
TrackedAnswer TrackWithPlan(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                            const SolverOptions& solver_options, const TrackerOptions& options,
                            const TrackPlan& plan, Executor* executor, bool* needs_detection);

/// The tracks of one camera.
class Tracker {
 public:
  /// Throws g6d::Error when options.Check() fails.
  explicit Tracker(const TrackerOptions& options);

  const TrackerOptions& options() const { return options_; }

  /// Drops the tracks older than max_age_s at `time_s`, then assigns the instances of a
  /// frame at `time_s` (seconds, any epoch, increasing) to tracks: greedily by the overlap
  /// of the mask and the track's predicted silhouette, same object id, at least
  /// min_overlap. An instance whose object has no bank (lookup gives nullptr) gets a plan
  /// with track_id -1. Time going backwards (a log replayed again) forgets every track.
  std::vector<TrackPlan> Plan(double time_s, const std::vector<Instance>& instances, const Camera& camera,
                              const BankLookup& banks);

  /// Records the answers of the frame planned at `time_s` (one per plan, same order):
  /// continues or starts tracks (successful answers only), sets each answer's track_id and
  /// frames_since_detection. A failed answer leaves its track to expire. A track's velocity
  /// (TrackMotion) reads the object's shape from `banks`: the turn of a surface of
  /// revolution about its axis is no motion the depth saw, and is not extrapolated.
  void Update(double time_s, const std::vector<TrackPlan>& plans, const BankLookup& banks,
              std::vector<TrackedAnswer>* answers);

  /// A background re-detection of track `track_id` on a frame where the track's answer was
  /// `tracked`: `detection` (EstimatePose's result on that frame). When the detection is
  /// the better answer (DetectionIsBetter) and lies farther than a tenth of `diameter_m`
  /// from the tracked pose, the track is corrected: its pose becomes the detection moved
  /// by the motion tracked since that frame, and its next answer is a re-detection. Either
  /// way its re-detection count restarts. Returns true when the track was corrected; false
  /// also when the track is gone.
  bool ApplyConfirmation(int track_id, const PoseResult& tracked, const PoseResult& detection, double diameter_m);

  /// The live tracks, by id.
  const std::vector<Track>& tracks() const { return tracks_; }
  /// Forgets every track.
  void Clear() { tracks_.clear(); }
  /// Forgets the tracks of `object_id` (its template bank was replaced or removed);
  /// returns how many.
  int ForgetObject(const std::string& object_id);

 private:
  TrackerOptions options_;
  std::vector<Track> tracks_;
  int next_id_ = 1;
};

/// True when `detection` is a better answer than `tracked` under `options` (see
/// TrackerOptions::confirm_margin); false when the detection failed.
bool DetectionIsBetter(const TrackerOptions& options, const PoseResult& tracked, const PoseResult& detection);

/// The constant-velocity prediction of a track's pose at `time_s` (its last pose when it
/// has no velocity).
Eigen::Isometry3d PredictPose(const Track& track, double time_s);

/// The velocity of a track whose answer moved from `before` to `after` in `dt_s` seconds
/// (> 0): Track::velocity_m_s and Track::angular_rad_s (camera frame), so that PredictPose
/// reproduces the step. With `shape` a surface of revolution, the turn about its axis is
/// left out (the centre on the axis still moves as it did): depth and silhouette do not see
/// that turn, so a step along it is the solve's correction of an unobserved degree of
/// freedom (a detection's turn set right by the appearance search), and extrapolated it
/// grows frame after frame (the demo's can spun off its print after its jump; bench/RESULTS.md,
/// "A tracked can's turn"). `shape` may be nullptr (no symmetry known).
void TrackMotion(const Eigen::Isometry3d& before, const Eigen::Isometry3d& after, double dt_s,
                 const MeshSymmetries* shape, Eigen::Vector3d* velocity_m_s, Eigen::Vector3d* angular_rad_s);

}  // namespace g6d
