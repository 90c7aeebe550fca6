#include "common/scenario/robot_reader.h"

namespace nsim {

const std::vector<std::string>& RobotLimitKeys() {
  static const std::vector<std::string> keys = {
      "max_linear_speed",        "max_angular_speed", "max_linear_acceleration",
      "max_angular_acceleration", "workspace_min",     "workspace_max"};
  return keys;
}

void ReadRobotLimits(const YamlReader& node, CartesianRobotConfig* config) {
  node.Read("max_linear_speed", &config->max_linear_speed);
  node.Read("max_angular_speed", &config->max_angular_speed);
  node.Read("max_linear_acceleration", &config->max_linear_acceleration);
  node.Read("max_angular_acceleration", &config->max_angular_acceleration);
  node.Read("workspace_min", &config->workspace_min_W);
  node.Read("workspace_max", &config->workspace_max_W);
}

}  // namespace nsim
