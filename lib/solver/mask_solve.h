#pragma once
/// @file mask_solve.h
/// The solve on the caller's mask, the paper's pipeline (Sec. III-C..E) with the mask read as
/// evidence: the mask stage (mask_stage.h), the search stages (stages.h), the finalists
/// (finalists.h) and the mask refined with the answer (mask_refine.h). EstimatePose
/// (pipeline.h) adds the depth's own regions on top; DetectObjects solves each of its regions
/// with this.

#include <Eigen/Geometry>

#include "core/executor.h"
#include "core/frame.h"
#include "solver/result.h"
#include "solver/score.h"
#include "solver/solver_options.h"
#include "templates/template_bank.h"

namespace g6d {

/// S (and its parts) of a given pose for one instance, with the observation prepared
/// exactly as EstimatePose prepares it (refinement grid, z_M, occlusion reasoning): for
/// diagnostics such as scoring the ground-truth pose beside the answer. Throws g6d::Error
/// for input EstimatePose would refuse.
PoseScore ScoreInstancePose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                            const SolverOptions& options, const Eigen::Isometry3d& cam_from_object);

/// The solve on the caller's mask: EstimatePose without the depth's own regions
/// (SolverOptions::region_candidates is not read here; SolveOnDepthRegions, depth_regions.h,
/// reads it). Never throws for bad data: bad input gives success = false with termination
/// kBadInput and a message naming the problem. Per-hypothesis work fans out over `executor`;
/// any thread count gives the same result.
PoseResult EstimatePoseOnMask(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                              const SolverOptions& options, Executor* executor);

}  // namespace g6d
