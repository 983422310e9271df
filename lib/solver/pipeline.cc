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
#include "solver/depth_regions.h"
#include "solver/mask_stage.h"
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
  if (bad.empty()) bad = region.Check();
  if (bad.empty()) bad = segments.Check();
  if (bad.empty()) bad = ppf.Check();
  if (!bad.empty()) return bad;
  std::ostringstream out;
  if (num_hypotheses < 1) out << "SolverOptions.num_hypotheses must be >= 1 (got " << num_hypotheses << ")";
  else if (ppf_hypotheses < 0) out << "SolverOptions.ppf_hypotheses must be >= 0 (got " << ppf_hypotheses << ")";
  else if (region_candidates < 0 || region_candidates > 16) out << "SolverOptions.region_candidates must be in [0, 16] (got " << region_candidates << ")";
  else if (!(region_search_confidence >= 0.0 && region_search_confidence <= 1.0)) out << "SolverOptions.region_search_confidence must be in [0, 1] (got " << region_search_confidence << ")";
  else if (!(neighbour_min_fraction > 0.0 && neighbour_min_fraction <= 1.0)) out << "SolverOptions.neighbour_min_fraction must be in (0, 1] (got " << neighbour_min_fraction << ")";
  else if (max_search_regions < 0 || max_search_regions > 8) out << "SolverOptions.max_search_regions must be in [0, 8] (got " << max_search_regions << ")";
  else if (max_observed_points < 10) out << "SolverOptions.max_observed_points must be >= 10 (got " << max_observed_points << ")";
  else if (max_source_points < 10) out << "SolverOptions.max_source_points must be >= 10 (got " << max_source_points << ")";
  else if (min_valid_depth_pixels < 3) out << "SolverOptions.min_valid_depth_pixels must be >= 3 (got " << min_valid_depth_pixels << ")";
  else if (icp_coarse_points < 0) out << "SolverOptions.icp_coarse_points must be >= 0 (got " << icp_coarse_points << ")";
  else if (icp_probe_iterations < 0) out << "SolverOptions.icp_probe_iterations must be >= 0 (got " << icp_probe_iterations << ")";
  else if (icp_finish_hypotheses < 1) out << "SolverOptions.icp_finish_hypotheses must be >= 1 (got " << icp_finish_hypotheses << ")";
  else if (!(pnp_min_quality_ratio >= 0.0 && pnp_min_quality_ratio <= 1.0)) out << "SolverOptions.pnp_min_quality_ratio must be in [0, 1] (got " << pnp_min_quality_ratio << ")";
  else if (mask_refine_rounds < 0) out << "SolverOptions.mask_refine_rounds must be >= 0 (got " << mask_refine_rounds << ")";
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

std::vector<StageTime> StageTimes(const StageReport& s) {
  return {{"prepare", s.prepare_ms},     {"features", s.features_ms},       {"match", s.match_ms},
          {"pnp", s.pnp_ms},             {"ppf", s.ppf_ms},                 {"observable", s.observable_ms},   {"icp", s.icp_ms},
          {"mhpo", s.mhpo_ms},           {"post_refine", s.post_refine_ms}, {"finalists", s.finalists_ms},
          {"mask_refine", s.mask_refine_ms}, {"depth_regions", s.depth_regions_ms},
          {"neighbours", s.neighbours_ms},       {"total", s.total_ms}};
}

void CopyMaskSolveReport(const StageReport& from, StageReport* to) {
  to->prepare_ms = from.prepare_ms;
  to->features_ms = from.features_ms;
  to->match_ms = from.match_ms;
  to->pnp_ms = from.pnp_ms;
  to->observable_ms = from.observable_ms;
  to->icp_ms = from.icp_ms;
  to->mhpo_ms = from.mhpo_ms;
  to->post_refine_ms = from.post_refine_ms;
  to->finalists_ms = from.finalists_ms;
  to->mask_refine_ms = from.mask_refine_ms;
  to->depth_regions_ms = from.depth_regions_ms;
  to->mask_given_pixels = from.mask_given_pixels;
  to->mask_wider_than_object = from.mask_wider_than_object;
  to->mask_too_thin = from.mask_too_thin;
  to->mask_is_box = from.mask_is_box;
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

// Visible model points of a rendering on `grid` at `cam_from_object`, in the object frame:
// the ICP source. Pixels hidden behind an unmasked occluder (outside the mask, observed
// depth in front) are left out: nothing observed can match them; with `inside_mask_only`
// every pixel outside the observed mask is. Parts outside the image are never on the grid.
// With `normals`, also the unit normal (object frame) of the face each point lies on.
std::vector<Eigen::Vector3d> VisibleModelPoints(const Mesh& mesh, const EvaluationGrid& grid,
                                                const Eigen::Isometry3d& cam_from_object,
                                                const ScoreOptions& score_options, int max_points,
                                                bool inside_mask_only, RasterImage* scratch,
                                                std::vector<Eigen::Vector3d>* normals = nullptr) {
  RasterOptions raster_options;
  raster_options.want_face_id = normals != nullptr;
  raster_options.cull_backfaces = score_options.cull_backfaces;
  const Camera& camera = grid.camera;
  Rasterize(mesh, camera, cam_from_object, raster_options, scratch);
  const int count = std::max(1, scratch->pixel_count);
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count) / max_points))));
  const Eigen::Isometry3d object_from_cam = cam_from_object.inverse();
  std::vector<Eigen::Vector3d> points;
  if (normals != nullptr) normals->clear();
  for (int v = stride / 2; v < scratch->depth.rows; v += stride) {
    const float* row = scratch->depth.ptr<float>(v);
    const uint8_t* mask = grid.mask.ptr<uint8_t>(v);
    const float* observed = grid.depth.ptr<float>(v);
    for (int u = stride / 2; u < scratch->depth.cols; u += stride) {
      if (!(row[u] > 0.0f)) continue;
      if (!mask[u] && (inside_mask_only || IsOccluded(row[u], observed[u], score_options))) continue;
      points.push_back(object_from_cam * camera.Backproject(PixelCentre(u, v), row[u]));
      if (normals == nullptr) continue;
      const Eigen::Vector3i& face = mesh.faces[static_cast<size_t>(scratch->face_id.at<int32_t>(v, u))];
      const Eigen::Vector3d a = mesh.vertices[static_cast<size_t>(face[0])].cast<double>();
      const Eigen::Vector3d normal =
          (mesh.vertices[static_cast<size_t>(face[1])].cast<double>() - a).cross(mesh.vertices[static_cast<size_t>(face[2])].cast<double>() - a);
      const double length = normal.norm();
      normals->push_back(length > 0.0 ? Eigen::Vector3d(normal / length) : Eigen::Vector3d::Zero());
    }
  }
  return points;
}

