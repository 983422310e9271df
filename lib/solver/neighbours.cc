#include "solver/neighbours.h"

#include <algorithm>
#include <string>
#include <utility>

#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/timer.h"
#include "solver/depth_regions.h"
#include "solver/region.h"

namespace g6d {

namespace {

// The centre of the bank's mesh (the mean of its vertices), in the object frame.
Eigen::Vector3d MeshCentre(const TemplateBank& bank) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& v : bank.online_mesh.vertices) sum += v.cast<double>();
  return bank.online_mesh.vertices.empty() ? sum : sum / static_cast<double>(bank.online_mesh.vertices.size());
}

// SamePlace with the mesh's centre already known.
bool SamePlaceAt(const PoseResult& a, const PoseResult& b, const Eigen::Vector3d& centre, double diameter_m) {
  if (!a.success || !b.success) return false;
  return (a.cam_from_object * centre - b.cam_from_object * centre).norm() < kSamePlaceFraction * diameter_m;
}

}  // namespace

bool SamePlace(const PoseResult& a, const PoseResult& b, const TemplateBank& bank) {
  return SamePlaceAt(a, b, MeshCentre(bank), bank.diameter_m);
}

std::vector<int> DuplicateAnswers(const std::vector<Instance>& instances, const std::vector<const TemplateBank*>& banks,
                                  const std::vector<PoseResult>& answers, const SolverOptions& options) {
  std::vector<int> twins(answers.size(), -1);
  if (!options.resolve_duplicates) return twins;
  std::vector<Eigen::Vector3d> centres(answers.size(), Eigen::Vector3d::Zero());  // once per instance
  for (size_t i = 0; i < answers.size(); ++i) {
    if (banks[i] != nullptr && answers[i].success) centres[i] = MeshCentre(*banks[i]);
  }
  for (size_t i = 0; i < answers.size(); ++i) {
    if (banks[i] == nullptr || !answers[i].success) continue;
    for (size_t j = 0; j < answers.size(); ++j) {
      if (j == i || banks[j] == nullptr || instances[j].object_id != instances[i].object_id) continue;
      if (!SamePlaceAt(answers[i], answers[j], centres[i], banks[i]->diameter_m)) continue;
      // The lower S_A keeps the place (the lower index on a tie); the other is the twin's.
      const bool j_keeps = answers[j].score < answers[i].score || (answers[j].score == answers[i].score && j < i);
      if (j_keeps && (twins[i] < 0 || answers[j].score < answers[static_cast<size_t>(twins[i])].score)) {
        twins[i] = static_cast<int>(j);
      }
    }
  }
  return twins;
}

void ExplainAwayNeighbours(const Frame& frame, const std::vector<Instance>& instances,
                           const std::vector<const TemplateBank*>& banks, const std::vector<char>& may_solve_again,
                           const SolverOptions& options, Executor* executor, std::vector<PoseResult>* answers) {
  if (instances.size() != banks.size() || instances.size() != answers->size() ||
      !(may_solve_again.empty() || may_solve_again.size() == instances.size())) {
    throw Error("ExplainAwayNeighbours: " + std::to_string(instances.size()) + " instances, " +
                std::to_string(banks.size()) + " banks, " + std::to_string(answers->size()) + " answers and " +
                std::to_string(may_solve_again.size()) + " may_solve_again flags (must be equal; no flags = all)");
  }
  if (!options.explain_neighbours || options.mask_trust != MaskTrust::kDepth || instances.size() < 2) return;
  const std::vector<PoseResult>& first = *answers;  // every re-solve reads the first pass only
  std::vector<PoseResult> second(first.size());
  std::vector<char> replaced(first.size(), 0);
  const std::vector<int> twins = DuplicateAnswers(instances, banks, first, options);
  for (size_t i = 0; i < instances.size(); ++i) {
    const Instance& instance = instances[i];
    const int twin = twins[i];
    if (banks[i] == nullptr || (!may_solve_again.empty() && !may_solve_again[i]) ||
        (!AnswerInDoubt(first[i], options) && twin < 0)) {
      continue;
    }
    if (instance.mask.empty() || instance.mask.type() != CV_8U || instance.mask.size() != frame.depth.size()) continue;
    const Stopwatch watch;
    const cv::Mat given = instance.mask > 0;
    // The pixels the confident answers of lower S_A of the other instances imply.
    cv::Mat explained = cv::Mat::zeros(given.size(), CV_8U);
    for (size_t j = 0; j < first.size(); ++j) {
      const PoseResult& other = first[j];
      const bool is_twin = static_cast<int>(j) == twin;  // its object, whatever its S_A
      if (j == i || !other.success || (!is_twin && UnsureOfScore(options, other.score, other.ambiguous))) continue;
      if (!is_twin && first[i].success && !(other.score < first[i].score)) continue;
      if (other.corrected_mask.size() != given.size() || other.corrected_mask.type() != CV_8U) continue;
      explained |= other.corrected_mask;
    }
    explained &= given;
    const int given_pixels = cv::countNonZero(given);
    const int explained_pixels = cv::countNonZero(explained);
    if (given_pixels == 0 || explained_pixels < options.neighbour_min_fraction * given_pixels) continue;
    Instance rest{instance.object_id, given & ~explained};
    PoseResult again = EstimatePose(frame, rest, *banks[i], options, executor);
    const double ms = watch.ElapsedMs();
    // A twin's answer is another instance's: any answer elsewhere is better than a second
    // answer on that instance.
    const bool better = twin >= 0 ? again.success && !SamePlace(again, first[static_cast<size_t>(twin)], *banks[i])
                                  : again.success && (!first[i].success || again.score < first[i].score);
    if (better) {
      // The answer's counts and poses are its own solve's; the times are of the work this
      // instance cost: the first solve, then this one (neighbours_ms).
      CopyMaskSolveReport(first[i].stages, &again.stages);
      again.stages.neighbour_answer_chosen = true;
      again.truncated = again.truncated || first[i].truncated;
      again.mask_iou = MaskIntersectionOverUnion(again.corrected_mask, given);
      again.confidence = AnswerConfidence(options, again);  // of the mask the caller gave
      second[i] = std::move(again);
    } else {
      second[i] = first[i];
    }
    second[i].stages.neighbour_pixels = explained_pixels;
    second[i].stages.neighbours_ms = ms;
    second[i].stages.total_ms = first[i].stages.total_ms + ms;
    replaced[i] = 1;
  }
  for (size_t i = 0; i < first.size(); ++i) {
    if (replaced[i]) (*answers)[i] = std::move(second[i]);
  }
  // What is left on one place: at most one of the answers there is right.
  const std::vector<int> left = DuplicateAnswers(instances, banks, *answers, options);
  for (size_t i = 0; i < left.size(); ++i) {
    if (left[i] < 0) continue;
    PoseResult& answer = (*answers)[i];
    answer.stages.duplicate_answer = true;
    answer.confidence = std::min(answer.confidence, 1.0 - (*answers)[static_cast<size_t>(left[i])].confidence);
  }
}

}  // namespace g6d
