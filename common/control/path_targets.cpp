#include "common/control/path_targets.h"

#include <cmath>
#include <limits>
#include <utility>

#include "common/core/error.h"

namespace nsim {

void PathTargetConfig::Validate() const {
  if (!(switch_distance > 0.0) || !std::isfinite(switch_distance)) {
    throw InputError(Str("control.path.switch_distance must be > 0 (m), got ", switch_distance));
  }
}

PathTargetTracker::PathTargetTracker(std::vector<Eigen::Vector3d> points_W,
                                     const PathTargetConfig& config)
    : points_(std::move(points_W)), config_(config) {
  config_.Validate();
  if (points_.empty()) throw InputError("control.path needs at least one point, got none");
  for (size_t i = 0; i < points_.size(); ++i) {
    if (!points_[i].allFinite()) {
      throw InputError(
          Str("control.path point ", i, " must be finite, got (", points_[i].transpose(), ")"));
    }
  }
}

int PathTargetTracker::Update(const Eigen::Vector3d& p_WTip) {
  if (!p_WTip.allFinite()) return 0;
  int passed = 0;
  const int last = size() - 1;
  while ((p_WTip - points_[index_]).norm() <= config_.switch_distance) {
    if (index_ == last) {
      reached_end_ = true;
      break;
    }
    ++index_;
    ++passed;
  }
  return passed;
}

Eigen::Vector3d PathTargetTracker::CalcDirection(int i) const {
  NSIM_CHECK(i >= 0 && i < size(), "path index ", i, " out of [0, ", size(), ")");
  if (size() < 2) return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const int a = i < size() - 1 ? i : i - 1;
  return (points_[a + 1] - points_[a]).normalized();
}

}  // namespace nsim
