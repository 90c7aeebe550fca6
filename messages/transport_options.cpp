#include "messages/transport_options.h"

#include "common/core/bounds.h"

namespace nsim::transport {

void AddTransportOptions(CommandLine& cli) {
  const TransportConfig d;
  cli.Option("dds-config", "FILE", "Cyclone DDS XML configuration", NSIM_DEFAULT_DDS_CONFIG)
      .Option("domain", "N", "DDS domain id", std::to_string(d.domain_id))
      .Option("partition", "NAME", "DDS partition (both processes must use the same)", d.partition)
      .Option("lease", "S", "liveliness lease of this process's writers (s)", "2")
      .Option("deadline", "S", "max period between samples of a stream (s), 0 = none", "2");
}

TransportConfig TransportFromCli(const CommandLine& cli) {
  TransportConfig c;
  c.config_file = cli.GetString("dds-config");
  c.domain_id = static_cast<int>(cli.GetInt("domain"));
  c.partition = cli.GetString("partition");
  CheckName(c.partition, kMaxPartitionLength, "--partition");
  c.liveliness_lease_s = cli.GetDouble("lease");
  c.deadline_s = cli.GetDouble("deadline");
  c.Validate();
  return c;
}

void AddRos2Options(CommandLine& cli) {
  cli.Flag("ros2",
           "also publish on ROS 2 topics (/nsim/markers, /nsim/robot/pose, ...; standard ROS 2 "
           "types, domain --domain or ROS_DOMAIN_ID, no partition)");
}

std::optional<Ros2Config> Ros2FromCli(const CommandLine& cli, const TransportConfig& transport,
                                      bool force) {
  if (!force && !cli.GetFlag("ros2")) return std::nullopt;
  return Ros2ConfigFor(transport, cli.Given("domain"));
}

}  // namespace nsim::transport
