// The robot's hot functions under Eigen's allocation guard (built with EIGEN_RUNTIME_NO_MALLOC
// and eigen_assert enabled, the library sources compiled into this test): any Eigen heap
// allocation aborts. Covered: iiwa forward kinematics and Jacobian, IK (including restarts),
// the Cartesian and joint interpolator steps.

#include <gtest/gtest.h>

#include <Eigen/Core>

#include "common/robot/cartesian_robot.h"
#include "common/robot/iiwa14.h"
#include "common/robot/iiwa14_ik.h"
#include "common/robot/joint_interpolator.h"

namespace nsim {
namespace {

// scoped guard: allocation forbidden while alive
struct NoMalloc {
  NoMalloc() { Eigen::internal::set_is_malloc_allowed(false); }
  ~NoMalloc() { Eigen::internal::set_is_malloc_allowed(true); }
};

TEST(RobotNoMalloc, GuardIsActive) {
  // the guard must really abort on an allocation, else the tests below prove nothing
  EXPECT_DEATH(
      {
        NoMalloc guard;
        Eigen::MatrixXd m(50, 50);
        m.setZero();
      },
      "heap allocation is forbidden");
}

TEST(RobotNoMalloc, KinematicsIkAndInterpolators) {
  const Iiwa14Model model;
  const Iiwa14InverseKinematics ik(model, Iiwa14IkConfig());
  const CartesianRobot robot{CartesianRobotConfig()};
  const JointInterpolator interp(model);
  const Vector7d q = (Vector7d() << 0.2, 0.5, -0.3, -1.0, 0.4, 0.8, 0.1).finished();
  const Eigen::Isometry3d X_target = model.CalcToolPose(q);
  Eigen::Isometry3d unreachable = Eigen::Isometry3d::Identity();
  unreachable.translation() = Eigen::Vector3d(3, 0, 0);
  CartesianRobotState cs = robot.MakeState(Eigen::Isometry3d::Identity());
  JointState js = interp.MakeState(Vector7d::Zero());
  Iiwa14Kinematics kin;
  Jacobian67 J;
  NoMalloc guard;
  model.CalcForwardKinematics(q, &kin);
  model.CalcToolJacobian(kin, &J);
  const Iiwa14IkResult r = ik.Solve(X_target, Vector7d::Zero());
  const Iiwa14IkResult bad = ik.Solve(unreachable, Vector7d::Zero());  // all restarts
  for (int i = 0; i < 100; ++i) {
    robot.Step(X_target, 0.01, &cs);
    interp.Step(q, 0.01, &js);
  }
  EXPECT_TRUE(r.success);
  EXPECT_FALSE(bad.success);
  EXPECT_TRUE(J.allFinite());
}

}  // namespace
}  // namespace nsim
