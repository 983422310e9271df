#pragma once
/// @file depth_regions.h
/// The depth's own regions in place of a mask that holds more than the object (internal to
/// lib/solver; EstimatePose calls it, SolverOptions::region_candidates).
///
/// A merged mask or a box over neighbours that touch the object at the same depth is one
/// depth segment the mask stage's ownership cannot split, and S, read on that mask, prefers
/// a pose that covers the neighbours too. The depth can split it where DetectObjects does
/// (depth steps, concave creases where two convex objects meet): the regions inside the
/// mask that fit the object are ranked by size and colour, the best are solved as masks of
/// their own, and an answer whose S_A is lower than the mask's answer replaces it.
/// EstimatePose (pipeline.h) calls it on the answer of EstimatePoseOnMask (mask_solve.h); it
/// calls DetectObjects (detect.h), which solves each region with EstimatePoseOnMask.

#include "core/executor.h"
#include "core/frame.h"
#include "solver/result.h"
#include "solver/solver_options.h"
#include "templates/template_bank.h"

namespace g6d {

/// Whether an answer on a mask is in doubt, so that a second reading of the mask is worth
/// a solve (the depth's regions here, the neighbours' pixels taken out in neighbours.h): a
/// success whose mask holds more than the object (mask_wider_than_object), is a box
/// (mask_is_box) or that is unsure (UnsureOfScore: SolverOptions::unsure_score); a failure
/// for want of any hypothesis. Other refusals (bad input, reject_border_masks) stand.
bool AnswerInDoubt(const PoseResult& answer, const SolverOptions& options);

/// Returns `on_mask` (EstimatePoseOnMask's answer on the caller's mask), or, when the mask's
/// depth spans more than the object can reach (on_mask.stages.mask_wider_than_object, kDepth) or
/// the answer is unsure (SolverOptions::unsure_score) and a region of the depth
/// inside it gives a lower S_A, that answer, with the time, the count
/// of regions solved and `depth_region_chosen` in its stages and its corrected mask's IoU
/// with the caller's mask. Off when options.region_candidates is 0. Never throws.
PoseResult SolveOnDepthRegions(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                               const SolverOptions& options, Executor* executor, PoseResult on_mask);

}  // namespace g6d