// One trimmed ICP run of at most `max_iterations` from *cam_from_object, on a source of
// at most `max_points` visible model points rendered there (with their normals for
// point-to-plane).
IcpReport RunIcpFrom(const SolverOptions& options, const Mesh& mesh, const EvaluationGrid& grid,
                     const ScoreOptions& score_options, const PointCloudIndex& observed, double diameter_m,
                     int max_points, int max_iterations, RasterImage* scratch, Eigen::Isometry3d* cam_from_object) {
  std::vector<Eigen::Vector3d> normals;
  const std::vector<Eigen::Vector3d> source =
      VisibleModelPoints(mesh, grid, *cam_from_object, score_options, max_points, options.icp_source_in_mask, scratch,
                         options.icp.point_to_plane ? &normals : nullptr);
  IcpOptions icp = options.icp;
  icp.max_iterations = max_iterations;
  IcpReport report;
  RefineByTrimmedIcp(icp, source, observed, diameter_m, cam_from_object, &report,
                     options.icp.point_to_plane ? &normals : nullptr);
  return report;
}

// *result marked failed with `termination` and `message`, its total time taken from
// `total`; returns a copy for the caller to return.
PoseResult Failed(Termination termination, const std::string& message, const Stopwatch& total, PoseResult* result) {
  result->success = false;
  result->termination = termination;
  result->message = message;
  result->stages.total_ms = total.ElapsedMs();
  return *result;
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
  int hypothesis = -1;  // index of the kept hypothesis it came from; -1 = none (stage 6)
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
  stages.answer_hypothesis = distinct[chosen].hypothesis;
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

// Shares of SolverOptions::budget_ms after which a stage starts no new work, so that a
// tight budget still reaches ICP and MHPO on the best hypotheses instead of being spent
// on PnP for every template. They are where the stages end in a median LM-O solve at
// K = 18 (bench/RESULTS.md, issue 13): matching at 17%, PnP 48%, selection 55%, ICP 85%;
// a budget at or above the usual solve time therefore cuts nothing.
constexpr double kPnpBudgetShare = 0.5;
constexpr double kObservableBudgetShare = 0.6;
constexpr double kIcpBudgetShare = 0.85;

// The deadline of one solve, and whether work was skipped because of it.
class SolveClock {
 public:
  explicit SolveClock(const SolverOptions& options) : deadline_(options.budget_ms, options.stop_requested) {}
  // True, and records that work was skipped, once `share` of the budget is used up (or a
  // stop was requested).
  bool OutOfTime(double share = 1.0) {
    if (!deadline_.ExpiredAt(share)) return false;
    skipped_ = true;
    return true;
  }
  void MarkSkipped() { skipped_ = true; }
  bool Skipped() const { return skipped_; }
  const Deadline& deadline() const { return deadline_; }

 private:
  Deadline deadline_;
  std::atomic<bool> skipped_{false};
};

// Pose comparison modulo symmetries (mean distance of model points, as ADD), with a cheap
// lower bound that settles most pairs of distant poses: for any symmetry g,
// mean |a x - b g x| >= |a c - b g c| >= |a c - b c| - |c - g c|, c the points' centroid,
// and |c - g c| <= reach_ for every g.
class PoseComparer {
 public:
  PoseComparer(const MeshSymmetries& symmetries, std::vector<Eigen::Vector3d> points)
      : symmetries_(symmetries), points_(std::move(points)) {
    for (const Eigen::Vector3d& x : points_) centroid_ += x;
    centroid_ /= static_cast<double>(std::max<size_t>(1, points_.size()));
    for (const Eigen::Isometry3d& g : symmetries_.discrete) reach_ = std::max(reach_, (g * centroid_ - centroid_).norm());
    if (symmetries_.revolution) {
      const Eigen::Vector3d axis = symmetries_.axis.normalized();
      const Eigen::Vector3d offset = centroid_ - symmetries_.point;
      reach_ += 2.0 * (offset - offset.dot(axis) * axis).norm();
    }
  }
  const MeshSymmetries& symmetries() const { return symmetries_; }
  const std::vector<Eigen::Vector3d>& points() const { return points_; }
  // True when a and b are within `distance_m` of each other modulo the symmetries.
  bool Within(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double distance_m) const {
    if ((a * centroid_ - b * centroid_).norm() - reach_ > distance_m) return false;
    return SymmetricPoseDistance(symmetries_, points_, a, b) <= distance_m;
  }

 private:
  MeshSymmetries symmetries_;
  std::vector<Eigen::Vector3d> points_;
  Eigen::Vector3d centroid_ = Eigen::Vector3d::Zero();
  double reach_ = 0.0;
};

// A pose hypothesis and the rank (by Q_j, 0 = best) of the correspondence set it came from
// (-1: a point-pair-feature pose).
struct Hypothesis {
  Eigen::Isometry3d cam_from_object;
  int set_rank = 0;
};

// Everything the stages share for one instance.
struct SolveContext {
  const Frame& frame;
  const TemplateBank& bank;
  const SolverOptions& options;
  Executor* executor;
  const Observation& observation;
  const PoseComparer& comparer;      // modulo the answer symmetries
  ScoreOptions online_score;         // options.score, culling set for the online mesh
  ScoreOptions selection_score;      // the same for the selection mesh
  const Mesh* selection_mesh;        // the coarse mesh, or the online mesh
  SolveClock* clock;
  StageReport* stages;
};

// Stage 2: MSAC-PnP on every correspondence set (in rank order, down to
// options.pnp_min_quality_ratio of the best Q), then the poses equal modulo the symmetries
// to a better-ranked one are merged (options.merge_pnp_poses). Past the PnP share of the
// budget no new set starts once one pose exists.
std::vector<Hypothesis> RunPnpStage(const SolveContext& c, const Observation::SearchRegion& region,
                                    const std::vector<CorrespondenceSet>& sets, const std::vector<Feature>& query) {
  const SolverOptions& options = c.options;
  const Observation& observation = c.observation;
  const double projected_size_px = std::max(region.box.width, region.box.height);
  std::vector<Eigen::Vector2d> query_image_points(query.size());
  for (size_t i = 0; i < query.size(); ++i) {
    query_image_points[i] = query[i].xy.cast<double>() + Eigen::Vector2d::Constant(kOpenCvToImage);
  }
  const std::vector<Eigen::Vector3d> query_points_in_cam =
      BackprojectKeypoints(c.frame.camera, observation.depth, region.mask, query_image_points);
  PnpPrior prior;
  prior.z_m = region.z_m;
  prior.diameter_m = c.bank.diameter_m;
  prior.centre_in_object = c.bank.bounding_box.center();
  prior.query_points_in_cam = &query_points_in_cam;
  int tried = static_cast<int>(sets.size());
  for (int i = 1; i < tried; ++i) {
    if (sets[static_cast<size_t>(i)].quality < options.pnp_min_quality_ratio * sets.front().quality) tried = i;
  }
  std::vector<PnpResult> pnp(static_cast<size_t>(tried));
  std::atomic<bool> any_pose{false};
  c.executor->ParallelFor(tried, [&](int i) {
    if (any_pose && c.clock->OutOfTime(kPnpBudgetShare)) return;
    PnpResult& p = pnp[static_cast<size_t>(i)];
    EstimatePnp(options.pnp, sets[static_cast<size_t>(i)], c.frame.camera, projected_size_px, prior, &p);
    if (p.success) any_pose = true;
  });
  c.stages->sets_tried = tried;
  std::vector<Hypothesis> hypotheses;
  const double distinct_m = options.distinct_pose_fraction * c.bank.diameter_m;
  for (int i = 0; i < tried; ++i) {
    const PnpResult& p = pnp[static_cast<size_t>(i)];
    if (!p.success) continue;
    ++c.stages->pnp_hypotheses;
    c.stages->pnp_poses.push_back(p.cam_from_object);
    bool distinct = true;
    if (options.merge_pnp_poses) {
      for (size_t k = 0; k < hypotheses.size() && distinct; ++k) {
        distinct = !c.comparer.Within(p.cam_from_object, hypotheses[k].cam_from_object, distinct_m);
      }
    }
    if (distinct) hypotheses.push_back(Hypothesis{p.cam_from_object, i});
  }
  c.stages->pnp_merged = c.stages->pnp_hypotheses - static_cast<int>(hypotheses.size());
  return hypotheses;
}

// Stage 3: observable selection (eq. 7). Every hypothesis is rendered on the selection
// grid and ranked by E_obs; the first options.num_hypotheses distinct ones are kept.
std::vector<Hypothesis> SelectObservable(const SolveContext& c, const std::vector<Hypothesis>& hypotheses) {
  const SolverOptions& options = c.options;
  std::vector<PoseScore> observable(hypotheses.size());
  c.executor->ParallelFor(static_cast<int>(hypotheses.size()), [&](int i) {
    if (i > 0 && c.clock->OutOfTime(kObservableBudgetShare)) return;  // unscored: E_obs stays at its worst
    RasterImage scratch;
    observable[static_cast<size_t>(i)] = ScorePose(c.observation.selection_grid, *c.selection_mesh,
                                                   hypotheses[static_cast<size_t>(i)].cam_from_object,
                                                   c.observation.z_m, c.selection_score, &scratch);
  });
  std::vector<int> order(hypotheses.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return observable[static_cast<size_t>(a)].e_obs < observable[static_cast<size_t>(b)].e_obs;
  });
  // K slots for distinct poses: a hypothesis equal (modulo the symmetries) to a better
  // one already kept adds nothing (all distinct already when the PnP poses were merged).
  const double distinct_m = options.distinct_pose_fraction * c.bank.diameter_m;
  std::vector<Hypothesis> kept;
  // The PnP poses fill the K slots as in the paper; the point-pair-feature poses have slots
  // of their own beyond K (options.ppf_hypotheses, the best of them by E_obs), so that a
  // depth-voted pose never takes a textured object's PnP pose's place.
  int ppf_kept = 0;
  for (int i : order) {
    if (hypotheses[static_cast<size_t>(i)].set_rank < 0) {
      if (ppf_kept >= options.ppf_hypotheses) continue;
      ++ppf_kept;
      kept.push_back(hypotheses[static_cast<size_t>(i)]);
      if (kept.size() == 1) c.stages->best_e_obs = observable[static_cast<size_t>(i)].e_obs;
      continue;
    }
    if (static_cast<int>(kept.size()) - ppf_kept >= options.num_hypotheses) continue;
    if (!kept.empty() && c.clock->OutOfTime(kObservableBudgetShare)) break;
    const Hypothesis& h = hypotheses[static_cast<size_t>(i)];
    bool distinct = true;
    for (size_t k = 0; k < kept.size() && distinct && !options.merge_pnp_poses; ++k) {
      distinct = !c.comparer.Within(h.cam_from_object, kept[k].cam_from_object, distinct_m);
    }
    if (!distinct) continue;
    if (kept.empty()) c.stages->best_e_obs = observable[static_cast<size_t>(i)].e_obs;
    kept.push_back(h);
  }
  return kept;
}

