#pragma once
// The command-line options every networked subcommand shares (DESIGN.md "What a user runs").

#include "common/core/cli.h"
#include "messages/transport.h"

namespace nsim::transport {

/// Adds --dds-config, --domain, --partition, --lease and --deadline to `cli`. The default DDS
/// configuration is the repository's configs/dds/local.xml (one machine, loopback).
void AddTransportOptions(CommandLine& cli);

/// Reads the options added by AddTransportOptions; the result is validated.
TransportConfig TransportFromCli(const CommandLine& cli);

}  // namespace nsim::transport
