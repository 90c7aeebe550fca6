#include "common/mesh/aabb_tree.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "common/core/error.h"

namespace nsim {

AabbTree::AabbTree(const std::vector<Eigen::AlignedBox3d>& boxes) {
  if (boxes.empty()) return;
  std::vector<Eigen::Vector3d> centres(boxes.size());
  for (size_t i = 0; i < boxes.size(); ++i) {
    NSIM_CHECK(!boxes[i].isEmpty(), "primitive ", i, " has an empty (or NaN) box");
    centres[i] = boxes[i].center();
  }
  order_.resize(boxes.size());
  std::iota(order_.begin(), order_.end(), 0);
  nodes_.reserve(2 * boxes.size() / kLeafSize + 1);
  Build(boxes, centres, 0, static_cast<int>(boxes.size()));
  leaf_boxes_.reserve(boxes.size());
  for (int i : order_) leaf_boxes_.push_back(boxes[i]);
}

int AabbTree::Build(const std::vector<Eigen::AlignedBox3d>& boxes,
                    const std::vector<Eigen::Vector3d>& centres, int begin, int end) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox3d box, centre_box;
  for (int k = begin; k < end; ++k) {
    box.extend(boxes[order_[k]]);
    centre_box.extend(centres[order_[k]]);
  }
  nodes_[index].box = box;
  if (end - begin <= kLeafSize) {
    nodes_[index].begin = begin;
    nodes_[index].end = end;
    return index;
  }
  // median split along the longest extent of the centres: depth stays <= log2(n) + 1
  int axis = 0;
  centre_box.sizes().maxCoeff(&axis);
  const int mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](int a, int b) { return centres[a][axis] < centres[b][axis]; });
  const int left = Build(boxes, centres, begin, mid);
  const int right = Build(boxes, centres, mid, end);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

double AabbTree::RayEntry(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& origin,
                          const Eigen::Vector3d& inv_dir, double t_max) {
  // slab test; a zero direction component gives +-inf (or NaN when the origin is on the slab
  // plane, which std::min/max below discard in favour of the other operand)
  double t_enter = 0.0, t_exit = t_max;
  for (int k = 0; k < 3; ++k) {
    double a = (box.min()[k] - origin[k]) * inv_dir[k];
    double b = (box.max()[k] - origin[k]) * inv_dir[k];
    if (std::isnan(a) || std::isnan(b)) continue;  // origin on the slab boundary, parallel ray
    if (a > b) std::swap(a, b);
    t_enter = std::max(t_enter, a);
    t_exit = std::min(t_exit, b);
  }
  // widen by a relative epsilon so primitives touching the ray are not lost to rounding
  const double slack = 1e-12 * (1.0 + std::abs(t_exit));
  return t_enter <= t_exit + slack ? t_enter : std::numeric_limits<double>::infinity();
}

}  // namespace nsim
