#include "messages/convert.h"

#include <cmath>
#include <cstring>

#include "common/core/error.h"
#include "common/core/wire_pose.h"

namespace nsim::transport {
namespace {

constexpr double kUnitQuaternionTolerance = 1e-6;

void ToStamp(const Stamp& s, nsim_msgs_Stamp& m) {
  m.seq = s.seq;
  m.sim_time = s.sim_time;
  m.wall_time_ns = s.wall_time_ns;
}

std::string FromStamp(const nsim_msgs_Stamp& m, Stamp& s) {
  s.seq = m.seq;
  s.sim_time = m.sim_time;
  s.wall_time_ns = m.wall_time_ns;
  return std::isfinite(m.sim_time) ? "" : "stamp.sim_time is not finite";
}

nsim_msgs_Vec3 ToVec3(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

std::string FromVec3(const nsim_msgs_Vec3& m, Eigen::Vector3d& v, const char* field) {
  v = Eigen::Vector3d(m.x, m.y, m.z);
  return v.allFinite() ? "" : Str(field, " is not finite");
}

void ToPose(const Eigen::Isometry3d& X, nsim_msgs_Pose& m) {
  const WirePose w = ToWirePose(X);
  m.p = ToVec3(w.p);
  m.qw = w.q.w();
  m.qx = w.q.x();
  m.qy = w.q.y();
  m.qz = w.q.z();
}

std::string FromPose(const nsim_msgs_Pose& m, Eigen::Isometry3d& X, const char* field) {
  WirePose w;
  if (auto e = FromVec3(m.p, w.p, field); !e.empty()) return e;
  w.q = Eigen::Quaterniond(m.qw, m.qx, m.qy, m.qz);
  if (!w.q.coeffs().allFinite()) return Str(field, " quaternion is not finite");
  if (!(std::abs(w.q.norm() - 1.0) < kUnitQuaternionTolerance))
    return Str(field, " quaternion norm is ", w.q.norm(), ", expected 1");
  X = FromWirePose(w);
  return "";
}

template <typename Seq>
void PointSequence(Seq& seq, std::vector<double>& storage) {
  seq._maximum = seq._length = static_cast<uint32_t>(storage.size());
  seq._buffer = storage.empty() ? nullptr : storage.data();
  seq._release = false;
}

std::string FromJoints(const dds_sequence_double& seq, std::vector<double>& q) {
  q.assign(seq._buffer, seq._buffer + seq._length);
  for (double v : q)
    if (!std::isfinite(v)) return "q has a non-finite joint angle";
  return "";
}

void CopyString(const std::string& s, char* dst, size_t capacity) {
  const size_t n = std::min(s.size(), capacity - 1);
  std::memcpy(dst, s.data(), n);
  dst[n] = '\0';
}

}  // namespace

void ToMessage(const SensorFrame& sample, nsim_msgs_SensorFrame& msg, ConvertScratch& scratch) {
  NSIM_CHECK(sample.p_WM.size() <= 64, "at most 64 markers fit a SensorFrame, got ",
             sample.p_WM.size());
  NSIM_CHECK(sample.q.size() <= 7, "at most 7 joints, got ", sample.q.size());
  ToStamp(sample.stamp, msg.stamp);
  scratch.vec3.resize(sample.p_WM.size());
  for (size_t i = 0; i < sample.p_WM.size(); ++i) scratch.vec3[i] = ToVec3(sample.p_WM[i]);
  msg.p_WM._maximum = msg.p_WM._length = static_cast<uint32_t>(scratch.vec3.size());
  msg.p_WM._buffer = scratch.vec3.empty() ? nullptr : scratch.vec3.data();
  msg.p_WM._release = false;
  msg.has_robot = sample.has_robot;
  ToPose(sample.X_WE, msg.X_WE);
  scratch.values = sample.q;
  PointSequence(msg.q, scratch.values);
  msg.bevel_angle = sample.bevel_angle;
  msg.entry_punctured = sample.entry_punctured;
  msg.p_WP = ToVec3(sample.p_WP);
  msg.n_W = ToVec3(sample.n_W);
  msg.applied_seq = sample.applied_seq;
}

std::string FromMessage(const nsim_msgs_SensorFrame& msg, SensorFrame& sample) {
  if (auto e = FromStamp(msg.stamp, sample.stamp); !e.empty()) return e;
  sample.p_WM.resize(msg.p_WM._length);
  for (uint32_t i = 0; i < msg.p_WM._length; ++i)
    if (auto e = FromVec3(msg.p_WM._buffer[i], sample.p_WM[i], "p_WM"); !e.empty())
      return Str(e, " (marker ", i, ")");
  sample.has_robot = msg.has_robot;
  sample.applied_seq = msg.applied_seq;
  if (!msg.has_robot) {
    // a marker-only stream: the robot and entry fields carry nothing
    sample.X_WE = Eigen::Isometry3d::Identity();
    sample.q.clear();
    sample.bevel_angle = 0.0;
    sample.entry_punctured = false;
    sample.p_WP.setZero();
    sample.n_W = Eigen::Vector3d::UnitZ();
    return "";
  }
  if (auto e = FromPose(msg.X_WE, sample.X_WE, "X_WE"); !e.empty()) return e;
  if (auto e = FromJoints(msg.q, sample.q); !e.empty()) return e;
  sample.bevel_angle = msg.bevel_angle;
  if (!std::isfinite(msg.bevel_angle)) return "bevel_angle is not finite";
  sample.entry_punctured = msg.entry_punctured;
  if (auto e = FromVec3(msg.p_WP, sample.p_WP, "p_WP"); !e.empty()) return e;
  if (auto e = FromVec3(msg.n_W, sample.n_W, "n_W"); !e.empty()) return e;
  if (sample.entry_punctured && !(std::abs(sample.n_W.norm() - 1.0) < 1e-6))
    return Str("n_W norm is ", sample.n_W.norm(), ", expected 1");
  return "";
}

void ToMessage(const RobotTarget& sample, nsim_msgs_RobotTarget& msg, ConvertScratch& scratch) {
  NSIM_CHECK(sample.q.size() <= 7, "at most 7 joints, got ", sample.q.size());
  ToStamp(sample.stamp, msg.stamp);
  msg.answers_seq = sample.answers_seq;
  msg.mode = static_cast<uint8_t>(sample.mode);
  ToPose(sample.X_WE, msg.X_WE);
  scratch.values = sample.q;
  PointSequence(msg.q, scratch.values);
  msg.bevel_angle = sample.bevel_angle;
}

std::string FromMessage(const nsim_msgs_RobotTarget& msg, RobotTarget& sample) {
  if (auto e = FromStamp(msg.stamp, sample.stamp); !e.empty()) return e;
  sample.answers_seq = msg.answers_seq;
  if (msg.mode > 1) return Str("mode must be 0 (Cartesian) or 1 (joints), got ", int(msg.mode));
  sample.mode = static_cast<TargetMode>(msg.mode);
  if (auto e = FromPose(msg.X_WE, sample.X_WE, "X_WE"); !e.empty()) return e;
  if (auto e = FromJoints(msg.q, sample.q); !e.empty()) return e;
  sample.bevel_angle = msg.bevel_angle;
  return std::isfinite(msg.bevel_angle) ? "" : "bevel_angle is not finite";
}

void ToMessage(const SimStatus& sample, nsim_msgs_SimStatus& msg, ConvertScratch&) {
  ToStamp(sample.stamp, msg.stamp);
  CopyString(sample.sender, msg.sender, sizeof msg.sender);
  msg.state = static_cast<uint8_t>(sample.state);
  msg.last_seq = sample.last_seq;
  msg.frames_sent = sample.frames_sent;
  msg.rate_hz = sample.rate_hz;
  msg.phase = sample.phase;
  CopyString(sample.message, msg.message, sizeof msg.message);
  msg.scenario_hash = sample.scenario_hash;
}

std::string FromMessage(const nsim_msgs_SimStatus& msg, SimStatus& sample) {
  if (auto e = FromStamp(msg.stamp, sample.stamp); !e.empty()) return e;
  sample.sender.assign(msg.sender, strnlen(msg.sender, sizeof msg.sender));
  if (msg.state > 3) return Str("state must be 0..3, got ", int(msg.state));
  sample.state = static_cast<RunState>(msg.state);
  sample.last_seq = msg.last_seq;
  sample.frames_sent = msg.frames_sent;
  sample.rate_hz = msg.rate_hz;
  sample.phase = msg.phase;
  sample.message.assign(msg.message, strnlen(msg.message, sizeof msg.message));
  sample.scenario_hash = msg.scenario_hash;
  return "";
}

}  // namespace nsim::transport
