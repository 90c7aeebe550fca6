#pragma once
// Internal (transport-independent) forms of the streams the two processes exchange. The DDS
// message types in messages/nsim_msgs.idl mirror them; messages/convert.h maps one to the other.
// Units are SI; every position is in the world frame W unless its name says otherwise.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace nsim {

/// Stamp carried by every sample.
struct Stamp {
  uint64_t seq = 0;          ///< sequence number, strictly increasing per writer, starts at 0
  double sim_time = 0.0;     ///< simulation time of the sampled state (s)
  int64_t wall_time_ns = 0;  ///< wall-clock time of sending (ns since the Unix epoch)
};

/// Positions of the fiducial markers at one instant.
struct MarkerFrame {
  Stamp stamp;
  std::vector<Eigen::Vector3d> p_WM;  ///< marker positions in world (m), #markers entries
};

/// Localized skin entry point of the needle.
struct EntryPoint {
  Stamp stamp;
  bool punctured = false;                          ///< false until the skin is punctured
  Eigen::Vector3d p_WP = Eigen::Vector3d::Zero();  ///< entry point in world (m)
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();  ///< outward skin normal at the entry (unit)
};

/// Everything the controller needs from one instant of the patient side (DESIGN.md "Messages
/// and transport"): the markers, the robot's measured state and the localized entry point, all
/// sampled at stamp.sim_time, so nothing has to be re-joined by sequence number. The one state
/// message on the wire (messages/nsim_msgs.idl SensorFrame).
struct SensorFrame {
  Stamp stamp;
  std::vector<Eigen::Vector3d> p_WM;  ///< marker positions in world (m), in marker order
  /// false for a marker-only stream (direct_sim replay): the robot and entry fields are unset
  bool has_robot = true;
  Eigen::Isometry3d X_WE = Eigen::Isometry3d::Identity();  ///< end-effector (flange) pose
  std::vector<double> q;     ///< joint angles (rad); empty for the Cartesian robot
  double bevel_angle = 0.0;  ///< needle roll about its axis (rad)
  bool entry_punctured = false;                    ///< false until the skin is punctured
  Eigen::Vector3d p_WP = Eigen::Vector3d::Zero();  ///< skin entry point in world (m)
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();  ///< outward skin normal at the entry (unit)
  /// answers_seq of the target the robot executed during the step that led to this state;
  /// kNoTarget when it held still (no command, a hold timeout, a lost controller). The
  /// controller measures its loop latency from it (frame time minus the answered frame's).
  uint64_t applied_seq = kNoTarget;
  static constexpr uint64_t kNoTarget = ~uint64_t{0};

  MarkerFrame markers() const { return {stamp, p_WM}; }
  EntryPoint entry() const { return {stamp, entry_punctured, p_WP, n_W}; }
};

/// Whether a RobotTarget commands the end-effector pose or the joints.
enum class TargetMode : uint8_t { kCartesian = 0, kJoint = 1 };

/// A command for the robot, answering one marker frame.
struct RobotTarget {
  Stamp stamp;
  uint64_t answers_seq = 0;  ///< seq of the SensorFrame this target was computed from
  TargetMode mode = TargetMode::kCartesian;
  /// commanded flange pose (kCartesian); for kJoint the flange pose q implies, informative
  Eigen::Isometry3d X_WE = Eigen::Isometry3d::Identity();
  std::vector<double> q;     ///< commanded joint angles (rad) (kJoint)
  double bevel_angle = 0.0;  ///< commanded needle roll (rad)
};

/// Lifecycle state of a process, published in SimStatus.
enum class RunState : uint8_t { kStarting = 0, kRunning = 1, kFinished = 2, kFailed = 3 };

/// Health and progress of a process.
struct SimStatus {
  Stamp stamp;
  std::string sender;  ///< "direct_sim" or "inverse_sim"
  RunState state = RunState::kStarting;
  uint64_t last_seq = 0;     ///< last data seq written (valid when state is kFinished)
  uint64_t frames_sent = 0;  ///< data samples written so far
  double rate_hz = 0.0;      ///< loop rate over the recent window (Hz)
  uint8_t phase = 0;         ///< insertion phase 0 (outside), 1 (skin), 2 (liver)
  std::string message;       ///< human-readable detail (last warning or error)
  /// ScenarioHash of the scenario's shared part (common/scenario/shared_scenario.h); 0: none
  /// (a process that runs no scenario, e.g. replay). Checked at the start handshake.
  uint64_t scenario_hash = 0;
};

}  // namespace nsim
