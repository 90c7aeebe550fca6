#include "common/fem/fem_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/core/error.h"

namespace nsim {
namespace {

// relative tolerance for closed-form material constants (a few ulps of arithmetic)
constexpr double kFormulaTol = 1e-14;

TEST(FemConfigTest, DefaultsAreValidLiver) {
  FemConfig config;
  EXPECT_NO_THROW(config.Validate());
  EXPECT_EQ(config.density, 1060.0);
  EXPECT_EQ(config.young_modulus, 5500.0);
  EXPECT_FALSE(config.background_refactor);  // in-step refresh (see fem_config.h)
  EXPECT_EQ(config.refactor_adopt_delay, 3);
  EXPECT_EQ(config.refactor_slice, 0.0);
  EXPECT_EQ(config.refactor_hold_steps, 0);  // never held unless a scenario asks
}

std::string ValidateMessage(const FemConfig& config) {
  try {
    config.Validate();
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

TEST(FemConfigTest, RejectsBadValuesWithKeyAndValue) {
  FemConfig config;
  config.young_modulus = -3;
  EXPECT_EQ(ValidateMessage(config), "fem.young_modulus must be > 0 (Pa), got -3");
  config = FemConfig{};
  config.poisson_ratio = 0.5;
  EXPECT_EQ(ValidateMessage(config), "fem.poisson_ratio must be in (-1, 0.5), got 0.5");
  config = FemConfig{};
  config.density = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ValidateMessage(config), "fem.density must be > 0 (kg/m^3), got nan");
  config = FemConfig{};
  config.time_step = 0;
  EXPECT_EQ(ValidateMessage(config), "fem.time_step must be > 0 (s), got 0");
  config = FemConfig{};
  config.rayleigh_mass = -0.1;
  EXPECT_EQ(ValidateMessage(config), "fem.rayleigh_mass must be >= 0 (1/s), got -0.1");
  config = FemConfig{};
  config.rayleigh_stiffness = -1;
  EXPECT_EQ(ValidateMessage(config), "fem.rayleigh_stiffness must be >= 0 (s), got -1");
  config = FemConfig{};
  config.cg_relative_tolerance = 0;
  EXPECT_EQ(ValidateMessage(config), "fem.cg_relative_tolerance must be in (0, 1), got 0");
  config = FemConfig{};
  config.cg_max_iterations = 0;
  EXPECT_EQ(ValidateMessage(config), "fem.cg_max_iterations must be >= 1, got 0");
  config = FemConfig{};
  config.refactor_adopt_delay = 0;
  EXPECT_EQ(ValidateMessage(config), "fem.refactor_adopt_delay must be >= 1 (steps), got 0");
  config = FemConfig{};
  config.refactor_slice = -0.001;
  EXPECT_EQ(ValidateMessage(config), "fem.refactor_slice must be in [0, 1] (s), got -0.001");
  config.refactor_slice = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ValidateMessage(config), "fem.refactor_slice must be in [0, 1] (s), got nan");
  config = FemConfig{};
  config.refactor_hold_steps = -3;
  EXPECT_EQ(ValidateMessage(config), "fem.refactor_hold_steps must be >= 0 (steps), got -3");
  config.refactor_hold_steps = 2000000;
  EXPECT_EQ(ValidateMessage(config), "fem.refactor_hold_steps must be <= 1e+06 (steps), got 2e+06");
  config = FemConfig{};
  config.gravity.x() = std::numeric_limits<double>::infinity();
  EXPECT_NE(ValidateMessage(config).find("fem.gravity must be finite"), std::string::npos);
}

TEST(FemConfigTest, ParsesSolverNames) {
  EXPECT_EQ(ParseFemLinearSolver("direct", "fem.linear_solver"), FemLinearSolver::kDirect);
  EXPECT_EQ(ParseFemLinearSolver("pcg_cached_factor", "fem.linear_solver"),
            FemLinearSolver::kPcgCachedFactor);
  try {
    ParseFemLinearSolver("cg", "fem.linear_solver");
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(),
                 "fem.linear_solver must be \"direct\" or \"pcg_cached_factor\", got \"cg\"");
  }
}

TEST(FemConfigTest, LameParametersOfLiver) {
  // E = 5.5 kPa, nu = 0.45: mu = E / 2.9, lambda = E 0.45 / (1.45 0.1)
  const LameParameters lame = CalcLameParameters(5500.0, 0.45);
  EXPECT_NEAR(lame.mu, 5500.0 / 2.9, kFormulaTol * 5500.0);
  EXPECT_NEAR(lame.lambda, 5500.0 * 0.45 / 0.145, kFormulaTol * 1e5);
  // independent relations: bulk modulus E / (3 (1 - 2 nu)) = lambda + 2 mu / 3, and
  // nu = lambda / (2 (lambda + mu))
  EXPECT_NEAR(lame.lambda + 2.0 * lame.mu / 3.0, 5500.0 / (3.0 * 0.1), kFormulaTol * 1e5);
  EXPECT_NEAR(lame.lambda / (2.0 * (lame.lambda + lame.mu)), 0.45, kFormulaTol);
  // nu = 0: no lateral coupling, mu = E / 2
  const LameParameters zero = CalcLameParameters(1e6, 0.0);
  EXPECT_EQ(zero.lambda, 0.0);
  EXPECT_NEAR(zero.mu, 0.5e6, kFormulaTol * 1e6);
}

}  // namespace
}  // namespace nsim
