// Where things are in the embedded sample: objects placed on the table without
// overlapping footprints, the camera of an image, the camera path and the jump of a
// sequence (PlanSampleSequence), and the options' checks. One of the four files of
// g6d_sample (sample_texture, sample_layout, sample_render, sample_writers).
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"
#include "core/se3.h"
#include "sample/sample_internal.h"
#include "sample/sample_scene.h"

namespace g6d {
namespace sample_internal {
namespace {

double Uniform(cv::RNG* rng, double low, double high) {
  return low + (high - low) * rng->uniform(0.0, 1.0);
}

// ---------------------------------------------------------------------------------------
// Arrangements.

// The convex hull of the object's vertices projected on the table plane, at `world_from_object`.
std::vector<cv::Point2f> Footprint(const Mesh& mesh, const Eigen::Isometry3d& world_from_object,
                                   double margin_m) {
  std::vector<cv::Point2f> points;
  Eigen::Vector2d centre = world_from_object.translation().head<2>();
  for (const Eigen::Vector3f& v : mesh.vertices) {
    const Eigen::Vector3d p = world_from_object * v.cast<double>();
    // Grow away from the centre by the margin (conservative for a convex footprint).
    const Eigen::Vector2d offset = p.head<2>() - centre;
    const double length = offset.norm();
    const Eigen::Vector2d grown =
        length > 0 ? centre + offset * ((length + margin_m / 2) / length) : centre;
    points.emplace_back(static_cast<float>(grown.x()), static_cast<float>(grown.y()));
  }
  std::vector<cv::Point2f> hull;
  cv::convexHull(points, hull);
  return hull;
}

bool FootprintsOverlap(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
  std::vector<cv::Point2f> intersection;
  return cv::intersectConvexConvex(a, b, intersection, true) > 0.0f;
}

}  // namespace

bool DrawPlacements(const SampleOptions& options, const std::vector<SampleObject>& objects,
                    cv::RNG* rng, std::vector<Placement>* placements) {
  placements->clear();
  constexpr int kSpotTries = 60;
  for (const SampleObject& object : objects) {
    const SampleRest& rest = object.rests[rng->uniform(0, static_cast<int>(object.rests.size()))];
    Eigen::Matrix3d table_from_object = rest.table_from_object;
    if (rest.free_roll_about_object_z) {
      table_from_object = table_from_object *
                          Eigen::AngleAxisd(Uniform(rng, 0, 2 * M_PI), Eigen::Vector3d::UnitZ());
    }
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(Uniform(rng, 0, 2 * M_PI), Eigen::Vector3d::UnitZ()).toRotationMatrix() *
        table_from_object;
    double lowest = std::numeric_limits<double>::max();
    for (const Eigen::Vector3f& v : object.mesh.vertices)
      lowest = std::min(lowest, (rotation * v.cast<double>()).z());
    bool placed = false;
    for (int attempt = 0; attempt < kSpotTries && !placed; ++attempt) {
      // Uniform in the disc.
      const double radius = options.cluster_radius_m * std::sqrt(rng->uniform(0.0, 1.0));
      const double angle = Uniform(rng, 0, 2 * M_PI);
      Placement placement;
      placement.world_from_object = MakePose(
          rotation,
          {radius * std::cos(angle), radius * std::sin(angle), -lowest + options.contact_gap_m});
      placement.footprint =
          Footprint(object.mesh, placement.world_from_object, options.footprint_margin_m);
      placed = std::none_of(placements->begin(), placements->end(), [&](const Placement& other) {
        return FootprintsOverlap(placement.footprint, other.footprint);
      });
      if (placed) placements->push_back(placement);
    }
    if (!placed) return false;
  }
  return true;
}

Eigen::Isometry3d DrawCamera(const SampleOptions& options, const std::vector<Placement>& placements,
                             cv::RNG* rng) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Placement& p : placements) centroid += p.world_from_object.translation();
  centroid /= static_cast<double>(placements.size());
  const Eigen::Vector3d jitter(Uniform(rng, -1, 1), Uniform(rng, -1, 1), Uniform(rng, -1, 1));
  const Eigen::Vector3d target = centroid + options.look_at_jitter_m * jitter;
  const double azimuth = Uniform(rng, 0, 2 * M_PI);
  const double elevation =
      Uniform(rng, options.min_elevation_deg, options.max_elevation_deg) * M_PI / 180.0;
  const double distance = Uniform(rng, options.min_distance_m, options.max_distance_m);
  const Eigen::Vector3d eye =
      target + distance * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                          std::cos(elevation) * std::sin(azimuth),
                                          std::sin(elevation));
  return LookAt(eye, target, Eigen::Vector3d::UnitZ());
}

}  // namespace sample_internal

