#include "solver/pipeline.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>
#include <numeric>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/timer.h"
#include "render/raster.h"
#include "templates/crop.h"

namespace g6d {

std::string SolverOptions::Check() const {
  std::string bad = query_orb.Check();
  if (bad.empty()) bad = match.Check();
  if (bad.empty()) bad = pnp.Check();
  if (bad.empty()) bad = score.Check();
  if (bad.empty()) bad = selection_grid.Check();
  if (bad.empty()) bad = refine_grid.Check();
  if (bad.empty()) bad = icp.Check();
  if (bad.empty()) bad = mhpo.Check();
  if (bad.empty()) bad = appearance.Check();
  if (!bad.empty()) return bad;
  std::ostringstream out;
  if (num_hypotheses < 1) out << "SolverOptions.num_hypotheses must be >= 1 (got " << num_hypotheses << ")";
  else if (max_observed_points < 10) out << "SolverOptions.max_observed_points must be >= 10 (got " << max_observed_points << ")";
  else if (max_source_points < 10) out << "SolverOptions.max_source_points must be >= 10 (got " << max_source_points << ")";
  else if (min_valid_depth_pixels < 3) out << "SolverOptions.min_valid_depth_pixels must be >= 3 (got " << min_valid_depth_pixels << ")";
  else if (!(distinct_pose_fraction >= 0.0 && distinct_pose_fraction < 1.0)) out << "SolverOptions.distinct_pose_fraction must be in [0, 1) (got " << distinct_pose_fraction << ")";
  else if (!(ambiguity_distance_fraction > 0.0 && ambiguity_distance_fraction < 10.0)) out << "SolverOptions.ambiguity_distance_fraction must be in (0, 10) (got " << ambiguity_distance_fraction << ")";
  else if (!(ambiguity_margin >= 0.0 && ambiguity_margin < 2.0)) out << "SolverOptions.ambiguity_margin must be in [0, 2) (got " << ambiguity_margin << ")";
  else if (!(appearance_margin >= 0.0 && appearance_margin < 2.0)) out << "SolverOptions.appearance_margin must be in [0, 2) (got " << appearance_margin << ")";
  else if (!(appearance_min_gain >= 0.0 && appearance_min_gain <= 2.0)) out << "SolverOptions.appearance_min_gain must be in [0, 2] (got " << appearance_min_gain << ")";
  else if (!std::isfinite(budget_ms)) out << "SolverOptions.budget_ms must be finite (got " << budget_ms << ")";
  else if (!(confidence_score_weight < 0.0)) out << "SolverOptions.confidence_score_weight must be < 0 (got " << confidence_score_weight << ")";
  else if (!std::isfinite(confidence_bias) || !std::isfinite(confidence_ambiguous_weight)) out << "SolverOptions.confidence_bias and confidence_ambiguous_weight must be finite";
  return out.str();
}

const char* TerminationName(Termination termination) {
  switch (termination) {
    case Termination::kNotRun: return "not_run";
    case Termination::kConverged: return "converged";
    case Termination::kEarlyStopped: return "early_stopped";
    case Termination::kCutShort: return "cut_short";
    case Termination::kBadInput: return "bad_input";
    case Termination::kNoHypothesis: return "no_hypothesis";
  }
  return "unknown";
}

double ConfidenceFromScore(const SolverOptions& options, double score, bool ambiguous) {
  if (!std::isfinite(score)) return 0.0;
  const double logit = options.confidence_bias + options.confidence_score_weight * score +
                       (ambiguous ? options.confidence_ambiguous_weight : 0.0);
  return 1.0 / (1.0 + std::exp(-logit));
}

namespace {

// Returns an empty string when the inputs can be used, else what is wrong.
std::string ValidateInputs(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                           const SolverOptions& options) {
  std::ostringstream out;
  const std::string bad_camera = frame.camera.Check();
  const std::string bad_options = options.Check();
  const cv::Size size(frame.camera.width, frame.camera.height);
  if (!bad_options.empty()) out << "bad solver options: " << bad_options;
  else if (!bad_camera.empty()) out << "bad camera intrinsics: " << bad_camera;
  else if (frame.rgb.type() != CV_8UC3 || frame.rgb.size() != size)
    out << "rgb must be CV_8UC3 of " << size.width << "x" << size.height << " (got type " << frame.rgb.type() << ", " << frame.rgb.cols << "x" << frame.rgb.rows << ")";
  else if (frame.depth.type() != CV_32F || frame.depth.size() != size)
    out << "depth must be CV_32F metres of " << size.width << "x" << size.height << " (got type " << frame.depth.type() << ", " << frame.depth.cols << "x" << frame.depth.rows << ")";
  else if (instance.mask.type() != CV_8U || instance.mask.size() != size)
    out << "mask must be CV_8U of " << size.width << "x" << size.height << " (got type " << instance.mask.type() << ", " << instance.mask.cols << "x" << instance.mask.rows << ")";
  else if (instance.object_id != bank.object_id)
    out << "the template bank is for object '" << bank.object_id << "', not '" << instance.object_id << "'";
  else if (bank.templates.empty() || bank.online_mesh.faces.empty() || !(bank.diameter_m > 0.0))
    out << "the template bank for '" << bank.object_id << "' is empty";
  return out.str();
}

bool TouchesBorder(const cv::Rect& box, const cv::Size& size) {
  return box.x == 0 || box.y == 0 || box.x + box.width == size.width || box.y + box.height == size.height;
}

// Observed normals: from the depth kNormalReachPx pixels to each side, all within
// kNormalMaxStepM of the centre depth (a larger step is an edge or a flying pixel).
constexpr int kNormalReachPx = 2;
constexpr float kNormalMaxStepM = 0.02f;

// The observed data of one instance, shared read-only by every hypothesis.
struct Observation {
  cv::Mat mask;              // CV_8U 0/255, frame size
  cv::Mat depth;             // CV_32F metres, NaN patched to 0
  cv::Rect box;              // mask bounding box
  double z_m = 0.0;          // robust z_M (median; eq. (9) uses the mean)
  int valid_depth = 0;       // mask pixels with valid depth
  bool truncated = false;    // the mask touches the image border
  std::unique_ptr<PointCloudIndex> observed;  // Y: observed points inside the mask
  EvaluationGrid selection_grid, refine_grid;
};

// Fills *observation; returns an empty string, or what is wrong with the input.
std::string PrepareObservation(const Frame& frame, const Instance& instance, const SolverOptions& options,
                               Observation* observation) {
  observation->mask = instance.mask > 0;
  const cv::Mat& mask = observation->mask;
  observation->box = cv::boundingRect(mask);
  const cv::Rect& box = observation->box;
  if (box.area() == 0) return "the instance mask is empty";
  observation->truncated = TouchesBorder(box, mask.size());
  if (options.reject_border_masks && observation->truncated) {
    return "the instance mask touches the image border (object truncated; solved unless reject_border_masks)";
  }
  observation->depth = frame.depth.clone();
  cv::Mat& depth = observation->depth;
  cv::patchNaNs(depth, 0.0);
  int& valid_depth = observation->valid_depth;
  observation->z_m = MedianMaskedDepth(mask, depth, &valid_depth);  // eq. (9), robust
  if (valid_depth < options.min_valid_depth_pixels) {
    return "the mask has " + std::to_string(valid_depth) + " pixels with valid depth (need " +
           std::to_string(options.min_valid_depth_pixels) + ")";
  }
  // Observed cloud Y, deterministic image-space subsampling; for point-to-plane ICP also a
  // normal per point from its depth neighbours (zero where a neighbour is missing, off the
  // mask or across a depth step).
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(valid_depth) / options.max_observed_points))));
  const int reach = kNormalReachPx;
  auto neighbour = [&](int u, int v, float z, Eigen::Vector3d* point) {
    if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows || !mask.at<uint8_t>(v, u)) return false;
    const float zn = depth.at<float>(v, u);
    if (!(zn > 0.0f) || std::abs(zn - z) > kNormalMaxStepM) return false;
    *point = frame.camera.Backproject(PixelCentre(u, v), zn);
    return true;
  };
  std::vector<Eigen::Vector3d> observed, normals;
  for (int v = box.y + stride / 2; v < box.y + box.height; v += stride) {
    for (int u = box.x + stride / 2; u < box.x + box.width; u += stride) {
      const float z = depth.at<float>(v, u);
      if (!mask.at<uint8_t>(v, u) || !(z > 0.0f)) continue;
      const Eigen::Vector3d point = frame.camera.Backproject(PixelCentre(u, v), z);
      observed.push_back(point);
      if (!options.icp.point_to_plane) continue;
      Eigen::Vector3d left, right, up, down, normal = Eigen::Vector3d::Zero();
      if (neighbour(u - reach, v, z, &left) && neighbour(u + reach, v, z, &right) && neighbour(u, v - reach, z, &up) &&
          neighbour(u, v + reach, z, &down)) {
        normal = (right - left).cross(down - up);
        const double length = normal.norm();
        normal = length > 0.0 ? Eigen::Vector3d(normal / length) : Eigen::Vector3d::Zero();
        if (normal.dot(point) > 0.0) normal = -normal;  // towards the camera
      }
      normals.push_back(normal);
    }
  }
  observation->observed = options.icp.point_to_plane
                              ? std::make_unique<PointCloudIndex>(std::move(observed), std::move(normals))
                              : std::make_unique<PointCloudIndex>(std::move(observed));
  observation->selection_grid = MakeEvaluationGrid(frame.camera, mask, depth, options.selection_grid);
  observation->refine_grid = MakeEvaluationGrid(frame.camera, mask, depth, options.refine_grid);
  return "";
}

