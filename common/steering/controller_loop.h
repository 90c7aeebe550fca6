#pragma once
// The controller side of the closed loop, without transport (DESIGN.md "The two loops"): the
// marker predictor and the horizon (thesis §4.1), the registered liver model and the steering
// controller (§3.2-3.3). Step() takes one sensor frame and answers it with a robot target, or
// with nothing when the controller cannot compute a valid one (the robot then keeps its last
// command and the patient side's gate makes it hold after safety.hold_timeout). Frames that
// are not answered (realtime: older than the newest) still feed the predictor (Observe).
// The DDS pump of inverse_sim and the in-process closed loop drive the same class.
//
// A controller started (or restarted) in the middle of an insertion re-synchronizes its model
// from the frames. Given the frames from the start of the run (inverse_sim over DDS in
// lockstep: a late reader of the lossless frame stream gets its history, up to
// TransportConfig::lossless_depth = 4096 frames, 82 s at 50 Hz) it answers them all in order
// and its model, predictor and path index replay the insertion exactly. Otherwise (realtime: only the newest frame; a longer
// run) the first frame it answers finds the needle in: the model is built at the measured
// flange pose and caught up (SteeringController::CatchUp: driven in along the registered path,
// then moved to the measured pose, the markers at their measured positions), the first control
// step advances the path index past the targets the tip has passed, and the marker predictor,
// the horizon and the measured latency start fresh (the predictor is ready once its buffer
// has filled again; until then the model registers to the measured markers).

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/core/samples.h"
#include "common/core/statistics.h"
#include "common/mesh/tet_mesh.h"
#include "common/prediction/exhale_gate.h"
#include "common/prediction/horizon_estimator.h"
#include "common/prediction/marker_predictor.h"
#include "common/prediction/prediction_score.h"
#include "common/robot/motion_forecast.h"
#include "common/steering/steering_config.h"
#include "common/steering/steering_controller.h"

