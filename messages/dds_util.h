#pragma once
// Small helpers over the Cyclone C API shared by the nsim transport (transport.cpp) and the
// ROS 2 mirror (ros2.cpp). Internal to messages/.

#include <dds/dds.h>

#include <string>

namespace nsim::transport {

/// A time in seconds as a DDS duration; <= 0 is infinite.
dds_duration_t ToDuration(double seconds);

/// `rc`, or std::runtime_error "DDS: <what> failed: <reason>" if it is an error code.
int32_t Checked(int32_t rc, const char* what);

/// Creates DDS domain `domain_id` from the Cyclone XML file `config_file` (nothing when it is
/// empty: Cyclone's default, CYCLONEDDS_URI). A domain this process has already created (for
/// another participant) is reused as it is. Returns the domain entity the caller deletes, or 0
/// when there is none to delete. Throws std::runtime_error if Cyclone refuses the file.
dds_entity_t CreateDomain(int domain_id, const std::string& config_file);

}  // namespace nsim::transport
