#pragma once
// What the patient side writes and reports (README "Outputs"): timeseries.csv, one row per
// published frame with the true tip-to-target distance, e_p, phase, marker 0, target, tip and
// robot pose (deterministic: a lockstep run gives the same file byte for byte, in-process or
// over DDS); step_times.csv, the wall time of each physics step; and the summary.json of
// direct_sim: the final error and amplitude over the steady-state window (thesis fig. 5.9),
// step-time statistics, rates, punctures, the gate's counts, the loop latency and the
// settings.

#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/core/line_file.h"
#include "common/scene/patient_loop.h"

namespace nsim {

/// Facts of a run that the patient loop does not know: how it was driven.
struct PatientRunInfo {
  std::string scenario;        ///< the scenario file
  uint64_t scenario_hash = 0;  ///< of its shared part
  std::string liver_mesh;      ///< path of the patient's liver mesh
  uint64_t seed = 0;           ///< breathing seed
  double duration = 0.0;       ///< requested simulated time (s)
  bool realtime = false;       ///< realtime (wall-clock paced) or lockstep
  int latency_steps = 0;       ///< lockstep latency d (steps)
  int rt_priority = 0;         ///< realtime: the loop thread's SCHED_FIFO priority asked for
  std::string loop_class;      ///< realtime: the class the loop ran in ("fifo", "other", ...)
  std::string transport = "dds";  ///< "dds" or "in_process"
  std::string dds_identity;  ///< the DDS Security identity (--secure); empty: not secured
  /// completed, diverged (a solver failed), implausible_state (the physics watchdog stopped the
  /// run: `fault` says why), interrupted, controller_lost, ...
  std::string exit = "completed";
  std::string fault;  ///< PatientLoop::fault() when the watchdog stopped the run
  double wall_time = 0.0;      ///< (s)
  std::vector<double> latency_ms;  ///< per received target: frame sent -> target received (ms)
  uint64_t lockstep_timeouts = 0;  ///< lockstep steps that went on without the awaited answer
  /// In-process lockstep with a lossy link (direct_sim run --in-process --loss PCT): the loss
  /// asked for, and the frames and targets it lost.
  double link_loss_percent = 0.0;
  uint64_t frames_lost = 0, targets_lost = 0;
  uint64_t transport_invalid = 0;  ///< targets dropped by the transport (malformed)
  /// targets from a process other than the robot's owner (the controller bound at the start),
  /// rejected before the gate, in all and by writer (hex instance handle)
  uint64_t foreign_targets = 0;
  std::map<std::string, uint64_t> foreign_by_writer;
  std::optional<double> controller_lost_time;  ///< simulated time it was first lost (s)
  uint64_t controller_losses = 0, controller_returns = 0;  ///< losses, and comebacks (stalls)
  /// The robot's owners in turn: the controller bound at the start, then each that took over
  /// a lost one (a re-handshake), with the targets of it the robot carried out.
  struct Owner {
    std::string participant;  ///< ParticipantId (hex)
    double since = 0.0;       ///< simulated time it became the owner (s)
    uint64_t targets_applied = 0;
  };
  std::vector<Owner> owners;
  uint64_t takeovers = 0;  ///< owner changes after the start
  /// controllers that said "running" while the robot had a live owner, refused (distinct)
  uint64_t refused_controllers = 0;
  bool video = false, png = false;  ///< outputs written
  int vtk_snapshots = 0;
};

class PatientRecorder {
 public:
  /// The share of the run at its end over which the final error is averaged (thesis fig. 5.9:
  /// the steady state; 20 % of a 20 s run is one breathing period).
  static constexpr double kSteadyFraction = 0.2;

  /// Opens DIR/timeseries.csv and DIR/step_times.csv (InputError naming the file when it
  /// cannot); each row is written whole with one write (common/core/line_file.h).
  explicit PatientRecorder(const std::string& out_dir);

  /// A published frame: its row of timeseries.csv and the error statistics.
  void AddFrame(const PatientLoop& loop);
  /// A physics step that was taken.
  void AddStep(const PatientLoop& loop);

  /// direct_sim's summary.json.
  nlohmann::json Summary(const PatientLoop& loop, const PatientRunInfo& info) const;
  /// Flushes and closes the two CSVs and writes Summary() to DIR/summary.json atomically.
  void WriteSummary(const PatientLoop& loop, const PatientRunInfo& info) const;

  double median_step_ms() const;
  double last_distance() const { return last_distance_; }
  const std::vector<double>& step_ms() const { return step_ms_; }

 private:
  std::string out_dir_;
  std::unique_ptr<LineFile> csv_, steps_csv_;
  std::vector<std::pair<double, double>> distance_log_;  // (t, true tip-target distance (m))
  std::vector<double> step_ms_;
  std::vector<double> prefetch_ms_;  // PatientLoop::Prefetch after each step
  int64_t prefetch_columns_ = 0;
  double last_distance_ = 0.0, min_distance_ = INFINITY, max_rib_penetration_ = 0.0;
  double min_joint_margin_ = INFINITY;  // iiwa: closest approach of a joint to its limit (rad)
  Eigen::Vector3d last_e_p_ = Eigen::Vector3d::Zero();
  int last_phase_ = 0;
  uint64_t hold_steps_ = 0, rib_contact_steps_ = 0, unconverged_solves_ = 0, frames_ = 0;
  // the liver's solver over the steps (FemStepStats)
  uint64_t liver_pcg_iterations_ = 0, liver_refactorized_ = 0, liver_adopted_ = 0;
  uint64_t liver_adoption_lag_ = 0, liver_waits_ = 0;
  uint64_t liver_sliced_steps_ = 0;
  uint64_t liver_held_steps_ = 0;
  double liver_slice_s_ = 0.0;  // FemStepStats::slice_wait summed
  uint64_t targets_applied_ = 0;  // targets the robot carried out (a held one counted once)
  uint64_t last_applied_ = SensorFrame::kNoTarget;
  std::optional<double> puncture_time_[2];
};

}  // namespace nsim
