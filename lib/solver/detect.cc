#include "solver/detect.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <mutex>
#include <numeric>
#include <set>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/timer.h"
#include "render/raster.h"
#include "solver/frame_check.h"
#include "solver/mask_solve.h"
#include "solver/ppf.h"
#include "solver/proposals.h"

namespace g6d {

namespace {

// What answers may claim as they are admitted one after the other: each object's count of
// instances, and the frame's pixels (an answer sharing more than max_overlap of its own with
// those admitted before is refused). The selection and the identity check's replacements
// admit answers by the same tests.
class AnswerSlots {
 public:
  AnswerSlots(const Frame& frame, const std::vector<DetectRequest>& requests, const DetectOptions& options)
      : requests_(requests), options_(options), answered_(requests.size(), 0),
        taken_(cv::Mat::zeros(frame.depth.size(), CV_8U)) {}

  // The pixels an answer claims: its corrected mask, or its region without one.
  static const cv::Mat& Pixels(const Detection& detection) {
    return detection.result.corrected_mask.empty() ? detection.region : detection.result.corrected_mask;
  }
  // Its object still wants an instance, it claims pixels, few of them taken, and it explains
  // the frame around it (DetectOptions::max_free_space, min_contour_support).
  bool Admits(const Detection& detection) const {
    const size_t r = static_cast<size_t>(detection.request);
    const cv::Mat& mask = Pixels(detection);
    const int pixels = cv::countNonZero(mask);
    const bool explains_frame = detection.check.free_space <= options_.max_free_space &&
                                detection.check.contour_support >= options_.min_contour_support;
    return answered_[r] < requests_[r].count && pixels > 0 && explains_frame &&
           cv::countNonZero(mask & taken_) <= options_.max_overlap * pixels;
  }
  void Take(const Detection& detection) {
    ++answered_[static_cast<size_t>(detection.request)];
    taken_ |= Pixels(detection);
  }

 private:
  const std::vector<DetectRequest>& requests_;
  const DetectOptions& options_;
  std::vector<int> answered_;
  cv::Mat taken_;
};

}  // namespace

std::vector<Detection> SelectAnswers(const Frame& frame, const std::vector<DetectRequest>& requests,
                                     const DetectOptions& options, const std::vector<Detection>& solved,
                                     int* suppressed) {
  std::vector<size_t> order(solved.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const PoseResult& x = solved[a].result;
    const PoseResult& y = solved[b].result;
    const bool x_sure = x.confidence >= options.sure_first_confidence;
    const bool y_sure = y.confidence >= options.sure_first_confidence;
    if (x_sure != y_sure) return x_sure;
    return x.score < y.score;
  });
  AnswerSlots slots(frame, requests, options);
  std::vector<Detection> kept;
  *suppressed = 0;
  for (size_t i : order) {
    const Detection& detection = solved[i];
    if (detection.result.score > options.max_score || detection.result.confidence < options.min_confidence ||
        !slots.Admits(detection)) {
      ++*suppressed;
      continue;
    }
    slots.Take(detection);
    kept.push_back(detection);
  }
  return kept;
}

