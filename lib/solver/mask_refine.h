#pragma once
/// @file mask_refine.h
/// The mask refined with the answer (internal to lib/solver): after the search, the mask the
/// pose implies is solved again from T_A (TrackPose) while S improves, and its IoU with the
/// caller's mask is reported. EstimatePoseOnMask calls it; nothing outside the solver does.

#include <functional>

#include "core/executor.h"
#include "core/frame.h"
#include "solver/mask_stage.h"
#include "solver/result.h"
#include "solver/score.h"
#include "solver/solver_options.h"
#include "templates/template_bank.h"

namespace g6d {

/// After the solve (MaskTrust::kDepth, options.mask_refine_rounds): ICP + MHPO from T_A
/// (TrackPose) on the mask T_A implies (CorrectedMask), kept while S against the caller's mask
/// (as evidence, `observation`) falls; then the corrected mask of the final T_A and its IoU
/// with the caller's mask go into *result (for kExact too, without the refinement).
/// `online_score` is the score options of the online mesh; `out_of_time` is asked before
/// each round.
void RefineWithCorrectedMask(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                             const SolverOptions& options, const Observation& observation,
                             const ScoreOptions& online_score, const std::function<bool()>& out_of_time,
                             Executor* executor, PoseResult* result);

}  // namespace g6d