// Visible model points of a rendering on `grid` at `cam_from_object`, in the object frame:
// the ICP source. Pixels hidden behind an unmasked occluder (outside the mask, observed
// depth in front) are left out: nothing observed can match them. Parts outside the image
// are never on the grid.
std::vector<Eigen::Vector3d> VisibleModelPoints(const Mesh& mesh, const EvaluationGrid& grid,
                                                const Eigen::Isometry3d& cam_from_object,
                                                const ScoreOptions& score_options, int max_points,
                                                RasterImage* scratch) {
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  const Camera& camera = grid.camera;
  Rasterize(mesh, camera, cam_from_object, raster_options, scratch);
  const int count = std::max(1, scratch->pixel_count);
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count) / max_points))));
  const Eigen::Isometry3d object_from_cam = cam_from_object.inverse();
  std::vector<Eigen::Vector3d> points;
  for (int v = stride / 2; v < scratch->depth.rows; v += stride) {
    const float* row = scratch->depth.ptr<float>(v);
    const uint8_t* mask = grid.mask.ptr<uint8_t>(v);
    const float* observed = grid.depth.ptr<float>(v);
    for (int u = stride / 2; u < scratch->depth.cols; u += stride) {
      if (!(row[u] > 0.0f)) continue;
      if (!mask[u] && IsOccluded(row[u], observed[u], score_options)) continue;
      points.push_back(object_from_cam * camera.Backproject(PixelCentre(u, v), row[u]));
    }
  }
  return points;
}