namespace {

bool ValidDepth(float z) { return z > 0.0f && std::isfinite(z); }

// Chromaticity (r, g) = (R, G) / (R + G + B) histograms, kBins x kBins over [0, 1]; colours
// darker than kMinSum (sum of channels in [0, 3]) carry no reliable chromaticity.
constexpr int kBins = 12;
constexpr double kMinSum = 0.15;
using ChromaHistogram = std::array<double, kBins * kBins>;

void AddColour(double r, double g, double b, ChromaHistogram* histogram, double* total) {
  const double sum = r + g + b;
  if (sum < kMinSum) return;
  const int i = std::min(kBins - 1, static_cast<int>(r / sum * kBins));
  const int j = std::min(kBins - 1, static_cast<int>(g / sum * kBins));
  (*histogram)[static_cast<size_t>(i * kBins + j)] += 1.0;
  *total += 1.0;
}

void Normalize(double total, ChromaHistogram* histogram) {
  if (total <= 0.0) return;
  for (double& h : *histogram) h /= total;
}

double Bhattacharyya(const ChromaHistogram& a, const ChromaHistogram& b) {
  double sum = 0.0;
  for (size_t k = 0; k < a.size(); ++k) sum += std::sqrt(a[k] * b[k]);
  return sum;
}

// The frame's white point: the 95th percentile of its pixels' lightness (mean of the
// channels, in [0, 1]; every 4th pixel of every 4th row). A white surface under the scene's
// light is about that bright, whatever the exposure.
double WhitePoint(const cv::Mat& rgb) {
  std::array<int, 256> counts{};
  int total = 0;
  for (int v = 0; v < rgb.rows; v += 4) {
    const cv::Vec3b* row = rgb.ptr<cv::Vec3b>(v);
    for (int u = 0; u < rgb.cols; u += 4) {
      ++counts[static_cast<size_t>((row[u][0] + row[u][1] + row[u][2]) / 3)];
      ++total;
    }
  }
  int seen = 0;
  for (int level = 0; level < 256; ++level) {
    seen += counts[static_cast<size_t>(level)];
    if (seen >= 0.95 * total) return std::max(1, level) / 255.0;
  }
  return 1.0;
}

// Regions of one object from the point-pair-feature vote over `region` (DetectOptions::ppf_*):
// at most `wanted` of them, most votes first, each the pixels on the rendered surface of a
// voted pose that sees little free space, none mostly inside another.
std::vector<Proposal> PpfProposals(const Frame& frame, const TemplateBank& bank, const cv::Mat& region, int wanted,
                                   const SolverOptions& solver_options, const DetectOptions& options, Executor* executor) {
  std::vector<Proposal> proposals;
  const PpfModel& model = bank.ppf;
  if (model.empty() || wanted <= 0) return proposals;
  PpfSearchOptions search = solver_options.ppf;
  search.reference_stride = options.ppf_reference_stride;
  search.max_scene_points = options.ppf_max_scene_points;
  search.max_poses = std::max(search.max_poses, 4 * wanted);
  search.min_cluster_ratio = std::min(search.min_cluster_ratio, 0.05);
  const PpfScene scene = MakePpfScene(frame.camera, frame.depth, region, model.step_m, model.options.normal_cluster_deg, search);
  const std::vector<PpfPose> poses = VotePpfPoses(model, scene, bank.diameter_m, search, executor, nullptr);
  const float tolerance = static_cast<float>(options.ppf_surface_fraction * bank.diameter_m);
  const double focal = std::min(frame.camera.fx, frame.camera.fy);
  RasterOptions raster_options;
  raster_options.want_face_id = false;
  raster_options.cull_backfaces = bank.online_mesh_closed;
  std::vector<Proposal> candidates(poses.size());
  std::vector<bool> usable(poses.size(), false);
  executor->ParallelFor(static_cast<int>(poses.size()), [&](int k) {
    // A pose mostly outside the image is no candidate of the vote: what little of it is seen
    // says too little (the depth segments still propose truncated objects).
    int in_image = 0;
    for (const Eigen::Vector3f& point : model.points) {
      const Eigen::Vector3d in_cam = poses[static_cast<size_t>(k)].cam_from_object * point.cast<double>();
      if (in_cam.z() <= 0.0) continue;
      const Eigen::Vector2d uv = frame.camera.Project(in_cam);
      in_image += uv.x() >= 0 && uv.y() >= 0 && uv.x() < frame.camera.width && uv.y() < frame.camera.height;
    }
    if (in_image < 0.8 * static_cast<double>(model.points.size())) return;
    RasterImage raster;
    Rasterize(bank.online_mesh, frame.camera, poses[static_cast<size_t>(k)].cam_from_object, raster_options, &raster);
    Proposal& proposal = candidates[static_cast<size_t>(k)];
    proposal.mask = cv::Mat::zeros(frame.depth.size(), CV_8U);
    int on_surface = 0, free_space = 0, seen = 0;
    std::vector<float> depths;
    for (int v = 0; v < raster.depth.rows; ++v) {
      const float* rendered = raster.depth.ptr<float>(v);
      const float* observed = frame.depth.ptr<float>(v);
      const uint8_t* inside = region.ptr<uint8_t>(v);
      uint8_t* m = proposal.mask.ptr<uint8_t>(v);
      for (int u = 0; u < raster.depth.cols; ++u) {
        if (!(rendered[u] > 0.0f) || !ValidDepth(observed[u])) continue;
        ++seen;
        if (observed[u] > rendered[u] + tolerance) {
          ++free_space;  // the camera sees past where the object would be
        } else if (observed[u] >= rendered[u] - tolerance && inside[u]) {
          ++on_surface;
          m[u] = 255;
          depths.push_back(observed[u]);
        }
      }
    }
    const double support = ContourSupport(raster.depth, frame.depth, 2, static_cast<float>(options.ppf_contour_step_m));
    if (on_surface == 0 || free_space > options.ppf_max_free_space * seen) return;
    if (support < options.ppf_min_contour_support) return;
    std::nth_element(depths.begin(), depths.begin() + static_cast<long>(depths.size() / 2), depths.end());
    proposal.depth_m = depths[depths.size() / 2];
    const double whole_px = focal * bank.diameter_m / proposal.depth_m;
    if (on_surface < options.min_area_fraction * whole_px * whole_px * M_PI / 8.0) return;
    proposal.pixels = on_surface;
    proposal.box = cv::boundingRect(proposal.mask);
    proposal.extent_m = bank.diameter_m;
    proposal.centre_m = poses[static_cast<size_t>(k)].cam_from_object * bank.bounding_box.center();
    proposal.ppf_votes = poses[static_cast<size_t>(k)].votes;
    usable[static_cast<size_t>(k)] = true;
  });
  for (size_t k = 0; k < candidates.size() && static_cast<int>(proposals.size()) < wanted; ++k) {
    if (!usable[k]) continue;
    bool inside_other = false;
    for (const Proposal& other : proposals) {
      inside_other = inside_other || 2 * cv::countNonZero(candidates[k].mask & other.mask) > candidates[k].pixels;
    }
    if (!inside_other) proposals.push_back(std::move(candidates[k]));
  }
  return proposals;
}

// The shape terms of one object's `trials` (DetectOptions::rank_uncoloured_by_shape): the PPF vote's
// support of `shape_references` scene points of each depth segment the trials' regions hold,
// a segment's best, a region's pixel-weighted mean, over the best region's.
void ShapeTerms(const Frame& frame, const TemplateBank& bank, const cv::Mat& region, const DepthSegmentation& segmentation,
                const std::vector<Proposal>& proposals, const DetectOptions& options, const PpfSearchOptions& ppf_options,
                Executor* executor, std::vector<CandidateTrial>* trials) {
  const PpfModel& model = bank.ppf;
  PpfSearchOptions search = ppf_options;
  search.max_scene_points = options.ppf_max_scene_points;
  const PpfScene scene = MakePpfScene(frame.camera, frame.depth, region, model.step_m, model.options.normal_cluster_deg, search);
  const size_t segment_count = segmentation.segments.size();
  // Units: the segments (1..segment_count), then the regions with their own mask (islands).
  std::vector<uint8_t> wanted(segment_count + 1, 0);
  std::vector<size_t> masked;  // trials whose region has its own mask; unit segment_count + 1 + k
  for (size_t t = 0; t < trials->size(); ++t) {
    const Proposal& proposal = proposals[static_cast<size_t>((*trials)[t].proposal)];
    if (!proposal.mask.empty()) masked.push_back(t);
    for (int label : proposal.segments) wanted[static_cast<size_t>(label)] = 1;
  }
  // Each wanted unit's scene points, in the cloud's order; then evenly spaced references.
  std::vector<std::vector<int>> members(segment_count + 1 + masked.size());
  for (size_t i = 0; i < scene.points.size(); ++i) {
    const Eigen::Vector2d uv = frame.camera.Project(scene.points[i].cast<double>());
    const int u = static_cast<int>(std::floor(uv.x())), v = static_cast<int>(std::floor(uv.y()));
    if (u < 0 || v < 0 || u >= segmentation.labels.cols || v >= segmentation.labels.rows) continue;
    const int label = segmentation.labels.at<int>(v, u);
    if (label > 0 && wanted[static_cast<size_t>(label)]) members[static_cast<size_t>(label)].push_back(static_cast<int>(i));
    for (size_t k = 0; k < masked.size(); ++k) {
      const cv::Mat& mask = proposals[static_cast<size_t>((*trials)[masked[k]].proposal)].mask;
      if (mask.at<uint8_t>(v, u)) members[segment_count + 1 + k].push_back(static_cast<int>(i));
    }
  }
  std::vector<int> references, reference_unit;
  for (size_t unit = 1; unit < members.size(); ++unit) {
    const std::vector<int>& m = members[unit];
    const size_t take = std::min(m.size(), static_cast<size_t>(options.shape_references));
    for (size_t k = 0; k < take; ++k) {
      references.push_back(m[(2 * k + 1) * m.size() / (2 * take)]);
      reference_unit.push_back(static_cast<int>(unit));
    }
  }
  const std::vector<float> support = PpfReferenceSupport(model, scene, references, search, executor);
  std::vector<double> unit_support(members.size(), -1.0);  // -1 = no reference
  for (size_t k = 0; k < references.size(); ++k) {
    double& best = unit_support[static_cast<size_t>(reference_unit[k])];
    best = std::max(best, static_cast<double>(support[k]));
  }
  for (size_t k = 0; k < masked.size(); ++k) {
    (*trials)[masked[k]].shape_term = std::max(0.0, unit_support[segment_count + 1 + k]);
  }
  double best_region = 0.0;
  for (CandidateTrial& trial : *trials) {
    if (!proposals[static_cast<size_t>(trial.proposal)].mask.empty()) {
      best_region = std::max(best_region, trial.shape_term);
      continue;
    }
    double sum = 0.0, weight = 0.0;
    for (int label : proposals[static_cast<size_t>(trial.proposal)].segments) {
      const double s = unit_support[static_cast<size_t>(label)];
      if (s < 0.0) continue;
      const double pixels = segmentation.segments[static_cast<size_t>(label) - 1].pixels;
      sum += s * pixels;
      weight += pixels;
    }
    trial.shape_term = weight > 0.0 ? sum / weight : 0.0;
    best_region = std::max(best_region, trial.shape_term);
  }
  for (CandidateTrial& trial : *trials) trial.shape_term = best_region > 0.0 ? trial.shape_term / best_region : 0.0;
}

// The templates' silhouette areas in pixels at a focal length of 1 px and a depth of 1 m (at
// depth z and focal f the object covers about this * (f / z)^2 pixels): their 10th, 50th and
// 90th percentiles; zeros without templates.
std::array<double, 3> SilhouetteAreas(const TemplateBank& bank) {
  std::vector<double> areas;
  const double focal = std::sqrt(bank.template_camera.fx * bank.template_camera.fy);
  for (const Template& view : bank.templates) {
    const double z = view.cam_from_object.translation().z();
    if (view.mask.empty() || !(z > 0.0) || !(focal > 0.0)) continue;
    areas.push_back(cv::countNonZero(view.mask) * view.crop_scale * view.crop_scale * (z / focal) * (z / focal));
  }
  if (areas.empty()) return {0.0, 0.0, 0.0};
  std::sort(areas.begin(), areas.end());
  auto at = [&](double q) { return areas[static_cast<size_t>(q * static_cast<double>(areas.size() - 1) + 0.5)]; };
  return {at(0.1), at(0.5), at(0.9)};
}

// The frame's support plane around a region (SupportAround): in the ring of the solve's own
// support plane first, then in its wider ring (RegionOptions); null when neither has one.
const SupportPlane* FrameSupportAround(const Frame& frame, const std::vector<SupportPlane>& planes,
                                       const SolverOptions& solve_options, const cv::Mat& region) {
  const SupportPlane* under = SupportAround(planes, frame.depth, region, solve_options.region.ring_fraction);
  if (under == nullptr && solve_options.region.limit_ring_fraction > solve_options.region.ring_fraction) {
    under = SupportAround(planes, frame.depth, region, solve_options.region.limit_ring_fraction);
  }
  return under;
}

// The solve of `region` as object `object_id`, told the frame's support plane `under` as its
// support limit (Instance::has_support_limit) when `use_limit` and there is one.
Instance RegionInstance(const std::string& object_id, const cv::Mat& region, const SupportPlane* under, bool use_limit) {
  Instance instance{object_id, region};
  if (use_limit && under != nullptr) {
    instance.has_support_limit = true;
    instance.support_limit_normal = under->plane.normal;
    instance.support_limit_offset_m = under->plane.offset;
  }
  return instance;
}

// The support check of a solve (SolverOptions::support_penetration_fraction) against the
// frame's support plane `under` around the answer's region: the solve's own check uses the
// plane its ring shows, and a ring of depth holes (a lit floor, a pile) shows none. An answer
// reaching behind it by more than the same limit is behind the support.
void CheckFrameSupport(const SupportPlane* under, const SolverOptions& solve_options, const TemplateBank& bank,
                       Detection* detection) {
  if (under == nullptr || !(solve_options.support_penetration_fraction > 0.0) || !detection->result.success) return;
  double tolerance_m = 0.0;
  const double behind = DepthBehindPlane(*under, bank.online_mesh, detection->result.cam_from_object, &tolerance_m);
  StageReport& stages = detection->result.stages;
  stages.support_penetration_m = std::max(stages.support_penetration_m, behind);
  if (behind > solve_options.support_penetration_fraction * bank.diameter_m + tolerance_m) {
    stages.answer_behind_support = true;
  }
}

// The answers less sure than options.identity_check_below, each solved again on its own
// region as every other object that region was ranked for (an object whose extent or area
// rules the region out is no explanation of it). An answer is dropped when another object
// explains its region with a higher confidence (at least min_confidence); that object's
// answer takes its place when the object still wants instances and the pixels are free.
void CheckIdentities(const Frame& frame, const std::vector<DetectRequest>& requests, const DetectOptions& options,
                     const SolverOptions& solve_options, const SolverOptions& island_solve_options,
                     const std::vector<SupportPlane>& frame_planes, Executor* executor, DetectionReport* out,
                     std::vector<Detection>* detections) {
  struct Check {
    size_t detection;
    size_t request;
    size_t trial;  // the other object's ranked pair with the answer's region (its colour term)
  };
  std::vector<Check> checks;
  for (size_t d = 0; d < detections->size(); ++d) {
    const Detection& detection = (*detections)[d];
    if (detection.result.confidence >= options.identity_check_below) continue;
    ++out->identity_checked;
    const size_t own = static_cast<size_t>(detection.request);
    for (size_t t = 0; t < out->trials.size(); ++t) {
      const CandidateTrial& trial = out->trials[t];
      const size_t r = static_cast<size_t>(trial.request);
      if (trial.proposal != detection.proposal || r == own || requests[r].bank == requests[own].bank) continue;
      bool again = false;
      for (const Check& check : checks) again = again || (check.detection == d && check.request == r);
      if (!again) checks.push_back({d, r, t});
    }
  }
  std::vector<Detection> others(checks.size());
  executor->ParallelFor(static_cast<int>(checks.size()), [&](int i) {
    const Check& check = checks[static_cast<size_t>(i)];
    const Detection& detection = (*detections)[check.detection];
    const Proposal& proposal = out->proposals[static_cast<size_t>(detection.proposal)];
    const bool island = !proposal.mask.empty() && proposal.ppf_request < 0;
    const TemplateBank& bank = *requests[check.request].bank;
    Detection& other = others[static_cast<size_t>(i)];
    other.request = static_cast<int>(check.request);
    other.object_id = bank.object_id;
    other.proposal = detection.proposal;
    other.region = detection.region;
    const SupportPlane* under = FrameSupportAround(frame, frame_planes, solve_options, detection.region);
    other.result = EstimatePoseOnMask(frame, RegionInstance(bank.object_id, detection.region, under, options.support_limit_from_frame),
                                      bank, island ? island_solve_options : solve_options, executor);
    if (!other.result.success || other.result.score > options.max_score) {
      other.result.confidence = 0.0;
      return;
    }
    other.check = CheckAgainstFrame(frame, bank, other.result.cam_from_object,
                                    options.free_space_fraction * bank.diameter_m, options.ppf_contour_step_m);
    CheckFrameSupport(under, island ? island_solve_options : solve_options, bank, &other);
    const double iou = other.result.corrected_mask.empty()
                           ? 0.0
                           : MaskIntersectionOverUnion(other.result.corrected_mask, detection.region);
    other.region_iou = iou;
    other.colour_term = out->trials[check.trial].colour_term;
    other.lightness_ratio = out->trials[check.trial].lightness_ratio;
    other.result.confidence = DetectionConfidence(options, other.result, other.check, iou, other.colour_term);
  });
  out->identity_solves = static_cast<int>(checks.size());
  // Per answer, the best other explanation of its region, when better than the answer.
  std::vector<int> better(detections->size(), -1);
  for (size_t i = 0; i < checks.size(); ++i) {
    const size_t d = checks[i].detection;
    const double confidence = others[i].result.confidence;
    const double to_beat = better[d] >= 0 ? others[static_cast<size_t>(better[d])].result.confidence
                                          : (*detections)[d].result.confidence;
    if (confidence >= options.min_confidence && confidence > to_beat) better[d] = static_cast<int>(i);
  }
  std::vector<Detection> kept;
  AnswerSlots slots(frame, requests, options);
  std::vector<size_t> replacements;
  for (size_t d = 0; d < detections->size(); ++d) {
    if (better[d] >= 0) {
      ++out->identity_dropped;
      replacements.push_back(static_cast<size_t>(better[d]));
      continue;
    }
    Detection& detection = (*detections)[d];
    slots.Take(detection);  // selected already
    kept.push_back(std::move(detection));
  }
  std::stable_sort(replacements.begin(), replacements.end(), [&](size_t a, size_t b) {
    return others[a].result.confidence > others[b].result.confidence;
  });
  for (size_t i : replacements) {
    Detection& other = others[i];
    if (!slots.Admits(other)) continue;
    ++out->identity_replaced;
    slots.Take(other);
    kept.push_back(std::move(other));
  }
  *detections = std::move(kept);
}

}  // namespace

