#include "solver/mask_solve.h"

#include <exception>
#include <sstream>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/timer.h"
#include "render/raster.h"
#include "solver/finalists.h"
#include "solver/frame_check.h"
#include "solver/mask_refine.h"
#include "solver/mask_stage.h"
#include "solver/solve_context.h"
#include "solver/stages.h"

namespace g6d {

namespace {

// The mask stage's findings in the report: truncation and what the depth changed.
void ReportObservation(const Observation& observation, PoseResult* result) {
  StageReport& stages = result->stages;
  result->truncated = observation.truncated;
  stages.mask_given_pixels = observation.region.given_pixels;
  stages.mask_support_leak = observation.region.support_leak;
  stages.mask_far_leak = observation.region.far_leak;
  stages.support_plane = observation.region.has_plane;
  stages.limit_plane = observation.region.has_limit_plane;
  stages.surface_tolerance_m = observation.region.surface_tolerance_m;
  stages.mask_wider_than_object = observation.wider_than_object;
  stages.mask_is_box = observation.is_box;
}

// S_A, the check against the frame, the confidence and the message of a successful solve
// (cut short: says so).
void FinishAnswer(const Frame& frame, const TemplateBank& bank, const SolverOptions& options, const SolveClock& clock,
                  PoseResult* result) {
  result->score = result->details.s;
  result->success = true;
  const Stopwatch watch;
  result->frame_check = CheckAgainstFrame(frame, bank, result->cam_from_object,
                                          options.check_surface_fraction * bank.diameter_m, options.check_step_m);
  result->stages.frame_check_ms = watch.ElapsedMs();
  result->confidence = AnswerConfidence(options, *result);
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
    RunPpfStage(context, &search);         // texture-free hypotheses from the depth
    RunSilhouetteStage(context, &search);  // and from the mask's outline
    if (search.hypotheses.empty()) {
      return fail(Termination::kNoHypothesis,
                  (no_hypothesis.empty() ? std::string("no hypothesis from ORB-PnP") : no_hypothesis) +
                      (context.bank.ppf.empty() || !options.use_ppf ? std::string() : "; point-pair features gave no pose") +
                      (!options.use_silhouettes || options.silhouette_hypotheses == 0 ? std::string()
                       : observation.is_box || observation.wider_than_object
                           ? std::string("; no outline read (a box, or a mask wider than the object)")
                           : std::string("; no template outline matched the mask's")));
    }
    std::vector<Hypothesis> kept = RunObservableStage(context, search.hypotheses);  // stage 3 (eq. 7)
    const IcpOutcome icp = RunIcpStage(context, &kept);                              // stage 4
    const MhpoTarget target = MakeMhpoTarget(observation.refine_grid, observation.z_m);
    std::vector<Finalist> finalists = RunMhpoStage(context, target, kept, icp, &result);  // stage 5: T_A, S_A
    RunPostRefineStage(context, target, &result);                                    // stage 6 (optional)
    RunFinalistStage(context, target, std::move(finalists), kept, search.sets, &result);  // flips, runner-up, appearance
    watch.Restart();                                                                 // the mask refined with the pose
    RefineWithCorrectedMask(frame, instance, bank, options, observation, context.online_score,
                            [&clock] { return clock.OutOfTime(); }, executor, &result);
    stages.mask_refine_ms = watch.ElapsedMs();
    FinishAnswer(frame, bank, options, clock, &result);
    stages.total_ms = total.ElapsedMs();
    return result;
  } catch (const std::exception& e) {
    // Library code reports bad data through the result; an exception here is a bug or
    // an unexpected input that a lower layer refused. It must not escape to the caller.
    return fail(Termination::kBadInput, std::string("internal error: ") + e.what());
  }
}

}  // namespace g6d