namespace nsim {

/// When the insertion starts (ControllerLoopConfig::preparation).
enum class Preparation { kNone, kBuffer, kExhale };

/// Where the model's needle is while it registers to predicted markers
/// (ControllerLoopConfig::model_pose).
enum class ModelPose { kMeasured, kCommanded, kExpected, kAuto };

/// The scenario's name of a ModelPose: "measured", "commanded", "expected", "auto".
const char* ModelPoseName(ModelPose pose);

/// ModelPose::kAuto's bound in steps of measured latency (ControllerRecord::latency_steps):
/// the iiwa's forecast pose up to it, the last commanded pose beyond. Measured, prediction on,
/// 7-DoF, 22 runs a cell, `expected` against `commanded`: amplitude -67 % / -68 % / -50 % at 1
/// step (seeds 2001-2022, 1001-1022) and 2 steps (1001-1022), the mean within +0.01 mm; at 3
/// steps +33 % / -32 % (1001-1022, 2001-2022), at 5 steps +61 %, at 10 steps +18 % and
/// +0.05 mm (docs/control.md, "The model's pose per robot and latency").
inline constexpr int kAutoExpectedSteps = 2;

/// Everything the controller loop is made of.
struct ControllerLoopConfig {
  InverseModelConfig model;
  SteeringPathConfig path;
  SteeringControlConfig control;
  bool prediction_enabled = true;  ///< register to predicted markers (thesis fig. 4.4)
  PredictionConfig prediction;
  /// prediction.displacement: register to the measured markers plus the predicted displacement
  /// over the horizon (prediction at t + h minus the filter's own fit at t), instead of the
  /// filter's reconstructed position. The PCA + LF predictor reconstructs the markers on their
  /// first principal axis only; in the closed loop the liver's markers also move off that axis
  /// (needle drag, rib sliding, inhale/exhale hysteresis), and the reconstruction drops that
  /// part: measured nRMS 230-600 % at h = 0.04 s on liver_test_coarse.yaml. With the
  /// displacement the off-axis part is kept as measured.
  bool prediction_displacement = true;
  /// prediction.shrink: each marker's predicted displacement (prediction minus the measured
  /// marker) is scaled by the share of it that came true over the last pca_window scored
  /// predictions (PredictionScore::Shrinkage: the least-squares factor in [0, 1]). In the
  /// closed loop the needle moves the markers at frequencies the window search, run on free
  /// breathing, never saw; at long horizons the chosen short windows amplify them (10 steps:
  /// marker nRMS 280-850 %, the joint law oscillating to 4 mm) and the factor falls toward 0,
  /// where a prediction that pays keeps it near 1.
  bool prediction_shrink = false;
  /// The prediction horizon (eq. 4.10) uses the loop latency measured from the frames
  /// (SensorFrame::applied_seq: the time from a frame to the frame whose step executed its
  /// answer), on top of horizon.localization_delay (a tracker's own delay, not visible in
  /// simulation time); false: only the configured delay.
  bool measure_latency = true;
  /// prediction.search_lead `auto`: the LF window search scores predictions as many frames
  /// ahead as they are used (the measured horizon in frames; before a delay is measured,
  /// localization_delay plus one frame); false: the configured search_lead (the thesis's
  /// Algorithm 1 scores 1 frame ahead; a window chosen for 1 frame and used 6 frames ahead gave
  /// marker nRMS of 450 % at a 100 ms latency).
  bool search_lead_auto = true;
  /// prediction.model_pose: where the model's needle is when the model registers to markers
  /// predicted over the horizon (the loop's latency) and commands are in flight
  /// (control.compensate_in_flight). kMeasured: at the measured pose. kCommanded: at the last
  /// commanded pose, where the robot will be when the predicted markers are reached if it
  /// follows each command within a step. kExpected: where the robot will be after executing the
  /// commands in flight, forecast by its own motion law under its speed and acceleration limits
  /// (`robot`, MotionForecast) from the measured state: the commanded pose for a robot that
  /// keeps up, and behind it when the commands jump faster than the robot can follow. With
  /// kCommanded and kExpected the model simulates one instant, the markers and the needle both
  /// at t + horizon. kAuto: kExpected for the iiwa's joint targets while the measured latency
  /// is at most kAutoExpectedSteps steps, kCommanded otherwise (and always for the Cartesian
  /// robot): the choice 22-run batches made per robot and latency (README "The model's needle
  /// where the robot will be"). Without prediction (or before the predictor is ready, or when
  /// the robot held its last command) the model uses the measured pose either way.
  ModelPose model_pose = ModelPose::kMeasured;
  /// The robot's limits for ModelPose::kExpected (the scenario's `robot` section; the iiwa's
  /// joint limits are its data sheet's).
  MotionForecastConfig robot;
  /// prediction.preparation: when the insertion starts. kNone: at the first frame (the
  /// predictor joins when its buffer is full). kBuffer (thesis §4.1, fig. 4.1: "some cycles of
  /// the patient respiration are observed right before the needle insertion"): the robot is
  /// held at the flange pose of the first answered frame until the marker predictor's PCA
  /// buffer is full (pca_window frames); the model registers to the markers meanwhile and the
  /// latency is measured on the hold targets, so the insertion starts with the predictor and
  /// its window chosen on free breathing. kExhale: then also until the breathing enters its
  /// exhale rest (ExhaleGate, common/prediction/exhale_gate.h, on the same window; at most
  /// pca_window frames more): a respiratory-gated start. Held with prediction off as well,
  /// so that paired runs insert at the same time; only for a loop that starts before the
  /// needle is in (not after a catch-up).
  Preparation preparation = Preparation::kNone;
  HorizonConfig horizon;
};

/// One answered frame, for the controller's log (inverse.csv).
struct ControllerRecord {
  uint64_t answers_seq = 0;
  double t = 0.0;         ///< simulation time of the frame (s)
  int phase = 0;          ///< InsertionPhase as a number
  int path_index = 0;
  bool valid = false;     ///< a target was produced
  double e_p_norm = 0.0;  ///< |e_p| in the model (m)
  double horizon = 0.0;   ///< prediction horizon (s); NaN before the horizon is known
  bool predicted = false; ///< registered to predicted markers
  Eigen::Vector3d model_tip = Eigen::Vector3d::Zero();
  /// the target as the model places it (its final path target, m): its distance to the true
  /// target is the registration's share of the final error
  Eigen::Vector3d model_target = Eigen::Vector3d::Zero();
  int latency_steps = 0;   ///< the measured latency the step used (frames; 0 = not yet)
  /// the preparation phase held the robot (ControllerLoopConfig::preparation): the target
  /// sent is the hold pose, not the law's
  bool preparing = false;
  double load_gain = 0.0;  ///< the gain of e_l's rows (0 without them)
  /// the mean over the markers of the factor their predicted displacements were scaled by
  /// (prediction.shrink; 1 without it or without prediction)
  double shrinkage = 1.0;
  /// the model's needle in its liver after the step (TissueCouplingReport): depth (m), the
  /// tip's distance past the last seeded point (m), the tip's hold (0 free, 1 rigid)
  double model_depth = 0.0;
  double model_past_seed = 0.0;
  double model_tip_hold = 0.0;
  SteeringTimings timings;
};

/// Counts of what the loop did.
struct ControllerCounts {
  uint64_t answered = 0;         ///< frames answered (valid or not)
  uint64_t targets = 0;          ///< targets produced
  uint64_t invalid_outputs = 0;  ///< answered without a target (non-finite objectives)
  uint64_t tilt_limited = 0;     ///< targets turned back onto controller.max_needle_tilt
  /// targets moved back onto controller.max_insertion_step or free_stretch_step
  uint64_t insertion_limited = 0;
  uint64_t rejected_frames = 0;  ///< frames refused (malformed, out of order, no robot state)
  uint64_t observed = 0;         ///< frames fed to the predictor
  uint64_t prepared = 0;         ///< frames answered with the hold of the preparation phase
  /// Targets the robot did not carry out when due (d + 1 frames after the frame they answer,
  /// d the measured latency): lost on the way, or late; the robot's forecast skips them.
  /// Counted while the model uses the forecast pose (UsesForecast), which keeps the commands.
  uint64_t unapplied_targets = 0;
  std::string last_rejection;
};

class ControllerLoop {
 public:
  /// Validates the configs (InputError). The model is built at the first answered frame, with
  /// the needle at the measured flange pose, caught up when the needle is already in (see the
  /// file comment).
  ControllerLoop(const ControllerLoopConfig& config, TetMesh mesh);
  ~ControllerLoop();