// Stage 4: trimmed ICP on depth for every kept hypothesis. Coarse to fine: each runs to
// convergence on options.icp_coarse_points source points first (the long slides from a
// poor start cost a quarter), then on the full source from there. With
// options.icp_probe_iterations > 0, every hypothesis first gets only that many coarse
// iterations and is scored (S); only the options.icp_finish_hypotheses best by S go on.
// Returns each hypothesis' score after ICP; refines the poses in place.
std::vector<PoseScore> RefineHypothesesByIcp(const SolveContext& c, std::vector<Hypothesis>* kept) {
  const SolverOptions& options = c.options;
  const size_t n = kept->size();
  std::vector<PoseScore> scores(n);
  std::vector<int> iterations(n, 0), converged(n, 0), unfinished(n, 0), at_max(n, 0);
  // One ICP run of at most `max_iterations` on a source of at most `max_points`.
  auto run_icp = [&](size_t k, int max_points, int max_iterations, RasterImage* scratch) {
    const IcpReport report = RunIcpFrom(options, c.bank.online_mesh, c.observation.refine_grid, c.online_score,
                                        *c.observation.observed, c.bank.diameter_m, max_points, max_iterations,
                                        scratch, &(*kept)[k].cam_from_object);
    iterations[k] += report.iterations;
    converged[k] = report.success;
    unfinished[k] = report.success && report.iterations >= max_iterations;
    at_max[k] += unfinished[k];
  };
  const bool coarse = options.icp_coarse_points > 0 && options.icp_coarse_points < options.max_source_points;
  // Coarse (unless `probe_only`, to convergence), fine, then S.
  auto refine = [&](size_t k, bool probe_only) {
    RasterImage scratch;
    if (options.run_icp) {
      if (probe_only) {
        run_icp(k, coarse ? options.icp_coarse_points : options.max_source_points, options.icp_probe_iterations, &scratch);
      } else {
        if (coarse) run_icp(k, options.icp_coarse_points, options.icp.max_iterations, &scratch);
        run_icp(k, options.max_source_points, options.icp.max_iterations, &scratch);
      }
    }
    scores[k] = ScorePose(c.observation.refine_grid, c.bank.online_mesh, (*kept)[k].cam_from_object, c.observation.z_m,
                          c.online_score, &scratch);
  };
  const bool two_pass = options.run_icp && options.icp_probe_iterations > 0;
  c.executor->ParallelFor(static_cast<int>(n), [&](int k) {
    if (k > 0 && c.clock->OutOfTime(kIcpBudgetShare)) return;  // not refined, not scored: S stays at its worst
    refine(static_cast<size_t>(k), two_pass);
  });
  if (two_pass) {
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return scores[static_cast<size_t>(a)].s < scores[static_cast<size_t>(b)].s;
    });
    std::vector<size_t> finish;
    for (int k : order) {
      if (finish.size() >= static_cast<size_t>(options.icp_finish_hypotheses)) break;
      if (unfinished[static_cast<size_t>(k)]) finish.push_back(static_cast<size_t>(k));
    }
    c.executor->ParallelFor(static_cast<int>(finish.size()), [&](int i) {
      if (c.clock->OutOfTime(kIcpBudgetShare)) return;
      refine(finish[static_cast<size_t>(i)], false);
    });
    c.stages->icp_finished = static_cast<int>(finish.size());
  }
  for (size_t k = 0; k < n; ++k) {
    c.stages->icp_converged += converged[k];
    c.stages->icp_iterations += iterations[k];
    c.stages->icp_runs_at_max += at_max[k];
  }
  return scores;
}

