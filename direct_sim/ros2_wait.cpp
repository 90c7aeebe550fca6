#include "direct_sim/ros2_wait.h"

#include <iostream>

#include "common/core/clock.h"

namespace nsim {

bool WaitForRos2Subscribers(const transport::Ros2Mirror& mirror, int count,
                            const std::vector<const char*>& topics, double timeout_s,
                            double settle_s, const std::string& who) {
  if (count <= 0) return true;
  if (const std::string short_of = mirror.WaitForSubscribers(count, topics, timeout_s);
      !short_of.empty()) {
    std::cerr << who << ": fewer than " << count << " ROS 2 subscriber(s) of " << short_of
              << " after " << timeout_s
              << " s (is it on the same domain, --domain or ROS_DOMAIN_ID?)\n";
    return false;
  }
  SleepUntilMonotonic(MonotonicSeconds() + settle_s);
  return true;
}

}  // namespace nsim
