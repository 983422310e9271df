#pragma once
/// @file mask_stage.h
/// The mask stage of the solver (internal to lib/solver): the caller's mask read as evidence
/// before the search (PrepareObservation: leaks removed, depth segments, the grids every
/// score is taken on). After the search the mask is refined with the answer (mask_refine.h).
/// EstimatePoseOnMask and TrackPose call it; nothing outside the solver does.

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/frame.h"
#include "solver/icp.h"
#include "solver/observation.h"
#include "solver/region.h"
#include "solver/score.h"
#include "solver/solver_options.h"

namespace g6d {

/// The observed data of one instance, shared read-only by every hypothesis of a solve.
struct Observation {
  cv::Mat mask;              // CV_8U 0/255, frame size
  cv::Mat depth;             // CV_32F metres, NaN patched to 0
  cv::Rect box;              // mask bounding box
  double z_m = 0.0;          // robust z_M (median; eq. (9) uses the mean)
  int valid_depth = 0;       // mask pixels with valid depth
  bool truncated = false;    // the mask touches the image border
  ObservedRegion region;     // what the depth changed in the caller's mask (MaskTrust::kDepth)
  // The regions the search reads (ORB crop, keypoint depths, the mask box and z of PnP's
  // prior). First the mask grown by the depth over the object it missed (kDepth,
  // RegionOptions::grow_fraction), else the mask; then, when the region spans more than
  // the object can (a merged or boxed mask), its largest depth segments within the
  // object's reach, each alone (SolverOptions::max_search_regions).
  struct SearchRegion {
    cv::Mat mask;
    cv::Rect box;
    double z_m = 0.0;
  };
  std::vector<SearchRegion> search_regions;
  // kDepth: the region's depth points span more than the object can reach (a merged mask, a
  // box over neighbours): it holds more than the object.
  bool wider_than_object = false;
  // The caller's mask fills its bounding box: a detector's box, whose outline is not the object's.
  bool is_box = false;
  // PrepareObservation refused the mask for too little evidence (a sliver with too few
  // pixels with depth, or nothing left once its leaks are removed): it still says where.
  bool too_thin = false;
  ScoreOptions score;        // options.score with this instance's depth evidence
  std::unique_ptr<PointCloudIndex> observed;  // Y: observed points inside the mask
  EvaluationGrid selection_grid, refine_grid;
};

/// Fills *observation from the frame and the caller's mask, read as options.mask_trust says
/// (kDepth: leaks removed by the depth, depth segments for ownership). `diameter_m` is the
/// object's. Returns an empty string, or what is wrong with the input (the solve's kBadInput).
std::string PrepareObservation(const Frame& frame, const Instance& instance, const SolverOptions& options,
                               double diameter_m, Observation* observation);

}  // namespace g6d
