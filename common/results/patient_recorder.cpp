#include "common/results/patient_recorder.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <memory>
#include <sstream>

#include "common/core/error.h"
#include "common/core/statistics.h"
#include "common/results/atomic_file.h"

namespace nsim {
namespace {

using nlohmann::json;

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

// null figures when there is nothing to summarize (e.g. no loop latency in-process)
json StatsMs(const std::vector<double>& ms) {
  if (ms.empty())
    return {{"mean", nullptr}, {"median", nullptr}, {"p90", nullptr}, {"p95", nullptr},
            {"p99", nullptr},  {"max", nullptr},    {"count", 0}};
  const SampleSummary s = Summarize(ms);
  return {{"mean", s.mean}, {"median", s.median}, {"p90", s.p90}, {"p95", s.p95},
          {"p99", s.p99},   {"max", s.max},       {"count", s.count}};
}

std::unique_ptr<LineFile> Open(const std::string& path) {
  try {
    return std::make_unique<LineFile>(path, LineFile::Mode::kInPlace);
  } catch (const InputError& e) {
    throw InputError(Str("--out: ", e.what()));
  }
}

}  // namespace

PatientRecorder::PatientRecorder(const std::string& out_dir) : out_dir_(out_dir) {
  csv_ = Open(out_dir_ + "/timeseries.csv");
  csv_->WriteLine(
      "t,tip_target_distance_m,e_p_x,e_p_y,e_p_z,phase,m0_x,m0_y,m0_z,target_x,target_y,"
      "target_z,tip_x,tip_y,tip_z,robot_x,robot_y,robot_z,robot_qw,robot_qx,robot_qy,"
      "robot_qz,holding,liver_depth_m,liver_past_seed_m,liver_tip_hold");
  steps_csv_ = Open(out_dir_ + "/step_times.csv");
  steps_csv_->WriteLine("step,t,step_ms,holding,liver_pcg_iterations,liver_factor_adopted,"
                        "liver_adoption_waited");
}

void PatientRecorder::AddFrame(const PatientLoop& loop) {
  const PatientRecord& r = loop.record();
  const SensorFrame& f = loop.frame();
  last_distance_ = r.distance;
  last_e_p_ = r.e_p;
  last_phase_ = r.phase;
  min_distance_ = std::min(min_distance_, r.distance);
  distance_log_.emplace_back(r.t, r.distance);
  if (r.skin.punctured && !puncture_time_[kSkinTissue]) puncture_time_[kSkinTissue] = r.skin.puncture_time;
  if (r.liver.punctured && !puncture_time_[kLiverTissue])
    puncture_time_[kLiverTissue] = r.liver.puncture_time;
  ++frames_;
  const Eigen::Vector3d& m0 = f.p_WM.at(0);
  const Eigen::Vector3d p = f.X_WE.translation();
  const Eigen::Quaterniond q(f.X_WE.linear());
  std::ostringstream row;  // the whole row, written at once: a kill leaves no half row
  row << std::setprecision(17);
  row << r.t << ',' << r.distance << ',' << r.e_p.x() << ',' << r.e_p.y() << ',' << r.e_p.z()
      << ',' << r.phase << ',' << m0.x() << ',' << m0.y() << ',' << m0.z() << ','
      << r.target.x() << ',' << r.target.y() << ',' << r.target.z() << ',' << r.tip.x() << ','
      << r.tip.y() << ',' << r.tip.z() << ',' << p.x() << ',' << p.y() << ',' << p.z() << ','
      << q.w() << ',' << q.x() << ',' << q.y() << ',' << q.z() << ',' << (r.holding ? 1 : 0)
      << ',' << r.liver.depth << ',' << r.liver.past_seed << ',' << r.liver.tip_hold;
  csv_->WriteLine(row.str());
}

void PatientRecorder::AddStep(const PatientLoop& loop) {
  const PatientStepReport& s = loop.last_step();
  step_ms_.push_back(s.wall_ms);
  prefetch_ms_.push_back(s.prefetch_ms);
  prefetch_columns_ += s.prefetch_columns;
  if (s.holding) ++hold_steps_;
  const uint64_t applied = loop.frame().applied_seq;
  if (applied != SensorFrame::kNoTarget && applied != last_applied_) ++targets_applied_;
  last_applied_ = applied;
  if (s.scene.num_active_rib_contacts > 0) ++rib_contact_steps_;
  if (!s.scene.solve.converged) ++unconverged_solves_;
  max_rib_penetration_ = std::max(max_rib_penetration_, s.max_rib_penetration);
  min_joint_margin_ = std::min(min_joint_margin_, loop.robot().joint_limit_margin());
  std::ostringstream row;
  row << std::setprecision(17);
  const FemStepStats& liver = s.scene.liver_stats;
  liver_pcg_iterations_ += liver.cg_iterations;
  liver_refactorized_ += liver.refactorized;
  if (liver.factor_swapped) {
    ++liver_adopted_;
    liver_adoption_lag_ += liver.adoption_lag;
  }
  liver_waits_ += liver.waited_for_worker;
  liver_sliced_steps_ += liver.slice_wait > 0.0;
  liver_held_steps_ += s.scene.refresh_held;
  liver_slice_s_ += liver.slice_wait;
  row << loop.steps() << ',' << loop.time() << ',' << s.wall_ms << ',' << (s.holding ? 1 : 0)
      << ',' << liver.cg_iterations << ',' << (liver.factor_swapped ? 1 : 0) << ','
      << (liver.waited_for_worker ? 1 : 0);
  steps_csv_->WriteLine(row.str());
}

double PatientRecorder::median_step_ms() const { return Median(step_ms_); }

json PatientRecorder::Summary(const PatientLoop& loop, const PatientRunInfo& info) const {
  const PatientLoopConfig& c = loop.config();
  const PatientSceneConfig& sc = c.scene;
  json j;
  j["scenario"] = info.scenario;
  j["scenario_hash"] = info.scenario_hash;
  j["exit"] = info.exit;
  if (!info.fault.empty()) j["fault"] = info.fault;  // why the watchdog stopped the run
  j["mode"] = info.realtime ? "realtime" : "lockstep";
  j["transport"] = info.transport;
  // realtime only: the loop thread's scheduling class (run.rt_priority) and what was asked
  if (info.realtime && !info.loop_class.empty())
    j["loop_thread"] = {{"class", info.loop_class}, {"rt_priority", info.rt_priority}};
  // only in secured runs: the summary of any other run stays as it was
  if (!info.dds_identity.empty()) j["dds_security"] = {{"identity", info.dds_identity}};
  j["controller"] = c.controller;
  j["steps"] = loop.steps();
  j["time_step_s"] = sc.time_step;
  j["simulated_time_s"] = loop.time();
  j["wall_time_s"] = info.wall_time;
  j["step_time_ms"] = StatsMs(step_ms_);
  // the work between steps (PatientScene::Prefetch): its time after each step and the
  // compliance columns it solved
  j["prefetch"] = {{"time_ms", StatsMs(prefetch_ms_)}, {"columns", prefetch_columns_}};
  // the patient liver's solver: PCG iterations a step, the factor refreshes adopted from the
  // background worker (how many steps after their request, how many made their step wait), the
  // factorizations done inside a step, and the slices given to the worker on one CPU
  const double steps = std::max<double>(1.0, static_cast<double>(step_ms_.size()));
  j["liver_solver"] = {
      {"refactor_adoption",
       sc.liver.refactor_adoption == FactorAdoption::kWhenReady ? "when_ready" : "scheduled"},
      {"pcg_iterations_per_step", liver_pcg_iterations_ / steps},
      {"factors_adopted", liver_adopted_},
      {"adoptions_that_waited", liver_waits_},
      {"mean_adoption_lag_steps",
       liver_adopted_ > 0 ? json(static_cast<double>(liver_adoption_lag_) / liver_adopted_)
                          : json(nullptr)},
      {"in_step_factorizations", liver_refactorized_},
      // on one CPU (patient.liver.refactor_slice): the steps that gave the refresh the core
      {"refactor_slice_s", sc.liver.refactor_slice},
      {"sliced_steps", liver_sliced_steps_},
      {"mean_slice_ms", liver_sliced_steps_ > 0 ? json(1e3 * liver_slice_s_ / liver_sliced_steps_)
                                                : json(nullptr)},
      // on one CPU (patient.liver.refactor_hold_steps): the steps that kept the refresh waiting
      {"refactor_hold_steps", sc.liver.refactor_hold_steps},
      {"held_steps", liver_held_steps_},
      // the worker's scheduling class: idle with when_ready adoptions (realtime), normal with
      // scheduled ones (lockstep; they wait for it)
      {"refresh_worker_class", sc.liver.RefreshWorkerIdle() ? "idle" : "normal"}};
  const double rate = info.wall_time > 0 ? loop.steps() / info.wall_time : 0.0;
  const double mean_ms = Summarize(step_ms_).mean;
  j["rate_hz"] = rate;
  j["direct_rate_hz"] = rate;
  j["physics_rate_hz"] = mean_ms > 0 ? 1e3 / mean_ms : 0.0;
  json punctured = json::object();
  const char* names[] = {"skin", "liver"};
  for (int tissue : {kSkinTissue, kLiverTissue})
    punctured[names[tissue]] = {
        {"punctured", puncture_time_[tissue].has_value()},
        {"time_s", puncture_time_[tissue] ? json(*puncture_time_[tissue]) : json(nullptr)}};
  j["punctured"] = punctured;
  // thesis fig. 5.9: the final error is the mean true tip-to-target distance over the
  // steady-state window, its amplitude the peak-to-peak there
  const double t_end = distance_log_.empty() ? 0.0 : distance_log_.back().first;
  const double t_begin = t_end - kSteadyFraction * t_end;
  double sum = 0.0, lo = INFINITY, hi = -INFINITY;
  int n = 0;
  for (const auto& [t, d] : distance_log_) {
    if (t < t_begin - 1e-9) continue;
    sum += d;
    lo = std::min(lo, d);
    hi = std::max(hi, d);
    ++n;
  }
  j["final_error_mm"] = n ? json(1e3 * sum / n) : json(nullptr);
  j["final_error_amplitude_mm"] = n ? json(1e3 * (hi - lo)) : json(nullptr);
  j["steady_window_s"] = {t_begin, t_end};
  j["steady_window_samples"] = n;
  j["loop_latency_ms"] = StatsMs(info.latency_ms);
  j["final_tip_to_target_distance_mm"] = 1e3 * last_distance_;
  j["min_tip_to_target_distance_mm"] = 1e3 * min_distance_;
  j["final_e_p_m"] = Vec(last_e_p_);
  j["final_phase"] = last_phase_;
  const GateCounts& g = loop.gate().counts();
  json rejected = json::object(), clamped = json::object();
  for (int r = 0; r < kNumGateReasons; ++r) {
    const GateReason reason = static_cast<GateReason>(r);
    (r <= static_cast<int>(GateReason::kOverLimit) ? rejected : clamped)[ToString(reason)] =
        g.by_reason[r];
  }
  j["targets"] = {{"received", g.received},
                  {"accepted", g.accepted},
                  // carried out by the robot: an accepted target is not while the robot holds
                  // for a lost controller, nor when a newer one replaces it before the step
                  {"applied", targets_applied_},
                  {"rejected_total", g.rejected()},
                  {"rejected", rejected},
                  {"clamped", clamped},
                  {"transport_invalid", info.transport_invalid},
                  {"foreign", info.foreign_targets},
                  {"foreign_by_writer", info.foreign_by_writer},
                  {"hold_steps", hold_steps_},
                  {"lockstep_timeouts", info.lockstep_timeouts}};
  j["link_loss"] = {{"percent", info.link_loss_percent},
                    {"frames_lost", info.frames_lost},
                    {"targets_lost", info.targets_lost}};
  j["controller_lost"] = info.controller_lost_time.has_value();
  j["controller_losses"] = info.controller_losses;
  j["controller_returns"] = info.controller_returns;
  j["controller_lost_time_s"] =
      info.controller_lost_time ? json(*info.controller_lost_time) : json(nullptr);
  j["controller_takeovers"] = info.takeovers;
  j["controllers_refused"] = info.refused_controllers;
  json owners = json::array();
  for (const PatientRunInfo::Owner& o : info.owners)
    owners.push_back({{"participant", o.participant},
                      {"since_s", o.since},
                      {"targets_applied", o.targets_applied}});
  j["controller_owners"] = owners;
  j["max_rib_penetration_mm"] = 1e3 * max_rib_penetration_;
  // iiwa: how close any joint came to its position limit over the run (rad); null otherwise
  j["min_joint_limit_margin_rad"] =
      std::isfinite(min_joint_margin_) ? json(min_joint_margin_) : json(nullptr);
  j["rib_contact_steps"] = rib_contact_steps_;
  j["unconverged_constraint_solves"] = unconverged_solves_;
  j["frames_published"] = frames_;
  j["outputs"] = {{"timeseries", "timeseries.csv"},
                  {"step_times", "step_times.csv"},
                  {"video", info.video ? json("view.avi") : json(nullptr)},
                  {"png", info.png ? json("view.png") : json(nullptr)},
                  {"vtk_snapshots", info.vtk_snapshots}};
  const TargetGateConfig& safety = c.safety;
  j["settings"] = {{"seed", info.seed},
                   {"duration_s", info.duration},
                   {"latency_steps", info.latency_steps},
                   {"liver_mesh", info.liver_mesh},
                   {"liver_nodes", loop.scene().model().liver().get_mesh().num_nodes()},
                   {"mode", info.realtime ? "realtime" : "lockstep"},
                   {"liver_young_modulus_pa", sc.liver.young_modulus},
                   {"liver_poisson_ratio", sc.liver.poisson_ratio},
                   {"skin_young_modulus_pa", sc.skin.fem.young_modulus},
                   {"needle", sc.needle.kind == NeedleKind::kRigid ? "rigid" : "flexible"},
                   {"bevel", sc.needle.coupling.bevel.enabled},
                   {"robot", c.robot.kind == RobotKind::kCartesian ? "cartesian" : "iiwa"},
                   {"insertion_speed_m_s", c.insertion.speed},
                   {"breathing_period_s", sc.breathing.period},
                   {"breathing_si_amplitude_m", sc.breathing.si_amplitude},
                   {"tracker_marker_noise_m", c.tracker.marker_std},
                   {"entry_m", Vec(sc.entry_W)},
                   {"target_m", Vec(sc.target_W)},
                   {"safety_max_age_s", safety.max_age},
                   {"safety_hold_timeout_s", safety.hold_timeout},
                   {"safety_over_limit",
                    safety.over_limit == OverLimitAction::kClamp ? "clamp" : "reject"}};
  return j;
}

void PatientRecorder::WriteSummary(const PatientLoop& loop, const PatientRunInfo& info) const {
  // the CSVs flushed and closed, then the summary that describes them
  csv_->Commit();
  steps_csv_->Commit();
  WriteFileAtomically(out_dir_ + "/summary.json", Summary(loop, info).dump(2) + "\n");
}

}  // namespace nsim
