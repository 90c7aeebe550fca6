#include "direct_sim/run_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/core/cli.h"
#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/mesh/vtk_writer.h"
#include "common/scene/patient_scene.h"
#include "common/scene/robot_driver.h"
#include "common/scene/target_gate.h"
#include "direct_sim/scenario_loader.h"
#include "direct_sim/viewer.h"
#include "messages/transport.h"
#include "messages/transport_options.h"

namespace nsim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// longest wait for a controller's "running" status once its readers and writer are matched,
// and for its acknowledgement of frame 0 (s)
constexpr double kPeerSettle_s = 2.0;

// true when `--name` appears on the command line (to let it override the scenario)
bool GivenOnCommandLine(int argc, char** argv, const std::string& name) {
  const std::string flag = "--" + name;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == flag || arg.rfind(flag + "=", 0) == 0) return true;
  }
  return false;
}

std::string DefaultOutDir() {
  const std::time_t now = std::time(nullptr);
  char text[64];
  std::strftime(text, sizeof(text), "results/direct_%Y%m%d_%H%M%S", std::localtime(&now));
  return text;
}

uint8_t PhaseOf(const PatientScene& scene) {
  if (scene.GetTissueStatus(kLiverTissue).punctured) return 2;
  if (scene.GetTissueStatus(kSkinTissue).punctured) return 1;
  return 0;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

// the whole run: scenario, scene, robot, gate, transport and outputs
class DirectRun {
 public:
  DirectRun(DirectScenario scenario, const transport::TransportConfig& transport,
            std::string out_dir, bool controller, bool quiet)
      : s_(std::move(scenario)),
        out_dir_(std::move(out_dir)),
        controller_(controller),
        quiet_(quiet),
        gate_(s_.safety) {
    const double h = s_.scene.time_step;
    steps_ = static_cast<int64_t>(std::llround(s_.run.duration / h));
    if (steps_ < 1) throw InputError(Str("run.duration must cover at least one step of ", h, " s"));
    const RigidNeedleModel needle(s_.scene.needle.geometry());
    plan_ = MakeInsertionPlan(s_.scene.entry_W, s_.scene.target_W, needle,
                              s_.insertion.approach_distance);
    robot_ = std::make_unique<RobotDriver>(s_.robot, plan_.CalcFlangePose(0.0));
    scene_ = std::make_unique<PatientScene>(s_.scene, s_.liver_mesh, s_.skin_mesh, robot_->X_WE());

    fs::create_directories(out_dir_);
    if (s_.run.vtk_every > 0) fs::create_directories(out_dir_ + "/vtk");
    csv_.open(out_dir_ + "/timeseries.csv");
    if (!csv_) throw InputError(Str("--out: cannot write ", out_dir_, "/timeseries.csv"));
    csv_ << "t,tip_target_distance_m,e_p_x,e_p_y,e_p_z,phase,m0_x,m0_y,m0_z,target_x,target_y,"
            "target_z,tip_x,tip_y,tip_z,robot_x,robot_y,robot_z,robot_qw,robot_qx,robot_qy,"
            "robot_qz,holding,step_time_ms\n";
    csv_.precision(9);
    if (s_.run.video) {
      renderer_ = std::make_unique<SceneRenderer>(s_.view);
      viewer_ = std::make_unique<SceneViewer>(s_.view, out_dir_ + "/view.avi");
    }

    participant_ = std::make_unique<transport::Participant>(transport);
    // lockstep: every frame is kept until acknowledged (frame k + 1 is written before frame k
    // is acknowledged, and with keep-last 1 a frame lost on the wire could not be resent: the
    // loop would wait for it until lockstep_timeout); realtime: only the newest state matters
    const transport::Qos state_qos = s_.run.mode == RunMode::kLockstep
                                         ? transport::Qos::kLossless
                                         : transport::Qos::kStateStream;
    markers_ = std::make_unique<transport::Writer<MarkerFrame>>(*participant_, state_qos);
    robot_state_ = std::make_unique<transport::Writer<RobotState>>(*participant_, state_qos);
    entry_ = std::make_unique<transport::Writer<EntryPoint>>(*participant_, state_qos);
    status_writer_ =
        std::make_unique<transport::Writer<SimStatus>>(*participant_, transport::Qos::kStatus);
    // lockstep: every answer is kept until taken (with latency_steps >= 2 the controller may
    // answer frame k - 1 before this process took the answer to k - 2; a keep-last-1 reader
    // would drop it and the run would depend on timing)
    if (controller_) {
      targets_ = std::make_unique<transport::Reader<RobotTarget>>(
          *participant_,
          s_.run.mode == RunMode::kLockstep ? transport::Qos::kLossless : transport::Qos::kTarget);
      peer_status_ =
          std::make_unique<transport::Reader<SimStatus>>(*participant_, transport::Qos::kStatus);
    }
    status_.sender = "direct_sim";
  }

  int Run() {
    PublishStatus(RunState::kStarting,
                  controller_ ? "waiting for the controller" : "no controller");
    if (controller_ && !WaitForController()) {
      PublishStatus(RunState::kFailed, "no controller");
      std::cerr << "direct_sim run: no controller (MarkerFrame reader) after "
                << s_.run.start_timeout
                << " s (is inverse_sim running with the same --domain, --partition and DDS "
                   "config? use --no-controller to run the scene alone)\n";
      exit_reason_ = "no_controller";
      WriteSummary(0.0);
      return 1;
    }
    PublishStatus(RunState::kRunning, "running");
    const double h = s_.scene.time_step;
    const double wall_start = MonotonicSeconds();
    double next_status = wall_start + s_.run.status_period, next_progress = wall_start + 1.0;
    int64_t k = 0;
    for (; k < steps_; ++k) {
      if (InterruptRequested()) {
        exit_reason_ = "interrupted";
        break;
      }
      const double t = scene_->time();
      if (!PublishFrame(k, t)) {
        exit_reason_ = "diverged";
        break;
      }
      // the controller has frame 0 before frame 1 can replace it in the writers' history
      if (k == 0 && controller_) {
        markers_->WaitForAcks(kPeerSettle_s);
        robot_state_->WaitForAcks(kPeerSettle_s);
        entry_->WaitForAcks(kPeerSettle_s);
      }
      const double step_start = MonotonicSeconds();
      const bool holding = CommandRobot(k, t, h);
      const SceneStepReport report = scene_->Step(robot_->X_WE(), bevel_angle_);
      last_step_ms_ = 1e3 * (MonotonicSeconds() - step_start);
      step_ms_.push_back(last_step_ms_);
      holding_ = holding;
      if (report.num_active_rib_contacts > 0) ++rib_contact_steps_;
      max_rib_penetration_ = std::max(max_rib_penetration_, scene_->CalcMaxRibPenetration());
      if (!report.solve.converged) ++unconverged_solves_;
      NotePunctures();
      if (s_.run.vtk_every > 0 && (k + 1) % s_.run.vtk_every == 0) WriteVtk(k + 1);
      if (viewer_ && (k + 1) % s_.run.view_every == 0) Render();

      const double now = MonotonicSeconds();
      if (now >= next_status) {
        PublishStatus(RunState::kRunning, message_);
        next_status = now + s_.run.status_period;
      }
      if (!quiet_ && now >= next_progress) {
        std::printf(
            "run: t = %6.2f s, step %lld/%lld, %.1f ms/step, phase %d, tip-target %.2f mm%s\n",
            scene_->time(), static_cast<long long>(k + 1), static_cast<long long>(steps_),
            last_step_ms_, PhaseOf(*scene_), 1e3 * last_distance_, holding ? ", holding" : "");
        std::fflush(stdout);
        next_progress = now + 1.0;
      }
      if (s_.run.mode == RunMode::kRealtime) SleepUntilMonotonic(wall_start + (k + 1) * h);
    }
    steps_done_ = k;
    if (exit_reason_.empty()) {
      PublishFrame(k, scene_->time());  // the final state
      exit_reason_ = controller_lost_ ? "controller_lost" : "completed";
    }
    const double wall = MonotonicSeconds() - wall_start;
    const bool ok = exit_reason_ == "completed";
    PublishStatus(ok ? RunState::kFinished : RunState::kFailed, ok ? "finished" : exit_reason_);
    markers_->WaitForAcks(2.0);
    status_writer_->WaitForAcks(2.0);
    if (viewer_) viewer_->Finish(out_dir_ + "/view.png");
    WriteSummary(wall);
    std::printf(
        "run: %s after %lld steps (%.2f s simulated, %.2f s wall), median step %.2f ms, "
        "final tip-target %.2f mm, skin %s, liver %s\n",
        exit_reason_.c_str(), static_cast<long long>(steps_done_), scene_->time(), wall,
        Median(step_ms_), 1e3 * last_distance_,
        scene_->GetTissueStatus(kSkinTissue).punctured ? "punctured" : "intact",
        scene_->GetTissueStatus(kLiverTissue).punctured ? "punctured" : "intact");
    return ok ? 0 : 1;
  }

 private:
  // Waits until the controller reads our frames and we its targets, then for its "running"
  // status: its readers know our writers, so frame 0 is not dropped (a run whose controller
  // missed frame 0 would differ from the same run that did not). A controller that never says
  // so (not inverse_sim) gets kPeerSettle_s.
  bool WaitForController() {
    const double end = MonotonicSeconds() + s_.run.start_timeout;
    if (!markers_->WaitForReaders(1, s_.run.start_timeout)) return false;
    bool matched = false;
    while (!matched && MonotonicSeconds() < end && !InterruptRequested()) {
      matched = targets_->health().writers_matched > 0;
      if (!matched) targets_->Wait(0.05);
    }
    if (!matched) return false;
    if (!transport::WaitForPeerRunning(*peer_status_, "direct_sim", kPeerSettle_s)) {
      if (!quiet_)
        std::printf("run: the controller sent no running status; starting after %.1f s\n",
                    kPeerSettle_s);
      return true;
    }
    // inverse_sim reads the robot state and entry point too: our writers must know its readers
    robot_state_->WaitForReaders(1, kPeerSettle_s);
    entry_->WaitForReaders(1, kPeerSettle_s);
    return true;
  }

  void PublishStatus(RunState state, const std::string& message) {
    status_.state = state;
    status_.message = message.substr(0, 255);
    status_.stamp.sim_time = scene_->time();
    status_.phase = PhaseOf(*scene_);
    status_.frames_sent = frames_sent_;
    status_.last_seq = frames_sent_ > 0 ? frames_sent_ - 1 : 0;
    status_.rate_hz = step_ms_.empty() ? 0.0 : 1e3 / std::max(1e-6, Median(step_ms_));
    status_writer_->Write(status_);
    status_.stamp.seq++;
  }

  // publishes frame k (markers, robot, entry) of the state at time t and logs it; false when
  // the state is not finite (diverged)
  bool PublishFrame(int64_t k, double t) {
    scene_->CalcMarkerPositions(&marker_frame_.p_WM);
    const Eigen::Vector3d tip = scene_->CalcTipPosition(), target = scene_->CalcTargetPosition();
    bool finite = tip.allFinite() && target.allFinite();
    for (const auto& p : marker_frame_.p_WM) finite = finite && p.allFinite();
    if (!finite) {
      std::cerr << "direct_sim run: the simulation diverged at t = " << t << " s\n";
      message_ = "diverged";
      return false;
    }
    const uint64_t seq = static_cast<uint64_t>(k);
    marker_frame_.stamp.seq = seq;
    marker_frame_.stamp.sim_time = t;
    markers_->Write(marker_frame_);
    if (sent_at_.size() <= seq) sent_at_.resize(seq + 1, 0.0);
    sent_at_[seq] = MonotonicSeconds();
    RobotState rs;
    rs.stamp = marker_frame_.stamp;
    rs.X_WE = robot_->X_WE();
    rs.q = robot_->q();
    rs.bevel_angle = bevel_angle_;
    robot_state_->Write(rs);
    EntryPoint ep;
    ep.stamp = marker_frame_.stamp;
    ep.punctured = scene_->CalcEntryPoint(&ep.p_WP, &ep.n_W);
    entry_->Write(ep);
    gate_.NotePublishedFrame(seq, t);
    frames_sent_ = seq + 1;

    const Eigen::Vector3d e_p = target - tip;  // thesis eq. 3.3
    last_distance_ = e_p.norm();
    last_e_p_ = e_p;
    min_distance_ = std::min(min_distance_, last_distance_);
    const Eigen::Isometry3d& X = rs.X_WE;
    const Eigen::Quaterniond q(X.linear());
    const Eigen::Vector3d& m0 = marker_frame_.p_WM[0];
    distance_log_.emplace_back(t, last_distance_);
    csv_ << t << ',' << last_distance_ << ',' << e_p.x() << ',' << e_p.y() << ',' << e_p.z() << ','
         << int(PhaseOf(*scene_)) << ',' << m0.x() << ',' << m0.y() << ',' << m0.z() << ','
         << target.x() << ',' << target.y() << ',' << target.z() << ',' << tip.x() << ',' << tip.y()
         << ',' << tip.z() << ',' << X.translation().x() << ',' << X.translation().y() << ','
         << X.translation().z() << ',' << q.w() << ',' << q.x() << ',' << q.y() << ',' << q.z()
         << ',' << (holding_ ? 1 : 0) << ',' << last_step_ms_ << '\n';
    return true;
  }

  // the inverse_sim's liveliness on the target reader; reports a loss once
  void CheckController(double t) {
    if (!targets_ || controller_lost_) return;
    const transport::ReaderHealth health = targets_->health();
    if (health.writers_alive > 0) seen_alive_ = true;
    if (health.liveliness_lost > 0 || (seen_alive_ && health.writers_alive == 0)) {
      controller_lost_ = true;
      controller_lost_time_ = t;
      message_ = health.liveliness_lost > 0
                     ? "inverse_sim lost (liveliness lease expired); robot holds"
                     : "inverse_sim left; robot holds";
      std::cerr << "direct_sim run: " << message_ << " at t = " << t << " s\n";
      PublishStatus(RunState::kRunning, message_);
    }
  }

  // loop latency: wall time from sending frame answers_seq to receiving its target
  void NoteLatency(const RobotTarget& target) {
    if (target.answers_seq < sent_at_.size() && sent_at_[target.answers_seq] > 0)
      latency_ms_.push_back(1e3 * (MonotonicSeconds() - sent_at_[target.answers_seq]));
  }

  void Gate(const RobotTarget& target, double t) {
    const GateDecision d = gate_.Check(target, t, robot_->X_WE(), robot_->q());
    if (d.accepted) {
      command_ = d.target;
      bevel_angle_ = d.target.bevel_angle;
    }
    if (d.reason != GateReason::kCount) message_ = d.detail;
  }

  // lockstep: waits (bounded) until a target answering frame k - d or newer arrived, then
  // gates the newest one answering at most k - d
  void ReceiveLockstep(int64_t k, double t) {
    const int64_t need = k - s_.run.latency_steps;
    auto take = [&] {
      received_.clear();
      targets_->Take(received_);
      for (const RobotTarget& r : received_) {
        NoteLatency(r);
        pending_[r.answers_seq] = r;
      }
    };
    take();
    if (need < 0) return;
    const uint64_t needed = static_cast<uint64_t>(need);
    auto have = [&] { return !pending_.empty() && pending_.rbegin()->first >= needed; };
    const double end = MonotonicSeconds() + s_.run.lockstep_timeout;
    while (!have() && !controller_lost_ && !InterruptRequested() && MonotonicSeconds() < end) {
      targets_->Wait(std::min(0.05, std::max(1e-3, end - MonotonicSeconds())));
      take();
      CheckController(t);
    }
    if (!have()) {
      ++lockstep_timeouts_;
      return;
    }
    // the newest target answering at most k - d (a faster answer than d steps is used as is)
    auto it = pending_.upper_bound(needed);
    if (it != pending_.begin()) --it;
    Gate(it->second, t);
    pending_.erase(pending_.begin(), std::next(it));
  }

  // applies a command for the step from t to t + h; returns true when the robot held still
  bool CommandRobot(int64_t k, double t, double h) {
    if (!controller_) {
      const double s =
          std::min(s_.insertion.speed * (t + h), plan_.total_travel() + s_.insertion.overshoot);
      robot_->StepToPose(plan_.CalcFlangePose(s), h);
      return false;
    }
    CheckController(t);
    if (s_.run.mode == RunMode::kLockstep) {
      ReceiveLockstep(k, t);
    } else {
      received_.clear();
      targets_->Take(received_);
      for (const RobotTarget& r : received_) {
        NoteLatency(r);
        Gate(r, t);
      }
    }
    if (controller_lost_ || !command_ || gate_.ShouldHold(t)) {
      robot_->Hold(h);
      ++hold_steps_;
      return true;
    }
    if (command_->mode == TargetMode::kJoint) {
      robot_->StepToJoints(command_->q, h);
    } else {
      robot_->StepToPose(command_->X_WE, h);
    }
    return false;
  }

  void NotePunctures() {
    for (int tissue : {kSkinTissue, kLiverTissue}) {
      const TissueStatus st = scene_->GetTissueStatus(tissue);
      if (st.punctured && !puncture_time_[tissue]) puncture_time_[tissue] = st.puncture_time;
    }
  }

  void WriteVtk(int64_t step) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06lld", static_cast<long long>(step));
    const std::string dir = out_dir_ + "/vtk/";
    const PatientSceneState& st = scene_->state();
    WriteVtkTetMesh(dir + "liver_" + name + ".vtk", scene_->model().liver().get_mesh(), st.liver.x);
    WriteVtkTetMesh(dir + "skin_" + name + ".vtk", scene_->model().skin().get_mesh(), st.skin.x);
    WriteVtkPolyline(dir + "needle_" + name + ".vtk", scene_->CalcNeedlePolyline());
    ++vtk_written_;
  }

  void Render() {
    static const char* kPhase[] = {"outside", "in skin", "in liver"};
    char caption[160];
    std::snprintf(caption, sizeof(caption), "t = %.2f s   phase: %s   tip-target %.1f mm%s",
                  scene_->time(), kPhase[PhaseOf(*scene_)], 1e3 * last_distance_,
                  holding_ ? "   HOLD" : "");
    viewer_->Add(renderer_->Render(*scene_, caption));
  }

  void WriteSummary(double wall) {
    json j;
    j["scenario"] = s_.source;
    j["exit"] = exit_reason_;
    j["mode"] = s_.run.mode == RunMode::kRealtime ? "realtime" : "lockstep";
    j["controller"] = controller_;
    j["steps"] = steps_done_;
    j["time_step_s"] = s_.scene.time_step;
    j["simulated_time_s"] = scene_->time();
    j["wall_time_s"] = wall;
    double mean = 0;
    for (double v : step_ms_) mean += v;
    mean = step_ms_.empty() ? 0.0 : mean / step_ms_.size();
    j["step_time_ms"] = {
        {"mean", mean},
        {"median", Median(step_ms_)},
        {"p95", Percentile(step_ms_, 0.95)},
        {"max", step_ms_.empty() ? 0.0 : *std::max_element(step_ms_.begin(), step_ms_.end())}};
    j["rate_hz"] = wall > 0 ? steps_done_ / wall : 0.0;
    j["physics_rate_hz"] = mean > 0 ? 1e3 / mean : 0.0;
    json punctured = json::object();
    const char* names[] = {"skin", "liver"};
    for (int tissue : {kSkinTissue, kLiverTissue}) {
      json p;
      p["punctured"] = puncture_time_[tissue].has_value();
      p["time_s"] = puncture_time_[tissue] ? json(*puncture_time_[tissue]) : json(nullptr);
      punctured[names[tissue]] = p;
    }
    j["punctured"] = punctured;
    // thesis fig. 5.9: the final error is the mean true tip-to-target distance over the
    // steady-state window, its amplitude the peak-to-peak there; the window is the last
    // steady_fraction of the simulated time
    {
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
    }
    j["direct_rate_hz"] = wall > 0 ? steps_done_ / wall : 0.0;
    double latency_mean = 0.0, latency_max = 0.0;
    for (double v : latency_ms_) {
      latency_mean += v;
      latency_max = std::max(latency_max, v);
    }
    if (!latency_ms_.empty()) latency_mean /= latency_ms_.size();
    j["loop_latency_ms"] = {{"mean", latency_mean},
                            {"median", Median(latency_ms_)},
                            {"p95", Percentile(latency_ms_, 0.95)},
                            {"max", latency_max},
                            {"count", latency_ms_.size()}};
    j["final_tip_to_target_distance_mm"] = 1e3 * last_distance_;
    j["min_tip_to_target_distance_mm"] = 1e3 * min_distance_;
    j["final_e_p_m"] = Vec(last_e_p_);
    j["final_phase"] = PhaseOf(*scene_);
    const GateCounts& c = gate_.counts();
    json rejected = json::object(), clamped = json::object();
    for (int r = 0; r < kNumGateReasons; ++r) {
      const GateReason reason = static_cast<GateReason>(r);
      (r <= static_cast<int>(GateReason::kOverLimit) ? rejected : clamped)[ToString(reason)] =
          c.by_reason[r];
    }
    j["targets"] = {{"received", c.received},
                    {"accepted", c.accepted},
                    {"rejected_total", c.rejected()},
                    {"rejected", rejected},
                    {"clamped", clamped},
                    {"transport_invalid", targets_ ? targets_->health().invalid : 0},
                    {"hold_steps", hold_steps_},
                    {"lockstep_timeouts", lockstep_timeouts_}};
    j["controller_lost"] = controller_lost_;
    j["controller_lost_time_s"] = controller_lost_ ? json(controller_lost_time_) : json(nullptr);
    j["max_rib_penetration_mm"] = 1e3 * max_rib_penetration_;
    j["rib_contact_steps"] = rib_contact_steps_;
    j["unconverged_constraint_solves"] = unconverged_solves_;
    j["frames_published"] = frames_sent_;
    j["outputs"] = {
        {"timeseries", "timeseries.csv"},
        {"video", viewer_ && !viewer_->video_path().empty() ? json("view.avi") : json(nullptr)},
        {"png", viewer_ && viewer_->frames() > 0 ? json("view.png") : json(nullptr)},
        {"vtk_snapshots", vtk_written_}};
    const PatientSceneConfig& sc = s_.scene;
    j["settings"] = {{"seed", s_.random_seed},
                     {"duration_s", s_.run.duration},
                     {"latency_steps", s_.run.latency_steps},
                     {"liver_mesh", s_.liver_mesh_path},
                     {"liver_nodes", s_.liver_mesh.num_nodes()},
                     {"mode", s_.run.mode == RunMode::kRealtime ? "realtime" : "lockstep"},
                     {"liver_young_modulus_pa", sc.liver.young_modulus},
                     {"liver_poisson_ratio", sc.liver.poisson_ratio},
                     {"skin_young_modulus_pa", sc.skin.fem.young_modulus},
                     {"needle", sc.needle.kind == NeedleKind::kRigid ? "rigid" : "flexible"},
                     {"bevel", sc.needle.coupling.bevel.enabled},
                     {"robot", s_.robot.kind == RobotKind::kCartesian ? "cartesian" : "iiwa"},
                     {"insertion_speed_m_s", s_.insertion.speed},
                     {"breathing_period_s", sc.breathing.period},
                     {"breathing_si_amplitude_m", sc.breathing.si_amplitude},
                     {"entry_m", Vec(sc.entry_W)},
                     {"target_m", Vec(sc.target_W)},
                     {"safety_max_age_s", s_.safety.max_age},
                     {"safety_hold_timeout_s", s_.safety.hold_timeout},
                     {"safety_over_limit",
                      s_.safety.over_limit == OverLimitAction::kClamp ? "clamp" : "reject"}};
    std::ofstream out(out_dir_ + "/summary.json");
    out << j.dump(2) << '\n';
  }

  DirectScenario s_;
  std::string out_dir_;
  bool controller_, quiet_;
  TargetGate gate_;
  InsertionPlan plan_;
  std::unique_ptr<RobotDriver> robot_;
  std::unique_ptr<PatientScene> scene_;
  std::unique_ptr<SceneRenderer> renderer_;
  std::unique_ptr<SceneViewer> viewer_;
  std::unique_ptr<transport::Participant> participant_;
  std::unique_ptr<transport::Writer<MarkerFrame>> markers_;
  std::unique_ptr<transport::Writer<RobotState>> robot_state_;
  std::unique_ptr<transport::Writer<EntryPoint>> entry_;
  std::unique_ptr<transport::Writer<SimStatus>> status_writer_;
  std::unique_ptr<transport::Reader<RobotTarget>> targets_;
  std::unique_ptr<transport::Reader<SimStatus>> peer_status_;  // the controller's status
  std::ofstream csv_;

  int64_t steps_ = 0, steps_done_ = 0;
  SimStatus status_;
  MarkerFrame marker_frame_;
  uint64_t frames_sent_ = 0;
  std::vector<RobotTarget> received_;
  std::map<uint64_t, RobotTarget> pending_;
  std::optional<RobotTarget> command_;
  double bevel_angle_ = 0.0;
  bool holding_ = false, controller_lost_ = false, seen_alive_ = false;
  double controller_lost_time_ = 0.0;
  uint64_t hold_steps_ = 0, lockstep_timeouts_ = 0, rib_contact_steps_ = 0, unconverged_solves_ = 0;
  int vtk_written_ = 0;
  std::vector<double> step_ms_;
  std::vector<double> sent_at_;     // monotonic time each frame was published (s), by seq
  std::vector<double> latency_ms_;  // frame sent -> answering target received (ms)
  std::vector<std::pair<double, double>> distance_log_;  // (t, true tip-target distance (m))
  static constexpr double kSteadyFraction = 0.2;
  double last_step_ms_ = 0.0, last_distance_ = 0.0, min_distance_ = INFINITY;
  Eigen::Vector3d last_e_p_ = Eigen::Vector3d::Zero();
  double max_rib_penetration_ = 0.0;
  std::optional<double> puncture_time_[2];
  std::string message_, exit_reason_;
};

}  // namespace

