#include "track/tracker.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <tuple>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/timer.h"
#include "render/raster.h"

namespace g6d {

const char* AnswerModeName(AnswerMode mode) {
  switch (mode) {
    case AnswerMode::kDetected: return "detected";
    case AnswerMode::kTracked: return "tracked";
    case AnswerMode::kRedetected: return "redetected";
  }
  return "unknown";
}

std::string TrackerOptions::Check() const {
  std::ostringstream out;
  if (!(max_age_s > 0.0 && std::isfinite(max_age_s))) out << "TrackerOptions.max_age_s must be > 0 (got " << max_age_s << ")";
  else if (!(min_overlap >= 0.0 && min_overlap <= 1.0)) out << "TrackerOptions.min_overlap must be in [0, 1] (got " << min_overlap << ")";
  else if (!(loss_score > 0.0 && std::isfinite(loss_score))) out << "TrackerOptions.loss_score must be > 0 (got " << loss_score << ")";
  else if (!(min_iou >= 0.0 && min_iou <= 1.0)) out << "TrackerOptions.min_iou must be in [0, 1] (got " << min_iou << ")";
  else if (redetect_every < 0) out << "TrackerOptions.redetect_every must be >= 0 (got " << redetect_every << ")";
  else if (max_periodic_per_frame < 1) out << "TrackerOptions.max_periodic_per_frame must be >= 1 (got " << max_periodic_per_frame << ")";
  else if (!std::isfinite(appearance_drop)) out << "TrackerOptions.appearance_drop must be finite (got " << appearance_drop << ")";
  else if (!(confirm_margin >= 0.0 && confirm_margin < 2.0)) out << "TrackerOptions.confirm_margin must be in [0, 2) (got " << confirm_margin << ")";
  else if (!(confirm_appearance_gain >= 0.0 && confirm_appearance_gain <= 2.0)) out << "TrackerOptions.confirm_appearance_gain must be in [0, 2] (got " << confirm_appearance_gain << ")";
  if (!out.str().empty()) return out.str();
  return solve.Check();
}

bool DetectionIsBetter(const TrackerOptions& options, const PoseResult& tracked, const PoseResult& detection) {
  if (!detection.success) return false;
  if (!tracked.success || detection.score < tracked.score - options.confirm_margin) return true;
  return detection.score <= tracked.score + options.confirm_margin && detection.appearance_valid && tracked.appearance_valid &&
         detection.appearance_agreement > tracked.appearance_agreement + options.confirm_appearance_gain;
}

Eigen::Isometry3d PredictPose(const Track& track, double time_s) {
  if (!track.has_velocity) return track.cam_from_object;
  const double dt = time_s - track.time_s;
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d rotation = track.angular_rad_s * dt;
  if (rotation.norm() > 0.0) step.linear() = Eigen::AngleAxisd(rotation.norm(), rotation.normalized()).toRotationMatrix();
  step.translation() = track.velocity_m_s * dt;
  return step * track.cam_from_object;
}

namespace {

// The longer side of the images on which masks and predicted silhouettes are compared.
constexpr int kOverlapSidePx = 160;

// Poses closer than these are one start (the prediction adds nothing to the last pose).
constexpr double kSameStartM = 0.001;
constexpr double kSameStartRad = 0.2 * M_PI / 180.0;

// |a ∩ b| / min(|a|, |b|) of two 0/255 masks; 0 when either is empty.
double Overlap(const cv::Mat& a, const cv::Mat& b) {
  const int area_a = cv::countNonZero(a), area_b = cv::countNonZero(b);
  if (area_a == 0 || area_b == 0) return 0.0;
  cv::Mat both;
  cv::bitwise_and(a, b, both);
  return static_cast<double>(cv::countNonZero(both)) / std::min(area_a, area_b);
}

}  // namespace

TrackedAnswer SolveWithPlan(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                            const SolverOptions& solver_options, const TrackerOptions& options,
                            const TrackPlan& plan, Executor* executor) {
  TrackedAnswer answer;
  answer.track_id = plan.track_id;
  Stopwatch watch;
  if (!options.enabled || plan.track_id < 0) {
    answer.result = EstimatePose(frame, instance, bank, solver_options, executor);
    answer.detect_ms = watch.ElapsedMs();
    answer.mode = AnswerMode::kDetected;
    return answer;
  }
  bool needs_detection = false;
  answer = TrackWithPlan(frame, instance, bank, solver_options, options, plan, executor, &needs_detection);
  if (!needs_detection) return answer;
  PoseResult tracked = std::move(answer.result);
  answer.result = PoseResult();
  // Lost, or a periodic check: the full solver, and the lower S of the two.
  answer.periodic = plan.redetect && !answer.lost;
  answer.mode = AnswerMode::kRedetected;
  watch.Restart();
  PoseResult detected = EstimatePose(frame, instance, bank, solver_options, executor);
  answer.detect_ms = watch.ElapsedMs();
  // In the frame any lower S wins (never worse than detection by S), as does a clearly
  // better print at about the same S.
  const bool detection_better =
      detected.success && (detected.score < tracked.score || DetectionIsBetter(options, tracked, detected));
  answer.from_track = tracked.success && !detection_better;
  answer.result = answer.from_track ? std::move(tracked) : std::move(detected);
  return answer;
}

TrackedAnswer TrackWithPlan(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                            const SolverOptions& solver_options, const TrackerOptions& options,
                            const TrackPlan& plan, Executor* executor, bool* needs_detection) {
  if (plan.track_id < 0) G6D_THROW("TrackWithPlan: the plan continues no track");
  TrackedAnswer answer;
  answer.track_id = plan.track_id;
  Stopwatch watch;
  PoseResult tracked = TrackPose(frame, instance, bank, solver_options, options.solve, plan.starts, executor);
  answer.track_ms = watch.ElapsedMs();
  answer.tracked_score = tracked.details;
  answer.tracked_pose = tracked.cam_from_object;
  answer.lost = !tracked.success || tracked.score > options.loss_score || tracked.details.iou < options.min_iou;
  // Not for a surface of revolution: its agreement varies with the turn TrackPose searches
  // and raised false alarms on the sample sequence (bench/RESULTS.md, issue 14).
  if (!answer.lost && options.appearance_drop > 0.0 && !bank.geometric_symmetries.revolution &&
      plan.track.appearance_valid && tracked.appearance_valid &&
      tracked.appearance_agreement < plan.track.appearance - options.appearance_drop) {
    answer.lost = answer.lost_by_appearance = true;
  }
  if (!answer.lost && (!plan.redetect || options.background_redetect)) {
    answer.result = std::move(tracked);
    // A track that a background re-detection corrected answers as re-detected once.
    answer.mode = plan.track.corrected ? AnswerMode::kRedetected : AnswerMode::kTracked;
    answer.from_track = true;
    answer.confirm_requested = plan.redetect;
    *needs_detection = false;
    return answer;
  }
  answer.result = std::move(tracked);
  *needs_detection = true;
  return answer;
}

Tracker::Tracker(const TrackerOptions& options) : options_(options) {
  const std::string bad = options.Check();
  if (!bad.empty()) G6D_THROW("bad tracker options: " << bad);
}

std::vector<TrackPlan> Tracker::Plan(double time_s, const std::vector<Instance>& instances, const Camera& camera,
                                     const BankLookup& banks) {
  std::vector<TrackPlan> plans(instances.size());
  for (size_t i = 0; i < instances.size(); ++i) plans[i].object_id = instances[i].object_id;
  if (!options_.enabled) return plans;
  if (!tracks_.empty()) {
    double latest = tracks_.front().time_s;
    for (const Track& track : tracks_) latest = std::max(latest, track.time_s);
    if (time_s < latest) tracks_.clear();  // time went backwards: a new log or a replay
  }
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(),
                               [&](const Track& track) { return time_s - track.time_s > options_.max_age_s; }),
                tracks_.end());
  if (tracks_.empty() || instances.empty()) return plans;

  // Masks and predicted silhouettes on a small image.
  const double scale = std::min(1.0, static_cast<double>(kOverlapSidePx) / std::max(camera.width, camera.height));
  const Camera small = camera.Scaled(scale);
  const cv::Size small_size(small.width, small.height);
  std::vector<cv::Mat> masks(instances.size());
  for (size_t i = 0; i < instances.size(); ++i) {
    if (instances[i].mask.empty() || banks(instances[i].object_id) == nullptr) continue;
    cv::Mat resized;
    cv::resize(instances[i].mask, resized, small_size, 0, 0, cv::INTER_AREA);
    masks[i] = resized > 0;
  }
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  RasterImage raster;
  std::vector<std::tuple<double, size_t, size_t>> pairs;  // overlap, instance, track
  for (size_t t = 0; t < tracks_.size(); ++t) {
    const Track& track = tracks_[t];
    const TemplateBank* bank = banks(track.object_id);
    if (bank == nullptr) continue;
    const Mesh& mesh = bank->selection_mesh.faces.empty() ? bank->online_mesh : bank->selection_mesh;
    Rasterize(mesh, small, PredictPose(track, time_s), raster_options, &raster);
    const cv::Mat silhouette = raster.Mask();
    for (size_t i = 0; i < instances.size(); ++i) {
      if (masks[i].empty() || instances[i].object_id != track.object_id) continue;
      const double overlap = Overlap(masks[i], silhouette);
      if (overlap >= options_.min_overlap && overlap > 0.0) pairs.emplace_back(overlap, i, t);
    }
  }
  std::stable_sort(pairs.begin(), pairs.end(),
                   [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
  std::vector<bool> track_taken(tracks_.size(), false);
  std::vector<size_t> planned_tracks;
  for (const auto& [overlap, i, t] : pairs) {
    if (plans[i].track_id >= 0 || track_taken[t]) continue;
    track_taken[t] = true;
    TrackPlan& plan = plans[i];
    const Track& track = tracks_[t];
    plan.track_id = track.id;
    plan.overlap = overlap;
    plan.track = track;
    const Eigen::Isometry3d predicted = PredictPose(track, time_s);
    plan.starts.push_back(options_.constant_velocity ? predicted : track.cam_from_object);
    const Eigen::AngleAxisd turn(predicted.linear() * track.cam_from_object.linear().transpose());
    if (options_.constant_velocity &&
        ((predicted.translation() - track.cam_from_object.translation()).norm() > kSameStartM ||
         std::abs(turn.angle()) > kSameStartRad)) {
      plan.starts.push_back(track.cam_from_object);
    }
    planned_tracks.push_back(i);
  }
  // Periodic re-detections: the most overdue tracks first, a few per frame.
  if (options_.redetect_every > 0) {
    std::vector<size_t> due;
    for (size_t i : planned_tracks) {
      const Track& track = plans[i].track;
      if (track.frames_since_detection >= options_.redetect_every && !track.confirmation_pending) due.push_back(i);
    }
    std::stable_sort(due.begin(), due.end(), [&](size_t a, size_t b) {
      return plans[a].track.frames_since_detection > plans[b].track.frames_since_detection;
    });
    for (size_t k = 0; k < due.size() && k < static_cast<size_t>(options_.max_periodic_per_frame); ++k) {
      plans[due[k]].redetect = true;
    }
  }
  return plans;
}

int Tracker::ForgetObject(const std::string& object_id) {
  const auto end = std::remove_if(tracks_.begin(), tracks_.end(),
                                  [&](const Track& track) { return track.object_id == object_id; });
  const int forgotten = static_cast<int>(tracks_.end() - end);
  tracks_.erase(end, tracks_.end());
  return forgotten;
}

void TrackMotion(const Eigen::Isometry3d& before, const Eigen::Isometry3d& after, double dt_s,
                 const MeshSymmetries* shape, Eigen::Vector3d* velocity_m_s, Eigen::Vector3d* angular_rad_s) {
  if (!(dt_s > 0.0)) G6D_THROW("TrackMotion: dt must be > 0 (got " << dt_s << ")");
  Eigen::Isometry3d step = after * before.inverse();
  const Eigen::AngleAxisd turn(step.linear());
  Eigen::Vector3d rotation = turn.axis() * turn.angle();
  if (shape != nullptr && shape->revolution) {
    const Eigen::Vector3d axis = (after.linear() * shape->axis).normalized();
    rotation -= rotation.dot(axis) * axis;
    step.linear() = rotation.norm() > 0.0 ? Eigen::AngleAxisd(rotation.norm(), rotation.normalized()).toRotationMatrix()
                                          : Eigen::Matrix3d::Identity();
    // The centre on the axis moves from before's to after's position.
    step.translation() = after * shape->point - step.linear() * (before * shape->point);
  }
  *angular_rad_s = rotation / dt_s;
  *velocity_m_s = step.translation() / dt_s;
}

void Tracker::Update(double time_s, const std::vector<TrackPlan>& plans, const BankLookup& banks,
                     std::vector<TrackedAnswer>* answers) {
  if (answers->size() != plans.size()) G6D_THROW("Tracker::Update: " << answers->size() << " answers for " << plans.size() << " plans");
  for (size_t i = 0; i < plans.size(); ++i) {
    TrackedAnswer& answer = (*answers)[i];
    const TrackPlan& plan = plans[i];
    answer.track_id = -1;
    answer.frames_since_detection = 0;
    if (!options_.enabled || !answer.result.success) continue;
    const bool detection = answer.mode != AnswerMode::kTracked;
    auto continued = std::find_if(tracks_.begin(), tracks_.end(), [&](const Track& t) { return t.id == plan.track_id; });
    if (plan.track_id < 0 || continued == tracks_.end()) {
      Track track;
      track.id = next_id_++;
      track.object_id = plan.object_id;
      track.cam_from_object = answer.result.cam_from_object;
      track.score = answer.result.score;
      track.appearance_valid = answer.result.appearance_valid;
      track.appearance = answer.result.appearance_agreement;
      track.time_s = time_s;
      track.answers = 1;
      tracks_.push_back(track);
      answer.track_id = track.id;
      continue;
    }
    Track& track = *continued;
    const double dt = time_s - track.time_s;
    // Velocity only across a continuous motion: a re-detection may have jumped.
    track.has_velocity = answer.from_track && dt > 0.0;
    if (track.has_velocity) {
      const TemplateBank* bank = banks ? banks(track.object_id) : nullptr;
      TrackMotion(track.cam_from_object, answer.result.cam_from_object, dt,
                  bank != nullptr ? &bank->geometric_symmetries : nullptr, &track.velocity_m_s, &track.angular_rad_s);
    } else {
      track.angular_rad_s.setZero();
      track.velocity_m_s.setZero();
    }
    track.cam_from_object = answer.result.cam_from_object;
    track.score = answer.result.score;
    track.appearance_valid = answer.result.appearance_valid;
    track.appearance = answer.result.appearance_agreement;
    track.time_s = time_s;
    track.frames_since_detection = detection ? 0 : track.frames_since_detection + 1;
    track.confirmation_pending = track.confirmation_pending || answer.confirm_requested;
    track.corrected = false;
    ++track.answers;
    answer.track_id = track.id;
    answer.frames_since_detection = track.frames_since_detection;
  }
}

bool Tracker::ApplyConfirmation(int track_id, const PoseResult& tracked, const PoseResult& detection, double diameter_m) {
  auto track = std::find_if(tracks_.begin(), tracks_.end(), [&](const Track& t) { return t.id == track_id; });
  if (track == tracks_.end()) return false;
  track->confirmation_pending = false;
  track->frames_since_detection = 0;
  if (!DetectionIsBetter(options_, tracked, detection)) return false;
  const Eigen::Isometry3d& tracked_pose = tracked.cam_from_object;
  // Far apart: the mean displacement of points a diameter apart around the origin (a
  // cheap stand-in for ADD without the model's points).
  const Eigen::Isometry3d difference = detection.cam_from_object * tracked_pose.inverse();
  const double half = 0.5 * diameter_m;
  double moved = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    for (double sign : {-1.0, 1.0}) {
      const Eigen::Vector3d point = tracked_pose.translation() + sign * half * Eigen::Vector3d::Unit(axis);
      moved += (difference * point - point).norm() / 6.0;
    }
  }
  if (moved <= 0.1 * diameter_m) return false;
  // The motion tracked since that frame, applied to the detection.
  track->cam_from_object = track->cam_from_object * tracked_pose.inverse() * detection.cam_from_object;
  track->has_velocity = false;
  track->velocity_m_s.setZero();
  track->angular_rad_s.setZero();
  track->corrected = true;
  return true;
}

}  // namespace g6d
