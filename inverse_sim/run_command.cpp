#include "inverse_sim/run_command.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "common/core/cli.h"
#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/core/sequence_tracker.h"
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
      .Option("timeout", "S", "give up after S seconds in all", "3600")
      .Option("start-timeout", "S", "give up if direct_sim is not seen within S seconds", "60")
      .Flag("quiet", "no progress lines");
  transport::AddTransportOptions(cli);
  cli.Parse(argc, argv, 1);
  if (cli.help_requested()) {
    std::cout << cli.Help();
    return 0;
  }
  InverseScenario scenario = LoadInverseScenario(cli.GetString("config"));
  if (cli.Has("prediction")) {
    const std::string v = cli.GetString("prediction");
    if (v != "on" && v != "off") throw InputError(Str("--prediction must be on or off, got '", v, "'"));
    scenario.prediction_enabled = v == "on";
  }
  if (cli.Has("dof")) scenario.control.dof = ParseSteeringDof(cli.GetString("dof"), "--dof");
  if (cli.Has("young-modulus-factor")) {
    scenario.model.young_modulus_factor = cli.GetDouble("young-modulus-factor");
    scenario.model.Validate();
  }
  const double timeout = cli.GetDouble("timeout"), start_timeout = cli.GetDouble("start-timeout");
  if (!(timeout > 0) || !(start_timeout > 0)) throw InputError("--timeout and --start-timeout must be > 0 (s)");
  const bool quiet = cli.GetFlag("quiet");
  const std::filesystem::path out_dir = cli.GetString("out");
  std::filesystem::create_directories(out_dir);
  std::ofstream csv(out_dir / "inverse.csv");
  if (!csv) throw InputError(Str((out_dir / "inverse.csv").string(), ": cannot open for writing"));
  csv << "answers_seq,sim_time,phase,path_index,valid,e_p_norm,horizon,step_ms,jacobian_ms,total_ms\n";
  const TetMesh mesh = ReadGmshMesh(scenario.mesh_path);

  const transport::TransportConfig tc = transport::TransportFromCli(cli);
  InstallInterruptHandler();
  transport::Participant participant(tc);
  transport::Reader<MarkerFrame> marker_reader(participant, transport::Qos::kStateStream);
  transport::Reader<RobotState> robot_reader(participant, transport::Qos::kStateStream);
  transport::Reader<EntryPoint> entry_reader(participant, transport::Qos::kStateStream);
  transport::Reader<SimStatus> status_reader(participant, transport::Qos::kStatus);
  transport::Writer<RobotTarget> target_writer(participant, transport::Qos::kTarget);
  transport::Writer<SimStatus> status_writer(participant, transport::Qos::kStatus);

  SimStatus own;
  own.sender = "inverse_sim";
  own.state = RunState::kRunning;
  own.message = "waiting for direct_sim";
  status_writer.Write(own);

  std::unique_ptr<SteeringController> controller;
  std::unique_ptr<MarkerPredictor> predictor;
  HorizonEstimator horizon(scenario.horizon);
  SequenceTracker seqs;
  std::optional<RobotState> robot;
  EntryPoint entry;
  uint64_t rejected_frames = 0, invalid_outputs = 0, targets_sent = 0;
  std::string last_rejection;
  TimingStat step_time, jacobian_time, total_time, loop_period;
  // prediction quality: predicted positions at t + h against the next measured frame
  std::vector<double> pred_sq, delay_sq;
  std::vector<std::pair<double, std::vector<Eigen::Vector3d>>> pending;  // (time, predicted)
  std::vector<Eigen::Vector3d> last_measured;
  double last_loop_at = -1.0, last_status_at = 0.0;
  int last_phase = 0;

  const double start = MonotonicSeconds();
  std::string ending = "timeout";
  int exit_code = 1;
  bool seen_direct = false;
  std::vector<MarkerFrame> frames;
  std::vector<RobotState> robots;
  std::vector<EntryPoint> entries;
  std::vector<SimStatus> statuses;
  while (true) {
    marker_reader.Wait(0.02);
    const double now = MonotonicSeconds();
    robots.clear();
    robot_reader.Take(robots);
    if (!robots.empty()) robot = robots.back();
    entries.clear();
    entry_reader.Take(entries);
    if (!entries.empty()) entry = entries.back();
    frames.clear();
    marker_reader.Take(frames);
    // answer only the newest frame: older ones are stale by the time we are done
    const MarkerFrame* frame = nullptr;
    for (const MarkerFrame& f : frames) {
      if (seqs.Observe(f.stamp.seq) == SequenceTracker::Verdict::kLate) {
        ++rejected_frames;
        last_rejection = Str("frame ", f.stamp.seq, " out of order");
        continue;
      }
      frame = &f;
    }
    if (frame && robot) {
      seen_direct = true;
      const double t = frame->stamp.sim_time;
      try {
        if (!controller) {
          controller = std::make_unique<SteeringController>(scenario.model, scenario.path,
                                                            scenario.control, mesh, robot->X_WE);
          predictor = std::make_unique<MarkerPredictor>(scenario.prediction,
                                                        static_cast<int>(frame->p_WM.size()));
        }
        predictor->Update(*frame);
        // score earlier predictions made for this frame's time
        for (auto it = pending.begin(); it != pending.end();) {
          if (it->first <= t + 1e-9) {
            if (std::abs(it->first - t) < 1e-6 && !last_measured.empty()) {
              pred_sq.resize(frame->p_WM.size(), 0.0);
              delay_sq.resize(frame->p_WM.size(), 0.0);
              for (size_t m = 0; m < frame->p_WM.size(); ++m) {
                pred_sq[m] += (it->second[m] - frame->p_WM[m]).squaredNorm();
                delay_sq[m] += (last_measured[m] - frame->p_WM[m]).squaredNorm();
              }
            }
            it = pending.erase(it);
          } else {
            ++it;
          }
        }
        horizon.AddLoopTime(t);
        const double h = horizon.CalcHorizon(t);
        SteeringInput input;
        input.X_WE = robot->X_WE;
        if (robot->q.size() == 7) input.q = Eigen::Map<const Vector7d>(robot->q.data());
        input.entry = entry;
        if (scenario.prediction_enabled && predictor->ready() && std::isfinite(h)) {
          predictor->Predict(h, &input.p_WM);
          pending.emplace_back(t + h, input.p_WM);
        } else {
          input.p_WM = frame->p_WM;
        }
        last_measured = frame->p_WM;
        const SteeringOutput out = controller->Update(input);
        step_time.Add(out.timings.simulation);
        jacobian_time.Add(out.timings.jacobian);
        total_time.Add(out.timings.total);
        if (last_loop_at > 0) loop_period.Add(now - last_loop_at);
        last_loop_at = now;
        last_phase = static_cast<int>(out.phase) - 1;
        if (out.valid) {
          RobotTarget target;
          target.stamp.seq = targets_sent;
          target.stamp.sim_time = t;
          target.answers_seq = frame->stamp.seq;
          target.bevel_angle = robot->bevel_angle;
          if (scenario.control.dof == SteeringDof::kCartesian6) {
            target.mode = TargetMode::kCartesian;
            target.X_WE = out.X_WE_target;
          } else {
            target.mode = TargetMode::kJoint;
            target.q.assign(out.q_target.data(), out.q_target.data() + 7);
          }
          target_writer.Write(target);
          ++targets_sent;
        } else {
          ++invalid_outputs;
        }
        csv << frame->stamp.seq << ',' << t << ',' << static_cast<int>(out.phase) << ','
            << out.path_index << ',' << out.valid << ',' << out.e.head<3>().norm() << ',' << h
            << ',' << 1e3 * out.timings.simulation << ',' << 1e3 * out.timings.jacobian << ','
            << 1e3 * out.timings.total << '\n';
      } catch (const InputError& e) {
        ++rejected_frames;
        last_rejection = e.what();
      }
    }
    statuses.clear();
    status_reader.Take(statuses);
    bool finished = false;
    for (const SimStatus& s : statuses) {
      if (s.sender == "direct_sim") {
        seen_direct = true;
        if (s.state == RunState::kFinished || s.state == RunState::kFailed) finished = true;
      }
    }
    if (now - last_status_at > 0.5) {
      own.stamp.seq++;
      own.frames_sent = targets_sent;
      own.rate_hz = loop_period.count ? loop_period.count / loop_period.sum : 0.0;
      own.phase = static_cast<uint8_t>(std::max(0, last_phase));
      own.message = last_rejection;
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
    if (finished) {
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

  nlohmann::json nrms = nlohmann::json::array();
  for (size_t m = 0; m < pred_sq.size(); ++m) {
    nrms.push_back(delay_sq[m] > 0 ? 100.0 * std::sqrt(pred_sq[m] / delay_sq[m]) : 0.0);
  }
  nlohmann::json summary = {
      {"ending", ending},
      {"inverse_rate_hz", loop_period.count ? loop_period.count / loop_period.sum : 0.0},
      {"targets_sent", targets_sent},
      {"frames_received", seqs.received()},
      {"frames_missing", seqs.missing()},
      {"rejected_frames", rejected_frames},
      {"invalid_outputs", invalid_outputs},
      {"last_rejection", last_rejection},
      {"timings", {{"model_step", step_time.Json()}, {"jacobian", jacobian_time.Json()},
                   {"total", total_time.Json()}, {"loop_period", loop_period.Json()}}},
      {"nrms_percent", nrms},
      {"settings",
       {{"config", scenario.source}, {"mesh", scenario.mesh_path},
        {"dof", ToString(scenario.control.dof)}, {"prediction", scenario.prediction_enabled},
        {"filter", ToString(scenario.prediction.filter)}, {"order", scenario.prediction.order},
        {"optimize_window", scenario.prediction.optimize_window},
        {"young_modulus_factor", scenario.model.young_modulus_factor},
        {"regularization", scenario.control.law.regularization}}}};
  std::ofstream(out_dir / "summary.json") << summary.dump(2) << '\n';
  if (!quiet) std::printf("inverse_sim: %s, %lu targets\n", ending.c_str(), static_cast<unsigned long>(targets_sent));
  return exit_code;
}

}  // namespace nsim
