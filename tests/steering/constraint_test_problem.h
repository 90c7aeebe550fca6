#pragma once
// The small frozen-step problem shared by constraint_reference_test and
// constraint_snapshot_test: a 6-particle spring chain, the needle pose it is captured at and a
// perturbed one, and two probes (a node, a combination of three).

#include <Eigen/Geometry>
#include <vector>

#include "common/steering/constraint_snapshot.h"
#include "tests/constraints/test_helpers.h"

namespace nsim::constraint_test {

/// 6 particles along x (1 cm apart, springs to the first and second neighbours), gravity.
inline DenseLinearBodyConfig ChainConfig() {
  return testing::MakeChainConfig(6, 0.02, 0.01, 60.0, 0.01, Eigen::Vector3d::Zero(),
                                  Eigen::Vector3d(0.0, 0.0, -9.81));
}

/// The needle pose of the capture.
inline Eigen::Isometry3d CapturedPose() {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Eigen::Vector3d(0.0, 0.001, 0.0005);
  return X;
}

/// The captured pose turned by 0.02 rad and shifted by about half a millimetre.
inline Eigen::Isometry3d PerturbedPose() {
  Eigen::Isometry3d X = CapturedPose();
  X.rotate(Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.3, 0.2, 1.0).normalized()));
  X.translation() += Eigen::Vector3d(0.0005, -0.0003, 0.0002);
  return X;
}

/// Node 2, and 0.2 x_3 + 0.5 x_4 + 0.3 x_5.
inline std::vector<SnapshotProbe> Probes() {
  std::vector<SnapshotProbe> probes(2);
  probes[0].nodes = {2};
  probes[0].weights = {1.0};
  probes[1].nodes = {3, 4, 5};
  probes[1].weights = {0.2, 0.5, 0.3};
  return probes;
}

}  // namespace nsim::constraint_test
