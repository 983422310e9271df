#include "solver/point_tree.h"

#include <algorithm>
#include <limits>
#include <numeric>

namespace g6d {
namespace {

// Points per leaf: a leaf's points are contiguous, so a scan of 8 costs about one node visit.
constexpr int kLeafSize = 8;

}  // namespace

PointTree::PointTree(const std::vector<Eigen::Vector3d>& points) {
  const int n = static_cast<int>(points.size());
  ids_.resize(static_cast<size_t>(n));
  std::iota(ids_.begin(), ids_.end(), 0);
  // Build on the constructor's order, then lay the coordinates out in leaf order.
  xyz_.resize(3 * static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) xyz_[3 * static_cast<size_t>(i) + a] = points[static_cast<size_t>(i)][a];
  }
  nodes_.reserve(static_cast<size_t>(2 * (n / kLeafSize + 1)));
  if (n > 0) Build(0, n);
  std::vector<double> ordered(xyz_.size());
  slot_.resize(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) {
    const int id = ids_[static_cast<size_t>(k)];
    slot_[static_cast<size_t>(id)] = k;
    for (int a = 0; a < 3; ++a) ordered[3 * static_cast<size_t>(k) + a] = points[static_cast<size_t>(id)][a];
  }
  xyz_.swap(ordered);
}

// Splits ids_[begin, end) at the median of its widest axis; returns the node's index.
int PointTree::Build(int begin, int end) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back(Node());
  if (end - begin <= kLeafSize) {
    nodes_[static_cast<size_t>(index)] = Node{0.0, -1 - (end - begin), begin};
    return index;
  }
  auto coordinate = [&](int id, int axis) { return xyz_[3 * static_cast<size_t>(id) + axis]; };
  Eigen::Vector3d low = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d high = -low;
  for (int k = begin; k < end; ++k) {
    for (int a = 0; a < 3; ++a) {
      const double c = coordinate(ids_[static_cast<size_t>(k)], a);
      low[a] = std::min(low[a], c);
      high[a] = std::max(high[a], c);
    }
  }
  int axis = 0;
  (high - low).maxCoeff(&axis);
  const int middle = begin + (end - begin) / 2;
  std::nth_element(ids_.begin() + begin, ids_.begin() + middle, ids_.begin() + end,
                   [&](int a, int b) { return coordinate(a, axis) < coordinate(b, axis); });
  // Left: coordinates <= split; right: >= split (nth_element's partition).
  const double split = coordinate(ids_[static_cast<size_t>(middle)], axis);
  Build(begin, middle);  // the left child is the next node
  const int right = Build(middle, end);
  nodes_[static_cast<size_t>(index)] = Node{split, axis, right};
  return index;
}

void PointTree::Search(const double* query, double* best_squared, int* best) const {
  // Depth-first, near side first, as a recursion would go (so ties go to the same point), with
  // the far sides waiting on a stack beside the squared distance to their splitting plane:
  // one is entered only if that plane is still nearer than the best found meanwhile. The tree
  // is balanced (median splits), so its depth, and the stack, stay below 64 for any size.
  struct Pending {
    int node;
    double plane_squared;
  };
  Pending stack[64];
  int top = 0;
  int node_index = 0;
  double best_so_far = *best_squared;
  int best_index = *best;
  for (;;) {
    const Node* node = &nodes_[static_cast<size_t>(node_index)];
    while (node->axis >= 0) {
      const double offset = query[node->axis] - node->split;
      const int left = node_index + 1;
      const int near_child = offset < 0.0 ? left : node->child;
      const int far_child = offset < 0.0 ? node->child : left;
      stack[top++] = Pending{far_child, offset * offset};
      node_index = near_child;
      node = &nodes_[static_cast<size_t>(node_index)];
    }
    const int leaf_end = node->child - 1 - node->axis;
    for (int k = node->child; k < leaf_end; ++k) {
      const double* p = &xyz_[3 * static_cast<size_t>(k)];
      const double dx = p[0] - query[0], dy = p[1] - query[1], dz = p[2] - query[2];
      const double squared = dx * dx + dy * dy + dz * dz;
      if (squared < best_so_far) {
        best_so_far = squared;
        best_index = k;
      }
    }
    // The next far side whose plane is nearer than the best.
    while (top > 0 && !(stack[top - 1].plane_squared < best_so_far)) --top;
    if (top == 0) break;
    node_index = stack[--top].node;
  }
  *best_squared = best_so_far;
  *best = best_index;
}

int PointTree::Nearest(const Eigen::Vector3d& query, double bound_squared, int hint, double* squared_distance) const {
  double best_squared = bound_squared;
  int best = -1;
  if (hint >= 0 && hint < size()) {
    const int k = slot_[static_cast<size_t>(hint)];
    const double* p = &xyz_[3 * static_cast<size_t>(k)];
    const double dx = p[0] - query[0], dy = p[1] - query[1], dz = p[2] - query[2];
    const double squared = dx * dx + dy * dy + dz * dz;
    if (squared < best_squared) {
      best_squared = squared;
      best = k;
    }
  }
  if (!nodes_.empty()) Search(query.data(), &best_squared, &best);
  *squared_distance = best_squared;
  return best < 0 ? -1 : ids_[static_cast<size_t>(best)];
}

}  // namespace g6d
