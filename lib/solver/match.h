#pragma once
/// @file match.h
/// Template matching (paper Sec. III-C): every query ORB descriptor is matched to its
/// nearest descriptor in each template by Hamming distance; matches with δ < τ_H give
/// 2D-3D correspondences C_j; templates are ranked by Q_j = Σ (1 − δ/τ_H) (eq. 4)
/// and the best N_P correspondence sets are kept.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/executor.h"
#include "templates/features.h"
#include "templates/template_bank.h"

namespace g6d {

/// Options of MatchTemplates(). Defaults are the paper's.
struct MatchOptions {
  int hamming_threshold = 64;   ///< τ_H: matches need δ < τ_H (bits of 256)
  int max_sets = 256;           ///< N_P: correspondence sets kept for PnP
  int min_correspondences = 6;  ///< templates with fewer matches are discarded
  /// Use the AVX-512 (VPOPCNTDQ) distance loop where the CPU has it, else the AVX2 one where
  /// it has that; false = the portable loop. All give the same result bit for bit.
  bool simd = true;
  /// With simd: false = the AVX2 loop even where the CPU has AVX-512 (to measure what a
  /// machine without it takes).
  bool simd_avx512 = true;

  std::string Check() const;
};

/// The 2D-3D correspondences of one template (C_j).
struct CorrespondenceSet {
  int template_index = -1;
  double quality = 0.0;                       ///< Q_j
  std::vector<Eigen::Vector2d> image_points;  ///< u_i^q, image coordinates under K (centre +0.5)
  std::vector<Eigen::Vector3d> object_points; ///< X_{jπ(i)}^o, object frame, metres
  std::vector<int> distances;                 ///< δ_i, Hamming distance of each correspondence
  std::vector<int> query_indices;             ///< index of the query feature of each correspondence
};

/// Counts and timing of the matching stage.
struct MatchReport {
  bool success = false;
  std::string message = "not run";
  int query_features = 0;
  int templates_with_matches = 0;  ///< templates with at least min_correspondences matches
  int sets_kept = 0;
  double best_quality = 0.0;
};

/// Matches `query` features (OpenCV pixel coordinates of the full image) against every
/// template of `bank`. Templates fan out over `executor`; the result does not depend on
/// the number of threads. Sets are sorted by quality, best first (ties by template index).
void MatchTemplates(const MatchOptions& options, const std::vector<Feature>& query,
                    const TemplateBank& bank, Executor* executor,
                    std::vector<CorrespondenceSet>* sets, MatchReport* report);

/// Hamming distance between two 256-bit descriptors.
int HammingDistance(const std::array<uint8_t, 32>& a, const std::array<uint8_t, 32>& b);

}  // namespace g6d