  /// Feeds a frame that will not be answered to the predictor and the prediction score. A
  /// malformed frame is counted as rejected.
  void Observe(const SensorFrame& frame);
  /// Observes `frame` and answers it: registration, objectives, Jacobian and law. Returns the
  /// target (stamped with answers_seq = frame.stamp.seq), or nothing for a rejected frame or an
  /// invalid output. InputError when the model cannot be built from the config (first frame);
  /// SolverError when a model solve diverged.
  std::optional<RobotTarget> Step(const SensorFrame& frame);

  const ControllerRecord& last_record() const { return record_; }
  const ControllerCounts& counts() const { return counts_; }
  /// The score of the predictions the model registered to (after prediction.shrink).
  const PredictionScore& score() const { return score_; }
  /// The score of the predictor's own predictions (before prediction.shrink) and their
  /// shrinkage factors.
  const PredictionScore& predictor_score() const { return predictor_score_; }
  /// Wall-clock cost of the model step, the Jacobian and the whole control step (s).
  const TimingStat& model_time() const { return model_time_; }
  const TimingStat& jacobian_time() const { return jacobian_time_; }
  const TimingStat& total_time() const { return total_time_; }
  /// Wall time between successive answers (s): its rate is the controller's loop rate.
  const TimingStat& loop_period() const { return loop_period_; }
  /// Every measured loop delay: the frame's time minus the time of the frame whose answer the
  /// robot executed in the step before it (s); (d + 1) time steps in lockstep with latency d.
  const std::vector<double>& measured_delays() const { return delays_; }
  /// Frames ahead the predictor's window search scores now (the measured horizon in frames
  /// with search_lead_auto, else prediction.search_lead).
  int search_lead() const { return search_lead_ > 0 ? search_lead_ : config_.prediction.search_lead; }
  /// The marker predictor (null before the first accepted frame).
  const MarkerPredictor* predictor() const { return predictor_.get(); }
  /// The current insertion phase (0 outside, 1 skin, 2 liver), for status messages.
  int phase() const { return phase_; }
  const ControllerLoopConfig& config() const { return config_; }
  const TetMesh& mesh() const { return mesh_; }
  /// The steering controller (null before the first answered frame).
  const SteeringController* controller() const { return controller_.get(); }
  /// What the model's catch-up at the first answered frame did (done = false: the needle was
  /// not in, or no frame answered yet).
  const CatchUpReport& catch_up() const { return catch_up_; }
  /// The sequence number of the first frame answered (-1: none yet).
  int64_t first_answered_seq() const { return first_answered_seq_; }