// The mask stage's findings in the report: truncation and what the depth changed.
void ReportObservation(const Observation& observation, PoseResult* result) {
  StageReport& stages = result->stages;
  result->truncated = observation.truncated;
  stages.mask_given_pixels = observation.region.given_pixels;
  stages.mask_support_leak = observation.region.support_leak;
  stages.mask_far_leak = observation.region.far_leak;
  stages.support_plane = observation.region.has_plane;
  stages.surface_tolerance_m = observation.region.surface_tolerance_m;
  stages.mask_wider_than_object = observation.wider_than_object;
  stages.mask_is_box = observation.is_box;
}

// The context of one solve: the score options per mesh (back faces culled only on closed
// meshes) and the selection mesh (the coarse one when the bank has it).
SolveContext MakeSolveContext(const Frame& frame, const TemplateBank& bank, const SolverOptions& options,
                              Executor* executor, const Observation& observation, const PoseComparer& comparer,
                              SolveClock* clock, StageReport* stages) {
  SolveContext context{frame, bank, options, executor, observation, comparer, observation.score, observation.score,
                       &bank.online_mesh, clock, stages};
  context.online_score.cull_backfaces = options.cull_backfaces && bank.online_mesh_closed;
  const bool coarse = options.coarse_selection_mesh && !bank.selection_mesh.faces.empty();
  context.selection_mesh = coarse ? &bank.selection_mesh : &bank.online_mesh;
  context.selection_score.cull_backfaces =
      options.cull_backfaces && (coarse ? bank.selection_mesh_closed : bank.online_mesh_closed);
  // Observable selection ranks PnP poses before any refinement, their depth often
  // centimetres off: the depth cannot judge them yet (a pose 2 cm too far would have every
  // mask pixel "in front of it", an occluder). It reads the region the depth corrected, as
  // the paper reads the mask; the depth's evidence enters from ICP on.
  context.selection_score.depth_evidence = false;
  return context;
}

// What the search found: the correspondence sets (best Q first) and the PnP hypotheses.
struct Search {
  std::vector<CorrespondenceSet> sets;
  std::vector<Hypothesis> hypotheses;
};

