#pragma once
// The robot's motion limits in a scenario's `robot:` section (max_linear_speed,
// max_angular_speed, max_linear_acceleration, max_angular_acceleration, workspace_min,
// workspace_max). Read by both processes' loaders: direct_sim moves its robot under them, and
// inverse_sim forecasts where the commands in flight will have taken it
// (prediction.model_pose: expected, common/robot/motion_forecast.h).

#include "common/core/yaml_reader.h"
#include "common/robot/cartesian_robot.h"

namespace nsim {

/// The keys of the section that ReadRobotLimits reads.
const std::vector<std::string>& RobotLimitKeys();

/// Reads the limit keys present in `node` into `config` (the others keep their values); does
/// not check for unknown keys (the caller's section may have more). InputError naming the key
/// for a malformed value.
void ReadRobotLimits(const YamlReader& node, CartesianRobotConfig* config);

}  // namespace nsim