namespace {

using sample_internal::DerivedSeed;
using sample_internal::DrawPlacements;
using sample_internal::Footprint;
using sample_internal::FootprintsOverlap;
using sample_internal::kSequencePart;
using sample_internal::LeastVisible;
using sample_internal::MeasureArrangement;
using sample_internal::Placement;
using sample_internal::Uniform;

// The camera path of a sequence before any slow-down: at s in [0, 1] the camera looks at
// target + (s - 1/2) drift from azimuth azimuth_mid + (s - 1/2) sweep, elevation
// elevation_mid + elevation_amplitude sin(2 pi s + elevation_phase) and distance likewise.
struct CameraPath {
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  // metres, world
  Eigen::Vector3d drift = Eigen::Vector3d::Zero();   // metres, horizontal
  double azimuth_mid = 0.0, sweep = 0.0;             // radians
  double elevation_mid = 0.0, elevation_amplitude = 0.0, elevation_phase = 0.0;  // radians
  double distance_mid = 0.0, distance_amplitude = 0.0, distance_phase = 0.0;     // metres
};

// A value in [low, high] and its amplitude in [min_amplitude, max_amplitude] such that
// value +- amplitude stays in [low, high].
void DrawWobble(double low, double high, double min_amplitude, double max_amplitude, cv::RNG* rng,
                double* mid, double* amplitude) {
  *amplitude = std::min(Uniform(rng, min_amplitude, max_amplitude), (high - low) / 2);
  *mid = Uniform(rng, low + *amplitude, high - *amplitude);
}

CameraPath DrawCameraPath(const SampleOptions& options, const std::vector<Placement>& placements,
                          cv::RNG* rng) {
  const SampleSequenceOptions& sequence = options.sequence;
  CameraPath path;
  for (const Placement& p : placements) path.target += p.world_from_object.translation();
  path.target /= static_cast<double>(placements.size());
  const Eigen::Vector3d jitter(Uniform(rng, -1, 1), Uniform(rng, -1, 1), Uniform(rng, -1, 1));
  path.target += options.look_at_jitter_m * jitter;
  const double drift_angle = Uniform(rng, 0, 2 * M_PI);
  path.drift =
      sequence.look_at_drift_m * Eigen::Vector3d(std::cos(drift_angle), std::sin(drift_angle), 0);
  path.azimuth_mid = Uniform(rng, 0, 2 * M_PI);
  const double direction = rng->uniform(0, 2) == 0 ? 1.0 : -1.0;
  path.sweep =
      direction * Uniform(rng, sequence.min_sweep_deg, sequence.max_sweep_deg) * M_PI / 180.0;
  constexpr double kRadiansPerDegree = M_PI / 180.0;
  DrawWobble(options.min_elevation_deg * kRadiansPerDegree,
             options.max_elevation_deg * kRadiansPerDegree,
             sequence.min_elevation_wobble_deg * kRadiansPerDegree,
             sequence.max_elevation_wobble_deg * kRadiansPerDegree, rng, &path.elevation_mid,
             &path.elevation_amplitude);
  path.elevation_phase = Uniform(rng, 0, 2 * M_PI);
  DrawWobble(options.min_distance_m, options.max_distance_m, sequence.min_distance_wobble_m,
             sequence.max_distance_wobble_m, rng, &path.distance_mid, &path.distance_amplitude);
  path.distance_phase = Uniform(rng, 0, 2 * M_PI);
  return path;
}

// cam_from_world at s in [0, 1] of `path` with every motion scaled by `scale` in [0, 1]
// (which keeps elevation and distance inside their ranges).
Eigen::Isometry3d CameraOnPath(const CameraPath& path, double scale, double s) {
  const double centred = s - 0.5;
  const Eigen::Vector3d target = path.target + scale * centred * path.drift;
  const double azimuth = path.azimuth_mid + scale * centred * path.sweep;
  const double elevation = path.elevation_mid + scale * path.elevation_amplitude *
                                                    std::sin(2 * M_PI * s + path.elevation_phase);
  const double distance = path.distance_mid + scale * path.distance_amplitude *
                                                  std::sin(2 * M_PI * s + path.distance_phase);
  const Eigen::Vector3d eye =
      target + distance * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                          std::cos(elevation) * std::sin(azimuth),
                                          std::sin(elevation));
  return LookAt(eye, target, Eigen::Vector3d::UnitZ());
}

