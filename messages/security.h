#pragma once
// DDS Security for the nsim participant (transport.h SecurityConfig): the dds.sec.* properties
// of the participant QoS that load Cyclone's builtin plugins with one identity's credentials,
// and the participant's creation with Cyclone's reason for a refusal. Internal to messages/.

#include <dds/dds.h>

#include <string>

#include "messages/transport.h"

namespace nsim::transport {

/// Sets the dds.sec.* properties of `security` (enabled) on a participant QoS: the three
/// builtin plugins (authentication, access control, cryptography) and the credentials as
/// file: URIs of absolute paths.
void SetSecurityProperties(const SecurityConfig& security, dds_qos_t* qos);

/// Creates a participant on `domain_id` with the QoS `qos` carrying the properties of
/// `security`. Throws InputError when DDS Security refuses it, with Cyclone's reason (captured
/// from its log) and the file that reason concerns.
dds_entity_t CreateSecureParticipant(int domain_id, const SecurityConfig& security,
                                     const dds_qos_t* qos);

/// The InputError text for an entity DDS Security does not allow: `what` is "publishing" or
/// "subscribing to" (or "using"), `topic` the DDS topic name.
std::string PermissionDenied(const SecurityConfig& security, const char* what, const char* topic);

}  // namespace nsim::transport
