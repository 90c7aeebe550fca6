#pragma once
// A static bounding-volume hierarchy of axis-aligned boxes, the acceleration structure behind
// point location in tetrahedra and closest-point / ray queries on surfaces.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>
#include <vector>

namespace nsim {

/// Binary tree of axis-aligned boxes over a fixed set of primitives (each given by its box),
/// built once by median splits along the longest axis of the centroids; leaves hold at most
/// kLeafSize primitives. Queries call back with primitive indices; the callbacks do the exact
/// geometry. Build O(n log n), memory O(n).
class AabbTree {
 public:
  static constexpr int kLeafSize = 4;

  AabbTree() = default;
  /// Builds over `boxes` (one per primitive, same units as the queries).
  explicit AabbTree(const std::vector<Eigen::AlignedBox3d>& boxes);

  int num_primitives() const { return static_cast<int>(order_.size()); }
  bool empty() const { return nodes_.empty(); }
  /// Box of everything (empty box when there are no primitives).
  Eigen::AlignedBox3d bounds() const {
    return nodes_.empty() ? Eigen::AlignedBox3d() : nodes_[0].box;
  }

  /// Calls visit(i) for each primitive i whose box contains `p` (boundary included) until visit
  /// returns true; returns whether some call returned true.
  template <typename Visit>
  bool VisitContaining(const Eigen::Vector3d& p, Visit&& visit) const;

  /// Branch and bound for the nearest primitive: distance_sq(i, best_sq) returns the squared
  /// distance from the query to primitive i (it may return any value >= best_sq when it can
  /// tell the primitive is no closer). Boxes farther than the best so far are pruned.
  /// Returns the best index (-1 if empty) and sets *best_sq.
  template <typename DistanceSq>
  int FindNearest(const Eigen::Vector3d& p, DistanceSq&& distance_sq, double* best_sq) const;

  /// Visits primitives whose box meets the ray origin + t dir, t in [0, *t_max], in roughly
  /// front-to-back order; visit(i, t_max) may lower *t_max (a first-hit search), which prunes
  /// boxes entirely beyond it.
  template <typename Visit>
  void VisitRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double* t_max,
                Visit&& visit) const;

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    int left = -1;  // child node index, -1 for a leaf
    int right = -1;
    int begin = 0;  // leaf: primitives order_[begin, end)
    int end = 0;
  };
  int Build(const std::vector<Eigen::AlignedBox3d>& boxes,
            const std::vector<Eigen::Vector3d>& centres, int begin, int end);
  static double BoxDistanceSq(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& p) {
    return box.squaredExteriorDistance(p);
  }
  // entry parameter of the ray into the box, +inf when it misses within [0, t_max]
  static double RayEntry(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& origin,
                         const Eigen::Vector3d& inv_dir, double t_max);

  std::vector<Node> nodes_;
  std::vector<int> order_;                       // primitive indices, leaves' ranges index it
  std::vector<Eigen::AlignedBox3d> leaf_boxes_;  // leaf_boxes_[k] is the box of order_[k]
};

template <typename Visit>
bool AabbTree::VisitContaining(const Eigen::Vector3d& p, Visit&& visit) const {
  if (nodes_.empty()) return false;
  int stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (!n.box.contains(p)) continue;
    if (n.left < 0) {
      for (int k = n.begin; k < n.end; ++k)
        if (leaf_boxes_[k].contains(p) && visit(order_[k])) return true;
    } else {
      stack[top++] = n.left;
      stack[top++] = n.right;
    }
  }
  return false;
}

template <typename DistanceSq>
int AabbTree::FindNearest(const Eigen::Vector3d& p, DistanceSq&& distance_sq,
                          double* best_sq) const {
  double best = std::numeric_limits<double>::infinity();
  int best_index = -1;
  if (!nodes_.empty()) {
    int stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& n = nodes_[stack[--top]];
      if (BoxDistanceSq(n.box, p) >= best) continue;
      if (n.left < 0) {
        for (int k = n.begin; k < n.end; ++k) {
          if (BoxDistanceSq(leaf_boxes_[k], p) >= best) continue;
          const double d = distance_sq(order_[k], best);
          if (d < best) {
            best = d;
            best_index = order_[k];
          }
        }
      } else {
        // descend into the nearer child first (pushed last)
        const double dl = BoxDistanceSq(nodes_[n.left].box, p);
        const double dr = BoxDistanceSq(nodes_[n.right].box, p);
        if (dl < dr) {
          stack[top++] = n.right;
          stack[top++] = n.left;
        } else {
          stack[top++] = n.left;
          stack[top++] = n.right;
        }
      }
    }
  }
  if (best_sq) *best_sq = best;
  return best_index;
}

template <typename Visit>
void AabbTree::VisitRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double* t_max,
                        Visit&& visit) const {
  if (nodes_.empty()) return;
  const Eigen::Vector3d inv_dir = dir.cwiseInverse();  // +-inf for zero components
  int stack[64];
  double entry[64];
  int top = 0;
  const double t0 = RayEntry(nodes_[0].box, origin, inv_dir, *t_max);
  if (!(t0 <= *t_max)) return;
  stack[top] = 0;
  entry[top++] = t0;
  while (top > 0) {
    --top;
    if (entry[top] > *t_max) continue;
    const Node& n = nodes_[stack[top]];
    if (n.left < 0) {
      for (int k = n.begin; k < n.end; ++k)
        if (RayEntry(leaf_boxes_[k], origin, inv_dir, *t_max) <= *t_max) visit(order_[k], t_max);
      continue;
    }
    const double tl = RayEntry(nodes_[n.left].box, origin, inv_dir, *t_max);
    const double tr = RayEntry(nodes_[n.right].box, origin, inv_dir, *t_max);
    // push the farther child first so the nearer one is visited first
    const bool left_first = tl <= tr;
    const int near_child = left_first ? n.left : n.right, far_child = left_first ? n.right : n.left;
    const double t_near = left_first ? tl : tr, t_far = left_first ? tr : tl;
    if (t_far <= *t_max) {
      stack[top] = far_child;
      entry[top++] = t_far;
    }
    if (t_near <= *t_max) {
      stack[top] = near_child;
      entry[top++] = t_near;
    }
  }
}

}  // namespace nsim