// Largest camera centre move (metres) and rotation (degrees) between consecutive poses.
void LargestSteps(const std::vector<Eigen::Isometry3d>& cam_from_world, double* step_m,
                  double* step_deg) {
  *step_m = 0.0;
  *step_deg = 0.0;
  for (size_t i = 1; i < cam_from_world.size(); ++i) {
    const Eigen::Isometry3d a = cam_from_world[i - 1].inverse(), b = cam_from_world[i].inverse();
    *step_m = std::max(*step_m, (a.translation() - b.translation()).norm());
    *step_deg = std::max(*step_deg, RotationErrorDeg(a.linear(), b.linear()));
  }
}

// The poses of `path` at the images of the sequence, slowed down (every motion scaled
// alike) until the camera keeps to the speed and rotation-rate bounds. Returns the scale.
double SampleCameraPath(const SampleOptions& options, const CameraPath& path,
                        std::vector<Eigen::Isometry3d>* cam_from_world) {
  const SampleSequenceOptions& sequence = options.sequence;
  const int frames = options.num_frames;
  // A bound per image step: the motion between images at `fps`.
  const double bound_m = sequence.max_camera_speed_m_s / sequence.fps;
  const double bound_deg = sequence.max_rotation_deg_s / sequence.fps;
  double scale = 1.0;
  // Steps shrink about linearly with the scale (and vanish at 0), so a few rounds settle.
  constexpr int kMaxRounds = 60;
  for (int round = 0; round < kMaxRounds; ++round) {
    cam_from_world->clear();
    for (int i = 0; i < frames; ++i) {
      const double s = frames > 1 ? static_cast<double>(i) / (frames - 1) : 0.0;
      cam_from_world->push_back(CameraOnPath(path, scale, s));
    }
    double step_m = 0.0, step_deg = 0.0;
    LargestSteps(*cam_from_world, &step_m, &step_deg);
    const double excess = std::max(step_m / bound_m, step_deg / bound_deg);
    if (excess <= 1.0) return scale;
    // 2% below the bound, so that the next round lands inside it.
    scale *= 0.98 / excess;
  }
  G6D_THROW("the camera path cannot keep to " << sequence.max_camera_speed_m_s << " m/s and "
                                              << sequence.max_rotation_deg_s << " deg/s at "
                                              << sequence.fps << " fps");
}