// Stages 1 and 2 on one search region: ORB on its normalized crop, template matching
// (correspondence sets ranked by Q_j), MSAC-PnP per set with equal poses merged. The sets
// are appended to search->sets and the hypotheses (their ranks into it) to `hypotheses`.
// Returns an empty string, or why this region gave no set.
std::string SearchOneRegion(const SolveContext& c, const Observation::SearchRegion& region, Search* search,
                         std::vector<Hypothesis>* hypotheses) {
  StageReport& stages = *c.stages;
  Stopwatch watch;
  const NormalizedCrop crop = NormalizeCrop(c.frame.rgb, region.mask, c.bank.options.crop);
  const std::vector<Feature> query = DetectOrb(crop, c.options.query_orb);
  stages.query_features += static_cast<int>(query.size());
  stages.features_ms += watch.ElapsedMs();
  watch.Restart();
  std::vector<CorrespondenceSet> sets;
  MatchReport match_report;
  MatchTemplates(c.options.match, query, c.bank, c.executor, &sets, &match_report);
  stages.match_ms += watch.ElapsedMs();
  stages.correspondence_sets += static_cast<int>(sets.size());
  stages.best_quality = std::max(stages.best_quality, match_report.best_quality);
  if (!match_report.success) return "matching: " + match_report.message;
  if (search->sets.empty()) {
    // Template seed: the best template's rotation, translated onto the region centre at z_M.
    const Template& best = c.bank.templates[static_cast<size_t>(sets.front().template_index)];
    const Eigen::Vector2d centre(region.box.x + 0.5 * region.box.width, region.box.y + 0.5 * region.box.height);
    stages.seed_pose.linear() = best.cam_from_object.linear();
    stages.seed_pose.translation() =
        c.frame.camera.Backproject(centre, region.z_m) - best.cam_from_object.linear() * c.bank.bounding_box.center();
  }
  watch.Restart();
  const int tried_before = stages.sets_tried;
  *hypotheses = RunPnpStage(c, region, sets, query);
  stages.sets_tried += tried_before;
  const int offset = static_cast<int>(search->sets.size());
  for (Hypothesis& h : *hypotheses) h.set_rank += offset;
  search->sets.insert(search->sets.end(), sets.begin(), sets.end());
  stages.pnp_ms += watch.ElapsedMs();
  return "";
}

// Stages 1 and 2 on every search region (the whole region first), the hypotheses pooled:
// one equal (modulo the symmetries) to an earlier region's is dropped. Returns an empty
// string, or why no hypothesis came out (the solve's kNoHypothesis).
std::string RunSearchStages(const SolveContext& c, Search* search) {
  StageReport& stages = *c.stages;
  std::string why_not;
  const double distinct_m = c.options.distinct_pose_fraction * c.bank.diameter_m;
  for (const Observation::SearchRegion& region : c.observation.search_regions) {
    if (!search->hypotheses.empty() && c.clock->OutOfTime(kPnpBudgetShare)) break;
    std::vector<Hypothesis> found;
    const std::string why = SearchOneRegion(c, region, search, &found);
    if (why_not.empty()) why_not = why;
    for (const Hypothesis& h : found) {
      bool distinct = true;
      for (size_t k = 0; k < search->hypotheses.size() && distinct && c.options.merge_pnp_poses; ++k) {
        distinct = !c.comparer.Within(h.cam_from_object, search->hypotheses[k].cam_from_object, distinct_m);
      }
      if (distinct) search->hypotheses.push_back(h);
    }
    ++stages.search_regions;
  }
  if (search->sets.empty()) return why_not;
  if (search->hypotheses.empty()) {
    return "MSAC-PnP found no valid pose in " + std::to_string(stages.sets_tried) + " correspondence sets";
  }
  stages.pnp_pose = search->hypotheses.front().cam_from_object;  // from the best-ranked template with a valid pose
  return "";
}

// Point-pair-feature voting on the first search region's depth (the mask the depth
// corrected and grew): its poses join the PnP hypotheses, those equal to one already there
// (modulo the symmetries) merged into it.
void RunPpfStage(const SolveContext& c, Search* search) {
  if (!c.options.use_ppf || c.bank.ppf.empty() || c.observation.search_regions.empty()) return;
  if (!search->hypotheses.empty() && c.clock->OutOfTime(kPnpBudgetShare)) return;
  StageReport& stages = *c.stages;
  const Stopwatch watch;
  const PpfModel& model = c.bank.ppf;
  const PpfScene scene = MakePpfScene(c.frame.camera, c.observation.depth, c.observation.search_regions.front().mask,
                                      model.step_m, model.options.normal_cluster_deg, c.options.ppf);
  PpfReport report;
  const std::vector<PpfPose> poses = VotePpfPoses(model, scene, c.bank.diameter_m, c.options.ppf, c.executor, &report);
  stages.ppf_scene_points = report.scene_points;
  stages.ppf_hypotheses = static_cast<int>(poses.size());
  const double distinct_m = c.options.distinct_pose_fraction * c.bank.diameter_m;
  const size_t pnp_count = search->hypotheses.size();
  for (const PpfPose& pose : poses) {
    stages.ppf_poses.push_back(pose.cam_from_object);
    bool distinct = true;
    for (size_t k = 0; k < pnp_count && distinct && c.options.merge_pnp_poses; ++k) {
      distinct = !c.comparer.Within(pose.cam_from_object, search->hypotheses[k].cam_from_object, distinct_m);
    }
    if (!distinct) continue;
    search->hypotheses.push_back(Hypothesis{pose.cam_from_object, -1});
    ++stages.ppf_distinct;
  }
  stages.ppf_ms = watch.ElapsedMs();
}

// Stage 3 with its report: the K hypotheses kept by E_obs.
std::vector<Hypothesis> RunObservableStage(const SolveContext& c, const std::vector<Hypothesis>& hypotheses) {
  const Stopwatch watch;
  std::vector<Hypothesis> kept = SelectObservable(c, hypotheses);
  c.stages->kept_hypotheses = static_cast<int>(kept.size());
  c.stages->observable_pose = kept.front().cam_from_object;
  for (const Hypothesis& h : kept) c.stages->kept_poses.push_back(h.cam_from_object);
  c.stages->observable_ms = watch.ElapsedMs();
  return kept;
}

// The kept hypotheses after ICP, their scores and the best of them.
struct IcpOutcome {
  std::vector<Eigen::Isometry3d> refined;
  std::vector<PoseScore> scores;
  int best = 0;
};

