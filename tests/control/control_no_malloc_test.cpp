// The regularized inverses under Eigen's allocation guard (built with EIGEN_RUNTIME_NO_MALLOC
// and eigen_assert enabled, the library sources compiled into this test): once the output has
// its size, computing J_r^+ or the damped least-squares inverse allocates nothing.

#include <gtest/gtest.h>

#include <Eigen/Core>

#include "common/control/regularized_inverse.h"

namespace nsim {
namespace {

struct NoMalloc {
  NoMalloc() { Eigen::internal::set_is_malloc_allowed(false); }
  ~NoMalloc() { Eigen::internal::set_is_malloc_allowed(true); }
};

TEST(ControlNoMalloc, GuardIsActive) {
  EXPECT_DEATH(
      {
        NoMalloc guard;
        Eigen::MatrixXd m(50, 50);
        m.setZero();
      },
      "heap allocation is forbidden");
}

TEST(ControlNoMalloc, RegularizedInverses) {
  for (const auto& [m, n] : {std::pair{6, 6}, std::pair{5, 7}, std::pair{4, 6}}) {
    const Eigen::MatrixXd J = Eigen::MatrixXd::Random(m, n);
    Eigen::MatrixXd out(n, m);
    {
      NoMalloc guard;
      CalcTikhonovPseudoInverse(J, 1e-6, &out);
      CalcTikhonovPseudoInverse(J, 1e-6, &out, TikhonovForm::kLiteralAdditive);
      CalcDampedLeastSquaresInverse(J, 1e-3, &out);
    }
    EXPECT_TRUE(out.allFinite());
  }
}

}  // namespace
}  // namespace nsim
