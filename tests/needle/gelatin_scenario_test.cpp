#include "common/needle/gelatin_scenario.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "common/core/error.h"

namespace nsim {
namespace {

// mirror symmetry is broken only by the Kuhn tetrahedra of the box mesh: 1 %
constexpr double kMirrorRelTol = 0.01;
// a symmetric tip: below 0.1 % of the beveled deflection
constexpr double kSymmetricRelTol = 1e-3;
// a deflection that counts as a curve (m)
constexpr double kClearDeflection = 1e-3;

TEST(GelatinScenarioTest, DeflectionTableAndMirrorSymmetry) {
  // the thesis scenario (30 x 15 x 5 nodes, 20 cm needle, table 5.3 bevel)
  GelatinBevelScenarioConfig config;
  std::printf("beta/alpha  Q (N)     M (mN m)   deflection Y (mm)\n");
  double dy09 = 0.0, previous_abs = -1.0, previous_m = -1.0;
  for (double ratio : {0.5, 0.25, 0.9, 1.0}) {  // increasing |M|
    config.bevel.beta_over_alpha = ratio;
    config.bevel_angle = 0.0;
    const GelatinBevelResult a = RunGelatinBevelScenario(config);
    std::printf("%10.2f  %8.4f  %9.4f  %17.3f\n", ratio, a.bevel_q, a.bevel_m * 1e3,
                a.tip_deflection_y * 1e3);
    EXPECT_TRUE(a.punctured);
    EXPECT_NEAR(a.depth, config.insertion_depth, 1e-3);
    // the tip stays in the insertion plane
    EXPECT_LT(std::abs(a.tip_deflection_z), 1e-3 * std::abs(a.tip_deflection_y) + 1e-7);
    if (ratio == 0.9) {
      // rolling the bevel by pi mirrors the curve
      config.bevel_angle = M_PI;
      const GelatinBevelResult b = RunGelatinBevelScenario(config);
      std::printf("      bevel rolled by pi: %.3f mm\n", b.tip_deflection_y * 1e3);
      EXPECT_NEAR(b.tip_deflection_y, -a.tip_deflection_y,
                  kMirrorRelTol * std::abs(a.tip_deflection_y));
    }
    // the curve grows with |M| and goes to the side M turns the tip to: M < 0 is +y_B
    EXPECT_GT(std::abs(a.tip_deflection_y), previous_abs);
    EXPECT_GT(std::abs(a.bevel_m), previous_m);
    previous_abs = std::abs(a.tip_deflection_y);
    previous_m = std::abs(a.bevel_m);
    if (std::abs(a.bevel_m) > 1e-4) {
      EXPECT_GT(std::abs(a.tip_deflection_y), kClearDeflection);
      EXPECT_EQ(a.tip_deflection_y > 0.0, a.bevel_m < 0.0);
    }
    if (ratio == 0.9) dy09 = a.tip_deflection_y;
  }
  // thesis §5.3.1: about 10 mm towards the bevel side at beta/alpha = 0.9
  EXPECT_GT(dy09, 5e-3);
  EXPECT_LT(dy09, 20e-3);

  config.bevel.enabled = false;
  config.bevel_angle = 0.0;
  const GelatinBevelResult sym = RunGelatinBevelScenario(config);
  std::printf("symmetric tip: deflection Y %.6f mm\n", sym.tip_deflection_y * 1e3);
  EXPECT_LT(std::abs(sym.tip_deflection_y), kSymmetricRelTol * std::abs(dy09));
  EXPECT_EQ(sym.num_points, 3);  // entry, 3.5 cm, 7 cm
}

TEST(GelatinScenarioTest, DefaultsMatchTheThesis) {
  const GelatinBevelScenarioConfig c;
  EXPECT_EQ(c.block_nodes, Eigen::Vector3i(30, 15, 5));
  EXPECT_DOUBLE_EQ(c.needle.needle.length, 0.2);
  EXPECT_DOUBLE_EQ(c.needle.needle.radius, 0.6e-3);
  EXPECT_DOUBLE_EQ(c.bevel.diameter, 1.2e-3);
  EXPECT_DOUBLE_EQ(c.bevel.bevel_angle, 0.2617);
  EXPECT_DOUBLE_EQ(c.bevel.tissue_stiffness, 150e3);
  EXPECT_DOUBLE_EQ(c.bevel.beta_over_alpha, 0.9);
  EXPECT_DOUBLE_EQ(c.coupling.point_spacing, 0.035);
  EXPECT_DOUBLE_EQ(c.gelatin.poisson_ratio, 0.45);
}

TEST(GelatinScenarioTest, BadConfigNamesTheKey) {
  GelatinBevelScenarioConfig c;
  c.insertion_depth = 0.5;
  try {
    RunGelatinBevelScenario(c);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("gelatin.insertion_depth"), std::string::npos);
  }
  c = GelatinBevelScenarioConfig{};
  c.needle.time_step = 0.01;
  EXPECT_THROW(c.Validate(), InputError);
  c = GelatinBevelScenarioConfig{};
  c.coupling.point_spacing = -1;
  EXPECT_THROW(c.Validate(), InputError);
}

}  // namespace
}  // namespace nsim
