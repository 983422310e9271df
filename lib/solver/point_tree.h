#pragma once
/// @file point_tree.h
/// A k-d tree over 3-D points for ICP's nearest-neighbour queries.
///
/// Why not Open3D's KDTreeFlann here: it is generic in the dimension (nanoflann over a
/// dynamic-size Eigen adaptor) and fills two std::vectors per query; ICP asks one nearest
/// neighbour for a few hundred points, dozens of times per hypothesis, and needs no neighbour
/// farther than its cutoff r_max. This tree is fixed at three dimensions, keeps the points in
/// leaf order, takes a distance bound (a query with nothing within it costs a few node visits)
/// and a hint (the point the query's previous position matched: its distance is a tight
/// first bound). It returns the exact nearest point within the bound: the same point as an
/// exhaustive search, up to ties in distance. Open3D keeps the other nearest-neighbour uses
/// (symmetry search, ADD-S), which run offline or in the benchmark.

#include <vector>

#include <Eigen/Core>

namespace g6d {

class PointTree {
 public:
  /// Builds the tree over `points` (copied into leaf order). O(n log n).
  explicit PointTree(const std::vector<Eigen::Vector3d>& points);

  int size() const { return static_cast<int>(ids_.size()); }

  /// The index (into the constructor's `points`) of the nearest point to `query` whose
  /// squared distance is below `bound_squared`, and that squared distance; -1 (and
  /// `bound_squared`) when none is. `hint`: an index to try first (-1 = none), e.g. the
  /// previous match of a query that moved a little.
  int Nearest(const Eigen::Vector3d& query, double bound_squared, int hint, double* squared_distance) const;

 private:
  /// 16 bytes. An inner node's left child is the node after it (the tree is laid out
  /// depth-first); a leaf holds the points [child, child + count) of the leaf order.
  struct Node {
    double split = 0.0;  ///< the splitting coordinate (inner nodes)
    int axis = -1;       ///< 0, 1, 2; a leaf: -1 - its count of points
    int child = 0;       ///< inner: index of the right child; leaf: its first point
  };
  int Build(int begin, int end);
  void Search(const double* query, double* best_squared, int* best) const;

  std::vector<double> xyz_;  // 3 per point, in leaf order
  std::vector<int> ids_;     // leaf order -> constructor index
  std::vector<int> slot_;    // constructor index -> leaf order
  std::vector<Node> nodes_;
};

}  // namespace g6d
