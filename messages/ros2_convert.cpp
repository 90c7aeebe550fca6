#include "messages/ros2_convert.h"

#include <cmath>

#include "common/core/error.h"
#include "common/core/wire_pose.h"
#include "messages/ros2.h"

namespace nsim::transport {
namespace {

// a received orientation may come from single precision (a tracker, tf2): it is accepted
// within this of unit norm and normalized
constexpr double kUnitQuaternionTolerance = 1e-3;

geometry_msgs_msg_dds__Point_ ToPoint(const Eigen::Vector3d& p) { return {p.x(), p.y(), p.z()}; }

std::string FromPoint(const geometry_msgs_msg_dds__Point_& m, Eigen::Vector3d* p,
                      const char* field) {
  *p = Eigen::Vector3d(m.x, m.y, m.z);
  return p->allFinite() ? "" : Str(field, " is not finite");
}

// the header's time; an error for another frame or a time that cannot be one
std::string FromHeader(const std_msgs_msg_dds__Header_& m, const std::string& frame_id,
                       double* t, const char* topic) {
  const char* frame = m.frame_id ? m.frame_id : "";
  if (frame != frame_id)
    return Str(topic, ": header.frame_id is '", frame, "', expected '", frame_id, "'");
  if (m.stamp.nanosec > 999999999u)
    return Str(topic, ": header.stamp.nanosec is ", m.stamp.nanosec, ", expected < 1e9");
  *t = FromRos2Time(m.stamp);
  return "";
}

}  // namespace

builtin_interfaces_msg_dds__Time_ ToRos2Time(double t) {
  double sec = std::floor(t);
  long long nanosec = std::llround((t - sec) * 1e9);
  if (nanosec >= 1000000000LL) {  // rounded up to the next second
    sec += 1;
    nanosec -= 1000000000LL;
  }
  return {static_cast<int32_t>(sec), static_cast<uint32_t>(nanosec)};
}

double FromRos2Time(const builtin_interfaces_msg_dds__Time_& m) {
  return static_cast<double>(m.sec) + 1e-9 * static_cast<double>(m.nanosec);
}

void ToRos2Header(double t, const std::string& frame_id, std_msgs_msg_dds__Header_& m) {
  m.stamp = ToRos2Time(t);
  m.frame_id = const_cast<char*>(frame_id.c_str());  // only read by dds_write
}

void ToRos2Markers(double t, const std::vector<Eigen::Vector3d>& p_WM,
                   const std::string& frame_id, geometry_msgs_msg_dds__PoseArray_& m,
                   Ros2Scratch& scratch) {
  ToRos2Header(t, frame_id, m.header);
  scratch.poses.resize(p_WM.size());
  for (size_t i = 0; i < p_WM.size(); ++i)
    scratch.poses[i] = {ToPoint(p_WM[i]), {0.0, 0.0, 0.0, 1.0}};
  m.poses._maximum = m.poses._length = static_cast<uint32_t>(scratch.poses.size());
  m.poses._buffer = scratch.poses.empty() ? nullptr : scratch.poses.data();
  m.poses._release = false;
}

void ToRos2Pose(double t, const Eigen::Isometry3d& X, const std::string& frame_id,
                geometry_msgs_msg_dds__PoseStamped_& m) {
  ToRos2Header(t, frame_id, m.header);
  const WirePose w = ToWirePose(X);
  m.pose.position = ToPoint(w.p);
  m.pose.orientation = {w.q.x(), w.q.y(), w.q.z(), w.q.w()};
}

void ToRos2Joints(double t, const std::vector<double>& q, const std::string& frame_id,
                  sensor_msgs_msg_dds__JointState_& m, Ros2Scratch& scratch) {
  const std::vector<std::string>& names = Ros2JointNames();
  NSIM_CHECK(q.size() <= names.size(), "at most ", names.size(), " joints, got ", q.size());
  ToRos2Header(t, frame_id, m.header);
  scratch.names.resize(q.size());
  for (size_t i = 0; i < q.size(); ++i) scratch.names[i] = const_cast<char*>(names[i].c_str());
  scratch.positions = q;
  m.name._maximum = m.name._length = static_cast<uint32_t>(q.size());
  m.name._buffer = q.empty() ? nullptr : scratch.names.data();
  m.name._release = false;
  m.position._maximum = m.position._length = static_cast<uint32_t>(q.size());
  m.position._buffer = q.empty() ? nullptr : scratch.positions.data();
  m.position._release = false;
  m.velocity = {0, 0, nullptr, false};
  m.effort = {0, 0, nullptr, false};
}

void ToRos2Point(double t, const Eigen::Vector3d& p, const std::string& frame_id,
                 geometry_msgs_msg_dds__PointStamped_& m) {
  ToRos2Header(t, frame_id, m.header);
  m.point = ToPoint(p);
}

std::string FromRos2Markers(const geometry_msgs_msg_dds__PoseArray_& m,
                            const std::string& frame_id, double* t,
                            std::vector<Eigen::Vector3d>* p_WM) {
  if (auto e = FromHeader(m.header, frame_id, t, ros2_topic::kMarkers); !e.empty()) return e;
  if (m.poses._length == 0) return Str(ros2_topic::kMarkers, ": no poses");
  p_WM->resize(m.poses._length);
  for (uint32_t i = 0; i < m.poses._length; ++i)
    if (auto e = FromPoint(m.poses._buffer[i].position, &(*p_WM)[i], "position"); !e.empty())
      return Str(ros2_topic::kMarkers, ": ", e, " (marker ", i, ")");
  return "";
}

std::string FromRos2Pose(const geometry_msgs_msg_dds__PoseStamped_& m, const std::string& frame_id,
                         double* t, Eigen::Isometry3d* X) {
  const char* topic = ros2_topic::kRobotPose;
  if (auto e = FromHeader(m.header, frame_id, t, topic); !e.empty()) return e;
  WirePose w;
  if (auto e = FromPoint(m.pose.position, &w.p, "pose.position"); !e.empty())
    return Str(topic, ": ", e);
  const auto& o = m.pose.orientation;
  w.q = Eigen::Quaterniond(o.w, o.x, o.y, o.z);
  if (!w.q.coeffs().allFinite()) return Str(topic, ": pose.orientation is not finite");
  if (!(std::abs(w.q.norm() - 1.0) < kUnitQuaternionTolerance))
    return Str(topic, ": pose.orientation norm is ", w.q.norm(), ", expected 1");
  *X = FromWirePose(w);  // normalizes
  return "";
}

std::string FromRos2Joints(const sensor_msgs_msg_dds__JointState_& m, std::vector<double>* q) {
  const char* topic = ros2_topic::kJointStates;
  const uint32_t n = m.position._length;
  if (m.name._length == 0) {
    q->assign(m.position._buffer, m.position._buffer + n);
  } else {
    if (m.name._length != n)
      return Str(topic, ": ", m.name._length, " names but ", n, " positions");
    const std::vector<std::string>& names = Ros2JointNames();
    q->assign(names.size(), 0.0);
    for (size_t j = 0; j < names.size(); ++j) {
      uint32_t i = 0;
      while (i < n && !(m.name._buffer[i] && names[j] == m.name._buffer[i])) ++i;
      if (i == n) return Str(topic, ": no joint named ", names[j]);
      (*q)[j] = m.position._buffer[i];
    }
  }
  for (double v : *q)
    if (!std::isfinite(v)) return Str(topic, ": a joint position is not finite");
  return "";
}

std::string FromRos2Point(const geometry_msgs_msg_dds__PointStamped_& m,
                          const std::string& frame_id, double* t, Eigen::Vector3d* p) {
  const char* topic = ros2_topic::kEntryPoint;
  if (auto e = FromHeader(m.header, frame_id, t, topic); !e.empty()) return e;
  if (auto e = FromPoint(m.point, p, "point"); !e.empty()) return Str(topic, ": ", e);
  return "";
}

}  // namespace nsim::transport
