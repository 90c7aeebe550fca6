#include "inverse_sim/run_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "common/core/cli.h"
#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/core/sequence_tracker.h"
#include "common/core/yaml_reader.h"
#include "common/mesh/gmsh_reader.h"
#include "common/prediction/horizon_estimator.h"
#include "common/prediction/marker_predictor.h"
#include "common/steering/steering_controller.h"
#include "inverse_sim/scenario_loader.h"
#include "messages/transport.h"
#include "messages/transport_options.h"

namespace nsim {
namespace {

// running mean / max of a duration (s)
struct TimingStat {
  double sum = 0.0, max = 0.0;
  uint64_t count = 0;
  void Add(double t) {
    sum += t;
    max = std::max(max, t);
    ++count;
  }
  nlohmann::json Json() const {
    return {{"mean_ms", count ? 1e3 * sum / count : 0.0}, {"max_ms", 1e3 * max}, {"count", count}};
  }
};

// true when `--name` appears on the command line (to let it override the scenario)
bool GivenOnCommandLine(int argc, char** argv, const std::string& name) {
  const std::string flag = "--" + name;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == flag || arg.rfind(flag + "=", 0) == 0) return true;
  }
  return false;
}

// Prediction quality (thesis §4.1.7): each prediction made at t for t + h is compared with the
// measured stream at t + h, linearly interpolated between the two frames around it; the
// baseline is not predicting (the markers measured at t). nRMS = 100 RMS(pred) / RMS(baseline).
class PredictionScore {
 public:
  void AddPrediction(double t_for, std::vector<Eigen::Vector3d> predicted,
                     std::vector<Eigen::Vector3d> measured_now) {
    pending_.push_back({t_for, std::move(predicted), std::move(measured_now)});
  }
  // a measured frame (strictly increasing times); scores the predictions it brackets
  void AddMeasurement(double t, const std::vector<Eigen::Vector3d>& p) {
    if (pred_sq_.size() != p.size()) {
      pred_sq_.assign(p.size(), 0.0);
      base_sq_.assign(p.size(), 0.0);
      pred_sum_.assign(p.size(), Eigen::Vector3d::Zero());
    }
    while (!pending_.empty() && pending_.front().t_for <= t + 1e-9) {
      const Pending& e = pending_.front();
      if (has_last_ && e.t_for >= last_t_ - 1e-9 && e.predicted.size() == p.size()) {
        const double span = t - last_t_;
        const double a = span > 0 ? std::clamp((e.t_for - last_t_) / span, 0.0, 1.0) : 1.0;
        for (size_t m = 0; m < p.size(); ++m) {
          const Eigen::Vector3d truth = (1.0 - a) * last_p_[m] + a * p[m];
          pred_sq_[m] += (e.predicted[m] - truth).squaredNorm();
          pred_sum_[m] += e.predicted[m] - truth;
          base_sq_[m] += (e.measured[m] - truth).squaredNorm();
        }
        ++scored_;
      }
      pending_.pop_front();
    }
    last_t_ = t;
    last_p_ = p;
    has_last_ = true;
  }
  nlohmann::json NrmsPercent() const {
    nlohmann::json out = nlohmann::json::array();
    for (size_t m = 0; m < pred_sq_.size(); ++m)
      out.push_back(base_sq_[m] > 0 ? nlohmann::json(100.0 * std::sqrt(pred_sq_[m] / base_sq_[m]))
                                    : nlohmann::json(nullptr));
    return out;
  }
  nlohmann::json RmsMm() const {
    nlohmann::json out = nlohmann::json::array();
    for (size_t m = 0; m < pred_sq_.size(); ++m)
      out.push_back(scored_ ? 1e3 * std::sqrt(pred_sq_[m] / scored_) : 0.0);
    return out;
  }
  // mean prediction error per marker, world axes (mm): a biased predictor shifts the mean
  nlohmann::json BiasMm() const {
    nlohmann::json out = nlohmann::json::array();
    for (const Eigen::Vector3d& sum : pred_sum_) {
      const Eigen::Vector3d mean =
          scored_ ? Eigen::Vector3d(1e3 * sum / scored_) : Eigen::Vector3d::Zero();
      out.push_back({mean.x(), mean.y(), mean.z()});
    }
    return out;
  }
  uint64_t scored() const { return scored_; }

