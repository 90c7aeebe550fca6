#include "common/steering/controller_loop.h"

#include <cmath>

#include "common/core/clock.h"
#include "common/core/error.h"

namespace nsim {
namespace {

constexpr size_t kFrameTimesKept = 1024;  // frames whose time a delay can be measured against
constexpr size_t kRecentDelays = 10;      // the horizon uses the median of the last delays
constexpr size_t kInFlightKept = 256;     // commands kept while the robot has not executed them

}  // namespace

const char* ModelPoseName(ModelPose pose) {
  switch (pose) {
    case ModelPose::kMeasured: return "measured";
    case ModelPose::kCommanded: return "commanded";
    case ModelPose::kExpected: return "expected";
    case ModelPose::kAuto: return "auto";
  }
  return "?";
}

ControllerLoop::ControllerLoop(const ControllerLoopConfig& config, TetMesh mesh)
    : config_(config),
      mesh_(std::move(mesh)),
      horizon_(config.horizon),
      predictor_score_(config.prediction.pca_window),
      forecast_(config.robot) {
  config_.model.Validate();
  config_.path.Validate();
  config_.control.Validate();
  config_.prediction.Validate();
  if (config_.preparation == Preparation::kExhale) {
    ExhaleGateConfig gate;
    gate.capacity = config_.prediction.pca_window;
    exhale_gate_ = std::make_unique<ExhaleGate>(gate);
  }
}

ControllerLoop::~ControllerLoop() = default;

void ControllerLoop::Reject(const std::string& why) {
  ++counts_.rejected_frames;
  counts_.last_rejection = why;
}

bool ControllerLoop::Accept(const SensorFrame& frame) {
  if (observed_any_ && !(frame.stamp.sim_time > last_observed_time_)) {
    Reject(Str("frame ", frame.stamp.seq, " at t = ", frame.stamp.sim_time,
               " s does not follow t = ", last_observed_time_, " s"));
    return false;
  }
  if (!predictor_) {
    if (frame.p_WM.empty()) {
      Reject(Str("frame ", frame.stamp.seq, " has no markers"));
      return false;
    }
    predictor_ =
        std::make_unique<MarkerPredictor>(config_.prediction, static_cast<int>(frame.p_WM.size()));
  }
  try {
    predictor_->Update(frame.markers());
  } catch (const InputError& e) {
    Reject(Str("frame ", frame.stamp.seq, ": ", e.what()));
    return false;
  }
  if (frame.has_robot && UsesForecast()) {  // the forecast's state
    try {
      forecast_.Observe(frame.stamp.sim_time, frame.X_WE, frame.q);
    } catch (const InputError& e) {
      Reject(Str("frame ", frame.stamp.seq, ": ", e.what()));
      return false;
    }
  }
  score_.AddMeasurement(frame.stamp.sim_time, frame.p_WM);
  predictor_score_.AddMeasurement(frame.stamp.sim_time, frame.p_WM);
  if (exhale_gate_ && !exhale_entered_) {  // the gated start: the first exhale rest once the
                                           // predictor is ready
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& p : frame.p_WM) centroid += p;
    const bool entered = exhale_gate_->Add(frame.stamp.sim_time, centroid / frame.p_WM.size());
    if (predictor_->ready()) {
      exhale_entered_ = exhale_entered_ || entered;
      ++ready_frames_;
    }
  }
  frame_times_.emplace_back(frame.stamp.seq, frame.stamp.sim_time);
  if (frame_times_.size() > kFrameTimesKept) frame_times_.pop_front();
  MeasureLatency(frame);
  if (observed_any_ && frame.stamp.seq > last_observed_seq_)
    frame_period_ = (frame.stamp.sim_time - last_observed_time_) /
                    static_cast<double>(frame.stamp.seq - last_observed_seq_);
  observed_any_ = true;
  last_observed_time_ = frame.stamp.sim_time;
  last_observed_seq_ = frame.stamp.seq;
  ++counts_.observed;
  return true;
}

