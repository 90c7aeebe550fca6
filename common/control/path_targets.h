#pragma once
// Target switching along the predefined needle path (thesis §3.3: e_p pulls the tip toward the
// current trajectory point q_target; the target advances along the path as the tip reaches it).

#include <Eigen/Core>
#include <vector>

namespace nsim {

/// Settings of the path-target switching.
struct PathTargetConfig {
  double switch_distance =
      0.002;  ///< advance to the next point when |p_tip - target| <= this (m), > 0

  /// Throws InputError, e.g. "control.path.switch_distance must be > 0 (m), got 0".
  void Validate() const;
};

/// The current target on a path of points in world. Advances (possibly several points in one
/// update) while the tip is within switch_distance of the current point and a next point
/// exists; never goes back; stays on the last point.
class PathTargetTracker {
 public:
  /// `points_W` (m, world, >= 1, finite) in insertion order. Throws InputError on bad input.
  PathTargetTracker(std::vector<Eigen::Vector3d> points_W, const PathTargetConfig& config);

  /// Advances the target for the tip position p_WTip (m); returns how many points were passed.
  /// A non-finite tip position changes nothing and returns 0.
  int Update(const Eigen::Vector3d& p_WTip);

  /// The current target point q_target (m, world).
  const Eigen::Vector3d& target() const { return points_[index_]; }

  /// Index of the current target in the path.
  int index() const { return index_; }

  /// Number of path points.
  int size() const { return static_cast<int>(points_.size()); }

  /// True once the current target is the last point and the tip is within switch_distance.
  bool reached_end() const { return reached_end_; }

  /// Unit direction of the path at point i (toward point i + 1; at the last point, from the
  /// previous one). For a one-point path, NaN. Used as n_traj of eq. 3.4 at the entry point.
  Eigen::Vector3d CalcDirection(int i) const;

 private:
  std::vector<Eigen::Vector3d> points_;
  PathTargetConfig config_;
  int index_ = 0;
  bool reached_end_ = false;
};

}  // namespace nsim
