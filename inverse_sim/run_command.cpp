#include "inverse_sim/run_command.h"

#include <cstdio>
#include <filesystem>
#include <optional>

#include "common/core/cli.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/mesh/gmsh_reader.h"
#include "common/results/controller_recorder.h"
#include "common/steering/controller_loop.h"
#include "inverse_sim/controller_options.h"
#include "inverse_sim/dds_controller.h"
#include "inverse_sim/ros2_controller.h"
#include "inverse_sim/scenario_loader.h"
#include "messages/transport_options.h"

namespace nsim {
namespace {

// --ros2-io: the options of the ROS 2 pump (realtime only: a ROS 2 source does not wait for
// answers)
ControllerRos2Options Ros2IoOptions(const CommandLine& cli, const InverseScenario& scenario,
                                    const ControllerPumpOptions& pump) {
  if (cli.Has("mode") && cli.GetString("mode") == "lockstep")
    throw InputError("--ros2-io is realtime only: not with --mode lockstep");
  ControllerRos2Options o;
  o.ros2 = *transport::Ros2FromCli(cli, pump.transport, /*force=*/true);
  o.timeout = pump.timeout;
  o.start_timeout = pump.start_timeout;
  o.idle_timeout = cli.GetDouble("ros2-idle");
  if (!(o.idle_timeout > 0)) throw InputError("--ros2-idle must be > 0 (s)");
  o.quiet = pump.quiet;
  const SteeringPathConfig& path = scenario.loop.path;
  o.entry_normal_W = (path.entry_W - path.target_W).normalized();
  if (scenario.loop.control.dof == SteeringDof::kJoint7) o.joints_required = 7;
  return o;
}

}  // namespace

int RunInverseSim(int argc, char** argv) {
  CommandLine cli("inverse_sim run --config S.yaml [options]",
                  "The controller: registration, prediction, Jacobian and control law.");
  cli.Option("config", "S.yaml", "scenario file (shared:, inverse:, controller:, prediction:)",
             "", true)
      .Option("out", "DIR", "results folder (summary.json, inverse.csv)", "results/inverse")
      .Choice("mode", "realtime|lockstep",
              "lockstep: answer every frame in order (reproducible); realtime: answer the newest "
              "frame only (default: the scenario's run.mode)",
              {"realtime", "lockstep"})
      .Option("timeout", "S", "give up after S seconds in all", "3600")
      .Option("start-timeout", "S", "give up if direct_sim is not seen within S seconds", "60")
      .Option("direct-timeout", "S",
              "give up when direct_sim stays not alive (lease expired) for S seconds; it may be "
              "stalled and come back, and it waits run.takeover_timeout (30 s) for this "
              "controller",
              "30")
      .Option("link-delay", "S",
              "realtime: take each frame up S seconds after it arrived and write each target S "
              "seconds after it was computed (a slower network, each way; the controller "
              "measures the latency and predicts over it)",
              "0")
      .Flag("quiet", "no progress lines")
      .Flag("ros2-io",
            "take markers, robot state and entry point from the ROS 2 topics and publish the "
            "targets there (/nsim/target_pose, /nsim/robot/joint_command); realtime")
      .Option("ros2-idle", "S", "with --ros2-io: end when no markers came for S seconds", "5")
      .Flag("check",
            "only read and check the scenario, its mesh and the options, then exit (0: valid, "
            "2: the reason)");
  AddControllerOptions(cli);
  transport::AddTransportOptions(cli, "inverse_sim");
  transport::AddRos2Options(cli);
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  InverseScenario scenario = LoadInverseScenario(cli.GetString("config"));
  ApplyControllerOptions(cli, &scenario);
  if (cli.Has("mode")) scenario.lockstep = cli.GetString("mode") == "lockstep";

  ControllerPumpOptions options;
  options.lockstep = scenario.lockstep;
  options.timeout = cli.GetDouble("timeout");
  options.start_timeout = cli.GetDouble("start-timeout");
  options.direct_timeout = cli.GetDouble("direct-timeout");
  // a day at most: the longest run is an hour of simulated time
  if (!(options.timeout > 0 && options.timeout <= 86400) ||
      !(options.start_timeout > 0 && options.start_timeout <= 86400) ||
      !(options.direct_timeout > 0 && options.direct_timeout <= 86400))
    throw InputError("--timeout, --start-timeout and --direct-timeout must be in (0, 86400] (s)");
  options.link_delay = cli.GetDouble("link-delay");
  if (!(options.link_delay >= 0 && options.link_delay <= 10))
    throw InputError("--link-delay must be in [0, 10] (s), got " + cli.GetString("link-delay"));
  if (options.link_delay > 0 && (options.lockstep || cli.GetFlag("ros2-io")))
    throw InputError("--link-delay is for realtime runs over DDS (lockstep: the scenario's "
                     "run.latency_steps or direct_sim --latency-steps)");
  options.quiet = cli.GetFlag("quiet");
  options.scenario_hash = scenario.scenario_hash;
  options.transport = transport::TransportFromCli(cli);
  if (!cli.Given("domain")) options.transport.domain_id = scenario.dds_domain;
  if (!cli.Given("partition")) options.transport.partition = scenario.dds_partition;
  options.transport.Validate();
  options.ros2 = transport::Ros2FromCli(cli, options.transport);
  std::optional<ControllerRos2Options> ros2_io;
  if (cli.GetFlag("ros2-io")) {
    ros2_io = Ros2IoOptions(cli, scenario, options);
    scenario.lockstep = false;
  }
  if (cli.GetFlag("check")) {
    ReadGmshMesh(scenario.mesh_path);
    if (!options.quiet) std::printf("run: %s is valid\n", cli.GetString("config").c_str());
    return 0;
  }

  const std::string out_dir = cli.GetString("out");
  std::filesystem::create_directories(out_dir);
  ControllerRecorder recorder(out_dir);
  ControllerLoop loop(scenario.LoopConfig(), ReadGmshMesh(scenario.mesh_path));
  InstallInterruptHandler();

  ControllerRunInfo info;
  info.scenario = scenario.source;
  info.mesh = scenario.mesh_path;
  info.scenario_hash = scenario.scenario_hash;
  info.lockstep = scenario.lockstep;
  info.link_delay = options.link_delay;
  info.domain = options.transport.domain_id;
  info.partition = options.transport.partition;
  if (options.transport.security.enabled()) info.dds_identity = options.transport.security.identity;
  int code = 0;
  if (ros2_io) {
    info.transport = "ros2";
    info.domain = ros2_io->ros2.domain_id;
    info.partition.clear();
    code = RunControllerOverRos2(loop, recorder, *ros2_io, &info);
  } else {
    code = RunControllerOverDds(loop, recorder, options, &info);
  }
  recorder.WriteSummary(loop, info);
  return code;
}

}  // namespace nsim
