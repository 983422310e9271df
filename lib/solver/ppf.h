#pragma once
/// @file ppf.h
/// Point-pair-feature voting on the observed depth (Drost et al. 2010; Vidal et al. 2018's
/// refinements: normals from the depth, neighbouring bins, pose clustering): pose
/// hypotheses that need no texture and no segmentation. The scene's oriented points come
/// from the depth inside a region (a mask, a box, or the whole frame less its support);
/// each reference point pairs with the points within the model's reach, every pair looks
/// its feature up in the model's table (templates/ppf_model.h) and votes for a model point
/// and a rotation about the reference normal; the peaks become poses, clustered, best
/// first. They join the ORB-PnP hypotheses before observable selection (RunPpfStage, stages.h).

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/executor.h"
#include "templates/ppf_model.h"

namespace g6d {

/// Options of the scene cloud and the vote.
struct PpfSearchOptions {
  /// Every n-th scene point (in the reduced cloud's order) is a reference point (Drost: 5),
  /// and at most `max_reference_points` of them (the stride grows): a large object seen up
  /// close has thousands of scene points, and each reference pairs with all of them.
  int reference_stride = 2;
  int max_reference_points = 300;
  /// A feature value within this fraction of a bin's width of its border votes in the
  /// neighbouring bin too (Vidal et al.: sensor noise moves features across borders).
  double neighbour_spread = 0.25;
  /// Features that hold more than this fraction of the model's pairs (the pairs of two
  /// points of one plane, say) say almost nothing about the pose and are not looked up. At
  /// 0.01 a box's vote cast 3000 votes per scene pair (170 ms on real YCB-V); 0.001 halves
  /// the vote's time there, with the same recall on synth_dev and YCB-V (bench/RESULTS.md).
  double max_bucket_fraction = 0.001;
  /// Peaks taken per reference point (distinct model points or rotations).
  int peaks_per_reference = 2;
  /// A peak below this fraction of the reference's best is not taken.
  double peak_ratio = 0.6;
  /// Poses closer than these are one cluster: translation as a fraction of the diameter,
  /// rotation in degrees (Drost: 1/10 d and 12 degrees).
  double cluster_distance_fraction = 0.1;
  double cluster_angle_deg = 15.0;
  /// Clusters returned at most, best (most votes) first.
  int max_poses = 12;
  /// A cluster with fewer votes than this fraction of the best cluster's is dropped.
  double min_cluster_ratio = 0.1;
  /// Normals from the depth: the principal axes of the points with depth within this many
  /// sampling steps of the pixel's 3D point (and at most 6 px away).
  double normal_radius_steps = 1.0;
  /// Scene points at most (after the voxel reduction); more are thinned evenly.
  int max_scene_points = 4000;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// Oriented scene points, camera frame, metres.
struct PpfScene {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> normals;  ///< unit, towards the camera
};

/// The scene cloud of a region: the depth's points inside `region` (CV_8U, non-zero =
/// inside; empty = the whole frame) with normals from their neighbourhood in the depth,
/// reduced as the model is (VoxelReduceOriented at `step_m`). `depth_m` CV_32F metres, 0 =
/// none.
PpfScene MakePpfScene(const Camera& camera, const cv::Mat& depth_m, const cv::Mat& region, double step_m,
                      double normal_cluster_deg, const PpfSearchOptions& options);

/// One pose from the vote.
struct PpfPose {
  Eigen::Isometry3d cam_from_object = Eigen::Isometry3d::Identity();
  double votes = 0.0;  ///< votes of its cluster
};

/// What the vote did.
struct PpfReport {
  int scene_points = 0;
  int reference_points = 0;
  long long pairs = 0;        ///< scene pairs looked up
  long long votes = 0;        ///< votes cast
  int peaks = 0;              ///< poses before clustering
  int clusters = 0;           ///< poses after clustering (before max_poses)
  double best_votes = 0.0;
  double ms = 0.0;
};

/// Votes for the poses of `model` in `scene`; clusters, best first. Empty when the scene
/// has too few points or the model is empty. Reference points fan out over `executor`
/// (any thread count gives the same poses).
std::vector<PpfPose> VotePpfPoses(const PpfModel& model, const PpfScene& scene, double diameter_m,
                                  const PpfSearchOptions& options, Executor* executor, PpfReport* report);

/// How well the scene around each of `references` (indices into `scene`; out of range = 0)
/// agrees with one pose of the model through it: the votes of the reference's best (model
/// point, rotation) bin. A point on the object gathers the votes of the object's other
/// points; a point on a surface of another shape, or on a fragment of a few points, gathers
/// few. (A plane looks like any flat face of the model, locally: the votes do not tell a
/// wall from a box's face; peak² / pairs, which would, ranked worse on synth_dev.)
/// Detection ranks its depth regions by it (DetectOptions::rank_uncoloured_by_shape). Same result on
/// any executor.
std::vector<float> PpfReferenceSupport(const PpfModel& model, const PpfScene& scene, const std::vector<int>& references,
                                       const PpfSearchOptions& options, Executor* executor);

}  // namespace g6d
