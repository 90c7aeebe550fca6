#include "common/mesh/oriented_box.h"

#include <gtest/gtest.h>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kTol = 1e-12;

OrientedBox MakeBox() {
  OrientedBox box;
  box.center = Eigen::Vector3d(1, 2, 3);
  box.half_size = Eigen::Vector3d(0.1, 0.2, 0.3);
  box.R_WB = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  return box;
}

TEST(BoxTest, SignedDistanceOutsideFaceEdgeAndInside) {
  const OrientedBox box = MakeBox();
  const Eigen::Matrix3d& R = box.R_WB;
  // outside a face: 0.05 beyond +x_B
  BoxProximity p = CalcBoxProximity(box, box.center + R * Eigen::Vector3d(0.15, 0.05, 0));
  EXPECT_NEAR(p.signed_distance, 0.05, kTol);
  EXPECT_TRUE(p.normal_W.isApprox(R.col(0), kTol));
  EXPECT_TRUE(p.p_W.isApprox(box.center + R * Eigen::Vector3d(0.1, 0.05, 0), kTol));
  // outside an edge: (0.03, 0.04) beyond the +x/+y edge -> distance 0.05
  p = CalcBoxProximity(box, box.center + R * Eigen::Vector3d(0.13, 0.24, 0.1));
  EXPECT_NEAR(p.signed_distance, 0.05, kTol);
  EXPECT_TRUE(p.normal_W.isApprox(R * Eigen::Vector3d(0.6, 0.8, 0), kTol));
  // inside, nearest to the -z face (0.02 deep)
  const Eigen::Vector3d q = box.center + R * Eigen::Vector3d(0.0, 0.0, -0.28);
  p = CalcBoxProximity(box, q);
  EXPECT_NEAR(p.signed_distance, -0.02, kTol);
  EXPECT_TRUE(p.normal_W.isApprox(-R.col(2), kTol));
  EXPECT_TRUE(box.Contains(q));
  EXPECT_FALSE(box.Contains(box.center + R * Eigen::Vector3d(0.15, 0, 0)));
}

TEST(BoxTest, ValidateNamesTheKey) {
  OrientedBox box = MakeBox();
  box.half_size.y() = -1;
  try {
    box.Validate("patient.ribs[1]");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("patient.ribs[1].half_size must be > 0 (m)", 0), 0u);
  }
}

}  // namespace
}  // namespace nsim