double RunnerUpGap(const PoseResult& result) {
  constexpr double kNoRival = 0.25;
  return result.has_runner_up ? std::min(kNoRival, result.runner_up_score - result.score) : kNoRival;
}

double DetectionConfidence(const DetectOptions& options, const PoseResult& result, const FrameCheck& check,
                           double region_iou, double colour_term) {
  if (!std::isfinite(result.score)) return 0.0;
  if (options.refuse_behind_support && result.stages.answer_behind_support) return 0.0;
  const double logit = options.confidence_bias + options.confidence_score_weight * result.score +
                       (result.ambiguous ? options.confidence_ambiguous_weight : 0.0) +
                       options.confidence_on_surface_weight * check.on_surface +
                       options.confidence_free_space_weight * check.free_space +
                       options.confidence_contour_weight * check.contour_support +
                       options.confidence_region_iou_weight * region_iou +
                       options.confidence_colour_weight * colour_term +
                       options.confidence_in_image_weight * check.in_image +
                       options.confidence_edge_weight * check.oriented_edge +
                       options.confidence_runner_up_weight * RunnerUpGap(result) +
                       options.confidence_free_band_weight * check.free_space_band_px;
  return 1.0 / (1.0 + std::exp(-logit));
}

std::vector<Detection> DetectObjects(const Frame& frame, const std::vector<DetectRequest>& requests,
                                     const SolverOptions& solver_options, const DetectOptions& options,
                                     Executor* executor, DetectionReport* report) {
  DetectionReport local_report;
  DetectionReport& out = report ? *report : local_report;
  out = DetectionReport();
  out.solve_stages = StageTimes(StageReport());  // every stage's name, 0 ms
  const Stopwatch total_watch;
  if (requests.empty()) G6D_THROW("DetectObjects: no objects requested");
  for (size_t r = 0; r < requests.size(); ++r) {
    if (requests[r].bank == nullptr) G6D_THROW("DetectObjects: request " << r << " has no template bank");
    if (requests[r].count < 1) G6D_THROW("DetectObjects: request " << r << " (" << requests[r].bank->object_id << ") asks for " << requests[r].count << " instances (must be >= 1)");
    const cv::Mat& within = requests[r].within;
    if (!within.empty() && (within.type() != CV_8U || within.size() != frame.depth.size())) {
      G6D_THROW("DetectObjects: request " << r << " (" << requests[r].bank->object_id
                << ")'s `within` must be CV_8U of the frame's size (got type " << within.type() << ", "
                << within.cols << "x" << within.rows << ", frame " << frame.depth.cols << "x" << frame.depth.rows << ")");
    }
  }
  const std::string bad = options.Check();
  if (!bad.empty()) G6D_THROW(bad);
  std::vector<Detection> detections;
  if (frame.depth.empty() || frame.depth.type() != CV_32F || frame.rgb.type() != CV_8UC3 ||
      frame.depth.size() != frame.rgb.size() || frame.depth.cols != frame.camera.width ||
      frame.depth.rows != frame.camera.height) {
    out.message = "bad frame: depth must be CV_32F and rgb CV_8UC3, both of the camera's size";
    return detections;
  }
  double largest_diameter_m = 0.0;
  for (const DetectRequest& request : requests) largest_diameter_m = std::max(largest_diameter_m, request.bank->diameter_m);

  std::vector<SupportPlane> frame_planes;  // the support planes, for the answers' support check
  bool all_within = true;  // every request says where its object is (the mask path's search)
  for (const DetectRequest& request : requests) all_within = all_within && !request.within.empty();
  {
    const ScopedTimer timer(&out.support_ms);
    // Outlined thin parts only join the islands, and requests with a place have none.
    DetectOptions support_options = options;
    if (all_within) support_options.raised_outline_edge = 0.0;
    out.support_planes = FindSupport(frame, support_options, largest_diameter_m, &out.support, &out.raised, &frame_planes);
  }
  const double focal = std::min(frame.camera.fx, frame.camera.fy);
  const double white_point = WhitePoint(frame.rgb);
  const double noise = options.segments.noise_sigmas * options.segments.sensor_noise_at_1m;
  // How much longer than a diameter a region's extent may be: the noise at both ends and
  // extent_margin_px at the region's depth.
  auto allowance_m = [&](double z) { return 2.0 * (noise * z * z + options.extent_margin_px * z / focal); };
  SolverOptions solve_options = solver_options;
  solve_options.mask_trust = MaskTrust::kDepth;
  solve_options.region_candidates = 0;  // a region of the depth is solved as it is
  // A region the depth drew (its edge where the segments or the support end) is no one's
  // outline of the object: its depthless pixels at the edge are unsure (RegionOptions).
  solve_options.region.unsure_area_min_px = 1;
  if (options.max_solve_hypotheses > 0) {
    solve_options.num_hypotheses = std::min(solve_options.num_hypotheses, options.max_solve_hypotheses);
  }
  solve_options.pnp_min_quality_ratio = std::max(solve_options.pnp_min_quality_ratio, options.solve_pnp_min_quality);
  SolverOptions island_solve_options = solve_options;
  solve_options.use_silhouettes = solve_options.use_silhouettes && options.solve_silhouettes;
  solve_options.check_flips = options.solve_check_flips;
  island_solve_options.check_flips = solve_options.check_flips;
  solve_options.check_flips_max_score = std::min(solve_options.check_flips_max_score, options.max_score);
  island_solve_options.check_flips_max_score = solve_options.check_flips_max_score;
  island_solve_options.use_silhouettes = island_solve_options.use_silhouettes && options.island_silhouettes;
  cv::Mat first_region = out.support == 0;
  // Requests that all say where their object is: only the area around their `within` is
  // segmented, grown by its longer side and by the object's size in pixels at the nearest
  // depth inside it (a region the object continues beyond a sliver stays whole).
  std::vector<int> within_pixels(requests.size(), 0);  // pixels with depth inside `within`
  cv::Rect within_area;
  for (size_t r = 0; r < requests.size(); ++r) {
    const cv::Mat& within = requests[r].within;
    if (within.empty()) continue;
    const cv::Rect box = cv::boundingRect(within);
    float nearest = std::numeric_limits<float>::infinity();
    for (int v = box.y; v < box.y + box.height; ++v) {
      const uint8_t* w = within.ptr<uint8_t>(v);
      const float* d = frame.depth.ptr<float>(v);
      for (int u = box.x; u < box.x + box.width; ++u) {
        if (!w[u] || !ValidDepth(d[u])) continue;
        ++within_pixels[r];
        nearest = std::min(nearest, d[u]);
      }
    }
    double grow = std::max(box.width, box.height);
    if (std::isfinite(nearest)) {
      grow = std::max(grow, std::max(frame.camera.fx, frame.camera.fy) * requests[r].bank->diameter_m / nearest);
    }
    const int g = static_cast<int>(std::ceil(std::min(grow, static_cast<double>(std::max(frame.depth.cols, frame.depth.rows)))));
    within_area |= cv::Rect(box.x - g, box.y - g, box.width + 2 * g, box.height + 2 * g);
  }
  if (all_within) {
    cv::Mat area = cv::Mat::zeros(first_region.size(), CV_8U);
    area(within_area & cv::Rect(0, 0, area.cols, area.rows)).setTo(255);
    first_region &= area;
  }
  std::vector<std::array<double, 3>> silhouette_areas(requests.size());  // for the ranking's area term
  for (size_t r = 0; r < requests.size(); ++r) silhouette_areas[r] = SilhouetteAreas(*requests[r].bank);
  std::vector<Detection> solved;
  std::vector<int> wanted(requests.size());
  for (size_t r = 0; r < requests.size(); ++r) wanted[r] = requests[r].count;
  // Per request, the pixels of the regions solved in earlier passes: a later pass does not
  // solve the same pixels again (a region nothing was taken from comes back unchanged).
  std::vector<std::vector<cv::Mat>> solved_regions(requests.size());
  cv::Mat segment_depth;  // the frame's depth with its small holes bridged (bridge_holes_px)
  for (int pass = 0; pass <= options.explain_away_passes + options.found_object_passes; ++pass) {
    cv::Mat region = first_region.clone();
    cv::Mat island_region = first_region | out.raised;  // islands: with the thin parts lying on the support
    if (pass > 0) {
      // Explaining away: the pixels of the answers kept so far (their corrected masks,
      // grown by the fill gap) are no longer anyone's, and the rest is split again: a
      // region that held a found object and a touching one now holds the other alone.
      cv::Mat claimed = cv::Mat::zeros(frame.depth.size(), CV_8U);
      for (const Detection& detection : detections) {
        claimed |= detection.result.corrected_mask.empty() ? detection.region : detection.result.corrected_mask;
      }
      if (options.fill_gap_px > 0) {
        const int size = 2 * options.fill_gap_px + 1;
        cv::dilate(claimed, claimed, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(size, size)));
      }
      region.setTo(0, claimed);
      island_region.setTo(0, claimed);
      ++out.explain_away_passes;
    }
    DetectionReport::Pass& step = out.passes.emplace_back();
    {
      const ScopedTimer timer(&out.segment_ms);
      if (pass == 0) segment_depth = BridgeDepthHoles(frame.camera, frame.depth, options.bridge_holes_px, options.segments);
      step.segmentation = SegmentByDepthAndCreases(frame.camera, segment_depth, region, options.segments,
                                                   pass == 0 ? &out.creases : nullptr);
    }
    const DepthSegmentation& segmentation = step.segmentation;
    const size_t first_proposal = out.proposals.size();
    {
      const ScopedTimer timer(&out.propose_ms);
      double farthest = 0.0;
      for (const DepthSegment& segment : segmentation.segments) farthest = std::max(farthest, segment.median_depth_m);
      const double largest_extent_m = largest_diameter_m + allowance_m(farthest);
      std::set<std::pair<int, int>> neighbours = NeighbourSegments(segmentation.labels, options.neighbour_gap_px);
      if (options.gap_neighbour_reach_m > 0.0) {
        const std::set<std::pair<int, int>> across = NeighboursAcrossGaps(
            frame.camera, segment_depth, region, segmentation, options.gap_neighbour_reach_m, options.gap_occluder_margin_m);
        neighbours.insert(across.begin(), across.end());
      }
      std::vector<Proposal> proposals = FormRegions(segmentation, neighbours, largest_extent_m, options);
      if (!all_within) {  // an island is no candidate for a request that says where its object is
        for (Proposal& proposal : FormIslands(frame, island_region, largest_extent_m, options)) proposals.push_back(std::move(proposal));
      }
      for (Proposal& proposal : proposals) proposal.pass = pass;
      out.proposals.insert(out.proposals.end(), proposals.begin(), proposals.end());
    }
    step.proposals = static_cast<int>(out.proposals.size() - first_proposal);

    // Rank every (object, region) pair that fits, for the objects still wanted.
    std::vector<std::vector<int>> chosen(requests.size());
    {
      const ScopedTimer timer(&out.rank_ms);
      struct RegionColour {
        ChromaHistogram chroma{};
        double lightness = 0.0;  ///< mean lightness over the white point
      };
      std::map<size_t, RegionColour> region_colours;
      auto region_colour = [&](size_t index) -> const RegionColour& {
        auto found = region_colours.find(index);
        if (found != region_colours.end()) return found->second;
        RegionColour& colour = region_colours[index];
        ChromaHistogram& histogram = colour.chroma;
        histogram.fill(0.0);
        double total = 0.0, lightness = 0.0;
        int pixels = 0;
        const Proposal& proposal = out.proposals[index];
        for (int v = proposal.box.y; v < proposal.box.y + proposal.box.height; v += 2) {
          const int* l = segmentation.labels.ptr<int>(v);
          const uint8_t* m = proposal.mask.empty() ? nullptr : proposal.mask.ptr<uint8_t>(v);
          const cv::Vec3b* rgb = frame.rgb.ptr<cv::Vec3b>(v);
          for (int u = proposal.box.x; u < proposal.box.x + proposal.box.width; u += 2) {
            if (m != nullptr ? !m[u]
                             : (l[u] <= 0 || !std::binary_search(proposal.segments.begin(), proposal.segments.end(), l[u]))) {
              continue;
            }
            AddColour(rgb[u][0] / 255.0, rgb[u][1] / 255.0, rgb[u][2] / 255.0, &histogram, &total);
            lightness += (rgb[u][0] + rgb[u][1] + rgb[u][2]) / (3.0 * 255.0);
            ++pixels;
          }
        }
        Normalize(total, &histogram);
        colour.lightness = pixels > 0 ? lightness / pixels / white_point : 0.0;
        return colour;
      };
      for (size_t r = 0; r < requests.size(); ++r) {
        if (wanted[r] <= 0) continue;
        const TemplateBank& bank = *requests[r].bank;
        ChromaHistogram model_colour{};
        double model_total = 0.0;
        double model_lightness = 0.0;
        for (const Eigen::Vector3f& c : bank.appearance.colors) {
          AddColour(c.x(), c.y(), c.z(), &model_colour, &model_total);
          model_lightness += (c.x() + c.y() + c.z()) / 3.0;
        }
        Normalize(model_total, &model_colour);
        const bool has_colour = model_total > 0.0;
        if (has_colour) model_lightness /= static_cast<double>(bank.appearance.colors.size());
        const bool has_near = requests[r].near_point_m.allFinite();
        const std::array<double, 3>& unit_areas = silhouette_areas[r];
        std::vector<CandidateTrial> trials;
        for (size_t p = first_proposal; p < out.proposals.size(); ++p) {
          const Proposal& proposal = out.proposals[p];
          if (!proposal.mask.empty() && !requests[r].within.empty()) continue;  // islands: over the frame only
          if (proposal.island_piece && has_colour && options.island_pieces_uncoloured_only) continue;
          const double d = bank.diameter_m;
          if (proposal.extent_m > d + allowance_m(proposal.depth_m)) continue;
          if (proposal.extent_m < options.min_extent_fraction * d) continue;
          const double whole_px = focal * d / proposal.depth_m;
          const int area = proposal.mask.empty() ? proposal.pixels : std::max(proposal.pixels, proposal.mask_pixels);
          if (area < options.min_area_fraction * whole_px * whole_px * M_PI / 8.0) continue;
          if (!requests[r].within.empty() &&
              2 * PixelsInside(segmentation.labels, proposal, requests[r].within) < std::min(proposal.pixels, within_pixels[r])) {
            continue;
          }
          CandidateTrial trial;
          trial.request = static_cast<int>(r);
          trial.proposal = static_cast<int>(p);
          trial.pass = pass;
          trial.size_term = std::min(1.0, proposal.extent_m / d);
          const double at_depth = focal * focal / (proposal.depth_m * proposal.depth_m);
          trial.area_ratio = unit_areas[1] > 0.0 ? area / (unit_areas[1] * at_depth) : 0.0;
          if (unit_areas[0] > 0.0) {
            const double low = unit_areas[0] * at_depth, high = unit_areas[2] * at_depth;
            trial.area_term = area < low ? area / low : area > high ? high / area : 1.0;
          }
          const double size_agreement = (1.0 - options.area_weight) * trial.size_term + options.area_weight * trial.area_term;
          if (has_colour) {
            const RegionColour& seen = region_colour(p);
            trial.colour_term = Bhattacharyya(model_colour, seen.chroma);
            if (model_lightness > 0.0) trial.lightness_ratio = seen.lightness / model_lightness;
          }
          trial.rank = (1.0 - options.colour_weight) * size_agreement + options.colour_weight * trial.colour_term;
          trials.push_back(trial);
        }
        if (!has_colour && options.rank_uncoloured_by_shape && solver_options.use_ppf && !bank.ppf.empty() &&
            !trials.empty()) {
          const ScopedTimer shape_timer(&out.shape_ms);
          ShapeTerms(frame, bank, all_within ? region : island_region, segmentation, out.proposals, options, solver_options.ppf, executor, &trials);
          for (CandidateTrial& trial : trials) {
            trial.rank = (1.0 - options.colour_weight) *
                             ((1.0 - options.area_weight) * trial.size_term + options.area_weight * trial.area_term) +
                         options.colour_weight * trial.shape_term;
          }
        }
        for (CandidateTrial& trial : trials) {
          const Proposal& proposal = out.proposals[static_cast<size_t>(trial.proposal)];
          if (has_near && (proposal.centre_m - requests[r].near_point_m).norm() <= bank.diameter_m) trial.rank += 1.0;
          if (!has_colour && !proposal.mask.empty() && proposal.ppf_request < 0) trial.rank += options.uncoloured_island_bonus;
        }
        std::stable_sort(trials.begin(), trials.end(),
                         [](const CandidateTrial& a, const CandidateTrial& b) { return a.rank > b.rank; });
        // The best ones, skipping a region mostly inside one already chosen.
        const int limit = wanted[r] + options.extra_candidates;
        for (size_t t = 0; t < trials.size() && static_cast<int>(chosen[r].size()) < limit; ++t) {
          const Proposal& proposal = out.proposals[static_cast<size_t>(trials[t].proposal)];
          bool inside = false;
          for (int c : chosen[r]) {
            const Proposal& other = out.proposals[static_cast<size_t>(trials[static_cast<size_t>(c)].proposal)];
            inside = inside || 2 * SharedPixels(proposal, other, segmentation, frame.depth) > proposal.pixels;
          }
          if (inside) continue;
          if (pass > 0 && !solved_regions[r].empty()) {
            const cv::Mat pixels = RegionMask(segmentation.labels, proposal);
            bool again = false;
            for (const cv::Mat& before : solved_regions[r]) {
              again = again || cv::countNonZero(pixels != before) <= proposal.pixels / 20;
            }
            if (again) continue;
          }
          chosen[r].push_back(static_cast<int>(t));
        }
        for (int c : chosen[r]) {
          solved_regions[r].push_back(RegionMask(segmentation.labels, out.proposals[static_cast<size_t>(trials[static_cast<size_t>(c)].proposal)]));
        }
        for (int& c : chosen[r]) c += static_cast<int>(out.trials.size());  // indices into out.trials
        out.trials.insert(out.trials.end(), trials.begin(), trials.end());
      }
    }
    // The point-pair-feature vote's regions (first pass only), each for its own object, unless
    // mostly inside a region already chosen for that object.
    if (pass == 0 && options.ppf_extra > 0 && solver_options.use_ppf) {
      const ScopedTimer timer(&out.ppf_ms);
      for (size_t r = 0; r < requests.size(); ++r) {
        if (wanted[r] <= 0) continue;
        std::vector<cv::Mat> chosen_masks;
        for (int c : chosen[r]) {
          chosen_masks.push_back(FilledRegionMask(segmentation.labels, out.support,
                                                  out.proposals[static_cast<size_t>(out.trials[static_cast<size_t>(c)].proposal)],
                                                  options.fill_gap_px));
        }
        cv::Mat ppf_region = region.clone();
        if (!requests[r].within.empty()) ppf_region &= requests[r].within;
        for (Proposal& proposal : PpfProposals(frame, *requests[r].bank, ppf_region, wanted[r] + options.ppf_extra,
                                               solve_options, options, executor)) {
          bool inside = false;
          for (const cv::Mat& mask : chosen_masks) inside = inside || 2 * cv::countNonZero(proposal.mask & mask) > proposal.pixels;
          if (inside) continue;
          proposal.ppf_request = static_cast<int>(r);
          proposal.pass = pass;
          CandidateTrial trial;
          trial.request = static_cast<int>(r);
          trial.proposal = static_cast<int>(out.proposals.size());
          trial.pass = pass;
          trial.size_term = 1.0;
          trial.rank = 0.0;
          out.proposals.push_back(std::move(proposal));
          chosen[r].push_back(static_cast<int>(out.trials.size()));
          out.trials.push_back(trial);
          ++out.ppf_regions;
        }
      }
    }

    // Solve the chosen candidates: all at once over the executor (each solve fans out its
    // own hypotheses too, so the threads stay busy through a solve's serial stages), or,
    // with early acceptance, one after the other in rank order.
    {
      const ScopedTimer timer(&out.solve_ms);
      struct Job {
        size_t request;
        int trial;
      };
      std::vector<Job> jobs;
      std::mutex stage_mutex;
      for (size_t r = 0; r < requests.size(); ++r) {
        for (int t : chosen[r]) jobs.push_back({r, t});
      }
      auto solve = [&](const Job& job) {
        CandidateTrial& trial = out.trials[static_cast<size_t>(job.trial)];
        const Stopwatch watch;
        Detection detection;
        detection.request = static_cast<int>(job.request);
        detection.object_id = requests[job.request].bank->object_id;
        detection.proposal = trial.proposal;
        const Proposal& proposal = out.proposals[static_cast<size_t>(trial.proposal)];
        detection.region = FilledRegionMask(segmentation.labels, out.support, proposal, options.fill_gap_px);
        const SupportPlane* under = FrameSupportAround(frame, frame_planes, solve_options, detection.region);
        const Instance instance =
            RegionInstance(detection.object_id, detection.region, under, options.support_limit_from_frame);
        // The solve on the region as a mask: EstimatePose without its depth regions
        // (solve_options.region_candidates is 0), so detection sits below EstimatePose.
        const bool island = !proposal.mask.empty() && proposal.ppf_request < 0;
        detection.result = EstimatePoseOnMask(frame, instance, *requests[job.request].bank,
                                              island ? island_solve_options : solve_options, executor);
        const Stopwatch check_watch;
        if (detection.result.success) {
          const TemplateBank& bank = *requests[job.request].bank;
          // The solve checked its answer against the frame; again only with other tolerances.
          const bool same_check = options.free_space_fraction == solve_options.check_surface_fraction &&
                                  options.ppf_contour_step_m == solve_options.check_step_m;
          detection.check = same_check ? detection.result.frame_check
                                       : CheckAgainstFrame(frame, bank, detection.result.cam_from_object,
                                                           options.free_space_fraction * bank.diameter_m,
                                                           options.ppf_contour_step_m);
          CheckFrameSupport(under, island ? island_solve_options : solve_options, bank, &detection);
        }
        {
          const std::vector<StageTime> times = StageTimes(detection.result.stages);
          const std::lock_guard<std::mutex> lock(stage_mutex);
          for (size_t i = 0; i < times.size(); ++i) out.solve_stages[i].ms += times[i].ms;
          out.check_ms += check_watch.ElapsedMs();
        }
        trial.solved = true;
        trial.success = detection.result.success;
        trial.score = detection.result.score;
        trial.ms = watch.ElapsedMs();
        if (detection.result.success && !detection.result.corrected_mask.empty()) {
          trial.region_iou = MaskIntersectionOverUnion(detection.result.corrected_mask, detection.region);
        }
        detection.region_iou = trial.region_iou;
        detection.colour_term = trial.colour_term;
        detection.lightness_ratio = trial.lightness_ratio;
        if (detection.result.success) {
          detection.result.confidence = DetectionConfidence(options, detection.result, detection.check, trial.region_iou,
                                                             trial.colour_term);
          trial.confidence = detection.result.confidence;
          trial.cam_from_object = detection.result.cam_from_object;
        }
        return detection;
      };
      if (options.accept_confidence >= 1.0) {
        std::vector<Detection> results(jobs.size());
        executor->ParallelFor(static_cast<int>(jobs.size()),
                              [&](int i) { results[static_cast<size_t>(i)] = solve(jobs[static_cast<size_t>(i)]); });
        for (Detection& detection : results) {
          if (detection.result.success) solved.push_back(std::move(detection));
        }
        out.solves += static_cast<int>(jobs.size());
        step.solves += static_cast<int>(jobs.size());
      } else {
        std::vector<cv::Mat> accepted(requests.size());
        std::vector<int> confident(requests.size(), 0);
        for (const Job& job : jobs) {
          if (confident[job.request] >= wanted[job.request]) continue;  // enough sure answers
          Detection detection = solve(job);
          ++out.solves;
          ++step.solves;
          if (!detection.result.success) continue;
          const CandidateTrial& trial = out.trials[static_cast<size_t>(job.trial)];
          if (detection.result.confidence >= options.accept_confidence && trial.region_iou >= options.accept_region_iou) {
            const cv::Mat& mask = detection.result.corrected_mask;
            cv::Mat& taken = accepted[job.request];
            if (taken.empty()) taken = cv::Mat::zeros(frame.depth.size(), CV_8U);
            const int pixels = cv::countNonZero(mask);
            if (pixels > 0 && cv::countNonZero(mask & taken) <= options.max_overlap * pixels) {
              ++confident[job.request];
              taken |= mask;
            }
          }
          solved.push_back(std::move(detection));
        }
      }
    }

    // Keep answers by S_A over every pass so far: a pixel belongs to at most one answer,
    // each object's count holds.
    {
      const ScopedTimer timer(&out.select_ms);
      detections = SelectAnswers(frame, requests, options, solved, &out.suppressed);
    }
    bool missing = false;
    for (size_t r = 0; r < requests.size(); ++r) {
      int answered = 0;
      for (const Detection& detection : detections) answered += detection.request == static_cast<int>(r);
      wanted[r] = requests[r].count - answered;
      // Past the explaining-away passes, only objects found already look for more.
      if (pass + 1 > options.explain_away_passes && answered == 0) wanted[r] = 0;
      missing = missing || wanted[r] > 0;
    }
    if (!missing || detections.empty()) break;  // all found, or nothing to explain away
  }
  if (options.identity_check_below > 0.0 && requests.size() > 1) {
    const ScopedTimer timer(&out.identity_ms);
    CheckIdentities(frame, requests, options, solve_options, island_solve_options, frame_planes, executor, &out,
                    &detections);
  }
  out.segmentation = out.passes.front().segmentation;
  out.answers = static_cast<int>(detections.size());
  out.success = true;
  std::ostringstream message;
  message << out.answers << " answers from " << out.solves << " solves of " << out.proposals.size() << " regions ("
          << out.segmentation.segments.size() << " segments, " << out.support_planes << " support planes, "
          << out.explain_away_passes << " explaining-away passes)";
  out.message = message.str();
  out.total_ms = total_watch.ElapsedMs();
  return detections;
}

}  // namespace g6d
