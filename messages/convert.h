#pragma once
// The one place where DDS message types (generated from nsim_msgs.idl) and the internal sample
// structs (common/core/samples.h) meet. Internal to messages/.

#include <string>
#include <vector>

#include "common/core/samples.h"
#include "nsim_msgs.h"

namespace nsim::transport {

/// Per sample type: the generated message type, its topic descriptor and topic name.
template <typename Sample>
struct MessageTraits;

#define NSIM_MESSAGE_TRAITS(SampleT, MsgT, TopicName)                          \
  template <>                                                                  \
  struct MessageTraits<SampleT> {                                              \
    using Msg = MsgT;                                                          \
    static const dds_topic_descriptor_t* descriptor() { return &MsgT##_desc; } \
    static constexpr const char* kTopic = TopicName;                           \
  };
NSIM_MESSAGE_TRAITS(SensorFrame, nsim_msgs_SensorFrame, "nsim_SensorFrame")
NSIM_MESSAGE_TRAITS(RobotTarget, nsim_msgs_RobotTarget, "nsim_RobotTarget")
NSIM_MESSAGE_TRAITS(SimStatus, nsim_msgs_SimStatus, "nsim_SimStatus")
#undef NSIM_MESSAGE_TRAITS

/// Storage that sequence fields of an outgoing message point into; reused between writes.
struct ConvertScratch {
  std::vector<nsim_msgs_Vec3> vec3;
  std::vector<double> values;
};

/// Fills `msg` from `sample`. Sequence buffers point into `scratch` (valid until its next use).
void ToMessage(const SensorFrame& sample, nsim_msgs_SensorFrame& msg, ConvertScratch& scratch);
void ToMessage(const RobotTarget& sample, nsim_msgs_RobotTarget& msg, ConvertScratch& scratch);
void ToMessage(const SimStatus& sample, nsim_msgs_SimStatus& msg, ConvertScratch& scratch);

/// Fills `sample` from a received message. Returns an empty string if the message is valid,
/// otherwise what is wrong with it (a NaN, a non-unit quaternion, an unknown enum value); the
/// reader then drops it and counts it.
std::string FromMessage(const nsim_msgs_SensorFrame& msg, SensorFrame& sample);
std::string FromMessage(const nsim_msgs_RobotTarget& msg, RobotTarget& sample);
std::string FromMessage(const nsim_msgs_SimStatus& msg, SimStatus& sample);

}  // namespace nsim::transport
