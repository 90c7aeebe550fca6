#pragma once
// The command-line options every networked subcommand shares (DESIGN.md "What a user runs").

#include <optional>
#include <string>

#include "common/core/cli.h"
#include "messages/ros2.h"
#include "messages/transport.h"

namespace nsim::transport {

/// Adds --dds-config, --domain, --partition, --lease, --deadline, --secure and --identity to
/// `cli`. The default DDS configuration is the repository's configs/dds/local.xml (one machine,
/// loopback). `identity` is the default of --identity: the program's own credentials
/// ("direct_sim", "inverse_sim").
void AddTransportOptions(CommandLine& cli, const std::string& identity);

/// Reads the options added by AddTransportOptions; the result is validated (with --secure, the
/// credentials exist and are what they should be). --identity without --secure is an error.
TransportConfig TransportFromCli(const CommandLine& cli);

/// Adds --ros2 (mirror the process's streams to ROS 2 topics, messages/ros2.h).
void AddRos2Options(CommandLine& cli);

/// Adds --ros2-wait N: with --ros2, wait for N ROS 2 subscribers of each of `topics` (for the
/// help text) before the first message.
void AddRos2WaitOption(CommandLine& cli, const std::string& topics);

/// Sets `ros2`'s wait_subscribers from --ros2-wait (declared by AddRos2WaitOption);
/// InputError for --ros2-wait > 0 without --ros2 (its range is checked when parsing).
void ApplyRos2Wait(const CommandLine& cli, std::optional<Ros2Config>* ros2);

/// The ROS 2 configuration when --ros2 was given (or `force`, for --ros2-io), else nothing: the
/// domain of --domain if given, else ROS_DOMAIN_ID, else 0; the DDS configuration file of
/// `transport`. InputError with --secure: the ROS 2 topics are not secured.
std::optional<Ros2Config> Ros2FromCli(const CommandLine& cli, const TransportConfig& transport,
                                      bool force = false);

}  // namespace nsim::transport
