// Robot and controller kernels: iiwa forward kinematics + tool Jacobian, IK (near seed, and
// from a far random seed), the Cartesian interpolator step, the controller's forecast of the
// robot over the commands in flight (MotionForecast, `prediction.model_pose: expected`/`auto`:
// 1, 2, 5 and 10 commands, iiwa and Cartesian robot), and the regularized inverses of the
// simulation Jacobian (6 x 6 Cartesian phase 2, 5 x 7 joint phase 3). Measure on one core:
//   taskset -c 0 robot_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "common/control/regularized_inverse.h"
#include "common/robot/cartesian_robot.h"
#include "common/robot/iiwa14.h"
#include "common/robot/iiwa14_ik.h"
#include "common/robot/motion_forecast.h"

namespace nsim {
namespace {

Vector7d RandomJoints(const Iiwa14Model& model, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Vector7d q;
  for (int i = 0; i < 7; ++i) {
    q[i] = model.config().position_lower[i] +
           u(rng) * (model.config().position_upper[i] - model.config().position_lower[i]);
  }
  return q;
}

void BM_IiwaForwardKinematicsAndJacobian(benchmark::State& state) {
  const Iiwa14Model model;
  std::mt19937_64 rng(1);
  std::vector<Vector7d> qs(64);
  for (auto& q : qs) q = RandomJoints(model, rng);
  Iiwa14Kinematics kin;
  Jacobian67 J;
  size_t i = 0;
  for (auto _ : state) {
    model.CalcForwardKinematics(qs[i++ & 63], &kin);
    model.CalcToolJacobian(kin, &J);
    benchmark::DoNotOptimize(J.data());
  }
}
BENCHMARK(BM_IiwaForwardKinematicsAndJacobian);

// seed = the solution perturbed by ~0.05 rad (tracking a moving target)
void BM_IiwaIkNearSeed(benchmark::State& state) {
  const Iiwa14Model model;
  const Iiwa14InverseKinematics ik(model, Iiwa14IkConfig());
  std::mt19937_64 rng(2);
  std::normal_distribution<double> g(0.0, 0.05);
  std::vector<std::pair<Eigen::Isometry3d, Vector7d>> cases(64);
  for (auto& [X, seed] : cases) {
    const Vector7d q = model.ClampToLimits(RandomJoints(model, rng) * 0.9);
    X = model.CalcToolPose(q);
    seed = q;
    for (int j = 0; j < 7; ++j) seed[j] += g(rng);
  }
  size_t i = 0;
  for (auto _ : state) {
    const auto& [X, seed] = cases[i++ & 63];
    benchmark::DoNotOptimize(ik.Solve(X, seed).q.data());
  }
}
BENCHMARK(BM_IiwaIkNearSeed);

// seed = unrelated random joints (cold start, may restart)
void BM_IiwaIkRandomSeed(benchmark::State& state) {
  const Iiwa14Model model;
  const Iiwa14InverseKinematics ik(model, Iiwa14IkConfig());
  std::mt19937_64 rng(3);
  std::vector<std::pair<Eigen::Isometry3d, Vector7d>> cases(64);
  for (auto& [X, seed] : cases) {
    X = model.CalcToolPose(RandomJoints(model, rng));
    seed = RandomJoints(model, rng);
  }
  size_t i = 0;
  for (auto _ : state) {
    const auto& [X, seed] = cases[i++ & 63];
    benchmark::DoNotOptimize(ik.Solve(X, seed).q.data());
  }
}
BENCHMARK(BM_IiwaIkRandomSeed);

void BM_CartesianRobotStep(benchmark::State& state) {
  const CartesianRobot robot{CartesianRobotConfig()};
  CartesianRobotState s = robot.MakeState(Eigen::Isometry3d::Identity());
  Eigen::Isometry3d cmd = Eigen::Isometry3d::Identity();
  cmd.translation() = Eigen::Vector3d(0.5, 0.2, -0.3);
  cmd.linear() = ExpSO3(Eigen::Vector3d(1.0, -0.5, 2.0));
  for (auto _ : state) {
    robot.Step(cmd, 1e-4, &s);  // small dt: stays in motion
    benchmark::DoNotOptimize(s.X_WE.data());
  }
}
BENCHMARK(BM_CartesianRobotStep);

// the forecast the controller runs once a frame: the robot moving (two measured states 20 ms
// apart), then range(0) commands in flight, each 1 mm and 0.5 mrad a joint further, one step each
void ForecastBench(benchmark::State& state, bool joints) {
  constexpr double kDt = 0.02;
  MotionForecast forecast{MotionForecastConfig()};
  const Iiwa14Model iiwa;
  const Vector7d q0 = iiwa.CalcMidRange();
  const Vector7d dq = Vector7d::Constant(5e-4);
  auto joint_vector = [](const Vector7d& q) { return std::vector<double>(q.data(), q.data() + 7); };
  const Eigen::Isometry3d X0 = iiwa.CalcFlangePoseInBase(q0),
                                X1 = iiwa.CalcFlangePoseInBase(q0 + dq);
  forecast.Observe(0.0, X0, joints ? joint_vector(q0) : std::vector<double>());
  forecast.Observe(kDt, X1, joints ? joint_vector(q0 + dq) : std::vector<double>());
  const int n = static_cast<int>(state.range(0));
  std::vector<Vector7d> q_commands;
  std::vector<Eigen::Isometry3d> X_commands;
  for (int i = 0; i < n; ++i) {
    q_commands.push_back(q0 + (i + 2) * dq);
    Eigen::Isometry3d X = X1;
    X.translation() += Eigen::Vector3d(1e-3 * (i + 1), 0.0, 0.0);
    X_commands.push_back(X);
  }
  for (auto _ : state) {
    if (joints) {
      const Vector7d q = forecast.ForecastJoints(q_commands, kDt);
      benchmark::DoNotOptimize(q.data());
    } else {
      const Eigen::Isometry3d X = forecast.ForecastPose(X_commands, kDt);
      benchmark::DoNotOptimize(X.data());
    }
  }
}
void BM_ForecastIiwa(benchmark::State& state) { ForecastBench(state, true); }
void BM_ForecastCartesian(benchmark::State& state) { ForecastBench(state, false); }
BENCHMARK(BM_ForecastIiwa)->Arg(1)->Arg(2)->Arg(5)->Arg(10);
BENCHMARK(BM_ForecastCartesian)->Arg(1)->Arg(2)->Arg(5)->Arg(10);

void InverseBench(benchmark::State& state, bool tikhonov) {
  const int m = static_cast<int>(state.range(0));
  const int n = static_cast<int>(state.range(1));
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd J(m, n);
  for (int i = 0; i < m * n; ++i) J.data()[i] = u(rng);
  Eigen::MatrixXd out(n, m);
  for (auto _ : state) {
    if (tikhonov) {
      CalcTikhonovPseudoInverse(J, 1e-6, &out);
    } else {
      CalcDampedLeastSquaresInverse(J, 1e-3, &out);
    }
    benchmark::DoNotOptimize(out.data());
  }
}
void BM_TikhonovPseudoInverse(benchmark::State& state) { InverseBench(state, true); }
void BM_DampedLeastSquaresInverse(benchmark::State& state) { InverseBench(state, false); }
BENCHMARK(BM_TikhonovPseudoInverse)->Args({6, 6})->Args({5, 7})->Args({4, 6});
BENCHMARK(BM_DampedLeastSquaresInverse)->Args({6, 6})->Args({5, 7});

}  // namespace
}  // namespace nsim

BENCHMARK_MAIN();
