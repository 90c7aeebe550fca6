#pragma once
// The facts of a scenario that both processes must agree on, written once in the scenario's
// `shared:` section and read by both loaders: the fiducial markers at rest, the planned entry
// and target, the approach distance, the needle's geometry on the flange and the robot's base
// pose. Its hash travels in every SimStatus, and each process refuses a peer whose hash
// differs (the start handshake), so the two sides cannot run different plans unnoticed.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "common/core/yaml_reader.h"

namespace nsim {

/// The shared part of a scenario. SI units, world frame W (the liver mesh frame).
struct SharedScenario {
  std::vector<Eigen::Vector3d> markers_W;  ///< fiducial markers in the liver at rest (m), >= 1
  Eigen::Vector3d entry_W = Eigen::Vector3d::Zero();   ///< planned skin entry (m)
  Eigen::Vector3d target_W = Eigen::Vector3d::Zero();  ///< target (tumour) at rest (m)
  double approach_distance = 0.01;  ///< the tip starts this far before the entry (m), >= 0
  double needle_length = 0.13;      ///< base to tip (m), > 0
  double needle_radius = 0.723e-3;  ///< outer radius (m), > 0
  Eigen::Vector3d tool_offset_F = Eigen::Vector3d::Zero();  ///< needle base in the flange (m)
  Eigen::Vector3d axis_F = Eigen::Vector3d::UnitZ();        ///< needle direction in the flange
  /// The iiwa's base pose X_WB (used when robot.type is iiwa / controller.dof joint7).
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();

  /// Throws InputError "shared.<key> ..." for the first invalid value.
  void Validate() const;
};

/// Reads the `shared:` section (required keys: markers, entry, target). InputError
/// "<file>: shared.<key>: ..." on a missing, malformed or unknown key.
SharedScenario ReadSharedScenario(const YamlReader& root);

/// A 64-bit FNV-1a hash of the canonical text of `shared` (every number with 17 significant
/// digits, so equal values give equal hashes on any machine and any difference changes it);
/// never 0.
uint64_t ScenarioHash(const SharedScenario& shared);

/// The canonical text that ScenarioHash hashes (for messages and tests).
std::string CanonicalText(const SharedScenario& shared);

/// Fails (InputError "<file>: <section>.<key>: moved to shared.<new key>") when `node`, the
/// section `section`, has one of the keys that moved to `shared:` (older scenario files).
void RejectKeysMovedToShared(const YamlReader& node, const std::string& section);

}  // namespace nsim