// Stage 4 with its report: trimmed ICP on every kept hypothesis (in place), then S.
IcpOutcome RunIcpStage(const SolveContext& c, std::vector<Hypothesis>* kept) {
  const Stopwatch watch;
  IcpOutcome outcome;
  outcome.scores = RefineHypothesesByIcp(c, kept);
  for (const Hypothesis& h : *kept) outcome.refined.push_back(h.cam_from_object);
  for (size_t k = 0; k < kept->size(); ++k) {
    if (outcome.scores[k].s < outcome.scores[static_cast<size_t>(outcome.best)].s) outcome.best = static_cast<int>(k);
  }
  c.stages->best_s_after_icp = outcome.scores[static_cast<size_t>(outcome.best)].s;
  c.stages->icp_pose = outcome.refined[static_cast<size_t>(outcome.best)];
  c.stages->icp_ms = watch.ElapsedMs();
  return outcome;
}

// Stage 5: MHPO from the ICP poses, T_A and S_A the best state over all hypotheses and
// rounds (the best ICP pose when MHPO does not improve on it). Returns every hypothesis'
// best state, the finalists for the runner-up and appearance.
std::vector<Finalist> RunMhpoStage(const SolveContext& c, const MhpoTarget& target, const std::vector<Hypothesis>& kept,
                                   const IcpOutcome& icp, PoseResult* result) {
  const SolverOptions& options = c.options;
  StageReport& stages = *c.stages;
  const Stopwatch watch;
  result->cam_from_object = stages.icp_pose;
  result->details = icp.scores[static_cast<size_t>(icp.best)];
  stages.answer_hypothesis = icp.best;
  result->termination = Termination::kConverged;
  if (options.run_mhpo && !c.clock->OutOfTime()) {
    Eigen::Isometry3d best;
    RefineByMhpo(options.mhpo, c.online_score, target, c.bank.online_mesh, icp.refined, c.executor, &best, &stages.mhpo,
                 &c.clock->deadline(), &icp.scores);
    if (stages.mhpo.cut_short) c.clock->MarkSkipped();
    if (stages.mhpo.success && stages.mhpo.best_score.s <= result->details.s) {
      result->cam_from_object = best;
      result->details = stages.mhpo.best_score;
      stages.answer_hypothesis = stages.mhpo.best_hypothesis;
    }
    if (stages.mhpo.early_stopped) result->termination = Termination::kEarlyStopped;
  }
  stages.mhpo_ms = watch.ElapsedMs();
  std::vector<Finalist> finalists;
  for (size_t k = 0; k < kept.size(); ++k) {
    const bool mhpo_ran = options.run_mhpo && stages.mhpo.success && k < stages.mhpo.hypotheses.size();
    finalists.push_back(mhpo_ran ? Finalist{stages.mhpo.hypotheses[k].best_cam_from_object, stages.mhpo.hypotheses[k].best_score, static_cast<int>(k)}
                                 : Finalist{icp.refined[k], icp.scores[k], static_cast<int>(k)});
  }
  return finalists;
}

// Stage 6 (options.post_refine): a poor T_A (S above the trigger) is tried again from its
// flips and re-centred copies (PostRefineHypotheses), ICP + MHPO, accepted by a margin.
void RunPostRefineStage(const SolveContext& c, const MhpoTarget& target, PoseResult* result) {
  const SolverOptions& options = c.options;
  const Observation& observation = c.observation;
  if (!options.post_refine || !(result->details.s > options.post_refine_trigger_s) || c.clock->OutOfTime()) return;
  StageReport& stages = *c.stages;
  const Stopwatch watch;
  stages.post_refine_ran = true;
  std::vector<Eigen::Isometry3d> extra =
      PostRefineHypotheses(result->cam_from_object, c.bank, c.frame.camera, observation.box, observation.z_m);
  c.executor->ParallelFor(static_cast<int>(extra.size()), [&](int k) {
    RasterImage scratch;
    RunIcpFrom(options, c.bank.online_mesh, observation.refine_grid, c.online_score, *observation.observed,
               c.bank.diameter_m, options.max_source_points, options.icp.max_iterations, &scratch,
               &extra[static_cast<size_t>(k)]);
  });
  Eigen::Isometry3d best;
  MhpoReport report;
  RefineByMhpo(options.mhpo, c.online_score, target, c.bank.online_mesh, extra, c.executor, &best, &report);
  if (report.success && report.best_score.s < result->details.s - options.post_refine_margin) {
    result->cam_from_object = best;
    result->details = report.best_score;
    stages.post_refine_accepted = true;
    stages.answer_hypothesis = -1;
  }
  stages.post_refine_ms = watch.ElapsedMs();
}

// The finalists (T_A last, as stage 6 may have moved it): symmetric duplicates merged,
// appearance tie-break, runner-up and ambiguity; then where the answer came from.
void RunFinalistStage(const SolveContext& c, std::vector<Finalist> finalists, const std::vector<Hypothesis>& kept,
                      const std::vector<CorrespondenceSet>& sets, PoseResult* result) {
  StageReport& stages = *c.stages;
  const Stopwatch watch;
  finalists.push_back(Finalist{result->cam_from_object, result->details, stages.answer_hypothesis});
  if (!c.clock->OutOfTime()) {
    ResolveFinalists(c.options, c.bank, c.frame, c.observation.mask, c.comparer.symmetries(), c.comparer.points(),
                     std::move(finalists), result);
  }
  stages.finalists_ms = watch.ElapsedMs();
  if (stages.answer_hypothesis >= 0) {
    const int rank = kept[static_cast<size_t>(stages.answer_hypothesis)].set_rank;
    stages.answer_from_ppf = rank < 0;
    if (rank >= 0) {
      stages.answer_set_rank = rank;
      stages.answer_quality_ratio = sets[static_cast<size_t>(rank)].quality / sets.front().quality;
    }
  }
}

