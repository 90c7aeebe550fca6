#include "common/prediction/marker_predictor.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <vector>

#include "common/core/error.h"

// counting global allocation: the hot update path must not allocate
namespace {
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  ++g_allocations;
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  ++g_allocations;
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace nsim {
namespace {

// marker m moves along a fixed direction u_m with a polynomial law s(t) of the given degree
struct PolynomialMotion {
  int degree;
  Eigen::Vector3d Position(int m, double t) const {
    const Eigen::Vector3d p0(0.05 * m, -0.02, 0.1 + 0.01 * m);
    const Eigen::Vector3d u = Eigen::Vector3d(0.1 * m, 0.2, -1.0).normalized();
    const double s = degree == 1 ? 0.004 * t - 0.01 : 0.0005 * t * t - 0.003 * t + 0.002;
    return p0 + s * u;
  }
};

double FrameTime(int k) { return 0.033 * k + 0.003 * std::sin(0.9 * k); }  // non-uniform (s)

MarkerFrame MakeFrame(const PolynomialMotion& motion, int k, int markers) {
  MarkerFrame f;
  f.stamp.seq = k;
  f.stamp.sim_time = FrameTime(k);
  for (int m = 0; m < markers; ++m) f.p_WM.push_back(motion.Position(m, f.stamp.sim_time));
  return f;
}

PredictionConfig SmallConfig(int order) {
  PredictionConfig c;
  c.order = order;
  c.pca_window = 80;
  c.window_max = 30;
  return c;
}

// a pure linear (quadratic) motion is predicted exactly by order 1 (2) at any horizon
TEST(MarkerPredictor, PolynomialMotionIsPredictedExactlyByItsOrder) {
  for (int order : {1, 2}) {
    for (bool optimize : {false, true}) {
      const PolynomialMotion motion{order};
      PredictionConfig config = SmallConfig(order);
      config.optimize_window = optimize;
      MarkerPredictor predictor(config, 3);
      std::vector<Eigen::Vector3d> predicted;
      for (int k = 0; k < 120; ++k) {
        predictor.Update(MakeFrame(motion, k, 3));
        EXPECT_EQ(predictor.ready(), k + 1 >= config.pca_window);
      }
      const double t = FrameTime(119);
      for (double h : {0.0, 0.033, 0.16, 0.5, 2.0}) {
        predictor.Predict(h, &predicted);
        ASSERT_EQ(predicted.size(), 3u);
        for (int m = 0; m < 3; ++m) {
          // relative round-off, growing with the extrapolation distance
          const double tol = 1e-12 * (1 + h / 0.3) * (1 + h / 0.3) + 1e-13;
          EXPECT_LE((predicted[m] - motion.Position(m, t + h)).norm(), tol)
              << "order " << order << " optimize " << optimize << " h " << h << " marker " << m;
        }
      }
    }
  }
}

TEST(MarkerPredictor, FirstOrderMissesAQuadraticMotion) {
  const PolynomialMotion motion{2};
  MarkerPredictor predictor(SmallConfig(1), 1);
  for (int k = 0; k < 100; ++k) predictor.Update(MakeFrame(motion, k, 1));
  std::vector<Eigen::Vector3d> predicted;
  predictor.Predict(1.0, &predicted);
  EXPECT_GT((predicted[0] - motion.Position(0, FrameTime(99) + 1.0)).norm(), 1e-5);
}

TEST(MarkerPredictor, BeforeTheBufferFillsAndWithFilterNoneTheLastSampleIsReturned) {
  const PolynomialMotion motion{1};
  for (PredictionFilterKind kind : {PredictionFilterKind::kLinear, PredictionFilterKind::kNone,
                                    PredictionFilterKind::kHarmonicKalman}) {
    PredictionConfig config = SmallConfig(2);
    config.filter = kind;
    MarkerPredictor predictor(config, 2);
    std::vector<Eigen::Vector3d> predicted;
    for (int k = 0; k < 10; ++k) predictor.Update(MakeFrame(motion, k, 2));
    EXPECT_EQ(predictor.ready(), kind == PredictionFilterKind::kNone);
    predictor.Predict(0.5, &predicted);
    EXPECT_EQ(predicted[1], motion.Position(1, FrameTime(9)));
  }
}

TEST(MarkerPredictor, ReportsTheWindowInUse) {
  PredictionConfig config = SmallConfig(2);
  config.optimize_window = false;
  config.window = 17;
  MarkerPredictor predictor(config, 1);
  EXPECT_EQ(predictor.filter(0).window(), 17);
  config.filter = PredictionFilterKind::kNone;
  EXPECT_EQ(MarkerPredictor(config, 1).filter(0).window(), 0);
}

// one steady-state update + prediction of all markers allocates nothing, for every filter and
// with the window search / period estimate rerun inside the update
TEST(MarkerPredictor, UpdateAndPredictDoNotAllocate) {
  for (PredictionFilterKind kind : {PredictionFilterKind::kLinear, PredictionFilterKind::kNone,
                                    PredictionFilterKind::kHarmonicKalman}) {
    PredictionConfig config = SmallConfig(2);
    config.filter = kind;
    config.search_interval = 7;
    MarkerPredictor predictor(config, 5);
    const PolynomialMotion motion{2};
    std::vector<MarkerFrame> frames;
    for (int k = 0; k < 200; ++k) frames.push_back(MakeFrame(motion, k, 5));
    std::vector<Eigen::Vector3d> predicted(5);
    for (int k = 0; k < 100; ++k) predictor.Update(frames[k]);
    const long before = g_allocations.load();
    for (int k = 100; k < 200; ++k) {
      predictor.Update(frames[k]);
      predictor.Predict(0.16, &predicted);
    }
    EXPECT_EQ(g_allocations.load() - before, 0) << ToString(kind);
  }
  // the counter does see allocations
  const long before = g_allocations.load();
  std::vector<double> allocated(100);
  EXPECT_GT(g_allocations.load() - before, 0);
  EXPECT_EQ(allocated.size(), 100u);
}

TEST(MarkerPredictor, BadInputThrowsInputErrorWithAClearMessage) {
  auto message = [](auto&& f) -> std::string {
    try {
      f();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  PredictionConfig config = SmallConfig(2);
  config.optimize_window = false;
  config.window = 2;
  EXPECT_EQ(message([&] { MarkerPredictor(config, 1); }),
            "prediction.window must be >= order+1 (3), got 2");
  config = SmallConfig(2);
  config.pca_window = 20;
  EXPECT_EQ(message([&] { MarkerPredictor(config, 1); }),
            "prediction.pca_window must be >= window_max + search_lead (31) for the window search, "
            "got 20");
  EXPECT_EQ(message([] { ParsePredictionFilter("wlms"); }),
            "prediction.filter must be one of none, lf, kalman; got 'wlms'");

  MarkerPredictor predictor(SmallConfig(2), 2);
  const PolynomialMotion motion{1};
  predictor.Update(MakeFrame(motion, 1, 2));
  EXPECT_EQ(message([&] { predictor.Update(MakeFrame(motion, 2, 3)); }),
            "marker frame seq 2: expected 2 markers, got 3");
  EXPECT_EQ(message([&] {
              predictor.Update(MakeFrame(motion, 1, 2));
            }).rfind("marker frame seq 1: time 0.", 0),
            0u);
  MarkerFrame bad = MakeFrame(motion, 3, 2);
  bad.p_WM[1].y() = std::nan("");
  EXPECT_EQ(message([&] {
              predictor.Update(bad);
            }).rfind("marker frame seq 3: marker 1 position is not finite", 0),
            0u);
  std::vector<Eigen::Vector3d> predicted;
  EXPECT_EQ(message([&] { predictor.Predict(-0.1, &predicted); }),
            "prediction horizon must be >= 0 and finite (s), got -0.1");
  // a rejected frame leaves the predictor usable
  predictor.Update(MakeFrame(motion, 4, 2));
  EXPECT_DOUBLE_EQ(predictor.last_time(), FrameTime(4));
}

}  // namespace
}  // namespace nsim
