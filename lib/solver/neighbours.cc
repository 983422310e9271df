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
  for (size_t i = 0; i < instances.size(); ++i) {
    const Instance& instance = instances[i];
    if (banks[i] == nullptr || (!may_solve_again.empty() && !may_solve_again[i]) || !AnswerInDoubt(first[i], options)) {
      continue;
    }
    if (instance.mask.empty() || instance.mask.type() != CV_8U || instance.mask.size() != frame.depth.size()) continue;
    const Stopwatch watch;
    const cv::Mat given = instance.mask > 0;
    // The pixels the confident answers of lower S_A of the other instances imply.
    cv::Mat explained = cv::Mat::zeros(given.size(), CV_8U);
    for (size_t j = 0; j < first.size(); ++j) {
      const PoseResult& other = first[j];
      if (j == i || !other.success || UnsureOfScore(options, other.score, other.ambiguous)) continue;
      if (first[i].success && !(other.score < first[i].score)) continue;
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
    if (again.success && (!first[i].success || again.score < first[i].score)) {
      // The answer's counts and poses are its own solve's; the times are of the work this
      // instance cost: the first solve, then this one (neighbours_ms).
      CopyMaskSolveReport(first[i].stages, &again.stages);
      again.stages.neighbour_answer_chosen = true;
      again.truncated = again.truncated || first[i].truncated;
      again.mask_iou = MaskIntersectionOverUnion(again.corrected_mask, given);
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
}

}  // namespace g6d
