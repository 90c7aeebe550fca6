#pragma once
// Safety gate for the robot targets that arrive from the controller (DESIGN.md "Bad input and
// faults"): a target that is not finite, stale (it answers a marker frame older than max_age in
// simulated time), out of order (answers_seq not newer than the last accepted one), for an
// unknown frame, of the wrong kind, or beyond the robot's velocity or workspace limits is
// rejected or clamped, and counted by reason. With no accepted target for longer than
// hold_timeout the robot must hold still (ShouldHold).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "common/core/samples.h"

namespace nsim {

/// What to do with a target beyond the velocity or workspace limits.
enum class OverLimitAction { kClamp, kReject };

/// Limits and timing of the gate. SI units, world frame.
struct TargetGateConfig {
  /// A target answering a frame whose simulated time is more than this before now is stale (s),
  /// > 0.
  double max_age = 0.5;
  /// With no accepted target for longer than this the robot holds still (s), > 0.
  double hold_timeout = 0.5;
  /// Largest motion a target may ask for, as the distance the robot covers at its speed limit in
  /// this time (s), > 0: |p_target - p_now| <= max_linear_speed * speed_horizon, likewise for the
  /// rotation angle and each joint.
  double speed_horizon = 0.2;
  OverLimitAction over_limit = OverLimitAction::kClamp;
  double max_linear_speed = 0.05;                     ///< (m/s), > 0, normally the robot's
  double max_angular_speed = 0.5;                     ///< (rad/s), > 0
  Eigen::Vector3d workspace_min_W{-1.0, -1.0, -1.0};  ///< box for the target's p_WE (m)
  Eigen::Vector3d workspace_max_W{1.0, 1.0, 1.0};
  /// Joint targets (iiwa): position limits (rad) and speed limits (rad/s), 7 entries each; empty:
  /// joint targets are rejected (the robot takes Cartesian targets only).
  std::vector<double> joint_lower, joint_upper, joint_velocity;

  /// Throws InputError "safety.<key> must be ..., got ...".
  void Validate() const;
};

/// Why a target was rejected or changed. Rejections first, then clamps.
enum class GateReason : int {
  kNonFinite = 0,     ///< a NaN or infinite value
  kStale,             ///< answers a frame older than max_age
  kOutOfOrder,        ///< answers_seq not newer than the last accepted target's
  kUnknownFrame,      ///< answers a frame that was never published
  kWrongMode,         ///< joint target for a Cartesian robot, wrong joint count
  kOverLimit,         ///< beyond the velocity or workspace limits, rejected (kReject)
  kSpeedClamped,      ///< accepted after scaling the motion down to the speed limit (kClamp)
  kWorkspaceClamped,  ///< accepted after clamping the position into the workspace (kClamp)
  kCount
};
inline constexpr int kNumGateReasons = static_cast<int>(GateReason::kCount);

/// Stable snake_case name of a reason ("non_finite", "stale", ...), used in summaries.
const char* ToString(GateReason reason);

/// Outcome of one check.
struct GateDecision {
  bool accepted = false;
  RobotTarget target;  ///< the target to execute (clamped when a clamp applied)
  /// The rejection reason (accepted = false), or the last clamp applied.
  GateReason reason = GateReason::kCount;
  std::string detail;  ///< human-readable, for status messages
};

/// Counts, per reason, of what the gate did.
struct GateCounts {
  uint64_t received = 0;
  uint64_t accepted = 0;
  std::array<uint64_t, kNumGateReasons> by_reason{};
  uint64_t rejected() const;
};

class TargetGate {
 public:
  /// Validates `config` (InputError).
  explicit TargetGate(const TargetGateConfig& config);

  /// Records that marker frame `seq` was published with simulated time `sim_time` (s), so that
  /// targets answering it can be aged. Keeps the last frames covering max_age and more.
  void NotePublishedFrame(uint64_t seq, double sim_time);

  /// Checks `target` at simulated time `now` (s) against the robot's current flange pose
  /// (Cartesian) or joints (q_now, 7 entries, iiwa; empty for the Cartesian robot). Counts the
  /// outcome; an accepted target becomes the newest (for order and hold).
  GateDecision Check(const RobotTarget& target, double now, const Eigen::Isometry3d& X_WE_now,
                     const std::vector<double>& q_now);

  /// True when no target was accepted during the last hold_timeout (s) before `now` (also
  /// before the first one).
  bool ShouldHold(double now) const;

  /// Time of the last accepted target (s), or -inf.
  double last_accept_time() const { return last_accept_time_; }
  const GateCounts& counts() const { return counts_; }
  const TargetGateConfig& config() const { return config_; }

 private:
  GateDecision Reject(GateDecision decision, GateReason reason, std::string detail);
  // the simulated time of a published frame; false when unknown
  bool FindFrameTime(uint64_t seq, double* sim_time) const;

  TargetGateConfig config_;
  GateCounts counts_;
  std::deque<std::pair<uint64_t, double>> frames_;  // (seq, sim_time), ascending seq
  bool any_accepted_ = false;
  uint64_t last_answers_seq_ = 0;
  double last_accept_time_;
};

}  // namespace nsim