// The symmetries of the shape: the mesh's geometric ones and those the user gave (BOP
// models_info.json) as discrete ones.
MeshSymmetries ShapeSymmetries(const TemplateBank& bank) {
  MeshSymmetries symmetries = bank.geometric_symmetries;
  for (const Eigen::Isometry3d& g : bank.symmetries) symmetries.discrete.push_back(g);
  return symmetries;
}

// The symmetries under which two poses are the same answer: the shape's, except the
// geometric ones of a coloured model. A printed box's 180-degree flips have the same shape
// but not the same print: they must stay apart (as hypotheses and as finalists) so that
// appearance can choose between them.
MeshSymmetries AnswerSymmetries(const TemplateBank& bank) {
  if (bank.appearance.Empty()) return ShapeSymmetries(bank);
  MeshSymmetries symmetries;
  symmetries.discrete = bank.symmetries;
  return symmetries;
}

// Up to `count` vertices of the online mesh (even stride): the points of pose distances.
std::vector<Eigen::Vector3d> DistancePoints(const Mesh& mesh, size_t count) {
  std::vector<Eigen::Vector3d> points;
  const size_t step = std::max<size_t>(1, mesh.vertices.size() / count);
  for (size_t i = 0; i < mesh.vertices.size(); i += step) points.push_back(mesh.vertices[i].cast<double>());
  return points;
}

