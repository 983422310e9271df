#include "solver/pipeline.h"

#include "solver/depth_regions.h"
#include "solver/mask_solve.h"

namespace g6d {

PoseResult EstimatePose(const Frame& frame, const Instance& instance, const TemplateBank& bank,
                        const SolverOptions& options, Executor* executor) {
  return SolveOnDepthRegions(frame, instance, bank, options, executor,  // depth_regions.h
                             EstimatePoseOnMask(frame, instance, bank, options, executor));
}

}  // namespace g6d