void ControllerLoop::MeasureLatency(const SensorFrame& frame) {
  if (!frame.has_robot) return;
  if (frame.applied_seq == SensorFrame::kNoTarget) {
    // the robot held still: the commands it held through did not take effect
    if (obeyed_) last_target_.reset();
    obeyed_ = false;
    in_flight_.clear();
    applied_target_.reset();
    return;
  }
  obeyed_ = true;
  while (!in_flight_.empty() && in_flight_.front().answers_seq <= frame.applied_seq) {
    applied_target_ = in_flight_.front();
    in_flight_.pop_front();
  }
  // a command the robot should have carried out by now (d + 1 frames after the frame it
  // answers) and did not never reached it, and a newer one replaces it: the forecast skips it
  if (!recent_delays_.empty() && frame.stamp.seq > static_cast<uint64_t>(latency_steps_ + 1)) {
    const uint64_t due = frame.stamp.seq - static_cast<uint64_t>(latency_steps_ + 1);
    while (!in_flight_.empty() && in_flight_.front().answers_seq <= due) {
      in_flight_.pop_front();
      ++counts_.unapplied_targets;
    }
  }
  for (auto it = frame_times_.rbegin(); it != frame_times_.rend(); ++it) {
    if (it->first != frame.applied_seq) continue;
    const double delay = frame.stamp.sim_time - it->second;
    delays_.push_back(delay);
    recent_delays_.push_back(delay);
    if (recent_delays_.size() > kRecentDelays) recent_delays_.pop_front();
    return;
  }
}

double ControllerLoop::CalcHorizon(double t) {
  horizon_.AddLoopTime(t);
  const double configured = horizon_.CalcHorizon(t);  // eq. 4.9-4.10, configured delay
  if (!config_.measure_latency || recent_delays_.empty() || !std::isfinite(configured))
    return configured;
  // the measured delay covers the loop period and the latency; the configured delay adds
  // what simulation time cannot see (a tracker's own localization delay)
  const double loop = configured - config_.horizon.localization_delay;
  const double measured = Median({recent_delays_.begin(), recent_delays_.end()});
  const double horizon = configured + std::max(0.0, measured - loop);
  // the delay spans the frame period and d frames of latency ((d + 1) periods in lockstep),
  // counted in the sensor's periods: the loop time grows with every frame lost or skipped
  const double period = frame_period_ > 0 ? frame_period_ : loop;
  if (period > 0)
    latency_steps_ = std::max(0, static_cast<int>(std::lround(measured / period)) - 1);
  if (config_.search_lead_auto && predictor_ && loop > 0) {
    const int lead = std::max(1, static_cast<int>(std::lround(horizon / loop)));
    if (lead != search_lead_) predictor_->SetSearchLead(lead);
    search_lead_ = lead;
  }
  return horizon;
}

void ControllerLoop::SetCommanded(SteeringInput* input) const {
  if (!last_target_ || !config_.control.compensate_in_flight) return;
  if (last_target_->mode == TargetMode::kJoint && last_target_->q.size() == 7)
    input->q_commanded = Eigen::Map<const Vector7d>(last_target_->q.data());
  else if (last_target_->mode == TargetMode::kCartesian)
    input->X_WE_commanded = last_target_->X_WE;
}

ModelPose ControllerLoop::ResolvedModelPose() const {
  if (config_.model_pose != ModelPose::kAuto) return config_.model_pose;
  return config_.control.dof == SteeringDof::kJoint7 && latency_steps_ <= kAutoExpectedSteps
             ? ModelPose::kExpected
             : ModelPose::kCommanded;
}

bool ControllerLoop::UsesForecast() const {
  return config_.model_pose == ModelPose::kExpected ||
         (config_.model_pose == ModelPose::kAuto && config_.control.dof == SteeringDof::kJoint7);
}

void ControllerLoop::SetModelPose(uint64_t seq, SteeringInput* input) const {
  const ModelPose pose = ResolvedModelPose();
  if (pose == ModelPose::kMeasured) return;
  const bool joints = input->q_commanded.has_value();
  if (!joints && !input->X_WE_commanded) return;  // nothing in flight, or the robot held
  if (pose == ModelPose::kCommanded || !forecast_.has_state() ||
      !(frame_period_ > 0.0)) {
    if (joints) input->q = *input->q_commanded;
    else input->X_WE = *input->X_WE_commanded;
    return;
  }
  const std::vector<const RobotTarget*> slots = CommandSlots(seq);
  if (joints) {
    std::vector<Vector7d> commands;
    for (const RobotTarget* t : slots)
      if (t->mode == TargetMode::kJoint && t->q.size() == 7)
        commands.push_back(Eigen::Map<const Vector7d>(t->q.data()));
    input->q = forecast_.ForecastJoints(commands, frame_period_);
  } else {
    std::vector<Eigen::Isometry3d> commands;
    for (const RobotTarget* t : slots)
      if (t->mode == TargetMode::kCartesian) commands.push_back(t->X_WE);
    input->X_WE = forecast_.ForecastPose(commands, frame_period_);
  }
}

