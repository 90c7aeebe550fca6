#include "messages/transport_options.h"

#include "common/core/bounds.h"
#include "common/core/error.h"

namespace nsim::transport {

void AddTransportOptions(CommandLine& cli, const std::string& identity) {
  const TransportConfig d;
  cli.Option("dds-config", "FILE", "Cyclone DDS XML configuration", NSIM_DEFAULT_DDS_CONFIG)
      .Option("domain", "N", "DDS domain id", std::to_string(d.domain_id))
      .Option("partition", "NAME", "DDS partition (both processes must use the same)", d.partition)
      .Option("lease", "S", "liveliness lease of this process's writers (s)", "2")
      .Option("deadline", "S", "max period between samples of a stream (s), 0 = none", "2")
      .Option("secure", "DIR",
              "DDS Security with the credentials in DIR (scripts/make_credentials.sh): "
              "authenticated, access-controlled and encrypted; talks only to processes with "
              "credentials of the same CA")
      .Option("identity", "NAME",
              "with --secure: whose credentials (DIR/NAME.cert.pem, DIR/NAME.key.pem, "
              "DIR/NAME.permissions.p7s)",
              identity);
}

TransportConfig TransportFromCli(const CommandLine& cli) {
  TransportConfig c;
  c.config_file = cli.GetString("dds-config");
  c.domain_id = static_cast<int>(cli.GetInt("domain"));
  c.partition = cli.GetString("partition");
  CheckName(c.partition, kMaxPartitionLength, "--partition");
  c.liveliness_lease_s = cli.GetDouble("lease");
  c.deadline_s = cli.GetDouble("deadline");
  if (cli.Has("secure")) {
    c.security.dir = cli.GetString("secure");
    if (c.security.dir.empty()) throw InputError("--secure: expected a credentials folder");
    c.security.identity = cli.GetString("identity");
    CheckName(c.security.identity, kMaxPartitionLength, "--identity");
  } else if (cli.Given("identity")) {
    throw InputError("--identity needs --secure DIR (the credentials folder)");
  }
  c.Validate();
  return c;
}

void AddRos2Options(CommandLine& cli) {
  cli.Flag("ros2",
           "also publish on ROS 2 topics (/nsim/markers, /nsim/robot/pose, ...; standard ROS 2 "
           "types, domain --domain or ROS_DOMAIN_ID, no partition)");
}

void AddRos2WaitOption(CommandLine& cli, const std::string& topics) {
  cli.Integer("ros2-wait", "N",
              "with --ros2: wait for N ROS 2 subscribers of each of " + topics +
                  " before the first message (then 1-2 s for them to know this process)",
              "0", 0, 1000);
}

void ApplyRos2Wait(const CommandLine& cli, std::optional<Ros2Config>* ros2) {
  const long n = cli.GetInt("ros2-wait");
  if (!*ros2) {
    if (n != 0) throw InputError("--ros2-wait needs --ros2");
    return;
  }
  (*ros2)->wait_subscribers = static_cast<int>(n);  // in 0..1000: checked when parsing
}

std::optional<Ros2Config> Ros2FromCli(const CommandLine& cli, const TransportConfig& transport,
                                      bool force) {
  if (!force && !cli.GetFlag("ros2")) return std::nullopt;
  if (transport.security.enabled())
    throw InputError(Str(force ? "--ros2-io" : "--ros2",
                         " cannot be used with --secure: the ROS 2 topics are not secured"));
  return Ros2ConfigFor(transport, cli.Given("domain"));
}

}  // namespace nsim::transport
