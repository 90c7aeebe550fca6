// The tracker's marker noise: white Gaussian per coordinate with the configured standard
// deviation (checked statistically against its definition: mean, variance, no correlation
// between coordinates, markers or frames), reproducible from its seed, and exact markers when
// its size is 0.
#include "common/markers/tracker_noise.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/core/error.h"

namespace nsim {
namespace {

std::vector<Eigen::Vector3d> Exact(int markers) {
  std::vector<Eigen::Vector3d> p;
  for (int m = 0; m < markers; ++m) p.emplace_back(0.01 * m, -0.02 * m, 0.03 + 0.001 * m);
  return p;
}

TEST(TrackerNoiseTest, ZeroLeavesTheMarkersExact) {
  TrackerNoise noise({0.0, 7});
  const std::vector<Eigen::Vector3d> exact = Exact(5);
  for (int k = 0; k < 10; ++k) {
    std::vector<Eigen::Vector3d> p = exact;
    noise.Apply(&p);
    for (size_t m = 0; m < p.size(); ++m) EXPECT_EQ(p[m], exact[m]);
  }
}

TEST(TrackerNoiseTest, IsWhiteGaussianWithTheConfiguredStandardDeviation) {
  const double sigma = 2e-4;
  const int markers = 5, frames = 20000;
  TrackerNoise noise({sigma, 3});
  const std::vector<Eigen::Vector3d> exact = Exact(markers);
  // the normalized noise z = (measured - exact) / sigma, one column per marker coordinate
  Eigen::MatrixXd z(frames, 3 * markers);
  for (int k = 0; k < frames; ++k) {
    std::vector<Eigen::Vector3d> p = exact;
    noise.Apply(&p);
    for (int m = 0; m < markers; ++m) z.block(k, 3 * m, 1, 3) = ((p[m] - exact[m]) / sigma).transpose();
  }
  const double n = frames;
  // z ~ N(0, 1): the mean's standard error is 1 / sqrt(n), the sample variance's sqrt(2 / n);
  // every bound below is 5 standard errors (a false failure about once in 3 million a check)
  int beyond_three_sigma = 0;
  for (int c = 0; c < z.cols(); ++c) {
    const Eigen::VectorXd col = z.col(c);
    EXPECT_NEAR(col.mean(), 0.0, 5.0 / std::sqrt(n)) << "coordinate " << c;
    EXPECT_NEAR(col.squaredNorm() / n, 1.0, 5.0 * std::sqrt(2.0 / n)) << "coordinate " << c;
    // white: no correlation with the previous frame
    const double lag1 = col.head(frames - 1).dot(col.tail(frames - 1)) / (n - 1);
    EXPECT_NEAR(lag1, 0.0, 5.0 / std::sqrt(n)) << "coordinate " << c;
    for (int k = 0; k < frames; ++k) beyond_three_sigma += std::abs(col[k]) > 3.0;
  }
  // independent coordinates and markers: no correlation between any two columns
  const Eigen::MatrixXd cov = z.transpose() * z / n;
  for (int a = 0; a < z.cols(); ++a)
    for (int b = a + 1; b < z.cols(); ++b) EXPECT_NEAR(cov(a, b), 0.0, 5.0 / std::sqrt(n));
  // Gaussian tails: P(|z| > 3) = 0.0026998 (a uniform or a clipped noise would fail this)
  const double draws = n * z.cols();
  const double p3 = std::erfc(3.0 / std::sqrt(2.0));
  EXPECT_NEAR(beyond_three_sigma / draws, p3, 5.0 * std::sqrt(p3 * (1 - p3) / draws));
}

TEST(TrackerNoiseTest, TheSeedDecidesTheDraws) {
  const std::vector<Eigen::Vector3d> exact = Exact(5);
  TrackerNoise a({1e-4, 11}), b({1e-4, 11}), c({1e-4, 12});
  bool differs = false;
  for (int k = 0; k < 50; ++k) {
    std::vector<Eigen::Vector3d> pa = exact, pb = exact, pc = exact;
    a.Apply(&pa);
    b.Apply(&pb);
    c.Apply(&pc);
    for (size_t m = 0; m < exact.size(); ++m) {
      EXPECT_EQ(pa[m], pb[m]);
      differs = differs || pa[m] != pc[m];
    }
  }
  EXPECT_TRUE(differs);
}

TEST(TrackerNoiseTest, ABadSizeIsRefusedByName) {
  for (double bad : {-1e-4, 0.02, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()}) {
    try {
      TrackerNoise noise({bad, 1});
      ADD_FAILURE() << "accepted marker_noise " << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("tracker.marker_noise"), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(TrackerNoise({0.01, 1}));
}

}  // namespace
}  // namespace nsim