// The new place of object k: moved by min_jump_m..max_jump_m in a random direction on the
// table and turned by min_jump_turn_deg..max_jump_turn_deg either way about the vertical
// through its centre, clear of the other footprints. False when no free spot was found.
bool DrawJump(const SampleOptions& options, const std::vector<SampleObject>& objects,
              const std::vector<Placement>& placements, int k, cv::RNG* rng, Placement* jumped,
              double* jump_m, double* turn_deg) {
  const SampleSequenceOptions& sequence = options.sequence;
  constexpr int kSpotTries = 60;
  const Eigen::Isometry3d& before = placements[k].world_from_object;
  for (int attempt = 0; attempt < kSpotTries; ++attempt) {
    const double direction = rng->uniform(0, 2) == 0 ? 1.0 : -1.0;
    *turn_deg = direction * Uniform(rng, sequence.min_jump_turn_deg, sequence.max_jump_turn_deg);
    *jump_m = Uniform(rng, sequence.min_jump_m, sequence.max_jump_m);
    const double angle = Uniform(rng, 0, 2 * M_PI);
    jumped->world_from_object = MakePose(
        Eigen::AngleAxisd(*turn_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
            before.linear(),
        before.translation() + *jump_m * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0));
    jumped->footprint =
        Footprint(objects[k].mesh, jumped->world_from_object, options.footprint_margin_m);
    bool free = true;
    for (int j = 0; j < static_cast<int>(placements.size()) && free; ++j)
      free = j == k || !FootprintsOverlap(jumped->footprint, placements[j].footprint);
    if (free) return true;
  }
  return false;
}

// The images in the order a candidate is checked: those around the jump and the ends
// first, then ever finer strides, so that an invalid candidate fails early.
std::vector<int> CheckOrder(int frames, int abrupt_frame) {
  std::vector<int> order;
  std::vector<bool> taken(frames, false);
  auto take = [&](int i) {
    if (i >= 0 && i < frames && !taken[i]) {
      taken[i] = true;
      order.push_back(i);
    }
  };
  take(abrupt_frame);
  take(abrupt_frame - 1);
  take(0);
  take(frames - 1);
  for (const int stride : {16, 4, 1}) {
    for (int i = 0; i < frames; i += stride) take(i);
  }
  return order;
}

}  // namespace

Eigen::Isometry3d SampleSequencePlan::WorldFromObject(int im_id, int k) const {
  if (k == abrupt_object && abrupt_frame >= 0 && im_id >= abrupt_frame)
    return jumped_world_from_object;
  return world_from_object[k];
}

