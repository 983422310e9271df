#pragma once
/// @file pipeline.h
/// EstimatePose: the whole G6D online pipeline for one instance (paper Sec. III-C..E):
/// match -> MSAC-PnP -> observable selection -> trimmed ICP -> MHPO, selected by S.
///
/// The solver's files in the order they call each other, each using only those before it
/// (tests/layering_test.cc, kSolverOrder, checks the includes):
///   the algorithms (segments, plane, observation, region, score, match, icp, pnp, mhpo, ppf) ->
///   solver_options.h, result.h (the types every stage shares) -> detect_options.h,
///   proposals.h (the depth's candidate regions) -> mask_stage.h (the mask as evidence) ->
///   solve_context.h -> track_pose.h (TrackPose) -> mask_refine.h -> finalists.h ->
///   stages.h -> mask_solve.h (EstimatePoseOnMask) -> detect.h (DetectObjects) ->
///   depth_regions.h (SolveOnDepthRegions) -> pipeline.h (EstimatePose: the solve on the
///   mask, then the depth's regions) -> neighbours.h (ExplainAwayNeighbours: a frame's
///   instances read together, EstimatePose again) -> identify.h.
/// This header also brings the shared types and TrackPose, for the callers outside.

#include "core/executor.h"
#include "core/frame.h"
#include "solver/mask_solve.h"
#include "solver/result.h"
#include "solver/solver_options.h"
#include "solver/track_pose.h"
#include "templates/template_bank.h"

namespace g6d {

/// Estimates cam_from_object for one instance. Never throws for bad data: bad input
/// gives success = false with termination kBadInput and a message naming the problem.
/// Per-hypothesis work fans out over `executor`; any thread count gives the same result.
PoseResult EstimatePose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                        const SolverOptions& options, Executor* executor);

}  // namespace g6d