std::vector<const RobotTarget*> ControllerLoop::CommandSlots(uint64_t seq) const {
  std::vector<const RobotTarget*> slots;
  if (!applied_target_) {  // the robot's own command not known yet: the commands in order
    for (const RobotTarget& t : in_flight_) slots.push_back(&t);
    return slots;
  }
  // the d steps from frame seq to the frame the new command takes effect: step seq + i
  // executes the newest command answering a frame <= seq + i - d (LockstepTargets; over DDS
  // the same at the measured latency), else keeps the one before: a frame lost on the way has
  // no answer, and the robot keeps its command for that step
  const RobotTarget* command = &*applied_target_;
  auto next = in_flight_.begin();
  const int d = latency_steps_;
  for (int i = 0; i < d; ++i) {
    const int64_t bound = static_cast<int64_t>(seq) + i - d;
    while (next != in_flight_.end() && static_cast<int64_t>(next->answers_seq) <= bound)
      command = &*next++;
    slots.push_back(command);
  }
  return slots;
}

void ControllerLoop::Observe(const SensorFrame& frame) { Accept(frame); }

std::optional<RobotTarget> ControllerLoop::Step(const SensorFrame& frame) {
  if (!Accept(frame)) return std::nullopt;
  if (!frame.has_robot) {
    Reject(Str("frame ", frame.stamp.seq, " has no robot state (a marker-only stream)"));
    return std::nullopt;
  }
  if (config_.control.dof == SteeringDof::kJoint7 && frame.q.size() != 7) {
    Reject(Str("frame ", frame.stamp.seq, " has ", frame.q.size(),
               " joint positions; the iiwa's joint law needs 7"));
    return std::nullopt;
  }
  if (!controller_) {  // InputError here is fatal: the model cannot be built from the config
    controller_ = std::make_unique<SteeringController>(config_.model, config_.path,
                                                       config_.control, mesh_, frame.X_WE);
    // the needle may already be in (a controller started mid-insertion): the model catches up
    // with the measured markers and pose (nothing happens at the start of an insertion)
    SteeringInput now;
    now.p_WM = frame.p_WM;
    now.X_WE = frame.X_WE;
    now.bevel_angle = frame.bevel_angle;
    if (frame.q.size() == 7) now.q = Eigen::Map<const Vector7d>(frame.q.data());
    try {
      catch_up_ = controller_->CatchUp(now);
    } catch (const InputError& e) {  // a malformed frame: the model is built at the next one
      controller_.reset();
      Reject(Str("frame ", frame.stamp.seq, ": ", e.what()));
      return std::nullopt;
    }
    first_answered_seq_ = static_cast<int64_t>(frame.stamp.seq);
    // the preparation phase: the robot held where it is until the insertion may start
    preparing_ = config_.preparation != Preparation::kNone && !catch_up_.done;
    hold_.X_WE = frame.X_WE;
    hold_.q = frame.q;
    hold_.mode = config_.control.dof == SteeringDof::kCartesian6 ? TargetMode::kCartesian
                                                                 : TargetMode::kJoint;
  }
  if (preparing_ && predictor_->ready() &&
      (config_.preparation == Preparation::kBuffer || exhale_entered_ ||
       ready_frames_ > config_.prediction.pca_window))
    preparing_ = false;  // latched off
  const double t = frame.stamp.sim_time;
  ControllerRecord& r = record_;
  r = ControllerRecord();
  r.answers_seq = frame.stamp.seq;
  r.t = t;
  ++counts_.answered;
  SteeringInput input;
  try {
    r.horizon = CalcHorizon(t);
    SetCommanded(&input);
    input.latency_steps = latency_steps_;
    input.hold = preparing_;
    input.X_WE = frame.X_WE;
    input.bevel_angle = frame.bevel_angle;
    if (frame.q.size() == 7) input.q = Eigen::Map<const Vector7d>(frame.q.data());
    input.entry = frame.entry();
    r.predicted = config_.prediction_enabled && predictor_->ready() && std::isfinite(r.horizon);
    if (r.predicted) {
      predictor_->Predict(r.horizon, &input.p_WM);
      if (config_.prediction_displacement) {
        predictor_->Predict(0.0, &fit_now_);
        for (size_t m = 0; m < input.p_WM.size(); ++m)
          input.p_WM[m] = frame.p_WM[m] + (input.p_WM[m] - fit_now_[m]);
      }
      predictor_score_.AddPrediction(t + r.horizon, input.p_WM, frame.p_WM);
      if (config_.prediction_shrink) {
        const std::vector<double> alpha = predictor_score_.Shrinkage();
        double sum = 0.0;
        for (size_t m = 0; m < input.p_WM.size() && m < alpha.size(); ++m) {
          input.p_WM[m] = frame.p_WM[m] + alpha[m] * (input.p_WM[m] - frame.p_WM[m]);
          sum += alpha[m];
        }
        if (!alpha.empty()) r.shrinkage = sum / static_cast<double>(alpha.size());
      }
      score_.AddPrediction(t + r.horizon, input.p_WM, frame.p_WM);
      // the needle where the robot will be when the markers are where they are predicted
      SetModelPose(frame.stamp.seq, &input);
    } else {
      input.p_WM = frame.p_WM;
    }
  } catch (const InputError& e) {
    Reject(Str("frame ", frame.stamp.seq, ": ", e.what()));
    return std::nullopt;
  }
  SteeringOutput out;
  try {
    out = controller_->Update(input);
  } catch (const InputError& e) {
    Reject(Str("frame ", frame.stamp.seq, ": ", e.what()));
    return std::nullopt;
  }
  if (!preparing_) {  // the control steps' cost (a held step has no Jacobian and no law)
    model_time_.Add(out.timings.simulation);
    jacobian_time_.Add(out.timings.jacobian);
    total_time_.Add(out.timings.total);
  }
  const double done = MonotonicSeconds();
  if (last_answer_wall_ > 0) loop_period_.Add(done - last_answer_wall_);
  last_answer_wall_ = done;
  phase_ = static_cast<int>(out.phase) - 1;
  r.phase = static_cast<int>(out.phase);
  r.path_index = out.path_index;
  r.valid = out.valid;
  r.e_p_norm = out.e.size() >= 3 ? out.e.head<3>().norm() : 0.0;
  r.model_tip = out.p_WTip;
  r.model_target = out.p_WFinal;
  r.latency_steps = input.latency_steps;
  r.load_gain = out.load_gain;
  r.preparing = preparing_;
  r.timings = out.timings;
  const TissueCouplingReport& liver = controller_->simulation().liver_coupling().report;
  r.model_depth = liver.depth;
  r.model_past_seed = liver.past_seed;
  r.model_tip_hold = liver.tip_hold;
  if (!out.valid) {
    ++counts_.invalid_outputs;
    return std::nullopt;
  }
  counts_.tilt_limited += out.tilt_limited ? 1 : 0;
  counts_.insertion_limited += out.insertion_limited ? 1 : 0;
  RobotTarget target;
  if (preparing_) {  // the model followed the markers; the robot stays at the hold pose
    target = hold_;
    ++counts_.prepared;
  } else if (config_.control.dof == SteeringDof::kCartesian6) {
    target.mode = TargetMode::kCartesian;
    target.X_WE = out.X_WE_target;
  } else {
    target.mode = TargetMode::kJoint;
    target.q.assign(out.q_target.data(), out.q_target.data() + 7);
    target.X_WE = out.X_WE_target;  // the flange pose q implies: informative (ROS 2 target pose)
  }
  target.stamp.seq = counts_.targets++;
  target.stamp.sim_time = t;
  target.answers_seq = frame.stamp.seq;
  target.bevel_angle = frame.bevel_angle;
  last_target_ = target;
  if (UsesForecast()) {  // only the forecast needs them
    in_flight_.push_back(target);
    if (in_flight_.size() > kInFlightKept) in_flight_.pop_front();
  }
  return target;
}

}  // namespace nsim
