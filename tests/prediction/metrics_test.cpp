#include "common/prediction/metrics.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

TEST(UniformGrid, CoversTheRangeWithTheStep) {
  const std::vector<double> g = UniformGrid(1.0, 2.0, 0.25);
  ASSERT_EQ(g.size(), 5u);
  EXPECT_DOUBLE_EQ(g.back(), 2.0);
  EXPECT_EQ(UniformGrid(1.0, 1.99, 0.25).size(), 4u);
  EXPECT_THROW(UniformGrid(0, 1, 0), InputError);
  EXPECT_THROW(UniformGrid(1, 0, 0.1), InputError);
}

TEST(ResampleLinear, IsExactOnPiecewiseLinearDataAndAtTheSamples) {
  const std::vector<double> t = {0.0, 0.1, 0.35, 0.4};
  Eigen::MatrixXd y(4, 2);
  for (int i = 0; i < 4; ++i) y.row(i) << 2 * t[i] + 1, -3 * t[i];
  const std::vector<double> q = {0.0, 0.05, 0.2, 0.35, 0.4};
  const Eigen::MatrixXd r = ResampleLinear(t, y, q);
  for (size_t i = 0; i < q.size(); ++i) {
    EXPECT_NEAR(r(i, 0), 2 * q[i] + 1, 1e-15);
    EXPECT_NEAR(r(i, 1), -3 * q[i], 1e-15);
  }
}

TEST(ResampleLinear, BadInputNamesTheProblem) {
  Eigen::MatrixXd y = Eigen::MatrixXd::Zero(3, 1);
  auto message = [&](const std::vector<double>& t, const std::vector<double>& q) -> std::string {
    try {
      ResampleLinear(t, y, q);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message({0, 0.1, 0.1}, {0.05}),
            "resample: times must increase strictly; t[2] = 0.1 after t[1] = 0.1");
  EXPECT_EQ(message({0, 0.1, 0.2}, {0.3}),
            "resample: query time 0.3 s outside the samples [0, 0.2] s");
  EXPECT_EQ(message({0, std::nan(""), 0.2}, {0.1}), "resample: time 1 is not finite");
  y(1, 0) = std::nan("");
  EXPECT_EQ(message({0, 0.1, 0.2}, {0.1}), "resample: a sample value is not finite");
}

TEST(Metrics, RmsNrmsJitterAndPowerOnKnownSeries) {
  Eigen::MatrixXd reference = Eigen::MatrixXd::Zero(4, 3);
  Eigen::MatrixXd estimate = reference;
  estimate.col(0).setConstant(3);
  estimate.col(1).setConstant(4);  // every 3D error has norm 5
  EXPECT_DOUBLE_EQ(RmsError(estimate, reference), 5.0);
  Eigen::MatrixXd delayed = reference;
  delayed.col(2).setConstant(10);
  EXPECT_DOUBLE_EQ(NormalizedRmsError(estimate, delayed, reference), 0.5);
  EXPECT_DOUBLE_EQ(NormalizedRmsError(delayed, delayed, reference), 1.0);
  EXPECT_THROW(NormalizedRmsError(estimate, reference, reference), InputError);
  EXPECT_THROW(RmsError(estimate, Eigen::MatrixXd::Zero(3, 3)), InputError);

  // jitter: 0 on a line, 4a on an alternating +-a series
  Eigen::MatrixXd line(6, 1), alternating(6, 1);
  for (int i = 0; i < 6; ++i) {
    line(i, 0) = 0.5 * i - 1;
    alternating(i, 0) = i % 2 ? 0.25 : -0.25;
  }
  EXPECT_NEAR(Jitter(line), 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(Jitter(alternating), 1.0);
  EXPECT_THROW(Jitter(line.topRows(2)), InputError);
  // power of the centred alternating series: a^2
  EXPECT_DOUBLE_EQ(SignalPower(alternating), 0.0625);
}

}  // namespace
}  // namespace nsim
