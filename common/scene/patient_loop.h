#pragma once
// The patient side of the closed loop, without transport (DESIGN.md "The two loops"): the
// patient scene (liver, skin, ribs, breathing, needle), the robot driver that holds the needle,
// the safety gate of incoming targets and the simulation clock. Each step applies the newest
// accepted target (or holds), advances the physics by one time step and yields the sensor
// frame of the new state. The DDS pump of direct_sim and the in-process closed loop drive the
// same class, so both give the same run.
//
// Without a controller (config.controller = false) the robot inserts along the planned path at
// insertion.speed (a check of the scene alone).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/core/samples.h"
#include "common/markers/tracker_noise.h"
#include "common/mesh/tet_mesh.h"
#include "common/scene/patient_scene.h"
#include "common/scene/physics_watchdog.h"
#include "common/scene/robot_driver.h"
#include "common/scene/target_gate.h"

namespace nsim {

/// The insertion along the planned path, and where it starts.
struct InsertionConfig {
  double approach_distance = 0.01;  ///< the tip starts this far before the entry (m), >= 0
  double speed = 0.01;              ///< insertion speed without a controller (m/s), > 0
  /// Without a controller the tip stops this far past the target along the path (m).
  double overshoot = 0.0;

  /// Throws InputError "insertion.<key> ...".
  void Validate() const;
};

/// Everything the patient loop is made of. SI units, world frame.
struct PatientLoopConfig {
  PatientSceneConfig scene;
  RobotDriverConfig robot;
  InsertionConfig insertion;
  /// Safety gate; its speed and workspace limits are normally the robot's.
  TargetGateConfig safety;
  /// false: no controller, the robot follows the planned path at insertion.speed.
  bool controller = true;
  /// The plausible bounds of the state (PhysicsWatchdog).
  WatchdogConfig watchdog;
  /// The tracker's noise on the published markers (the watchdog checks the exact ones).
  TrackerNoiseConfig tracker;
};

/// The truth of the current state, for logs and summaries (not sent to the controller).
struct PatientRecord {
  double t = 0.0;                                     ///< simulation time (s)
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();      ///< needle tip (m)
  Eigen::Vector3d target = Eigen::Vector3d::Zero();   ///< target, moving with the liver (m)
  Eigen::Vector3d e_p = Eigen::Vector3d::Zero();      ///< target - tip (thesis eq. 3.3) (m)
  double distance = 0.0;                              ///< |e_p| (m)
  int phase = 0;              ///< 0 outside, 1 in the skin, 2 in the liver
  bool holding = false;       ///< the robot held still during the step that led here
  TissueStatus skin, liver;   ///< puncture status
};

/// What one step did.
struct PatientStepReport {
  double wall_ms = 0.0;          ///< wall time of the physics step (ms)
  bool holding = false;          ///< the robot held still
  bool gated_target = false;     ///< a target went through the gate this step
  SceneStepReport scene;
  double max_rib_penetration = 0.0;  ///< after the step (m)
  /// Prefetch after the step (PatientLoop::Prefetch): its wall time (ms) and the compliance
  /// columns it solved; 0 when it was not called.
  double prefetch_ms = 0.0;
  int prefetch_columns = 0;
};

class PatientLoop {
 public:
  /// Builds the scene with the robot at the start of the planned insertion. InputError for
  /// invalid configs or meshes.
  PatientLoop(const PatientLoopConfig& config, const TetMesh& liver_mesh,
              const TetMesh& skin_mesh);
  ~PatientLoop();

  /// The sensor frame of the current state (seq = steps done), its markers as the tracker
  /// measures them (config.tracker); every frame handed out is registered with the gate, so
  /// targets answering it can be aged.
  const SensorFrame& frame() const { return frame_; }
  /// The truth of the current state.
  const PatientRecord& record() const { return record_; }
  /// Empty while every state was plausible; else why the first one that was not is not (a
  /// non-finite value, or a bound of config.watchdog broken): the caller stops the run as a
  /// runtime failure and reports it.
  const std::string& fault() const { return fault_; }
  bool healthy() const { return fault_.empty(); }

  /// Passes a target through the gate; an accepted one becomes the robot's command. Returns
  /// the gate's decision.
  GateDecision Receive(const RobotTarget& target);
  /// One time step: gates `target` (if any), moves the robot toward its command (or holds:
  /// no command yet, none accepted for safety.hold_timeout, or the controller marked lost),
  /// steps the physics, and returns the frame of the new state.
  const SensorFrame& Step(const std::optional<RobotTarget>& target = std::nullopt);
  const PatientStepReport& last_step() const { return last_step_; }
  /// The scene's work for the next steps (PatientScene::Prefetch), to call between steps: after
  /// Step, off the path from a target to the frame it produces (realtime: in the time left
  /// before the next period). Changes no result. Recorded in last_step().
  void Prefetch();

  /// While lost, the robot holds whatever targets arrive (the pump sets it from DDS liveliness).
  void set_controller_lost(bool lost) { controller_lost_ = lost; }
  /// Forgets the command: the robot holds until the gate accepts a new target (a new controller
  /// took over: the old one's last command is not carried out for it).
  void DropCommand() { command_.reset(); }

  int64_t steps() const { return steps_; }
  double time() const;
  const PatientScene& scene() const { return *scene_; }
  const RobotDriver& robot() const { return *robot_; }
  const TargetGate& gate() const { return gate_; }
  const InsertionPlan& plan() const { return plan_; }
  const PatientLoopConfig& config() const { return config_; }

 private:
  // fills frame_ and record_ from the current state and registers the frame with the gate
  void Sample();

  PatientLoopConfig config_;
  TargetGate gate_;
  InsertionPlan plan_;
  std::unique_ptr<RobotDriver> robot_;
  std::unique_ptr<PatientScene> scene_;
  std::optional<RobotTarget> command_;
  double bevel_angle_ = 0.0;
  std::unique_ptr<PhysicsWatchdog> watchdog_;
  std::string fault_;
  bool controller_lost_ = false, holding_ = false;
  uint64_t applied_seq_ = SensorFrame::kNoTarget;
  int64_t steps_ = 0;
  SensorFrame frame_;
  PatientRecord record_;
  TrackerNoise tracker_;
  std::vector<Eigen::Vector3d> exact_markers_;  // before the tracker's noise
  PatientStepReport last_step_;
};

}  // namespace nsim
