// The physics watchdog: each bound against a state built to break it (and only it), the
// inverted-element count against elements inverted by hand, and the patient loop: no fault in
// the thesis's breathing scene, a fault naming the bound when the bound is below the
// breathing's own motion.
#include "common/scene/physics_watchdog.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/core/error.h"
#include "common/mesh/tet_mesh.h"
#include "common/scene/patient_loop.h"
#include "tests/scene/scene_test_util.h"

namespace nsim {
namespace {

struct Box {
  Box() : mesh(MakeBoxTetMesh({3, 3, 3}, {0.1, 0.1, 0.1}, Eigen::Vector3d::Zero())),
          model(mesh, FemConfig{}), state(model) {}
  TetMesh mesh;
  FemModel model;
  FemState state;
};

struct Fixture {
  Eigen::Vector3d target = Eigen::Vector3d(0.01, 0.02, 0.03);
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> markers = {Eigen::Vector3d(0.0, 0.0, 0.05),
                                          Eigen::Vector3d(0.05, 0.0, 0.0)};
  Box liver;

  WatchdogInput Input(int64_t step = 0) {
    WatchdogInput in;
    in.step = step;
    in.target = &target;
    in.markers = &markers;
    in.tip = &tip;
    in.liver = &liver.model;
    in.liver_state = &liver.state;
    return in;
  }
};

TEST(PhysicsWatchdogTest, ARestStateIsPlausible) {
  Fixture f;
  const PhysicsWatchdog dog(WatchdogConfig{}, f.target, f.markers);
  EXPECT_EQ(dog.Check(f.Input()), "");
  EXPECT_EQ(CountInvertedTets(f.liver.model, f.liver.state), 0);
}

TEST(PhysicsWatchdogTest, TheTargetOrAMarkerFarFromRestIsNamed) {
  Fixture f;
  WatchdogConfig c;
  c.max_displacement = 0.05;
  const PhysicsWatchdog dog(c, f.target, f.markers);
  f.target.x() += 0.049;
  EXPECT_EQ(dog.Check(f.Input()), "");
  f.target.x() += 0.002;
  const std::string why = dog.Check(f.Input());
  EXPECT_NE(why.find("target moved 51"), std::string::npos) << why;
  EXPECT_NE(why.find("watchdog.max_displacement 50 mm"), std::string::npos) << why;
  f.target.x() -= 0.051;
  f.markers[1].z() -= 0.2;
  EXPECT_NE(dog.Check(f.Input()).find("marker 1 moved 200"), std::string::npos);
}

TEST(PhysicsWatchdogTest, ExplodingKineticEnergyIsNamed) {
  Fixture f;
  WatchdogConfig c;
  c.max_kinetic_energy = 1.0;
  const PhysicsWatchdog dog(c, f.target, f.markers);
  // uniform speed v: E = m v^2 / 2 with the box's total (lumped) mass
  const double m = f.liver.model.get_total_mass();
  f.liver.state.v.setZero();
  f.liver.state.v.row(0).setConstant(std::sqrt(2.0 * 0.99 / m));
  EXPECT_EQ(dog.Check(f.Input()), "");
  f.liver.state.v.row(0).setConstant(std::sqrt(2.0 * 1.01 / m));
  const std::string why = dog.Check(f.Input());
  EXPECT_NE(why.find("liver's kinetic energy is 1.01"), std::string::npos) << why;
}

TEST(PhysicsWatchdogTest, InvertedElementsAreCountedAndNamed) {
  Fixture f;
  const PhysicsWatchdog dog(WatchdogConfig{}, f.target, f.markers);
  // a mirror image of the whole mesh inverts every element; a rigid rotation inverts none
  Eigen::Matrix3d mirror = Eigen::Matrix3d::Identity();
  mirror(0, 0) = -1.0;
  const Eigen::Matrix3Xd rest = f.liver.state.x;
  f.liver.state.x =
      Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix() * rest;
  EXPECT_EQ(CountInvertedTets(f.liver.model, f.liver.state), 0);
  f.liver.state.x = mirror * rest;
  EXPECT_EQ(CountInvertedTets(f.liver.model, f.liver.state), f.liver.model.num_tets());
  // one corner node pushed through the opposite faces of its elements
  f.liver.state.x = rest;
  f.liver.state.x.col(0) = Eigen::Vector3d(0.2, 0.2, 0.2);
  const int inverted = CountInvertedTets(f.liver.model, f.liver.state);
  EXPECT_GT(inverted, 0);
  EXPECT_LT(inverted, f.liver.model.num_tets());
  const std::string why = dog.Check(f.Input());
  EXPECT_NE(why.find("liver element"), std::string::npos) << why;
  EXPECT_NE(why.find("inverted"), std::string::npos) << why;
  // checked only every N steps when asked so
  WatchdogConfig sparse;
  sparse.inversion_check_every = 10;
  const PhysicsWatchdog lazy(sparse, f.target, f.markers);
  EXPECT_EQ(lazy.Check(f.Input(3)), "");
  EXPECT_NE(lazy.Check(f.Input(20)), "");
}

TEST(PhysicsWatchdogTest, NonFiniteValuesAreCaughtEvenWhenDisabled) {
  Fixture f;
  WatchdogConfig off;
  off.enabled = false;
  const PhysicsWatchdog dog(off, f.target, f.markers);
  f.target.x() += 10.0;  // far, but the bounds are off
  EXPECT_EQ(dog.Check(f.Input()), "");
  f.markers[0].y() = std::nan("");
  EXPECT_EQ(dog.Check(f.Input()), "marker 0 is not finite");
  f.markers[0].y() = 0.0;
  f.tip.z() = INFINITY;
  EXPECT_EQ(dog.Check(f.Input()), "the needle tip position is not finite");
}

TEST(PhysicsWatchdogTest, BadBoundsAreRefusedWithTheirKey) {
  for (const auto& [set, key] : std::vector<std::pair<void (*)(WatchdogConfig&), std::string>>{
           {[](WatchdogConfig& c) { c.max_displacement = 0.0; }, "watchdog.max_displacement"},
           {[](WatchdogConfig& c) { c.max_displacement = 5.0; }, "watchdog.max_displacement"},
           {[](WatchdogConfig& c) { c.max_kinetic_energy = NAN; }, "watchdog.max_kinetic_energy"},
           {[](WatchdogConfig& c) { c.inversion_check_every = -1; },
            "watchdog.inversion_check_every"}}) {
    WatchdogConfig c;
    set(c);
    try {
      c.Validate();
      ADD_FAILURE() << key << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

TEST(PhysicsWatchdogTest, TheBreathingSceneIsPlausibleAndATighterBoundThanItsMotionIsNot) {
  const DirectScenario s = testing::LoadCoarseScenario();
  PatientLoop loop(s.LoopConfig(false), s.liver_mesh, s.skin_mesh);
  for (int k = 0; k < 150; ++k) loop.Step();  // 3 s: the needle through the skin, breathing
  EXPECT_TRUE(loop.healthy()) << loop.fault();

  // the breathing moves the liver about 12 mm: a 2 mm bound is broken within the first cycle
  PatientLoopConfig tight = s.LoopConfig(false);
  tight.watchdog.max_displacement = 0.002;
  PatientLoop strict(tight, s.liver_mesh, s.skin_mesh);
  int k = 0;
  for (; k < 250 && strict.healthy(); ++k) strict.Step();
  ASSERT_FALSE(strict.healthy()) << "no fault in 5 s";
  EXPECT_NE(strict.fault().find("watchdog.max_displacement 2 mm"), std::string::npos)
      << strict.fault();
  EXPECT_GT(k, 1);
}

}  // namespace
}  // namespace nsim