// S_A, the confidence and the message of a successful solve (cut short: says so).
void FinishAnswer(const SolverOptions& options, const SolveClock& clock, PoseResult* result) {
  result->score = result->details.s;
  result->confidence = ConfidenceFromScore(options, result->score, result->ambiguous);
  result->success = true;
  result->message = "ok";
  if (!clock.Skipped()) return;
  result->cut_short = true;
  result->termination = Termination::kCutShort;
  std::ostringstream message;
  message << "ok, cut short after " << static_cast<int>(clock.deadline().ElapsedMs()) << " ms ("
          << (clock.deadline().Stopped() ? "stop requested" : "budget " + std::to_string(static_cast<int>(options.budget_ms)) + " ms")
          << "): the best pose so far";
  result->message = message.str();
}

}  // namespace

PoseScore ScoreInstancePose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                            const SolverOptions& options, const Eigen::Isometry3d& cam_from_object) {
  const std::string bad = ValidateInputs(frame, instance, bank, options);
  if (!bad.empty()) G6D_THROW(bad);
  Observation observation;
  const std::string bad_observation = PrepareObservation(frame, instance, options, bank.diameter_m, &observation);
  if (!bad_observation.empty()) G6D_THROW(bad_observation);
  RasterImage scratch;
  return ScorePose(observation.refine_grid, bank.online_mesh, cam_from_object, observation.z_m, observation.score,
                   &scratch);
}

namespace {

// The solve on the caller's mask (the paper's pipeline, the mask read as evidence).
PoseResult EstimatePoseOnMask(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                              const SolverOptions& options, Executor* executor) {
  PoseResult result;
  StageReport& stages = result.stages;
  const Stopwatch total;
  // Past the deadline every stage keeps only what is needed to return a pose: the first
  // PnP pose found, its score; the clock records that work was left out.
  SolveClock clock(options);
  auto fail = [&](Termination termination, const std::string& message) {
    return Failed(termination, message, total, &result);
  };
  try {
    const std::string bad = ValidateInputs(frame, instance, bank, options);
    if (!bad.empty()) return fail(Termination::kBadInput, bad);
    Stopwatch watch;
    Observation observation;  // the mask stage (mask_stage.h): the mask as evidence
    const std::string bad_observation = PrepareObservation(frame, instance, options, bank.diameter_m, &observation);
    if (!bad_observation.empty()) {
      stages.mask_too_thin = observation.too_thin;
      stages.mask_is_box = observation.is_box;
      return fail(Termination::kBadInput, bad_observation);
    }
    ReportObservation(observation, &result);
    const PoseComparer comparer(AnswerSymmetries(bank), DistancePoints(bank.online_mesh, 64));
    const SolveContext context = MakeSolveContext(frame, bank, options, executor, observation, comparer, &clock, &stages);
    stages.prepare_ms = watch.ElapsedMs();

    Search search;  // stages 1 and 2: features, template matching, MSAC-PnP
    const std::string no_hypothesis = RunSearchStages(context, &search);
    RunPpfStage(context, &search);  // texture-free hypotheses from the depth
    if (search.hypotheses.empty()) {
      return fail(Termination::kNoHypothesis,
                  no_hypothesis.empty() ? std::string("no hypothesis from ORB-PnP or point-pair features")
                                        : no_hypothesis + (context.bank.ppf.empty() || !options.use_ppf
                                                               ? std::string()
                                                               : "; point-pair features gave no pose"));
    }
    std::vector<Hypothesis> kept = RunObservableStage(context, search.hypotheses);  // stage 3 (eq. 7)
    const IcpOutcome icp = RunIcpStage(context, &kept);                              // stage 4
    const MhpoTarget target = MakeMhpoTarget(observation.refine_grid, observation.z_m);
    std::vector<Finalist> finalists = RunMhpoStage(context, target, kept, icp, &result);  // stage 5: T_A, S_A
    RunPostRefineStage(context, target, &result);                                    // stage 6 (optional)
    RunFinalistStage(context, std::move(finalists), kept, search.sets, &result);     // runner-up, appearance
    watch.Restart();                                                                 // the mask refined with the pose
    RefineWithCorrectedMask(frame, instance, bank, options, observation, context.online_score,
                            [&clock] { return clock.OutOfTime(); }, executor, &result);
    stages.mask_refine_ms = watch.ElapsedMs();
    FinishAnswer(options, clock, &result);
    stages.total_ms = total.ElapsedMs();
    return result;
  } catch (const std::exception& e) {
    // Library code reports bad data through the result; an exception here is a bug or
    // an unexpected input that a lower layer refused. It must not escape to the caller.
    return fail(Termination::kBadInput, std::string("internal error: ") + e.what());
  }
}

}  // namespace

PoseResult EstimatePose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                        const SolverOptions& options, Executor* executor) {
  return SolveOnDepthRegions(frame, instance, bank, options, executor,  // depth_regions.h
                             EstimatePoseOnMask(frame, instance, bank, options, executor));
}

std::string TrackSolveOptions::Check() const {
  std::ostringstream out;
  if (icp_iterations < 0) out << "TrackSolveOptions.icp_iterations must be >= 0 (got " << icp_iterations << ")";
  else if (max_source_points < 10) out << "TrackSolveOptions.max_source_points must be >= 10 (got " << max_source_points << ")";
  else if (max_observed_points < 10) out << "TrackSolveOptions.max_observed_points must be >= 10 (got " << max_observed_points << ")";
  else if (mhpo_rounds < 0) out << "TrackSolveOptions.mhpo_rounds must be >= 0 (got " << mhpo_rounds << ")";
  else if (!(appearance_search_deg >= 0.0 && appearance_search_deg <= 180.0)) out << "TrackSolveOptions.appearance_search_deg must be in [0, 180] (got " << appearance_search_deg << ")";
  else if (!(appearance_step_deg > 0.0)) out << "TrackSolveOptions.appearance_step_deg must be > 0 (got " << appearance_step_deg << ")";
  return out.str();
}

