#pragma once
// direct_sim's wait for its ROS 2 subscribers (--ros2-wait) before its first message, so that
// a ROS 2 recorder started before it records a run or a replay from its first frame.

#include <string>
#include <vector>

#include "messages/ros2.h"

namespace nsim {

/// Waits until `count` subscribers of each of `topics` are matched on `mirror`, then `settle_s`
/// more: the subscribers must know this writer too, and a ROS 2 node does not say when it does
/// (a volatile subscriber drops what comes before). False, after a message on stderr naming the
/// topic and `who` (the command), when `timeout_s` passed first. count 0: returns at once.
bool WaitForRos2Subscribers(const transport::Ros2Mirror& mirror, int count,
                            const std::vector<const char*>& topics, double timeout_s,
                            double settle_s, const std::string& who);

}  // namespace nsim