 private:
  struct Pending {
    double t_for;
    std::vector<Eigen::Vector3d> predicted, measured;
  };
  std::deque<Pending> pending_;
  std::vector<double> pred_sq_, base_sq_;
  std::vector<Eigen::Vector3d> pred_sum_;
  double last_t_ = 0.0;
  std::vector<Eigen::Vector3d> last_p_;
  bool has_last_ = false;
  uint64_t scored_ = 0;
};

}  // namespace

int RunInverseSim(int argc, char** argv) {
  CommandLine cli("inverse_sim run --config S.yaml [options]",
                  "The controller: registration, prediction, Jacobian and control law.");
  cli.Option("config", "S.yaml", "scenario file (inverse:, controller:, prediction: sections)", "",
             true)
      .Option("out", "DIR", "results folder (summary.json, inverse.csv)", "results/inverse")
      .Option("prediction", "on|off", "register to predicted markers (default: the scenario's)")
      .Option("dof", "cartesian6|joint7", "Jacobian DoF (default: the scenario's)")
      .Option("young-modulus-factor", "X", "factor on the model's Young's modulus")
      .Option("localization-delay", "S",
              "added to the predicted loop period to form the horizon (s), overrides "
              "prediction.localization_delay")
      .Option("mode", "realtime|lockstep",
              "lockstep: answer every frame in order (reproducible); realtime: answer the newest "
              "frame only (default: the scenario's run.mode)")
      .Option("timeout", "S", "give up after S seconds in all", "3600")
      .Option("start-timeout", "S", "give up if direct_sim is not seen within S seconds", "60")
      .Flag("quiet", "no progress lines");
  transport::AddTransportOptions(cli);
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  InverseScenario scenario = LoadInverseScenario(cli.GetString("config"));
  if (cli.Has("prediction")) {
    const std::string v = cli.GetString("prediction");
    if (v != "on" && v != "off")
      throw InputError(Str("--prediction must be on or off, got '", v, "'"));
    scenario.prediction_enabled = v == "on";
  }
  if (cli.Has("dof")) scenario.control.dof = ParseSteeringDof(cli.GetString("dof"), "--dof");
  if (cli.Has("young-modulus-factor")) {
    scenario.model.young_modulus_factor = cli.GetDouble("young-modulus-factor");
    ValidateAs([&] { scenario.model.Validate(); }, "--young-modulus-factor", "inverse.", "");
  }
  if (cli.Has("localization-delay")) {
    scenario.horizon.localization_delay = cli.GetDouble("localization-delay");
    ValidateAs([&] { scenario.horizon.Validate(); }, "--localization-delay", "horizon.", "");
    ResolveSearchLead(&scenario);
    ValidateAs([&] { scenario.prediction.Validate(); }, "--localization-delay", "prediction.", "");
  }
  if (cli.Has("mode")) {
    const std::string v = cli.GetString("mode");
    if (v != "realtime" && v != "lockstep")
      throw InputError(Str("--mode must be realtime or lockstep, got '", v, "'"));
    scenario.lockstep = v == "lockstep";
  }
  const double timeout = cli.GetDouble("timeout"), start_timeout = cli.GetDouble("start-timeout");
  if (!(timeout > 0) || !(start_timeout > 0))
    throw InputError("--timeout and --start-timeout must be > 0 (s)");
  const bool quiet = cli.GetFlag("quiet");
  const std::filesystem::path out_dir = cli.GetString("out");
  std::filesystem::create_directories(out_dir);
  std::ofstream csv(out_dir / "inverse.csv");
  if (!csv) throw InputError(Str((out_dir / "inverse.csv").string(), ": cannot open for writing"));
  csv << "answers_seq,sim_time,phase,path_index,valid,e_p_norm,horizon,predicted,model_tip_x,"
         "model_tip_y,model_tip_z,step_ms,jacobian_ms,total_ms\n";
  csv.precision(9);
  const TetMesh mesh = ReadGmshMesh(scenario.mesh_path);

  transport::TransportConfig tc = transport::TransportFromCli(cli);
  if (!GivenOnCommandLine(argc, argv, "domain")) tc.domain_id = scenario.dds_domain;
  if (!GivenOnCommandLine(argc, argv, "partition")) tc.partition = scenario.dds_partition;
  tc.Validate();
  InstallInterruptHandler();
  transport::Participant participant(tc);
  // every frame and robot state is received (lossless readers against the keep-last-1 state
  // writers): the predictor needs the whole marker stream, and each answered frame is paired
  // with the robot state of the same sequence number
  transport::Reader<MarkerFrame> marker_reader(participant, transport::Qos::kLossless);
  transport::Reader<RobotState> robot_reader(participant, transport::Qos::kLossless);
  transport::Reader<EntryPoint> entry_reader(participant, transport::Qos::kLossless);
  transport::Reader<SimStatus> status_reader(participant, transport::Qos::kStatus);
  // lockstep: every answer is delivered (a deep writer history, so an answer not yet
  // acknowledged is not replaced by the next one)
  transport::Writer<RobotTarget> target_writer(
      participant, scenario.lockstep ? transport::Qos::kLossless : transport::Qos::kTarget);
  transport::Writer<SimStatus> status_writer(participant, transport::Qos::kStatus);

  SimStatus own;
  own.sender = "inverse_sim";
  // "starting" until each reader has matched direct_sim's writer (transport::WaitForPeerRunning)
  own.state = RunState::kStarting;
  own.message = "waiting for direct_sim";
  status_writer.Write(own);

  std::unique_ptr<SteeringController> controller;
  std::unique_ptr<MarkerPredictor> predictor;
  HorizonEstimator horizon(scenario.horizon);
  SequenceTracker seqs;
  std::deque<MarkerFrame> queue;          // received, not yet answered or skipped
  std::map<uint64_t, RobotState> robots;  // by sequence number
  std::map<uint64_t, EntryPoint> entries;
  uint64_t rejected_frames = 0, invalid_outputs = 0, targets_sent = 0, skipped_frames = 0;
  std::string last_rejection;
  TimingStat step_time, jacobian_time, total_time, loop_period, answer_latency;
  PredictionScore score;
  double last_loop_at = -1.0, last_status_at = 0.0;
  int last_phase = 0;

  const double start = MonotonicSeconds();
  std::string ending = "timeout";
  int exit_code = 1;
  bool seen_direct = false;
  std::vector<MarkerFrame> frames;
  std::vector<RobotState> robot_samples;
  std::vector<EntryPoint> entry_samples;
  std::vector<SimStatus> statuses;
  std::vector<Eigen::Vector3d> fit_now;
  bool answered_last = false;
  // once direct_sim has finished: the frames it sent last are still answered (their samples
  // may arrive after its status), up to its last sequence number or for at most 1 s
  bool finishing = false;
  uint64_t final_seq = 0;
  int64_t last_answered_seq = -1;
  double finish_deadline = 0.0;
  while (true) {
    // wait for a frame, or for the robot state of a frame already queued
    if (queue.empty()) {
      marker_reader.Wait(0.02);
    } else if (!answered_last) {
      robot_reader.Wait(0.002);
      entry_reader.Wait(0.002);
    }
    answered_last = false;
    const double now = MonotonicSeconds();
    if (own.state == RunState::kStarting && marker_reader.health().writers_matched > 0 &&
        robot_reader.health().writers_matched > 0 && entry_reader.health().writers_matched > 0) {
      own.state = RunState::kRunning;
      own.stamp.seq++;
      own.message = "readers matched";
      status_writer.Write(own);
    }
    robot_samples.clear();
    robot_reader.Take(robot_samples);
    for (const RobotState& r : robot_samples) robots[r.stamp.seq] = r;
    entry_samples.clear();
    entry_reader.Take(entry_samples);
    for (const EntryPoint& e : entry_samples) entries[e.stamp.seq] = e;
    frames.clear();
    marker_reader.Take(frames);
    for (const MarkerFrame& f : frames) {
      if (seqs.Observe(f.stamp.seq) == SequenceTracker::Verdict::kLate ||
          (!queue.empty() && f.stamp.sim_time <= queue.back().stamp.sim_time)) {
        ++rejected_frames;
        last_rejection = Str("frame ", f.stamp.seq, " out of order");
        continue;
      }
      queue.push_back(f);
    }
    // realtime: answer the newest queued frame whose robot state arrived; older ones only
    // feed the predictor (they are stale by the time we are done). lockstep: answer the oldest,
    // so every frame is answered in order whatever the timing.
    int answer = -1;
    if (scenario.lockstep) {
      // the frame's robot state and entry point (same sequence number) are both needed, so
      // the answer does not depend on which arrived first; a front frame whose robot state or
      // entry point is lost (a frame two later has both) is skipped
      auto complete = [&](size_t i) {
        return robots.count(queue[i].stamp.seq) && entries.count(queue[i].stamp.seq);
      };
      while (queue.size() > 2 && !complete(0) && complete(2)) {
        ++skipped_frames;
        queue.pop_front();
      }
      if (!queue.empty() && complete(0)) answer = 0;
    } else {
      for (int i = static_cast<int>(queue.size()) - 1; i >= 0; --i) {
        if (robots.count(queue[i].stamp.seq)) {
          answer = i;
          break;
        }
      }
    }
    if (answer >= 0) {
      seen_direct = true;
      answered_last = true;
      const RobotState robot = robots[queue[answer].stamp.seq];
      try {
        if (!controller) {
          controller = std::make_unique<SteeringController>(scenario.model, scenario.path,
                                                            scenario.control, mesh, robot.X_WE);
          predictor = std::make_unique<MarkerPredictor>(
              scenario.prediction, static_cast<int>(queue[answer].p_WM.size()));
        }
      } catch (const InputError& e) {
        // a model that cannot be built from this scenario: fatal
        std::fprintf(stderr, "inverse_sim run: %s\n", e.what());
        own.state = RunState::kFailed;
        own.message = std::string(e.what()).substr(0, 255);
        status_writer.Write(own);
        status_writer.WaitForAcks(1.0);
        return 2;
      }
      for (int i = 0; i <= answer; ++i) {
        const MarkerFrame& f = queue[i];
        try {
          predictor->Update(f);
          score.AddMeasurement(f.stamp.sim_time, f.p_WM);
        } catch (const InputError& e) {
          ++rejected_frames;
          last_rejection = e.what();
        }
        if (i < answer) ++skipped_frames;
      }
      const MarkerFrame frame = queue[answer];
      last_answered_seq = static_cast<int64_t>(frame.stamp.seq);
      queue.erase(queue.begin(), queue.begin() + answer + 1);
      robots.erase(robots.begin(), robots.upper_bound(frame.stamp.seq));
      const auto entry_it = entries.upper_bound(frame.stamp.seq);
      EntryPoint entry;
      if (entry_it != entries.begin()) entry = std::prev(entry_it)->second;
      entries.erase(entries.begin(), entry_it == entries.begin() ? entry_it : std::prev(entry_it));

      const double t = frame.stamp.sim_time;
      try {
        horizon.AddLoopTime(t);
        const double h = horizon.CalcHorizon(t);
        SteeringInput input;
        input.X_WE = robot.X_WE;
        if (robot.q.size() == 7) input.q = Eigen::Map<const Vector7d>(robot.q.data());
        input.entry = entry;
        const bool predicted =
            scenario.prediction_enabled && predictor->ready() && std::isfinite(h);
        if (predicted) {
          predictor->Predict(h, &input.p_WM);
          if (scenario.prediction_displacement) {
            predictor->Predict(0.0, &fit_now);
            for (size_t m = 0; m < input.p_WM.size(); ++m)
              input.p_WM[m] = frame.p_WM[m] + (input.p_WM[m] - fit_now[m]);
          }
          score.AddPrediction(t + h, input.p_WM, frame.p_WM);
        } else {
          input.p_WM = frame.p_WM;
        }
        const SteeringOutput out = controller->Update(input);
        step_time.Add(out.timings.simulation);
        jacobian_time.Add(out.timings.jacobian);
        total_time.Add(out.timings.total);
        const double done = MonotonicSeconds();
        if (last_loop_at > 0) loop_period.Add(done - last_loop_at);
        last_loop_at = done;
        last_phase = static_cast<int>(out.phase) - 1;
        if (out.valid) {
          RobotTarget target;
          target.stamp.seq = targets_sent;
          target.stamp.sim_time = t;
          target.answers_seq = frame.stamp.seq;
          target.bevel_angle = robot.bevel_angle;
          if (scenario.control.dof == SteeringDof::kCartesian6) {
            target.mode = TargetMode::kCartesian;
            target.X_WE = out.X_WE_target;
          } else {
            target.mode = TargetMode::kJoint;
            target.q.assign(out.q_target.data(), out.q_target.data() + 7);
          }
          target_writer.Write(target);
          ++targets_sent;
          answer_latency.Add(1e-9 * static_cast<double>(WallTimeNs() - frame.stamp.wall_time_ns));
        } else {
          ++invalid_outputs;
        }
        csv << frame.stamp.seq << ',' << t << ',' << static_cast<int>(out.phase) << ','
            << out.path_index << ',' << out.valid << ',' << out.e.head<3>().norm() << ',' << h
            << ',' << predicted << ',' << out.p_WTip.x() << ',' << out.p_WTip.y() << ','
            << out.p_WTip.z() << ',' << 1e3 * out.timings.simulation << ','
            << 1e3 * out.timings.jacobian << ',' << 1e3 * out.timings.total << '\n';
      } catch (const InputError& e) {
        ++rejected_frames;
        last_rejection = e.what();
      }
    }
    statuses.clear();
    status_reader.Take(statuses);
    for (const SimStatus& s : statuses) {
      if (s.sender == "direct_sim") {
        seen_direct = true;
        if (!finishing && (s.state == RunState::kFinished || s.state == RunState::kFailed)) {
          finishing = true;
          final_seq = s.last_seq;
          finish_deadline = now + 1.0;
        }
      }
    }
    if (now - last_status_at > 0.5) {
      own.stamp.seq++;
      own.frames_sent = targets_sent;
      own.rate_hz = loop_period.count ? loop_period.count / loop_period.sum : 0.0;
      own.phase = static_cast<uint8_t>(std::max(0, last_phase));
      own.message = last_rejection.substr(0, 255);
      status_writer.Write(own);
      last_status_at = now;
      if (!quiet && controller) {
        std::printf("inverse_sim: %lu targets, %.1f Hz, step %.1f ms, jacobian %.2f ms, phase %d\n",
                    static_cast<unsigned long>(targets_sent), own.rate_hz,
                    step_time.count ? 1e3 * step_time.sum / step_time.count : 0.0,
                    jacobian_time.count ? 1e3 * jacobian_time.sum / jacobian_time.count : 0.0,
                    last_phase);
        std::fflush(stdout);
      }
    }
    if (finishing &&
        (last_answered_seq >= static_cast<int64_t>(final_seq) || now > finish_deadline)) {
      ending = "direct_finished";
      exit_code = 0;
      break;
    }
    const transport::ReaderHealth health = marker_reader.health();
    if (seen_direct && health.liveliness_lost > 0) {
      ending = "direct_lost";
      std::fprintf(stderr, "inverse_sim: direct_sim lost (liveliness lease expired)\n");
      break;
    }
    if (InterruptRequested()) {
      ending = "interrupted";
      break;
    }
    if (now - start > timeout || (!seen_direct && now - start > start_timeout)) break;
  }
  own.stamp.seq++;
  own.state = exit_code == 0 ? RunState::kFinished : RunState::kFailed;
  own.message = ending;
  status_writer.Write(own);
  status_writer.WaitForAcks(1.0);

  nlohmann::json summary = {
      {"ending", ending},
      {"inverse_rate_hz", loop_period.count ? loop_period.count / loop_period.sum : 0.0},
      {"targets_sent", targets_sent},
      {"frames_received", seqs.received()},
      {"frames_missing", seqs.missing()},
      {"frames_skipped", skipped_frames},
      {"rejected_frames", rejected_frames},
      {"invalid_outputs", invalid_outputs},
      {"last_rejection", last_rejection},
      {"timings",
       {{"model_step", step_time.Json()},
        {"jacobian", jacobian_time.Json()},
        {"total", total_time.Json()},
        {"loop_period", loop_period.Json()},
        {"frame_sent_to_target_sent", answer_latency.Json()}}},
      {"nrms_percent", score.NrmsPercent()},
      {"prediction_rms_mm", score.RmsMm()},
      {"prediction_bias_mm", score.BiasMm()},
      {"predictions_scored", score.scored()},
      {"settings",
       {{"config", scenario.source},
        {"mesh", scenario.mesh_path},
        {"mesh_nodes", mesh.num_nodes()},
        {"dof", ToString(scenario.control.dof)},
        {"prediction", scenario.prediction_enabled},
        {"filter", ToString(scenario.prediction.filter)},
        {"order", scenario.prediction.order},
        {"optimize_window", scenario.prediction.optimize_window},
        {"search_lead", scenario.prediction.search_lead},
        {"search_interval", scenario.prediction.search_interval},
        {"prediction_displacement", scenario.prediction_displacement},
        {"localization_delay_s", scenario.horizon.localization_delay},
        {"young_modulus_factor", scenario.model.young_modulus_factor},
        {"gains",
         {{"position", scenario.control.gains.position},
          {"angle", scenario.control.gains.angle},
          {"entry", scenario.control.gains.entry}}},
        {"regularization", scenario.control.law.regularization},
        {"mode", scenario.lockstep ? "lockstep" : "realtime"},
        {"domain", tc.domain_id},
        {"partition", tc.partition}}}};
  std::ofstream(out_dir / "summary.json") << summary.dump(2) << '\n';
  if (!quiet)
    std::printf("inverse_sim: %s, %lu targets\n", ending.c_str(),
                static_cast<unsigned long>(targets_sent));
  return exit_code;
}

}  // namespace nsim
