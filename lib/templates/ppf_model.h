#pragma once
/// @file ppf_model.h
/// The point-pair-feature model of an object (Drost et al. 2010, with Vidal et al. 2018's
/// refinements): a texture-free hypothesis source. Oriented points are sampled on the mesh
/// surface at a step of a fraction of its diameter; every ordered pair (m_r, m_i) of them
/// gives a feature F = (|d|, ∠(n_r, d), ∠(n_i, d), ∠(n_r, n_i)), d = m_i - m_r, quantized
/// into a table that maps a feature to the pairs that have it and the angle alpha_m of m_i
/// about n_r (PpfAlpha). A scene pair with the same feature votes for the model point m_r
/// and the rotation alpha_m - alpha_s (solver/ppf.h).
///
/// The sampled points and normals are built offline and stored in the template cache; the
/// table is a deterministic function of them and is rebuilt when a cache is read
/// (DerivePpfTable), in tens of milliseconds, instead of storing a few megabytes per object.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mesh/mesh.h"

namespace g6d {

/// What the model is built with; stored in the cache.
struct PpfModelOptions {
  /// Sampling step and distance quantum, as a fraction of the diameter (Drost: 0.05).
  double step_fraction = 0.05;
  /// Angle quantum of the feature's three angles and of alpha, degrees (Drost: 12).
  double angle_step_deg = 12.0;
  /// Samples within one voxel whose normals differ by more than this are kept apart
  /// (Vidal: the two sides of a thin sheet, an edge's two faces), degrees.
  double normal_cluster_deg = 30.0;
  /// Surface samples drawn (area-weighted) before the voxel reduction.
  int surface_samples = 60000;
  /// At most this many model points: when the step gives more, the step grows.
  int max_points = 1200;
  uint32_t seed = 7;  ///< surface sampling seed

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

/// One model pair in the table.
struct PpfEntry {
  uint16_t reference = 0;  ///< index of m_r
  /// alpha_m in units of 2 pi / 65536 (so that differences wrap in 16-bit arithmetic).
  int16_t alpha = 0;
};

/// An angle in radians as PpfEntry::alpha units (wrapping).
int16_t PpfAngleUnits(float radians);

/// The model: oriented points (stored) and the feature table (derived).
struct PpfModel {
  PpfModelOptions options;
  double step_m = 0.0;                   ///< the sampling step used, metres
  std::vector<Eigen::Vector3f> points;   ///< object frame, metres
  std::vector<Eigen::Vector3f> normals;  ///< unit, outward

  // Derived (DerivePpfTable), never stored.
  double max_distance_m = 0.0;  ///< the longest pair, metres (distance bins cover it)
  int distance_bins = 0;
  int angle_bins = 0;            ///< bins of [0, pi] for the feature's angles
  int alpha_bins = 0;            ///< bins of [-pi, pi) for alpha
  std::vector<uint32_t> offsets;  ///< table: entries of key k are entries[offsets[k] .. offsets[k+1])
  std::vector<PpfEntry> entries;
  /// Model point m_r's transform to the reference frame (m_r at the origin, n_r along +x).
  std::vector<Eigen::Isometry3f> reference_from_object;

  bool empty() const { return points.empty(); }
  /// Table key of a feature, or -1 when the distance is beyond the table.
  int Key(int distance_bin, int angle1_bin, int angle2_bin, int angle3_bin) const {
    if (distance_bin < 0 || distance_bin >= distance_bins) return -1;
    return ((distance_bin * angle_bins + angle1_bin) * angle_bins + angle2_bin) * angle_bins + angle3_bin;
  }
};

/// The transform that takes point p to the origin and its unit normal n onto +x.
Eigen::Isometry3f PpfReferenceFrame(const Eigen::Vector3f& p, const Eigen::Vector3f& n);

/// The angle (radians, [-pi, pi)) that turns `q_in_reference` (a point in a reference frame,
/// PpfReferenceFrame) about +x into the half-plane z = 0, y > 0.
float PpfAlpha(const Eigen::Vector3f& q_in_reference);

/// The four values of the feature of (p1, n1) -> (p2, n2): distance (metres) and the angles
/// ∠(n1, d), ∠(n2, d), ∠(n1, n2) in radians.
Eigen::Vector4f PpfFeature(const Eigen::Vector3f& p1, const Eigen::Vector3f& n1, const Eigen::Vector3f& p2,
                           const Eigen::Vector3f& n2);

/// Samples oriented points on `mesh` (outward normals by the faces' winding) at
/// options.step_fraction of `diameter_m`: area-weighted samples reduced per voxel, one
/// point per cluster of normals within the voxel. Throws g6d::Error for bad options or a
/// mesh without area. The table is filled too (DerivePpfTable).
PpfModel BuildPpfModel(const Mesh& mesh, double diameter_m, const PpfModelOptions& options);

/// Reduces oriented points to one per voxel of side `step_m` and cluster of normals
/// (normal_cluster_deg): the mean point and normal of each cluster, in a deterministic order.
/// Used for the model and for the scene alike.
void VoxelReduceOriented(const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3f>& normals,
                         double step_m, double normal_cluster_deg, std::vector<Eigen::Vector3f>* reduced_points,
                         std::vector<Eigen::Vector3f>* reduced_normals);

/// Fills the derived fields of *model (the feature table) from its points and normals.
void DerivePpfTable(PpfModel* model);

}  // namespace g6d
