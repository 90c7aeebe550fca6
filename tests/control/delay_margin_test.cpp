// The delayed integrator's gain limit against the roots of its characteristic polynomial
// (eigenvalues of the companion matrix) and against the recursion itself.
#include "common/control/delay_margin.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace nsim {
namespace {

// the largest root modulus of z^(d+1) - z^d + g
double LargestRoot(int d, double g) {
  const int n = d + 1;
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
  // monic z^n + c_{n-1} z^(n-1) + ... + c_0 with c_{n-1} = -1, c_0 = g (n = 1: z - 1 + g)
  Eigen::VectorXd c = Eigen::VectorXd::Zero(n);
  c[n - 1] = -1.0;
  c[0] += g;
  for (int i = 1; i < n; ++i) companion(i, i - 1) = 1.0;
  companion.col(n - 1) = -c;
  return companion.eigenvalues().cwiseAbs().maxCoeff();
}

// |eps| after `steps` of eps(k+1) = eps(k) - g eps(k - d) from eps = 1 everywhere (or once it
// passed 1e6)
double RecursionAfter(int d, double g, int steps) {
  std::vector<double> eps(d + 1, 1.0);
  for (int k = 0; k < steps && std::abs(eps.back()) < 1e6; ++k)
    eps.push_back(eps.back() - g * eps[eps.size() - 1 - d]);
  return std::abs(eps.back()) + std::abs(eps[eps.size() - 2]);
}

TEST(DelayMargin, TheLimitIsWhereTheRootsLeaveTheUnitCircle) {
  for (int d = 0; d <= 12; ++d) {
    const double limit = CalcDelayedIntegratorGainLimit(d);
    EXPECT_LT(LargestRoot(d, 0.99 * limit), 1.0) << d;
    EXPECT_GT(LargestRoot(d, 1.01 * limit), 1.0) << d;
    EXPECT_NEAR(LargestRoot(d, limit), 1.0, 1e-9) << d;
    EXPECT_LT(RecursionAfter(d, 0.98 * limit, 20000), 1e-3) << d;
    EXPECT_GT(RecursionAfter(d, 1.02 * limit, 20000), 1e3) << d;
  }
  EXPECT_NEAR(CalcDelayedIntegratorGainLimit(0), 2.0, 1e-15);
  EXPECT_NEAR(CalcDelayedIntegratorGainLimit(1), 1.0, 1e-15);
  EXPECT_NEAR(CalcDelayedIntegratorGainLimit(5), 0.2846, 1e-4);
}

TEST(DelayMargin, TheGainIsCappedOnlyWhereTheMarginAsks) {
  EXPECT_EQ(LimitGainForDelay(0.2, 1, 2.0), 0.2);
  EXPECT_EQ(LimitGainForDelay(0.2, 3, 2.0), 0.2);  // 0.445 / 2 = 0.2225
  EXPECT_NEAR(LimitGainForDelay(0.2, 5, 2.0), 0.1423, 1e-4);
  EXPECT_NEAR(LimitGainForDelay(0.2, 10, 2.0), 0.0747, 1e-4);
  EXPECT_THROW(CalcDelayedIntegratorGainLimit(-1), std::invalid_argument);
  EXPECT_THROW(LimitGainForDelay(0.2, 1, 0.5), std::invalid_argument);
}

}  // namespace
}  // namespace nsim
