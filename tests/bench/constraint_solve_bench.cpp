// Cost of one constraint resolution alone (assembly from cached compliance columns, the
// multiplier solve, the corrections), on a fixed problem of the size of the patient scene's
// (43 rows): a 40-particle spring chain (a DenseLinearBody, so the FEM does not enter the time)
// with 13 needle points on it (2 lateral rows and an axial row each) and 4 contacts. Three law
// mixes, one per method:
//   ConstraintSolve/direct/43rows    axial rows bilateral, contacts as bilateral rows (LDLT)
//   ConstraintSolve/activeset/43rows axial friction (mu 0.1, some points slip) and contacts
//                                    (two push, two are separated): the needle coupling's solve
//   ConstraintSolve/pgs/43rows       axial rows bilateral, the contacts unilateral (PGS)
// Run single-threaded: OPENBLAS_NUM_THREADS=1 taskset -c 1 constraint_solve_bench
// --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

#include "common/constraints/constraint_solver.h"
#include "common/constraints/dense_linear_body.h"

namespace nsim {
namespace {

constexpr int kNodes = 40;
constexpr int kNeedlePoints = 13;

enum class Mix { kDirect, kActiveSet, kPgs };

// the chain along x (5 mm spacing, springs to the first and second neighbours), loaded by
// gravity and pushed sideways, after its free motion from rest
std::unique_ptr<DenseLinearBody> MakeChain() {
  DenseLinearBodyConfig c;
  c.masses = Eigen::VectorXd::Constant(kNodes, 0.005);
  c.rest_positions.resize(3, kNodes);
  for (int i = 0; i < kNodes; ++i) c.rest_positions.col(i) = Eigen::Vector3d(0.005 * i, 0, 0);
  c.stiffness = Eigen::MatrixXd::Zero(3 * kNodes, 3 * kNodes);
  for (int i = 0; i < kNodes; ++i) {
    for (int j = i + 1; j <= i + 2 && j < kNodes; ++j) {
      const Eigen::Matrix3d k = 40.0 * Eigen::Matrix3d::Identity();
      c.stiffness.block<3, 3>(3 * i, 3 * i) += k;
      c.stiffness.block<3, 3>(3 * j, 3 * j) += k;
      c.stiffness.block<3, 3>(3 * i, 3 * j) -= k;
      c.stiffness.block<3, 3>(3 * j, 3 * i) -= k;
    }
  }
  c.time_step = 0.02;
  c.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  auto body = std::make_unique<DenseLinearBody>(c);
  for (int i = 0; i < kNodes; i += 7) body->external_forces().col(i) = Eigen::Vector3d(0, 0.01, 0);
  body->SolveFreeMotion();
  return body;
}

// the rows: needle points on nodes 3k, 3k + 1, the needle 1 mm to the side sliding by 0.2 mm
// (even points, friction holds them) or 2 mm (odd points, they slip); contacts under nodes 0,
// 10, 20, 30: 0.1 mm above the free motion (push) or 5 mm below it (separated)
void BuildRows(DenseLinearBody& body, Mix mix, ConstraintSet& set) {
  set.Clear();
  const int b = set.AddBody(body);
  Eigen::Matrix<double, 3, 2> lateral;
  lateral << Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ();
  for (int k = 0; k < kNeedlePoints; ++k) {
    const int pt = set.AddBodyPoint(b, std::vector<int>{3 * k, 3 * k + 1},
                                    std::vector<double>{0.6, 0.4}, k + 1);
    const Eigen::Vector3d start = set.CalcStartPosition(pt) + Eigen::Vector3d(0, 0.001, 0);
    const double slide = k % 2 == 0 ? 0.0002 : 0.002;
    const int pn = set.AddKinematicPoint(start, start + Eigen::Vector3d(slide, 0, 0));
    const int lateral_group = set.AddBilateral(pt, pn, lateral);
    if (mix == Mix::kActiveSet)
      set.AddAxialFriction(pt, pn, Eigen::Vector3d::UnitX(), lateral_group, 0.1, 0.0);
    else
      set.AddBilateral(pt, pn, Eigen::Vector3d::UnitX());
  }
  for (int c = 0; c < 4; ++c) {
    const int node = 10 * c;
    const double below = c % 2 == 0 ? -0.0001 : 0.005;
    const Eigen::Vector3d floor =
        body.free_positions().col(node) - Eigen::Vector3d(0.0, 0.0, below);
    const int pt = set.AddNodePoint(b, node, 100 + c);
    const int pf = set.AddKinematicPoint(floor, floor);
    if (mix == Mix::kDirect)
      set.AddBilateral(pt, pf, Eigen::Vector3d::UnitZ());
    else
      set.AddContact(pt, pf, Eigen::Vector3d::UnitZ());
  }
}

void ConstraintSolve(benchmark::State& bench, Mix mix) {
  const std::unique_ptr<DenseLinearBody> body = MakeChain();
  ConstraintSet set;
  BuildRows(*body, mix, set);
  ConstraintSolver solver;
  ConstraintSolveReport report = solver.Solve(set);  // fills the compliance cache
  for (auto _ : bench) {
    report = solver.Solve(set);
    benchmark::DoNotOptimize(solver.lambda().data());
  }
  if (!report.converged) bench.SkipWithError("the solve did not converge");
  bench.counters["rows"] = set.num_rows();
  bench.counters["iterations"] = report.iterations;
  bench.counters["violation_m"] = report.max_violation;
}
BENCHMARK_CAPTURE(ConstraintSolve, direct, Mix::kDirect)
    ->Name("ConstraintSolve/direct/43rows")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(ConstraintSolve, activeset, Mix::kActiveSet)
    ->Name("ConstraintSolve/activeset/43rows")
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(ConstraintSolve, pgs, Mix::kPgs)
    ->Name("ConstraintSolve/pgs/43rows")
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace nsim

BENCHMARK_MAIN();