struct Finalist {
  Eigen::Isometry3d cam_from_object;
  PoseScore score;
};

// Among the finalists (T_A last): drops poses equal modulo the symmetries to a better one,
// lets appearance pick among those within options.appearance_margin of the best S, and
// sets the runner-up and the ambiguity flag of *result (whose T_A and details it may replace).
void ResolveFinalists(const SolverOptions& options, const TemplateBank& bank, const Frame& frame, const cv::Mat& mask,
                      const MeshSymmetries& symmetries, const std::vector<Eigen::Vector3d>& distance_points,
                      std::vector<Finalist> finalists, PoseResult* result) {
  StageReport& stages = result->stages;
  std::stable_sort(finalists.begin(), finalists.end(),
                   [](const Finalist& a, const Finalist& b) { return a.score.s < b.score.s; });
  const double same_m = options.ambiguity_distance_fraction * bank.diameter_m;
  std::vector<Finalist> distinct;
  for (const Finalist& f : finalists) {
    bool is_new = true;
    for (size_t k = 0; k < distinct.size() && is_new; ++k) {
      is_new = SymmetricPoseDistance(symmetries, distance_points, f.cam_from_object, distinct[k].cam_from_object) > same_m;
    }
    if (is_new) distinct.push_back(f);
  }
  stages.distinct_finalists = static_cast<int>(distinct.size());
  size_t chosen = 0;
  std::vector<AppearanceScore> appearance(distinct.size());
  if (options.appearance_tiebreak && !bank.appearance.Empty()) {
    for (size_t k = 0; k < distinct.size(); ++k) {
      if (distinct[k].score.s > distinct[0].score.s + options.appearance_margin) break;
      appearance[k] = ScoreAppearance(options.appearance, bank.appearance, bank.online_mesh, frame.camera, frame.rgb, mask,
                                      distinct[k].cam_from_object);
      ++stages.appearance_compared;
    }
    // Only a valid comparison can overrule S: a pose whose visible model colours are
    // uniform (invalid score) is neither better nor worse in appearance.
    for (size_t k = 1; k < distinct.size() && appearance[0].valid; ++k) {
      if (appearance[k].valid && appearance[k].agreement > appearance[chosen].agreement + options.appearance_min_gain) {
        chosen = k;
      }
    }
  }
  if (chosen != 0) stages.appearance_changed = true;
  result->cam_from_object = distinct[chosen].cam_from_object;
  result->details = distinct[chosen].score;
  result->appearance_valid = appearance[chosen].valid;
  result->appearance_agreement = appearance[chosen].agreement;
  // Runner-up: the best distinct finalist by S that is not the answer moved by a
  // symmetry of the shape (a printed box's flip that appearance cannot tell apart is the
  // same shape: a symmetry, reported at build time, not an ambiguity).
  const MeshSymmetries shape_symmetries = ShapeSymmetries(bank);
  for (size_t k = 0; k < distinct.size(); ++k) {
    if (k == chosen) continue;
    if (SymmetricPoseDistance(shape_symmetries, distance_points, distinct[k].cam_from_object, distinct[chosen].cam_from_object) <=
        same_m) {
      continue;
    }
    result->has_runner_up = true;
    result->runner_up_cam_from_object = distinct[k].cam_from_object;
    result->runner_up_score = distinct[k].score.s;
    result->runner_up_appearance_valid = appearance[k].valid;
    result->runner_up_appearance_agreement = appearance[k].agreement;
    const bool appearance_separates = appearance[chosen].valid && appearance[k].valid &&
                                      appearance[chosen].agreement > appearance[k].agreement + options.appearance_min_gain;
    result->ambiguous = distinct[k].score.s < distinct[chosen].score.s + options.ambiguity_margin && !appearance_separates;
    break;
  }
}