int RunDirect(int argc, char** argv) {
  CommandLine cli("direct_sim run --config S.yaml [options]",
                  "Simulate the patient (liver, skin, ribs, breathing) and the robot holding the "
                  "needle; publish markers, robot state and entry point; apply robot targets.");
  cli.Option("config", "S.yaml", "scenario file", "", true)
      .Option("out", "DIR", "output folder (default results/direct_<date>_<time>)")
      .Option("duration", "S", "simulated time (s), overrides run.duration")
      .Option("mode", "MODE", "realtime or lockstep, overrides run.mode")
      .Option("latency-steps", "N", "lockstep latency in steps, overrides run.latency_steps")
      .Option("vtk-every", "N", "VTK snapshots every N steps, overrides run.vtk_every")
      .Option("seed", "N", "random seed (breathing), overrides random_seed")
      .Option("young-modulus", "PA",
              "Young's modulus of the patient's liver (Pa), overrides patient.liver.young_modulus")
      .Flag("no-controller", "insert along the planned path at insertion.speed, no controller")
      .Flag("no-video", "no view (no window, no video, no PNG)")
      .Flag("quiet", "no progress lines");
  transport::AddTransportOptions(cli);
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  DirectScenario scenario = LoadDirectScenario(cli.GetString("config"));
  if (cli.Has("duration")) scenario.run.duration = cli.GetDouble("duration");
  if (cli.Has("mode")) {
    const std::string mode = cli.GetString("mode");
    if (mode != "realtime" && mode != "lockstep")
      throw InputError(Str("--mode: expected realtime or lockstep, got '", mode, "'"));
    scenario.run.mode = mode == "realtime" ? RunMode::kRealtime : RunMode::kLockstep;
  }
  if (cli.Has("latency-steps"))
    scenario.run.latency_steps = static_cast<int>(cli.GetInt("latency-steps"));
  if (cli.Has("vtk-every")) scenario.run.vtk_every = static_cast<int>(cli.GetInt("vtk-every"));
  if (cli.Has("seed")) {
    const long seed = cli.GetInt("seed");
    if (seed < 0) throw InputError(Str("--seed must be >= 0, got ", seed));
    scenario.random_seed = static_cast<uint64_t>(seed);
    scenario.scene.breathing.random_seed = scenario.random_seed;
  }
  if (cli.Has("young-modulus")) {
    const double e = cli.GetDouble("young-modulus");
    if (!(e > 0) || !std::isfinite(e))
      throw InputError(Str("--young-modulus must be > 0 (Pa), got ", e));
    scenario.scene.liver.young_modulus = e;
  }
  if (cli.GetFlag("no-video")) scenario.run.video = false;
  ValidateAs([&] { scenario.run.Validate(); }, "command line", "run.", "run.");

  transport::TransportConfig tc = transport::TransportFromCli(cli);
  if (!GivenOnCommandLine(argc, argv, "domain")) tc.domain_id = scenario.dds_domain;
  if (!GivenOnCommandLine(argc, argv, "partition")) tc.partition = scenario.dds_partition;
  tc.Validate();
  const std::string out_dir = cli.Has("out") ? cli.GetString("out") : DefaultOutDir();
  InstallInterruptHandler();
  DirectRun run(std::move(scenario), tc, out_dir, !cli.GetFlag("no-controller"),
                cli.GetFlag("quiet"));
  return run.Run();
}

}  // namespace nsim