 private:
  bool Accept(const SensorFrame& frame);  // validity and order checks; counts a rejection
  void Reject(const std::string& why);
  // the loop delay from the frame's applied_seq, and whether the robot obeys our commands
  void MeasureLatency(const SensorFrame& frame);
  // the horizon at frame time t: eq. 4.9-4.10 with the measured delay
  double CalcHorizon(double t);
  // the commands in flight for the law (none when the robot stopped obeying)
  void SetCommanded(SteeringInput* input) const;
  // the model's needle pose, answering frame seq, while it registers to predicted markers
  // (config_.model_pose)
  void SetModelPose(uint64_t seq, SteeringInput* input) const;
  // the command each of the d steps until frame seq's answer takes effect executes
  std::vector<const RobotTarget*> CommandSlots(uint64_t seq) const;
  // config_.model_pose with kAuto resolved for the robot and the measured latency
  ModelPose ResolvedModelPose() const;
  // whether the model pose may be the forecast (the forecast's state and the commands in
  // flight are then kept)
  bool UsesForecast() const;

  ControllerLoopConfig config_;
  TetMesh mesh_;
  std::unique_ptr<SteeringController> controller_;
  CatchUpReport catch_up_;
  int64_t first_answered_seq_ = -1;
  // the preparation phase: on until the predictor is ready and (kExhale) the exhale rest
  // begins, then latched off; its hold pose, and the frames held since the predictor was ready
  bool preparing_ = false;
  RobotTarget hold_;
  std::unique_ptr<ExhaleGate> exhale_gate_;
  bool exhale_entered_ = false;
  int ready_frames_ = 0;
  std::unique_ptr<MarkerPredictor> predictor_;
  HorizonEstimator horizon_;
  PredictionScore score_, predictor_score_;
  ControllerCounts counts_;
  ControllerRecord record_;
  TimingStat model_time_, jacobian_time_, total_time_, loop_period_;
  double last_answer_wall_ = -1.0;
  double last_observed_time_ = -1.0;
  uint64_t last_observed_seq_ = 0;
  bool observed_any_ = false;
  int phase_ = 0;
  std::vector<Eigen::Vector3d> fit_now_;
  std::deque<std::pair<uint64_t, double>> frame_times_;  // (seq, t) of recent frames
  std::deque<double> recent_delays_;                     // the last measured delays (s)
  std::vector<double> delays_;
  std::optional<RobotTarget> last_target_;  // the last command sent
  // ModelPose::kExpected only: the commands sent and not yet executed, in order, and the
  // robot's motion from its measured states (neither is kept for the other poses)
  std::deque<RobotTarget> in_flight_;
  std::optional<RobotTarget> applied_target_;  // the newest of them the robot executed
  MotionForecast forecast_;
  // the sensor's frame period, from the time and sequence numbers of consecutive received
  // frames (s), 0 = not yet: the robot's step, whatever frames were lost or skipped
  double frame_period_ = 0.0;
  bool obeyed_ = false;                     // the robot executed one of our commands
  int search_lead_ = 0;
  int latency_steps_ = 0;  // the measured latency in frame periods (CalcHorizon), 0 = not yet
};

}  // namespace nsim