SampleSequencePlan PlanSampleSequence(const SampleOptions& options,
                                      const std::vector<SampleObject>& objects) {
  if (const std::string bad = options.Check(); !bad.empty())
    G6D_THROW("bad sample option: " << bad);
  if (static_cast<int>(objects.size()) != options.num_objects)
    G6D_THROW("PlanSampleSequence: " << objects.size() << " objects for num_objects "
                                     << options.num_objects);
  const SampleSequenceOptions& sequence = options.sequence;
  const int n = static_cast<int>(objects.size());
  const int frames = options.num_frames;
  const int abrupt_object =
      sequence.abrupt_frame >= 0 ? std::min(sequence.abrupt_object, n - 1) : -1;
  const std::vector<int> order = CheckOrder(frames, sequence.abrupt_frame);
  cv::RNG rng(DerivedSeed(options.seed, kSequencePart));

  // A single object cannot be hidden by another.
  const bool want_occlusion = n >= 2;
  SampleSequencePlan best;
  int valid_candidates = 0;
  int tries = 0;
  for (; tries < options.max_tries; ++tries) {
    std::vector<Placement> placements;
    if (!DrawPlacements(options, objects, &rng, &placements)) continue;
    SampleSequencePlan plan;
    plan.abrupt_frame = sequence.abrupt_frame;
    plan.abrupt_object = abrupt_object;
    for (const Placement& placement : placements)
      plan.world_from_object.push_back(placement.world_from_object);
    if (abrupt_object >= 0) {
      Placement jumped;
      if (!DrawJump(options, objects, placements, abrupt_object, &rng, &jumped, &plan.jump_m,
                    &plan.jump_turn_deg)) {
        continue;
      }
      plan.jumped_world_from_object = jumped.world_from_object;
    }
    const CameraPath path = DrawCameraPath(options, placements, &rng);
    const double scale = SampleCameraPath(options, path, &plan.cam_from_world);
    plan.sweep_deg = scale * path.sweep * 180.0 / M_PI;
    LargestSteps(plan.cam_from_world, &plan.max_step_m, &plan.max_step_deg);

    bool valid = true;
    for (const int im_id : order) {
      SampleFrame frame;
      frame.cam_from_world = plan.cam_from_world[im_id];
      std::vector<Eigen::Isometry3d> world_from_object;
      for (int k = 0; k < n; ++k) world_from_object.push_back(plan.WorldFromObject(im_id, k));
      const double least_visible = MeasureArrangement(options, objects, world_from_object, &frame)
                                       ? LeastVisible(frame.instances)
                                       : -1.0;
      if (least_visible < options.min_visible_fraction) {
        valid = false;
        break;
      }
      plan.min_visib_fract = std::min(plan.min_visib_fract, least_visible);
    }
    if (!valid) continue;
    plan.occluded = plan.min_visib_fract < options.occlusion_below_fraction;
    if (valid_candidates == 0 || plan.occluded) best = std::move(plan);
    ++valid_candidates;
    if (best.occluded || !want_occlusion || valid_candidates >= sequence.max_valid_candidates)
      break;
  }
  if (valid_candidates == 0) {
    G6D_THROW("no valid sequence of "
              << n << " objects in " << options.max_tries
              << " tries (every object inside the image and at least "
              << options.min_visible_fraction
              << " visible in every image, also after the jump): relax min_visible_fraction, "
                 "the camera distances or the jump");
  }
  best.tries = std::min(tries + 1, options.max_tries);
  return best;
}

std::string SampleOptions::Check() const {
  std::ostringstream out;
  auto finite_positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (num_objects < 1 || num_objects > 3)
    out << "num_objects must be in 1..3 (got " << num_objects << ")";
  else if (num_frames < 1 || num_frames > 10000)
    out << "num_frames must be in 1..10000 (got " << num_frames << ")";
  else if (const std::string bad = camera.Check(); !bad.empty())
    out << "camera: " << bad;
  else if (!finite_positive(min_distance_m) || !(max_distance_m >= min_distance_m)) {
    out << "min_distance_m / max_distance_m must satisfy 0 < min <= max (got " << min_distance_m
        << ", " << max_distance_m << ")";
  } else if (!(min_elevation_deg > 0.0) || !(max_elevation_deg >= min_elevation_deg) ||
             !(max_elevation_deg <= 90.0)) {
    out << "min_elevation_deg / max_elevation_deg must satisfy 0 < min <= max <= 90 (got "
        << min_elevation_deg << ", " << max_elevation_deg << ")";
  } else if (!(look_at_jitter_m >= 0.0))
    out << "look_at_jitter_m must be >= 0";
  else if (!finite_positive(cluster_radius_m))
    out << "cluster_radius_m must be > 0";
  else if (!(contact_gap_m >= 0.0))
    out << "contact_gap_m must be >= 0";
  else if (!(footprint_margin_m >= 0.0))
    out << "footprint_margin_m must be >= 0";
  else if (!(min_visible_fraction >= 0.0 && min_visible_fraction <= 1.0))
    out << "min_visible_fraction must be in [0, 1]";
  else if (!(occlusion_below_fraction >= 0.0 && occlusion_below_fraction <= 1.0)) {
    out << "occlusion_below_fraction must be in [0, 1]";
  } else if (max_tries < 1)
    out << "max_tries must be >= 1";
  else if (border_margin_px < 0)
    out << "border_margin_px must be >= 0";
  else if (!(depth_noise_m >= 0.0 && depth_noise_m < 0.1))
    out << "depth_noise_m must be in [0, 0.1) m";
  else if (!(color_noise >= 0.0 && color_noise <= 64.0))
    out << "color_noise must be in [0, 64]";
  else if (!finite_positive(depth_scale_mm))
    out << "depth_scale_mm must be > 0";
  else if (supersampling < 1 || supersampling > 4)
    out << "supersampling must be in 1..4";
  else if (!(texture_px_per_mm > 0.0 && texture_px_per_mm <= 20.0))
    out << "texture_px_per_mm must be in (0, 20]";
  else if (!finite_positive(table_size_m) || table_cells < 1 || !finite_positive(table_tile_m)) {
    out << "table_size_m, table_cells and table_tile_m must be > 0";
  } else if (const std::string bad = sequence.Check(); !bad.empty()) {
    out << "sequence." << bad;
  } else if (sequence.enabled && sequence.abrupt_frame != -1 &&
             (sequence.abrupt_frame < 1 || sequence.abrupt_frame >= num_frames)) {
    out << "sequence.abrupt_frame must be -1 or in 1..num_frames-1 = " << num_frames - 1 << " (got "
        << sequence.abrupt_frame << ")";
  }
  return out.str();
}

