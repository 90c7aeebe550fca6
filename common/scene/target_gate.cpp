#include "common/scene/target_gate.h"

#include <cmath>
#include <limits>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/robot/pose_math.h"

namespace nsim {
namespace {

constexpr size_t kMaxFrames = 100000;  // frames remembered for aging (beyond: stale)

void CheckPositive(double value, const char* key, const char* unit, double max) {
  if (!(value > 0) || !std::isfinite(value))
    throw InputError(Str("safety.", key, " must be > 0 (", unit, "), got ", value));
  CheckAtMost(value, max, Str("safety.", key), unit);
}

}  // namespace

const char* ToString(GateReason reason) {
  switch (reason) {
    case GateReason::kNonFinite:
      return "non_finite";
    case GateReason::kStale:
      return "stale";
    case GateReason::kOutOfOrder:
      return "out_of_order";
    case GateReason::kUnknownFrame:
      return "unknown_frame";
    case GateReason::kWrongMode:
      return "wrong_mode";
    case GateReason::kOverLimit:
      return "over_limit";
    case GateReason::kSpeedClamped:
      return "speed_clamped";
    case GateReason::kWorkspaceClamped:
      return "workspace_clamped";
    case GateReason::kCount:
      break;
  }
  return "none";
}

uint64_t GateCounts::rejected() const {
  uint64_t n = 0;
  for (int r = 0; r <= static_cast<int>(GateReason::kOverLimit); ++r) n += by_reason[r];
  return n;
}

void TargetGateConfig::Validate() const {
  // a target a minute old, or a minute without one before holding, is no safety gate; a
  // horizon of 100 s at full speed is no speed limit (the tests use 100 s to switch it off);
  // the speed limits are the robot's (robot.max_*: 2 m/s, 10 rad/s)
  CheckPositive(max_age, "max_age", "s", 60.0);
  CheckPositive(hold_timeout, "hold_timeout", "s", 60.0);
  CheckPositive(speed_horizon, "speed_horizon", "s", 100.0);
  CheckPositive(max_linear_speed, "max_linear_speed", "m/s", 2.0);
  CheckPositive(max_angular_speed, "max_angular_speed", "rad/s", 10.0);
  if (!workspace_min_W.allFinite() || !workspace_max_W.allFinite() ||
      !(workspace_min_W.array() < workspace_max_W.array()).all())
    throw InputError("safety workspace: workspace_min_W must be finite and < workspace_max_W");
  const size_t n = joint_lower.size();
  if (joint_upper.size() != n || joint_velocity.size() != n || (n != 0 && n != 7))
    throw InputError("safety joint limits: expected 0 or 7 entries in each list");
  for (size_t i = 0; i < n; ++i) {
    if (!(joint_lower[i] < joint_upper[i]))
      throw InputError(Str("safety.joint limits[", i, "]: lower must be < upper"));
    if (!(joint_velocity[i] > 0))
      throw InputError(
          Str("safety.joint_velocity[", i, "] must be > 0 (rad/s), got ", joint_velocity[i]));
  }
}

TargetGate::TargetGate(const TargetGateConfig& config)
    : config_(config), last_accept_time_(-std::numeric_limits<double>::infinity()) {
  config_.Validate();
}

void TargetGate::NotePublishedFrame(uint64_t seq, double sim_time) {
  if (!frames_.empty() && seq <= frames_.back().first) return;  // keep ascending
  frames_.emplace_back(seq, sim_time);
  while (frames_.size() > kMaxFrames) frames_.pop_front();
}

bool TargetGate::FindFrameTime(uint64_t seq, double* sim_time) const {
  if (frames_.empty() || seq < frames_.front().first || seq > frames_.back().first) return false;
  // frames are mostly consecutive: guess the index, then search
  size_t lo = 0, hi = frames_.size();
  while (lo + 1 < hi) {
    const size_t mid = (lo + hi) / 2;
    if (frames_[mid].first <= seq)
      lo = mid;
    else
      hi = mid;
  }
  if (frames_[lo].first != seq) return false;
  *sim_time = frames_[lo].second;
  return true;
}

GateDecision TargetGate::Reject(GateDecision decision, GateReason reason, std::string detail) {
  decision.accepted = false;
  decision.reason = reason;
  decision.detail = std::move(detail);
  counts_.by_reason[static_cast<int>(reason)]++;
  return decision;
}

GateDecision TargetGate::Check(const RobotTarget& target, double now,
                               const Eigen::Isometry3d& X_WE_now,
                               const std::vector<double>& q_now) {
  counts_.received++;
  GateDecision decision;
  decision.target = target;
  const bool joint = target.mode == TargetMode::kJoint;

  // values: finite, a rigid pose (Cartesian) or 7 joints
  bool finite = std::isfinite(target.bevel_angle);
  if (joint) {
    for (double q : target.q) finite = finite && std::isfinite(q);
  } else {
    finite = finite && target.X_WE.matrix().allFinite();
  }
  if (!finite)
    return Reject(decision, GateReason::kNonFinite, "target has a NaN or infinite value");
  if (!joint && !IsRigidTransform(target.X_WE, 1e-6))
    return Reject(decision, GateReason::kNonFinite, "target pose is not a rigid transform");
  if (joint && (config_.joint_lower.empty() || target.q.size() != config_.joint_lower.size() ||
                q_now.size() != target.q.size()))
    return Reject(decision, GateReason::kWrongMode,
                  Str("joint target with ", target.q.size(), " joints for this robot"));

  // timing: a published frame, newer than the last accepted, not too old
  if (frames_.empty() || target.answers_seq > frames_.back().first)
    return Reject(decision, GateReason::kUnknownFrame,
                  Str("target answers frame ", target.answers_seq, ", never published"));
  if (any_accepted_ && target.answers_seq <= last_answers_seq_)
    return Reject(
        decision, GateReason::kOutOfOrder,
        Str("target answers frame ", target.answers_seq, ", not newer than ", last_answers_seq_));
  double frame_time = 0.0;
  if (!FindFrameTime(target.answers_seq, &frame_time) || !(now - frame_time <= config_.max_age))
    return Reject(decision, GateReason::kStale,
                  Str("target answers frame ", target.answers_seq,
                      " older than max_age = ", config_.max_age, " s"));

  // limits: workspace and speed, clamped or rejected
  bool speed_clamp = false, workspace_clamp = false;
  if (joint) {
    for (size_t i = 0; i < target.q.size(); ++i) {
      double q = target.q[i];
      const double clamped = std::min(std::max(q, config_.joint_lower[i]), config_.joint_upper[i]);
      if (clamped != q) workspace_clamp = true;
      const double step = config_.joint_velocity[i] * config_.speed_horizon;
      const double limited = std::min(std::max(clamped, q_now[i] - step), q_now[i] + step);
      if (limited != clamped) speed_clamp = true;
      decision.target.q[i] = limited;
    }
  } else {
    Eigen::Vector3d p = target.X_WE.translation();
    const Eigen::Vector3d in_box =
        p.cwiseMax(config_.workspace_min_W).cwiseMin(config_.workspace_max_W);
    if (in_box != p) workspace_clamp = true;
    p = in_box;
    const Eigen::Vector3d dp = p - X_WE_now.translation();
    const double max_move = config_.max_linear_speed * config_.speed_horizon;
    if (dp.norm() > max_move) {
      speed_clamp = true;
      p = X_WE_now.translation() + dp * (max_move / dp.norm());
    }
    Eigen::Matrix3d R = target.X_WE.linear();
    const double angle = CalcRotationAngle(X_WE_now.linear(), R);
    const double max_turn = config_.max_angular_speed * config_.speed_horizon;
    if (angle > max_turn) {
      speed_clamp = true;
      const Eigen::Quaterniond q_now_(X_WE_now.linear()), q_target(R);
      R = q_now_.slerp(max_turn / angle, q_target).toRotationMatrix();
    }
    decision.target.X_WE.linear() = R;
    decision.target.X_WE.translation() = p;
  }
  if ((speed_clamp || workspace_clamp) && config_.over_limit == OverLimitAction::kReject)
    return Reject(decision, GateReason::kOverLimit,
                  speed_clamp ? "target beyond the speed limit" : "target outside the workspace");
  if (workspace_clamp) {
    counts_.by_reason[static_cast<int>(GateReason::kWorkspaceClamped)]++;
    decision.reason = GateReason::kWorkspaceClamped;
    decision.detail = "target clamped into the workspace";
  }
  if (speed_clamp) {
    counts_.by_reason[static_cast<int>(GateReason::kSpeedClamped)]++;
    decision.reason = GateReason::kSpeedClamped;
    decision.detail = "target scaled down to the speed limit";
  }
  decision.accepted = true;
  counts_.accepted++;
  any_accepted_ = true;
  last_answers_seq_ = target.answers_seq;
  last_accept_time_ = now;
  return decision;
}

bool TargetGate::ShouldHold(double now) const {
  return !(now - last_accept_time_ <= config_.hold_timeout);
}

}  // namespace nsim
