#include "direct_sim/run_command.h"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <memory>

#include "common/core/cli.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/core/lossy_link.h"
#include "common/mesh/gmsh_reader.h"
#include "common/results/controller_recorder.h"
#include "common/results/patient_recorder.h"
#include "common/scene/patient_loop.h"
#include "common/steering/controller_loop.h"
#include "direct_sim/dds_patient.h"
#include "direct_sim/in_process.h"
#include "direct_sim/patient_outputs.h"
#include "direct_sim/scenario_loader.h"
#include "inverse_sim/controller_options.h"
#include "inverse_sim/scenario_loader.h"
#include "messages/transport_options.h"

namespace nsim {
namespace {

std::string DefaultOutDir() {
  const std::time_t now = std::time(nullptr);
  char text[64];
  std::strftime(text, sizeof(text), "results/direct_%Y%m%d_%H%M%S", std::localtime(&now));
  return text;
}

void DeclareOptions(CommandLine& cli) {
  cli.Option("config", "S.yaml", "scenario file", "", true)
      .Option("out", "DIR",
              "output folder (default results/direct_<date>_<time>; with --in-process the "
              "controller writes DIR/../inverse)")
      .Option("duration", "S", "simulated time (s), overrides run.duration")
      .Choice("mode", "realtime|lockstep", "overrides run.mode", {"realtime", "lockstep"})
      .Option("latency-steps", "N", "lockstep latency in steps, overrides run.latency_steps")
      .Option("rt-priority", "N",
              "realtime: SCHED_FIFO priority (1-99) of the loop's thread, 0 = normal class; "
              "overrides run.rt_priority")
      .Option("vtk-every", "N", "VTK snapshots every N steps, overrides run.vtk_every")
      .Option("seed", "N", "random seed (breathing), overrides random_seed")
      .Option("young-modulus", "PA",
              "Young's modulus of the patient's liver (Pa), overrides patient.liver.young_modulus")
      .Flag("no-controller", "insert along the planned path at insertion.speed, no controller")
      .Flag("in-process",
            "run the controller (inverse_sim's loop) in this process, in lockstep, without DDS")
      .Option("controller-out", "DIR",
              "with --in-process: the controller's results folder (default DIR/../inverse)")
      .Option("restart-controller-at", "S",
              "with --in-process: replace the controller at simulated time S by a new one whose "
              "model catches up from that frame (a restart without the frame history)")
      .Option("loss", "PCT",
              "with --in-process: lose each frame and each target with probability PCT/100 "
              "(seeded by --seed), as a lossy network under keep-last-1 streams would; 0..100")
      .Flag("no-video", "no view (no window, no video, no PNG)")
      .Flag("check",
            "only read and check the scenario, its meshes and the options, then exit (0: valid, "
            "2: the reason)")
      .Flag("quiet", "no progress lines");
  AddControllerOptions(cli);
  transport::AddTransportOptions(cli, "direct_sim");
  transport::AddRos2Options(cli);
  transport::AddRos2WaitOption(cli,
                               "/nsim/markers, /nsim/robot/pose, /nsim/tip_to_target (and "
                               "/nsim/robot/joint_states for the iiwa)");
}

// the command line's overrides of the scenario (InputError naming the option)
void ApplyOptions(const CommandLine& cli, DirectScenario* s) {
  if (cli.Has("duration")) s->run.duration = cli.GetDouble("duration");
  if (cli.Has("mode"))
    s->run.mode = cli.GetString("mode") == "realtime" ? RunMode::kRealtime : RunMode::kLockstep;
  if (cli.GetFlag("in-process")) s->run.mode = RunMode::kLockstep;
  if (cli.Has("latency-steps")) s->run.latency_steps = static_cast<int>(cli.GetInt("latency-steps"));
  if (cli.Has("rt-priority")) s->run.rt_priority = static_cast<int>(cli.GetInt("rt-priority"));
  if (cli.Has("vtk-every")) s->run.vtk_every = static_cast<int>(cli.GetInt("vtk-every"));
  if (cli.Has("seed")) {
    const long seed = cli.GetInt("seed");
    if (seed < 0) throw InputError(Str("--seed must be >= 0, got ", seed));
    s->random_seed = static_cast<uint64_t>(seed);
    s->scene.breathing.random_seed = s->random_seed;
  }
  if (cli.Has("young-modulus")) {
    const double e = cli.GetDouble("young-modulus");
    // the stiffest solid (diamond) is 1.2e12 Pa
    if (!(e > 0) || !std::isfinite(e) || e > 1e12)
      throw InputError(Str("--young-modulus must be in (0, 1e12] (Pa), got ", e));
    s->scene.liver.young_modulus = e;
  }
  if (cli.GetFlag("no-video")) s->run.video = false;
  ValidateAs([&] { s->run.Validate(); }, "command line", "run.", "run.");
  const double steps = s->run.duration / s->scene.time_step;
  if (steps < 0.5) throw InputError(Str("run.duration must cover at least one step of ",
                                        s->scene.time_step, " s"));
  ValidateAs([&] { CheckStepCount(s->run.duration, s->scene.time_step); }, "--duration", "", "");
}

PatientRunInfo MakeInfo(const DirectScenario& s, bool in_process) {
  PatientRunInfo info;
  info.scenario = s.source;
  info.scenario_hash = s.scenario_hash;
  info.liver_mesh = s.liver_mesh_path;
  info.seed = s.random_seed;
  info.duration = s.run.duration;
  info.realtime = s.run.mode == RunMode::kRealtime;
  info.latency_steps = s.run.latency_steps;
  info.rt_priority = s.run.rt_priority;
  info.transport = in_process ? "in_process" : "dds";
  return info;
}

// both loops in this process; the controller's scenario is the same file's inverse side
int RunInProcess(const CommandLine& cli, const DirectScenario& scenario, PatientLoop& patient,
                 PatientOutputs& outputs, PatientRunInfo* info) {
  InverseScenario inverse = LoadInverseScenario(cli.GetString("config"));
  ApplyControllerOptions(cli, &inverse);
  inverse.lockstep = true;  // the two loops in one process take turns, frame by frame
  const std::string out = cli.Has("controller-out")
                              ? cli.GetString("controller-out")
                              : (std::filesystem::path(outputs.out_dir()).parent_path() /
                                 "inverse").string();
  std::filesystem::create_directories(out);
  ControllerRecorder recorder(out);
  const TetMesh mesh = ReadGmshMesh(inverse.mesh_path);
  auto controller = std::make_unique<ControllerLoop>(inverse.LoopConfig(), mesh);
  ControllerRestart restart;
  if (cli.Has("restart-controller-at")) {
    const double at = cli.GetDouble("restart-controller-at");
    if (!(at >= 0) || !std::isfinite(at))
      throw InputError(Str("--restart-controller-at must be >= 0 (s), got ", at));
    restart.at_step = std::llround(at / scenario.scene.time_step);
    restart.make = [&] { return std::make_unique<ControllerLoop>(inverse.LoopConfig(), mesh); };
  }
  LinkLoss loss;
  if (cli.Has("loss")) loss.percent = cli.GetDouble("loss");
  loss.seed = scenario.random_seed;
  ControllerRunInfo cinfo;
  cinfo.scenario = inverse.source;
  cinfo.mesh = inverse.mesh_path;
  cinfo.scenario_hash = inverse.scenario_hash;
  cinfo.transport = "in_process";
  const int code = RunClosedLoopInProcess(patient, outputs, controller, recorder, scenario.run,
                                          info, &cinfo, restart, loss);
  recorder.WriteSummary(*controller, cinfo);
  return code;
}

}  // namespace

int RunDirect(int argc, char** argv) {
  CommandLine cli("direct_sim run --config S.yaml [options]",
                  "Simulate the patient (liver, skin, ribs, breathing) and the robot holding the "
                  "needle; publish the sensor frames; apply robot targets.");
  DeclareOptions(cli);
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  const bool in_process = cli.GetFlag("in-process");
  const bool controller = !cli.GetFlag("no-controller");
  if (in_process && !controller)
    throw InputError("--in-process and --no-controller exclude each other");
  if (cli.Has("restart-controller-at") && !in_process)
    throw InputError("--restart-controller-at needs --in-process");
  if (cli.Has("loss") && !in_process)
    throw InputError("--loss needs --in-process (over DDS the network decides what is lost)");
  if (cli.Has("loss")) LossyLink::CheckPercent(cli.GetDouble("loss"), "--loss");
  DirectScenario scenario = LoadDirectScenario(cli.GetString("config"));
  ApplyOptions(cli, &scenario);
  transport::TransportConfig tc = transport::TransportFromCli(cli);
  if (!cli.Given("domain")) tc.domain_id = scenario.dds_domain;
  if (!cli.Given("partition")) tc.partition = scenario.dds_partition;
  tc.Validate();
  std::optional<transport::Ros2Config> ros2 = transport::Ros2FromCli(cli, tc);
  transport::ApplyRos2Wait(cli, &ros2);
  if (ros2 && in_process) throw InputError("--ros2 needs the DDS path: not with --in-process");
  if (tc.security.enabled() && in_process)
    throw InputError("--secure needs the DDS path: not with --in-process");
  if (cli.GetFlag("check")) {
    if (in_process) LoadInverseScenario(cli.GetString("config"));
    if (!cli.GetFlag("quiet")) std::printf("run: %s is valid\n", cli.GetString("config").c_str());
    return 0;
  }
  const std::string out_dir = cli.Has("out") ? cli.GetString("out") : DefaultOutDir();
  InstallInterruptHandler();

  PatientLoop loop(scenario.LoopConfig(controller), scenario.liver_mesh, scenario.skin_mesh);
  PatientOutputs outputs(out_dir, scenario.run, scenario.view, cli.GetFlag("quiet"));
  PatientRunInfo info = MakeInfo(scenario, in_process);
  if (tc.security.enabled()) info.dds_identity = tc.security.identity;
  const int code = in_process ? RunInProcess(cli, scenario, loop, outputs, &info)
                              : RunPatientOverDds(loop, outputs, scenario.run, tc, ros2,
                                                  scenario.scenario_hash, cli.GetFlag("quiet"),
                                                  &info);
  outputs.Finish(loop, &info);
  return code;
}

}  // namespace nsim