std::string SampleSequenceOptions::Check() const {
  std::ostringstream out;
  // Each pair: 0 <= low <= high (and finite).
  auto range = [](double low, double high) {
    return std::isfinite(low) && std::isfinite(high) && low >= 0.0 && high >= low;
  };
  if (!(std::isfinite(fps) && fps > 0.0))
    out << "fps must be finite and > 0 (got " << fps << ")";
  else if (abrupt_frame < -1)
    out << "abrupt_frame must be -1 (none) or an image index (got " << abrupt_frame << ")";
  else if (abrupt_object < 0)
    out << "abrupt_object must be >= 0 (got " << abrupt_object << ")";
  else if (max_valid_candidates < 1)
    out << "max_valid_candidates must be >= 1 (got " << max_valid_candidates << ")";
  else if (!range(min_sweep_deg, max_sweep_deg) || max_sweep_deg > 180.0) {
    out << "min_sweep_deg / max_sweep_deg must satisfy 0 <= min <= max <= 180 (got "
        << min_sweep_deg << ", " << max_sweep_deg << ")";
  } else if (!range(min_elevation_wobble_deg, max_elevation_wobble_deg)) {
    out << "min_elevation_wobble_deg / max_elevation_wobble_deg must satisfy 0 <= min <= max";
  } else if (!range(min_distance_wobble_m, max_distance_wobble_m)) {
    out << "min_distance_wobble_m / max_distance_wobble_m must satisfy 0 <= min <= max";
  } else if (!(look_at_drift_m >= 0.0 && std::isfinite(look_at_drift_m)))
    out << "look_at_drift_m must be >= 0";
  else if (!(max_camera_speed_m_s > 0.0 && std::isfinite(max_camera_speed_m_s)))
    out << "max_camera_speed_m_s must be > 0";
  else if (!(max_rotation_deg_s > 0.0 && std::isfinite(max_rotation_deg_s)))
    out << "max_rotation_deg_s must be > 0";
  else if (!range(min_jump_m, max_jump_m) || !(min_jump_m > 0.0)) {
    out << "min_jump_m / max_jump_m must satisfy 0 < min <= max (got " << min_jump_m << ", "
        << max_jump_m << ")";
  } else if (!range(min_jump_turn_deg, max_jump_turn_deg) || max_jump_turn_deg > 180.0) {
    out << "min_jump_turn_deg / max_jump_turn_deg must satisfy 0 <= min <= max <= 180 (got "
        << min_jump_turn_deg << ", " << max_jump_turn_deg << ")";
  }
  return out.str();
}
}  // namespace g6d
