// LossyLink: the share lost is the probability asked for (binomial bounds), the draws are
// reproducible from the seed and differ between streams, 0 and 100 % lose nothing and
// everything, and a percentage outside [0, 100] is refused with a message naming it.
#include "common/core/lossy_link.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/core/error.h"

namespace nsim {
namespace {

std::vector<bool> Draws(LossyLink link, int n) {
  std::vector<bool> lost(n);
  for (int i = 0; i < n; ++i) lost[i] = link.Drop();
  return lost;
}

TEST(LossyLink, LosesTheShareAskedForWithinBinomialBounds) {
  for (double percent : {1.0, 5.0, 20.0, 50.0}) {
    LossyLink link(percent, 7, 1);
    const int n = 100000;
    for (int i = 0; i < n; ++i) link.Drop();
    const double p = percent / 100.0;
    const double sd = std::sqrt(n * p * (1 - p));
    EXPECT_EQ(link.sent(), static_cast<uint64_t>(n));
    EXPECT_NEAR(static_cast<double>(link.lost()), n * p, 5 * sd) << percent << " %";
  }
}

TEST(LossyLink, LossesAreIndependentOfTheLastOne) {
  // a run of losses is as likely after a loss as after a delivery (no burst structure)
  LossyLink link(30.0, 11, 2);
  const int n = 200000;
  int after_loss = 0, lost_after_loss = 0, after_delivery = 0, lost_after_delivery = 0;
  bool previous = link.Drop();
  for (int i = 1; i < n; ++i) {
    const bool lost = link.Drop();
    (previous ? after_loss : after_delivery) += 1;
    (previous ? lost_after_loss : lost_after_delivery) += lost ? 1 : 0;
    previous = lost;
  }
  const double a = static_cast<double>(lost_after_loss) / after_loss;
  const double b = static_cast<double>(lost_after_delivery) / after_delivery;
  EXPECT_NEAR(a, 0.3, 0.01);
  EXPECT_NEAR(b, 0.3, 0.01);
}

TEST(LossyLink, TheSameSeedAndStreamGiveTheSameLossesAndOthersDiffer) {
  const std::vector<bool> a = Draws(LossyLink(10.0, 42, 1), 2000);
  EXPECT_EQ(a, Draws(LossyLink(10.0, 42, 1), 2000));
  EXPECT_NE(a, Draws(LossyLink(10.0, 42, 2), 2000));  // the other stream of the same run
  EXPECT_NE(a, Draws(LossyLink(10.0, 43, 1), 2000));  // the next seed
}

TEST(LossyLink, NoneAndAllAreExact) {
  LossyLink none(0.0, 1, 1), all(100.0, 1, 1);
  for (int i = 0; i < 10000; ++i) {
    EXPECT_FALSE(none.Drop());
    EXPECT_TRUE(all.Drop());
  }
  EXPECT_EQ(none.lost(), 0u);
  EXPECT_EQ(all.lost(), 10000u);
}

TEST(LossyLink, APercentageOutsideZeroToHundredIsRefusedByName) {
  for (double bad : {-1.0, 100.5, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()}) {
    try {
      LossyLink link(bad, 1, 1, "--loss");
      ADD_FAILURE() << bad << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--loss must be in [0, 100] (percent)"),
                std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace nsim