// Stage 6 hypotheses from T_A: its 180-degree flips about the bounding-box axes through
// the box centre (the usual confusions of near-symmetric shapes), and each of those plus
// T_A itself re-centred: the box centre moved onto the ray through the mask box centre,
// at z_M plus a quarter diameter (the centre lies behind the visible surface).
std::vector<Eigen::Isometry3d> PostRefineHypotheses(const Eigen::Isometry3d& cam_from_object, const TemplateBank& bank,
                                                    const Camera& camera, const cv::Rect& box, double z_m) {
  const Eigen::Vector3d centre = bank.bounding_box.center();
  std::vector<Eigen::Isometry3d> poses = {cam_from_object};
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
    flip.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
    flip.translation() = centre - flip.linear() * centre;  // about the box centre
    poses.push_back(cam_from_object * flip);
  }
  const Eigen::Vector2d box_centre(box.x + 0.5 * box.width, box.y + 0.5 * box.height);
  const Eigen::Vector3d target_centre = camera.Backproject(box_centre, z_m + 0.25 * bank.diameter_m);
  const size_t n = poses.size();
  for (size_t i = 0; i < n; ++i) {
    Eigen::Isometry3d moved = poses[i];
    moved.translation() += target_centre - poses[i] * centre;
    poses.push_back(moved);
  }
  return poses;
}

}  // namespace

PoseScore ScoreInstancePose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                            const SolverOptions& options, const Eigen::Isometry3d& cam_from_object) {
  const std::string bad = ValidateInputs(frame, instance, bank, options);
  if (!bad.empty()) G6D_THROW(bad);
  Observation observation;
  const std::string bad_observation = PrepareObservation(frame, instance, options, &observation);
  if (!bad_observation.empty()) G6D_THROW(bad_observation);
  RasterImage scratch;
  return ScorePose(observation.refine_grid, bank.online_mesh, cam_from_object, observation.z_m, options.score, &scratch);
}

