// The exhale gate against a breathing curve whose exhale rest is known in closed form:
// p(t) = p0 + s b cos^4(pi t / T) d, a tilted direction d, rest (cos^4 ~ 0) at p0. The band
// within 10 % of the range from the rest is cos^4 <= 0.1, entered at
// t = T acos(0.1^(1/4)) / pi + k T; the gate must report exactly the first sample at or after
// each such time once its history is full, whichever extreme the rest is, and nothing else.
#include "common/prediction/exhale_gate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr double kPeriod = 4.0, kRate = 50.0, kAmplitude = 0.012;

std::vector<double> GateTimes(double sign, double duration) {
  ExhaleGateConfig config;  // capacity 300 frames: 6 s, more than a period
  ExhaleGate gate(config);
  const Eigen::Vector3d p0(0.01, -0.02, 0.05), d = Eigen::Vector3d(0.2, 0.3, 1.0).normalized();
  std::vector<double> times;
  for (int k = 0; k < static_cast<int>(duration * kRate); ++k) {
    const double t = k / kRate;
    const double c = std::cos(M_PI * t / kPeriod);
    if (gate.Add(t, p0 + sign * kAmplitude * c * c * c * c * d)) times.push_back(t);
  }
  EXPECT_NEAR(gate.range(), kAmplitude, 1e-9);
  return times;
}

TEST(ExhaleGateTest, OpensWhereTheBreathingEntersItsExhaleRest) {
  const double entry = kPeriod * std::acos(std::pow(0.1, 0.25)) / M_PI;  // 1.2396 s
  for (double sign : {-1.0, 1.0}) {  // the rest at the high or the low extreme
    const std::vector<double> times = GateTimes(sign, 22.0);
    // history full at t = 5.98 s: the entries at 9.24, 13.24, 17.24 and 21.24 s
    ASSERT_EQ(times.size(), 4u) << "sign " << sign;
    for (size_t i = 0; i < times.size(); ++i) {
      const double expected = std::ceil((entry + (i + 2) * kPeriod) * kRate - 1e-9) / kRate;
      EXPECT_NEAR(times[i], expected, 1e-9) << "sign " << sign << ", entry " << i;
    }
  }
}

TEST(ExhaleGateTest, WithoutBreathingItOpensOnceTheHistoryIsFull) {
  ExhaleGate gate(ExhaleGateConfig{});
  for (int k = 0; k < 299; ++k) EXPECT_FALSE(gate.Add(k / kRate, Eigen::Vector3d(0, 0, 0.05)));
  EXPECT_TRUE(gate.Add(299 / kRate, Eigen::Vector3d(0, 0, 0.05)));
  EXPECT_EQ(gate.range(), 0.0);
}

TEST(ExhaleGateTest, RefusesABadConfigByName) {
  ExhaleGateConfig c;
  c.band = 0.5;
  EXPECT_THROW(
      {
        try {
          ExhaleGate gate(c);
        } catch (const InputError& e) {
          EXPECT_NE(std::string(e.what()).find("band must be in (0, 0.5), got 0.5"),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      InputError);
  c = ExhaleGateConfig{};
  c.capacity = 2;
  EXPECT_THROW(ExhaleGate{c}, InputError);
}

}  // namespace
}  // namespace nsim
