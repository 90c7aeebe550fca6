#include "common/scene/patient_loop.h"

#include <algorithm>
#include <cmath>

#include "common/core/clock.h"
#include "common/core/error.h"

namespace nsim {

void InsertionConfig::Validate() const {
  if (!(approach_distance >= 0) || !std::isfinite(approach_distance))
    throw InputError(Str("insertion.approach_distance must be >= 0 (m), got ", approach_distance));
  if (!(speed > 0) || !std::isfinite(speed))
    throw InputError(Str("insertion.speed must be > 0 (m/s), got ", speed));
  if (!std::isfinite(overshoot))
    throw InputError(Str("insertion.overshoot must be finite (m), got ", overshoot));
}

PatientLoop::PatientLoop(const PatientLoopConfig& config, const TetMesh& liver_mesh,
                         const TetMesh& skin_mesh)
    : config_(config), gate_(config.safety), tracker_(config.tracker) {
  config_.insertion.Validate();
  const PatientSceneConfig& sc = config_.scene;
  const RigidNeedleModel needle(sc.needle.geometry());
  plan_ = MakeInsertionPlan(sc.entry_W, sc.target_W, needle, config_.insertion.approach_distance);
  robot_ = std::make_unique<RobotDriver>(config_.robot, plan_.CalcFlangePose(0.0));
  scene_ = std::make_unique<PatientScene>(sc, liver_mesh, skin_mesh, robot_->X_WE());
  std::vector<Eigen::Vector3d> rest_markers;
  scene_->CalcMarkerPositions(&rest_markers);
  watchdog_ = std::make_unique<PhysicsWatchdog>(config_.watchdog, scene_->CalcTargetPosition(),
                                                rest_markers);
  Sample();
}

PatientLoop::~PatientLoop() = default;

double PatientLoop::time() const { return scene_->time(); }

void PatientLoop::Sample() {
  SensorFrame& f = frame_;
  f.stamp.seq = static_cast<uint64_t>(steps_);
  f.stamp.sim_time = scene_->time();
  f.stamp.wall_time_ns = 0;  // set by the transport when sent
  scene_->CalcMarkerPositions(&exact_markers_);
  f.p_WM = exact_markers_;
  tracker_.Apply(&f.p_WM);
  f.has_robot = true;
  f.X_WE = robot_->X_WE();
  f.q = robot_->q();
  f.bevel_angle = bevel_angle_;
  f.entry_punctured = scene_->CalcEntryPoint(&f.p_WP, &f.n_W);
  f.applied_seq = applied_seq_;

  PatientRecord& r = record_;
  r.t = f.stamp.sim_time;
  r.tip = scene_->CalcTipPosition();
  r.target = scene_->CalcTargetPosition();
  r.e_p = r.target - r.tip;  // thesis eq. 3.3
  r.distance = r.e_p.norm();
  r.skin = scene_->GetTissueStatus(kSkinTissue);
  r.liver = scene_->GetTissueStatus(kLiverTissue);
  r.phase = r.liver.punctured ? 2 : r.skin.punctured ? 1 : 0;
  r.holding = holding_;

  if (fault_.empty()) {
    WatchdogInput in;
    in.step = steps_;
    in.target = &r.target;
    in.markers = &exact_markers_;
    in.tip = &r.tip;
    in.liver = &scene_->model().liver();
    in.liver_state = &scene_->state().liver;
    in.skin = &scene_->model().skin();
    in.skin_state = &scene_->state().skin;
    fault_ = watchdog_->Check(in);
    if (fault_.empty() && !f.X_WE.matrix().allFinite()) fault_ = "the robot's pose is not finite";
  }
  gate_.NotePublishedFrame(f.stamp.seq, f.stamp.sim_time);
}

GateDecision PatientLoop::Receive(const RobotTarget& target) {
  GateDecision d = gate_.Check(target, scene_->time(), robot_->X_WE(), robot_->q());
  if (d.accepted) {
    command_ = d.target;
    bevel_angle_ = d.target.bevel_angle;
  }
  return d;
}

const SensorFrame& PatientLoop::Step(const std::optional<RobotTarget>& target) {
  const double h = config_.scene.time_step;
  const double t = scene_->time();
  last_step_ = PatientStepReport();
  if (target) {
    Receive(*target);
    last_step_.gated_target = true;
  }
  const double start = MonotonicSeconds();
  bool holding = false;
  applied_seq_ = SensorFrame::kNoTarget;
  if (!config_.controller) {
    const double s = std::min(config_.insertion.speed * (t + h),
                              plan_.total_travel() + config_.insertion.overshoot);
    robot_->StepToPose(plan_.CalcFlangePose(s), h);
  } else if (controller_lost_ || !command_ || gate_.ShouldHold(t)) {
    robot_->Hold(h);
    holding = true;
  } else if (command_->mode == TargetMode::kJoint) {
    robot_->StepToJoints(command_->q, h);
    applied_seq_ = command_->answers_seq;
  } else {
    robot_->StepToPose(command_->X_WE, h);
    applied_seq_ = command_->answers_seq;
  }
  last_step_.scene = scene_->Step(robot_->X_WE(), bevel_angle_);
  last_step_.wall_ms = 1e3 * (MonotonicSeconds() - start);
  last_step_.holding = holding;
  last_step_.max_rib_penetration = scene_->CalcMaxRibPenetration();
  holding_ = holding;
  ++steps_;
  Sample();
  return frame_;
}

void PatientLoop::Prefetch() {
  const double start = MonotonicSeconds();
  last_step_.prefetch_columns = scene_->Prefetch();
  last_step_.prefetch_ms = 1e3 * (MonotonicSeconds() - start);
}

}  // namespace nsim