PoseResult EstimatePose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                        const SolverOptions& options, Executor* executor) {
  PoseResult result;
  StageReport& stages = result.stages;
  const Stopwatch total;
  // Past the deadline every stage keeps only what is needed to return a pose: the first
  // PnP pose found, its score; `skipped` records that work was left out.
  const Deadline deadline(options.budget_ms, options.stop_requested);
  std::atomic<bool> skipped{false};
  auto out_of_time = [&]() {
    if (!deadline.Expired()) return false;
    skipped = true;
    return true;
  };
  auto fail = [&](Termination termination, const std::string& message) {
    result.success = false;
    result.termination = termination;
    result.message = message;
    stages.total_ms = total.ElapsedMs();
    return result;
  };
  try {
    const std::string bad = ValidateInputs(frame, instance, bank, options);
    if (!bad.empty()) return fail(Termination::kBadInput, bad);

    // ---- prepare the observation
    Stopwatch watch;
    Observation observation;
    const std::string bad_observation = PrepareObservation(frame, instance, options, &observation);
    if (!bad_observation.empty()) return fail(Termination::kBadInput, bad_observation);
    const cv::Mat& mask = observation.mask;
    const cv::Mat& depth = observation.depth;
    const cv::Rect& box = observation.box;
    const double z_m = observation.z_m;
    const PointCloudIndex& observed_index = *observation.observed;
    const EvaluationGrid& selection_grid = observation.selection_grid;
    const EvaluationGrid& refine_grid = observation.refine_grid;
    result.truncated = observation.truncated;
    stages.prepare_ms = watch.ElapsedMs();

    // ---- stage 1: features and template matching
    watch.Restart();
    const NormalizedCrop crop = NormalizeCrop(frame.rgb, mask, bank.options.crop);
    const std::vector<Feature> query = DetectOrb(crop, options.query_orb);
    stages.query_features = static_cast<int>(query.size());
    stages.features_ms = watch.ElapsedMs();
    watch.Restart();
    std::vector<CorrespondenceSet> sets;
    MatchReport match_report;
    MatchTemplates(options.match, query, bank, executor, &sets, &match_report);
    stages.match_ms = watch.ElapsedMs();
    stages.correspondence_sets = static_cast<int>(sets.size());
    stages.best_quality = match_report.best_quality;
    if (!match_report.success) return fail(Termination::kNoHypothesis, "matching: " + match_report.message);
    {
      // Template seed: the best template's rotation, translated onto the mask centre at z_M.
      const Template& best = bank.templates[static_cast<size_t>(sets.front().template_index)];
      const Eigen::Vector3d centre = bank.bounding_box.center();
      const Eigen::Vector2d mask_centre(box.x + 0.5 * box.width, box.y + 0.5 * box.height);
      stages.seed_pose.linear() = best.cam_from_object.linear();
      stages.seed_pose.translation() =
          frame.camera.Backproject(mask_centre, z_m) - best.cam_from_object.linear() * centre;
    }

    // ---- stage 2: MSAC-PnP per correspondence set
    watch.Restart();
    const double projected_size_px = std::max(box.width, box.height);
    std::vector<Eigen::Vector2d> query_image_points(query.size());
    for (size_t i = 0; i < query.size(); ++i) {
      query_image_points[i] = query[i].xy.cast<double>() + Eigen::Vector2d::Constant(kOpenCvToImage);
    }
    const std::vector<Eigen::Vector3d> query_points_in_cam =
        BackprojectKeypoints(frame.camera, depth, mask, query_image_points);
    PnpPrior prior;
    prior.z_m = z_m;
    prior.diameter_m = bank.diameter_m;
    prior.centre_in_object = bank.bounding_box.center();
    prior.query_points_in_cam = &query_points_in_cam;
    std::vector<PnpResult> pnp(sets.size());
    std::atomic<bool> any_pose{false};
    executor->ParallelFor(static_cast<int>(sets.size()), [&](int i) {
      if (any_pose && out_of_time()) return;
      PnpResult& p = pnp[static_cast<size_t>(i)];
      EstimatePnp(options.pnp, sets[static_cast<size_t>(i)], frame.camera, projected_size_px, prior, &p);
      if (p.success) any_pose = true;
    });
    std::vector<Eigen::Isometry3d> hypotheses;
    for (const PnpResult& p : pnp) {
      if (p.success) hypotheses.push_back(p.cam_from_object);
    }
    stages.pnp_ms = watch.ElapsedMs();
    stages.pnp_hypotheses = static_cast<int>(hypotheses.size());
    if (hypotheses.empty()) return fail(Termination::kNoHypothesis, "MSAC-PnP found no valid pose in " + std::to_string(sets.size()) + " correspondence sets");
    stages.pnp_pose = hypotheses.front();  // from the best-ranked template with a valid pose

    // ---- stage 3: observable selection (eq. 7)
    watch.Restart();
    const MeshSymmetries symmetries = AnswerSymmetries(bank);
    const std::vector<Eigen::Vector3d> distance_points = DistancePoints(bank.online_mesh, 64);
    std::vector<PoseScore> observable(hypotheses.size());
    executor->ParallelFor(static_cast<int>(hypotheses.size()), [&](int i) {
      if (i > 0 && out_of_time()) return;  // unscored: E_obs stays at its worst
      RasterImage scratch;
      observable[static_cast<size_t>(i)] = ScorePose(selection_grid, bank.online_mesh, hypotheses[static_cast<size_t>(i)], z_m, options.score, &scratch);
    });
    std::vector<int> order(hypotheses.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return observable[static_cast<size_t>(a)].e_obs < observable[static_cast<size_t>(b)].e_obs;
    });
    // K slots for distinct poses: a hypothesis equal (modulo the symmetries) to a better
    // one already kept adds nothing.
    const double distinct_m = options.distinct_pose_fraction * bank.diameter_m;
    std::vector<Eigen::Isometry3d> kept;
    std::vector<int> kept_order;
    for (int i : order) {
      if (kept.size() >= static_cast<size_t>(options.num_hypotheses)) break;
      if (!kept.empty() && out_of_time()) break;
      const Eigen::Isometry3d& pose = hypotheses[static_cast<size_t>(i)];
      bool distinct = true;
      for (size_t k = 0; k < kept.size() && distinct; ++k) {
        distinct = SymmetricPoseDistance(symmetries, distance_points, pose, kept[k]) > distinct_m;
      }
      if (!distinct) continue;
      kept.push_back(pose);
      kept_order.push_back(i);
    }
    order = kept_order;
    stages.kept_hypotheses = static_cast<int>(kept.size());
    stages.best_e_obs = observable[static_cast<size_t>(order.front())].e_obs;
    stages.observable_pose = kept.front();
    stages.pnp_poses = hypotheses;
    stages.kept_poses = kept;
    stages.observable_ms = watch.ElapsedMs();

    // ---- stage 4: trimmed ICP on depth, every kept hypothesis independently
    watch.Restart();
    std::vector<PoseScore> icp_scores(kept.size());
    std::vector<int> icp_ok(kept.size(), 0);
    executor->ParallelFor(static_cast<int>(kept.size()), [&](int k) {
      if (k > 0 && out_of_time()) return;  // not refined, not scored: S stays at its worst
      RasterImage scratch;
      Eigen::Isometry3d& pose = kept[static_cast<size_t>(k)];
      if (options.run_icp && !(k == 0 && out_of_time())) {
        const std::vector<Eigen::Vector3d> source =
            VisibleModelPoints(bank.online_mesh, refine_grid, pose, options.score, options.max_source_points, &scratch);
        IcpReport icp_report;
        RefineByTrimmedIcp(options.icp, source, observed_index, bank.diameter_m, &pose, &icp_report);
        icp_ok[static_cast<size_t>(k)] = icp_report.success;
      }
      icp_scores[static_cast<size_t>(k)] = ScorePose(refine_grid, bank.online_mesh, pose, z_m, options.score, &scratch);
    });
    int best_after_icp = 0;
    for (size_t k = 0; k < kept.size(); ++k) {
      stages.icp_converged += icp_ok[k];
      if (icp_scores[k].s < icp_scores[static_cast<size_t>(best_after_icp)].s) best_after_icp = static_cast<int>(k);
    }
    stages.best_s_after_icp = icp_scores[static_cast<size_t>(best_after_icp)].s;
    stages.icp_pose = kept[static_cast<size_t>(best_after_icp)];
    stages.icp_ms = watch.ElapsedMs();

    // ---- stage 5: MHPO, best state over all hypotheses and rounds (T_A, S_A)
    watch.Restart();
    result.cam_from_object = stages.icp_pose;
    result.details = icp_scores[static_cast<size_t>(best_after_icp)];
    result.termination = Termination::kConverged;
    if (options.run_mhpo && !out_of_time()) {
      const MhpoTarget target = MakeMhpoTarget(refine_grid, z_m);
      Eigen::Isometry3d best;
      RefineByMhpo(options.mhpo, options.score, target, bank.online_mesh, kept, executor, &best, &stages.mhpo,
                   &deadline);
      if (stages.mhpo.cut_short) skipped = true;
      if (stages.mhpo.success && stages.mhpo.best_score.s <= result.details.s) {
        result.cam_from_object = best;
        result.details = stages.mhpo.best_score;
      }
      if (stages.mhpo.early_stopped) result.termination = Termination::kEarlyStopped;
    }
    stages.mhpo_ms = watch.ElapsedMs();

    // Finalists: every hypothesis' best state, for the runner-up and appearance.
    std::vector<Finalist> finalists;
    for (size_t k = 0; k < kept.size(); ++k) {
      const bool refined = options.run_mhpo && stages.mhpo.success && k < stages.mhpo.hypotheses.size();
      finalists.push_back(refined ? Finalist{stages.mhpo.hypotheses[k].best_cam_from_object, stages.mhpo.hypotheses[k].best_score}
                                  : Finalist{kept[k], icp_scores[k]});
    }

    // ---- stage 6 (optional): post-refinement of a poor T_A
    if (options.post_refine && result.details.s > options.post_refine_trigger_s && !out_of_time()) {
      watch.Restart();
      stages.post_refine_ran = true;
      std::vector<Eigen::Isometry3d> extra = PostRefineHypotheses(result.cam_from_object, bank, frame.camera, box, z_m);
      executor->ParallelFor(static_cast<int>(extra.size()), [&](int k) {
        RasterImage scratch;
        Eigen::Isometry3d& pose = extra[static_cast<size_t>(k)];
        const std::vector<Eigen::Vector3d> source =
            VisibleModelPoints(bank.online_mesh, refine_grid, pose, options.score, options.max_source_points, &scratch);
        IcpReport icp_report;
        RefineByTrimmedIcp(options.icp, source, observed_index, bank.diameter_m, &pose, &icp_report);
      });
      const MhpoTarget target = MakeMhpoTarget(refine_grid, z_m);
      Eigen::Isometry3d best;
      MhpoReport report;
      RefineByMhpo(options.mhpo, options.score, target, bank.online_mesh, extra, executor, &best, &report);
      if (report.success && report.best_score.s < result.details.s - options.post_refine_margin) {
        result.cam_from_object = best;
        result.details = report.best_score;
        stages.post_refine_accepted = true;
      }
      stages.post_refine_ms = watch.ElapsedMs();
    }
    // ---- finalists: merge symmetric duplicates, appearance tie-break, ambiguity
    watch.Restart();
    finalists.push_back(Finalist{result.cam_from_object, result.details});  // T_A (stage 6 may have moved it)
    if (!out_of_time()) {
      ResolveFinalists(options, bank, frame, mask, symmetries, distance_points, std::move(finalists), &result);
    }
    stages.finalists_ms = watch.ElapsedMs();
    result.score = result.details.s;
    result.confidence = ConfidenceFromScore(options, result.score, result.ambiguous);
    result.success = true;
    result.message = "ok";
    if (skipped) {
      result.cut_short = true;
      result.termination = Termination::kCutShort;
      std::ostringstream message;
      message << "ok, cut short after " << static_cast<int>(deadline.ElapsedMs()) << " ms ("
              << (deadline.Stopped() ? "stop requested" : "budget " + std::to_string(static_cast<int>(options.budget_ms)) + " ms")
              << "): the best pose so far";
      result.message = message.str();
    }
    stages.total_ms = total.ElapsedMs();
    return result;
  } catch (const std::exception& e) {
    // Library code reports bad data through the result; an exception here is a bug or
    // an unexpected input that a lower layer refused. It must not escape to the caller.
    return fail(Termination::kBadInput, std::string("internal error: ") + e.what());
  }
}

}  // namespace g6d