PoseResult TrackPose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                     const SolverOptions& options, const TrackSolveOptions& track_options,
                     const std::vector<Eigen::Isometry3d>& starts, Executor* executor) {
  PoseResult result;
  StageReport& stages = result.stages;
  const Stopwatch total;
  auto fail = [&](Termination termination, const std::string& message) {
    return Failed(termination, message, total, &result);
  };
  try {
    std::string bad = ValidateInputs(frame, instance, bank, options);
    if (bad.empty()) bad = track_options.Check();
    if (bad.empty() && starts.empty()) bad = "no start pose to track from";
    if (!bad.empty()) return fail(Termination::kBadInput, bad);

    Stopwatch watch;
    SolverOptions prepare_options = options;
    prepare_options.max_observed_points = track_options.max_observed_points;
    Observation observation;
    const std::string bad_observation = PrepareObservation(frame, instance, prepare_options, bank.diameter_m, &observation);
    if (!bad_observation.empty()) return fail(Termination::kBadInput, bad_observation);
    result.truncated = observation.truncated;
    ScoreOptions online_score = observation.score;
    online_score.cull_backfaces = options.cull_backfaces && bank.online_mesh_closed;
    stages.prepare_ms = watch.ElapsedMs();

    // ICP from every start, then S.
    watch.Restart();
    std::vector<Eigen::Isometry3d> poses = starts;
    std::vector<PoseScore> scores(poses.size());
    std::vector<IcpReport> reports(poses.size());
    executor->ParallelFor(static_cast<int>(poses.size()), [&](int k) {
      RasterImage scratch;
      Eigen::Isometry3d& pose = poses[static_cast<size_t>(k)];
      if (options.run_icp && track_options.icp_iterations > 0) {
        reports[static_cast<size_t>(k)] =
            RunIcpFrom(options, bank.online_mesh, observation.refine_grid, online_score, *observation.observed,
                       bank.diameter_m, track_options.max_source_points, track_options.icp_iterations, &scratch, &pose);
      }
      scores[static_cast<size_t>(k)] =
          ScorePose(observation.refine_grid, bank.online_mesh, pose, observation.z_m, online_score, &scratch);
    });
    size_t best = 0;
    for (size_t k = 0; k < poses.size(); ++k) {
      stages.icp_iterations += reports[k].iterations;
      stages.icp_converged += reports[k].success;
      if (scores[k].s < scores[best].s) best = k;
    }
    stages.kept_hypotheses = static_cast<int>(poses.size());
    stages.best_s_after_icp = scores[best].s;
    stages.icp_pose = poses[best];
    result.cam_from_object = poses[best];
    result.details = scores[best];
    stages.answer_hypothesis = static_cast<int>(best);
    stages.icp_ms = watch.ElapsedMs();

    // MHPO from the ICP results: the best state over starts and rounds.
    watch.Restart();
    result.termination = Termination::kConverged;
    if (options.run_mhpo && track_options.mhpo_rounds > 0) {
      MhpoOptions mhpo = options.mhpo;
      mhpo.max_rounds = track_options.mhpo_rounds;
      const MhpoTarget target = MakeMhpoTarget(observation.refine_grid, observation.z_m);
      Eigen::Isometry3d refined;
      RefineByMhpo(mhpo, online_score, target, bank.online_mesh, poses, executor, &refined, &stages.mhpo, nullptr,
                   &scores);
      if (stages.mhpo.success && stages.mhpo.best_score.s <= result.details.s) {
        result.cam_from_object = refined;
        result.details = stages.mhpo.best_score;
        stages.answer_hypothesis = stages.mhpo.best_hypothesis;
      }
      if (stages.mhpo.early_stopped) result.termination = Termination::kEarlyStopped;
    }
    stages.mhpo_ms = watch.ElapsedMs();

    // A coloured surface of revolution: its turn about the axis, by appearance.
    const MeshSymmetries& shape = bank.geometric_symmetries;
    if (track_options.appearance_search_deg > 0.0 && shape.revolution && !bank.appearance.Empty() &&
        options.appearance_tiebreak) {
      watch.Restart();
      RasterImage scratch;
      const int steps = static_cast<int>(std::floor(track_options.appearance_search_deg / track_options.appearance_step_deg));
      const Eigen::Isometry3d refined = result.cam_from_object;
      for (int k = -steps; k <= steps; ++k) {
        Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
        turn.linear() = Eigen::AngleAxisd(k * track_options.appearance_step_deg * M_PI / 180.0, shape.axis).toRotationMatrix();
        turn.translation() = shape.point - turn.linear() * shape.point;
        const Eigen::Isometry3d pose = refined * turn;
        const AppearanceScore appearance = ScoreAppearance(options.appearance, bank.appearance, bank.online_mesh, frame.camera,
                                                           frame.rgb, observation.mask, pose, &scratch);
        ++stages.appearance_compared;
        if (!appearance.valid || (result.appearance_valid && appearance.agreement <= result.appearance_agreement)) continue;
        result.appearance_valid = true;
        result.appearance_agreement = appearance.agreement;
        result.cam_from_object = pose;
      }
      if (!result.cam_from_object.isApprox(refined)) {
        stages.appearance_changed = true;
        result.details = ScorePose(observation.refine_grid, bank.online_mesh, result.cam_from_object, observation.z_m,
                                   online_score, &scratch);
      }
      stages.finalists_ms = watch.ElapsedMs();
    } else if (track_options.score_appearance && !bank.appearance.Empty() && options.appearance_tiebreak) {
      // Any other coloured mesh: the agreement of the answer, for the caller's loss test
      // (a flip onto a shape symmetry scores as well by S but not by appearance).
      watch.Restart();
      const AppearanceScore appearance = ScoreAppearance(options.appearance, bank.appearance, bank.online_mesh,
                                                         frame.camera, frame.rgb, observation.mask, result.cam_from_object);
      ++stages.appearance_compared;
      result.appearance_valid = appearance.valid;
      result.appearance_agreement = appearance.agreement;
      stages.finalists_ms = watch.ElapsedMs();
    }
    result.score = result.details.s;
    result.confidence = ConfidenceFromScore(options, result.score, false);
    result.success = true;
    result.message = "ok";
    stages.total_ms = total.ElapsedMs();
    return result;
  } catch (const std::exception& e) {
    return fail(Termination::kBadInput, std::string("internal error: ") + e.what());
  }
}

}  // namespace g6d
