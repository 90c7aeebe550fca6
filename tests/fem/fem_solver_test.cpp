#include "common/fem/fem_solver.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/core/error.h"

namespace nsim {
namespace {

// relative round-off of a direct sparse solve and of sums over the mesh
constexpr double kDirectTol = 1e-9;

std::vector<int> NodesWhere(const TetMesh& mesh, int axis, double value) {
  std::vector<int> nodes;
  for (int i = 0; i < mesh.num_nodes(); ++i)
    if (std::abs(mesh.X(axis, i) - value) < 1e-12 * (1.0 + std::abs(value))) nodes.push_back(i);
  return nodes;
}

// quasi-static solve: implicit steps with a huge time step (A -> h^2 K, each step a Newton step
// with the co-rotated tangent) and the velocity reset, until the position update is below
// `tolerance` relative to the displacement
int SolveStatic(FemSolver& solver, FemState& state, double tolerance, int max_steps = 50) {
  const FemModel& model = solver.get_model();
  for (int step = 1; step <= max_steps; ++step) {
    const Eigen::Matrix3Xd before = state.x;
    state.v.setZero();
    state.dv_free.setZero();
    solver.Step(state);
    const double update = (state.x - before).norm();
    if (update <= tolerance * (state.x - model.get_rest_positions()).norm()) {
      state.v.setZero();
      return step;
    }
  }
  return -1;
}

// Euler-Bernoulli cantilever: L = 1 m, square section b = 0.1 m, nu = 0, end load F spread over
// the end face by trapezoidal weights; the FEM deflection of the end face (mean) converges to
// F L^3 / (3 E I) plus the Timoshenko shear part F L / (kappa G A) (0.6 % here)
double CantileverDeflection(int cells_across, int* num_nodes) {
  const double L = 1.0, b = 0.1, E = 1e6, F = 2.5e-3;  // delta / L ~ 1e-4: linear regime
  const int n_across = cells_across + 1, n_along = 10 * cells_across + 1;
  const TetMesh mesh = MakeBoxTetMesh({n_along, n_across, n_across}, {L, b, b});
  FemConfig config;
  config.young_modulus = E;
  config.poisson_ratio = 0.0;
  config.gravity.setZero();
  config.time_step = 1e3;
  config.linear_solver = FemLinearSolver::kDirect;
  const FemModel model(mesh, config, {NodesWhere(mesh, 0, 0.0), {}});
  *num_nodes = mesh.num_nodes();
  FemSolver solver(model);
  FemState state(model);
  const std::vector<int> tip = NodesWhere(mesh, 0, L);
  auto weight = [&](double s) {  // trapezoidal weight of a coordinate in [0, b]
    return (s < 1e-12 || s > b - 1e-12) ? 0.5 : 1.0;
  };
  double total = 0.0;
  for (int i : tip) total += weight(mesh.X(1, i)) * weight(mesh.X(2, i));
  for (int i : tip) state.external_forces(2, i) = -F * weight(mesh.X(1, i)) * weight(mesh.X(2, i)) / total;
  EXPECT_GT(SolveStatic(solver, state, 1e-10), 0);
  double deflection = 0.0;
  for (int i : tip) deflection += (model.get_rest_positions()(2, i) - state.x(2, i)) / tip.size();
  return deflection;
}

TEST(FemSolverTest, CantileverConvergesToEulerBernoulli) {
  const double L = 1.0, b = 0.1, E = 1e6, F = 2.5e-3;
  const double I = b * b * b * b / 12.0;
  const double euler_bernoulli = F * L * L * L / (3.0 * E * I);
  const double timoshenko = euler_bernoulli + F * L / (5.0 / 6.0 * E / 2.0 * b * b);
  double previous_error = 1e9;
  for (int cells : {2, 4, 8}) {
    int nodes = 0;
    const double deflection = CantileverDeflection(cells, &nodes);
    const double error = std::abs(deflection - euler_bernoulli) / euler_bernoulli;
    std::printf("cantilever %2d cells across (%5d nodes): deflection %.6e m, EB %.6e m, "
                "error vs EB %.2f %%, vs Timoshenko %.2f %%\n",
                cells, nodes, deflection, euler_bernoulli, 100 * error,
                100 * std::abs(deflection - timoshenko) / timoshenko);
    EXPECT_LT(error, previous_error) << cells;
    previous_error = error;
  }
  EXPECT_LT(previous_error, 0.05);
}

struct Scene {
  TetMesh mesh;
  FemBoundary boundary;
};

// a soft liver-like block: bottom fixed, top layer prescribed (a "diaphragm")
Scene Block(Eigen::Vector3i nodes, double size) {
  Scene scene;
  scene.mesh = MakeBoxTetMesh(nodes, Eigen::Vector3d(size, 0.8 * size, 0.6 * size));
  scene.boundary.fixed_nodes = NodesWhere(scene.mesh, 2, 0.0);
  scene.boundary.prescribed_nodes = NodesWhere(scene.mesh, 2, 0.6 * size);
  return scene;
}

// breathing-like motion of the prescribed layer: a shear along x plus a lift, rotating slightly
void Prescribe(const FemModel& model, FemState& state, double t, double scale = 1.0) {
  const auto& nodes = model.get_prescribed_nodes();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3 * std::sin(2.0 * t), Eigen::Vector3d::UnitY()).toRotationMatrix();
  for (size_t k = 0; k < nodes.size(); ++k) {
    const Eigen::Vector3d X = model.get_rest_positions().col(nodes[k]);
    state.prescribed_positions.col(k) = R * X + scale * Eigen::Vector3d(0.02 * std::sin(3.0 * t), 0.0, 0.01 * std::sin(2.0 * t));
  }
}

TEST(FemSolverTest, DirichletNodesFollowPrescriptionExactly) {
  const Scene scene = Block({6, 5, 4}, 0.1);
  FemConfig config;
  config.time_step = 0.02;
  const FemModel model(scene.mesh, config, scene.boundary);
  FemSolver solver(model);
  FemState state(model);
  for (int step = 0; step < 20; ++step) {
    Prescribe(model, state, state.time + config.time_step);
    solver.Step(state);
    for (size_t k = 0; k < model.get_prescribed_nodes().size(); ++k)
      EXPECT_EQ(state.x.col(model.get_prescribed_nodes()[k]), state.prescribed_positions.col(k));
    for (int i : model.get_fixed_nodes()) {
      EXPECT_EQ(state.x.col(i), model.get_rest_positions().col(i));
      EXPECT_EQ(state.v.col(i), Eigen::Vector3d::Zero());
    }
  }
}

// the matrix-free operator, the assembled A_ff and a dense sum of element matrices agree
TEST(FemSolverTest, AssembledMatrixEqualsDenseElementSum) {
  const Scene scene = Block({4, 4, 3}, 0.05);
  FemConfig config;
  config.rayleigh_mass = 0.3;
  config.rayleigh_stiffness = 0.05;
  const FemModel model(scene.mesh, config, scene.boundary);
  FemSolver solver(model);
  FemState state(model);
  Prescribe(model, state, 0.5);
  solver.Step(state);
  Prescribe(model, state, 0.6);
  solver.BeginStep(state);  // rotations of a deformed state
  const int n = model.num_nodes();
  const double h = config.time_step;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (int i = 0; i < n; ++i)
    A.block<3, 3>(3 * i, 3 * i) += (1 + h * 0.3) * model.get_lumped_mass()[i] * Eigen::Matrix3d::Identity();
  for (int e = 0; e < model.num_tets(); ++e) {
    const Matrix12d K = CalcCorotatedStiffness(model.get_rest_shapes()[e], model.get_lame(), state.rotations[e]);
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        A.block<3, 3>(3 * scene.mesh.tets[e][a], 3 * scene.mesh.tets[e][b]) += (h * 0.05 + h * h) * K.block<3, 3>(3 * a, 3 * b);
  }
  Eigen::MatrixXd A_ff(3 * model.num_free_nodes(), 3 * model.num_free_nodes());
  for (int k = 0; k < model.num_free_nodes(); ++k)
    for (int j = 0; j < model.num_free_nodes(); ++j)
      A_ff.block<3, 3>(3 * k, 3 * j) = A.block<3, 3>(3 * model.get_free_nodes()[k], 3 * model.get_free_nodes()[j]);
  const Eigen::MatrixXd assembled = Eigen::MatrixXd(solver.CalcSystemMatrix());
  EXPECT_LT((assembled - A_ff).norm(), 1e-13 * A_ff.norm());
  // A^-1 through the API: A_ff * (A^-1 B)_f = B_f, Dirichlet rows zero
  const Eigen::MatrixXd B = Eigen::MatrixXd::Random(3 * n, 5);
  Eigen::MatrixXd X;
  solver.ApplyInverse(B, X, FemInverse::kCurrentSystem);
  for (int i : model.get_dirichlet_nodes()) EXPECT_EQ(X.middleRows<3>(3 * i).norm(), 0.0);
  Eigen::MatrixXd B_f(3 * model.num_free_nodes(), 5), X_f(3 * model.num_free_nodes(), 5);
  for (int k = 0; k < model.num_free_nodes(); ++k) {
    B_f.middleRows<3>(3 * k) = B.middleRows<3>(3 * model.get_free_nodes()[k]);
    X_f.middleRows<3>(3 * k) = X.middleRows<3>(3 * model.get_free_nodes()[k]);
  }
  // PCG path (the default): each column to the tolerance
  EXPECT_LT((A_ff * X_f - B_f).colwise().norm().maxCoeff() / B_f.colwise().norm().minCoeff(),
            config.cg_relative_tolerance);
  // sparse columns give the same as dense ones
  Eigen::SparseMatrix<double> B_sparse = B.sparseView();
  Eigen::MatrixXd X_sparse;
  solver.ApplyInverse(B_sparse, X_sparse, FemInverse::kCurrentSystem);
  EXPECT_LT((X_sparse - X).norm(), 1e-12 * X.norm());
}

// the fast path (PCG + cached warped factor) and the direct path (refactorize every step) agree
// to the solver tolerance: ||dv_pcg - dv_direct|| <= cond(A) * tol * ||dv_direct|| (a rigorous
// bound, cond computed densely here), and in practice far closer
TEST(FemSolverTest, FastPathAgreesWithDirectPath) {
  const Scene scene = Block({6, 5, 4}, 0.1);
  FemConfig direct_config;
  direct_config.linear_solver = FemLinearSolver::kDirect;
  direct_config.rayleigh_mass = 0.1;
  direct_config.rayleigh_stiffness = 0.01;
  FemConfig fast_config = direct_config;
  fast_config.linear_solver = FemLinearSolver::kPcgCachedFactor;
  fast_config.cg_relative_tolerance = 1e-8;
  const FemModel direct_model(scene.mesh, direct_config, scene.boundary);
  const FemModel fast_model(scene.mesh, fast_config, scene.boundary);
  FemSolver direct(direct_model), fast(fast_model);
  FemState direct_state(direct_model), fast_state(fast_model);
  int iterations = 0, refactorizations = 0;
  for (int step = 0; step < 40; ++step) {
    Prescribe(direct_model, direct_state, direct_state.time + 0.02, 2.0);
    Prescribe(fast_model, fast_state, fast_state.time + 0.02, 2.0);
    fast_state = direct_state;  // same state: compare one solve
    direct.BeginStep(direct_state);
    const FemStepStats stats = fast.BeginStep(fast_state);
    iterations += stats.cg_iterations;
    refactorizations += stats.refactorized;
    EXPECT_LE(stats.relative_residual, fast_config.cg_relative_tolerance);
    EXPECT_LE(direct.get_last_stats().relative_residual, 1e-12);
    // PCG reports its recursive residual; the true one, ||A dv_pcg - b|| / ||b|| with
    // b = A dv_direct (the direct solve's residual is <= 1e-12), is within the tolerance and
    // equal to it up to round-off
    {
      const Eigen::SparseMatrix<double>& A = direct.CalcSystemMatrix();
      const auto reduced = [&](const Eigen::Matrix3Xd& full) {
        Eigen::VectorXd out(3 * direct_model.get_free_nodes().size());
        for (size_t k = 0; k < direct_model.get_free_nodes().size(); ++k)
          out.segment<3>(3 * k) = full.col(direct_model.get_free_nodes()[k]);
        return out;
      };
      const Eigen::VectorXd b = A * reduced(direct_state.dv_free);
      const double true_residual = (A * reduced(fast_state.dv_free) - b).norm() / b.norm();
      EXPECT_LE(true_residual, fast_config.cg_relative_tolerance) << step;
      EXPECT_NEAR(true_residual, stats.relative_residual,
                  1e-3 * fast_config.cg_relative_tolerance)
          << step;
    }
    if (step == 39) {
      const Eigen::MatrixXd A = Eigen::MatrixXd(direct.CalcSystemMatrix());
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(A);
      const double cond = eig.eigenvalues().maxCoeff() / eig.eigenvalues().minCoeff();
      const double difference = (fast_state.dv_free - direct_state.dv_free).norm() / direct_state.dv_free.norm();
      std::printf("fast vs direct: relative dv difference %.2e, cond(A) %.1f, tol %.0e, mean PCG "
                  "iterations %.2f, refactorizations %d / 40\n",
                  difference, cond, fast_config.cg_relative_tolerance, iterations / 40.0, refactorizations);
      EXPECT_LE(difference, cond * fast_config.cg_relative_tolerance);
    }
    EXPECT_LT((fast_state.dv_free - direct_state.dv_free).norm(),
              1e-5 * direct_state.dv_free.norm() + 1e-300);
    direct.CommitStep(direct_state);
  }
}

// the PCG's warm start predicts the free end velocity u = v + dv_free by extrapolating its
// changes (constant, line or parabola through the last one, two or three: the order whose
// prediction of the latest change was best) and starts from u - v, v carrying the last
// correction. The test keeps its own history and checks the reported initial residual
// ||A dv_0 - b|| / ||b|| against its own dv_0 and the step's A and b, on a smooth drive from
// rest with a correction (a contact's impulse, A_0^-1 times a point force) held over steps
// 20-22 and released: in the smooth parts the parabola is chosen (5x better than the line,
// summed); after the corrections the starts are better than those of the same rule applied
// to dv_free itself (the solver's warm start before), which carries the impulses on
TEST(FemSolverTest, WarmStartExtrapolatesTheFreeEndVelocity) {
  const Scene scene = Block({6, 5, 4}, 0.1);
  FemConfig config;
  config.rayleigh_mass = 0.1;
  config.rayleigh_stiffness = 0.01;
  config.linear_solver = FemLinearSolver::kPcgCachedFactor;
  config.cg_relative_tolerance = 1e-10;
  const FemModel model(scene.mesh, config, scene.boundary);
  FemSolver solver(model);
  FemState state(model);
  const auto& free_nodes = model.get_free_nodes();
  const int m = 3 * static_cast<int>(free_nodes.size());
  const auto reduced = [&](const Eigen::Matrix3Xd& full) {
    Eigen::VectorXd out(m);
    for (size_t k = 0; k < free_nodes.size(); ++k) out.segment<3>(3 * k) = full.col(free_nodes[k]);
    return out;
  };
  // the correction: the rest compliance's response to a point force at a free node mid-block
  Eigen::MatrixXd force = Eigen::MatrixXd::Zero(3 * model.num_nodes(), 1);
  force(3 * free_nodes[free_nodes.size() / 2] + 1, 0) = 1.0;
  Eigen::MatrixXd response;
  solver.ApplyInverse(force, response, FemInverse::kRestFactor);
  const auto correction_at = [&](int step) -> Eigen::VectorXd {
    if (step < 20 || step > 22) return Eigen::VectorXd::Zero(3 * model.num_nodes());
    return (0.05 / response.col(0).cwiseAbs().maxCoeff()) * response.col(0);  // 5 cm/s at most
  };
  Eigen::VectorXd u = Eigen::VectorXd::Zero(m), c0 = u, c1 = u, c2 = u;  // u and its changes
  Eigen::VectorXd dv1 = u, dv2 = u, dv3 = u;  // dv_free history, for the warm start before
  int best = 1, old_best = 1;
  double smooth_line = 0.0, smooth_parabola = 0.0, after_new = 0.0, after_old = 0.0;
  for (int step = 0; step < 80; ++step) {
    Prescribe(model, state, state.time + 0.02, 2.0);
    const Eigen::VectorXd v = reduced(state.v);
    const FemStepStats stats = solver.BeginStep(state);
    ASSERT_LE(stats.relative_residual, config.cg_relative_tolerance) << step;
    const Eigen::SparseMatrix<double>& A = solver.CalcSystemMatrix();
    const Eigen::VectorXd dv = reduced(state.dv_free);
    const Eigen::VectorXd b = A * dv;  // the step's b up to the solve's 1e-10 residual
    const auto residual = [&](const Eigen::VectorXd& dv0) { return (A * dv0 - b).norm() / b.norm(); };
    const Eigen::VectorXd predicted[3] = {c0, 2.0 * c0 - c1, 3.0 * (c0 - c1) + c2};
    const Eigen::VectorXd old_predicted[3] = {dv1, 2.0 * dv1 - dv2, 3.0 * (dv1 - dv2) + dv3};
    const double start = residual(u + predicted[best - 1] - v);
    EXPECT_NEAR(stats.initial_residual, start, 1e-6 * start + 1e-9) << step << " order " << best;
    if (step >= 16 && (step <= 20 || step >= 36)) {
      EXPECT_EQ(best, 3) << step;
      smooth_line += residual(u + predicted[1] - v);
      smooth_parabola += residual(u + predicted[2] - v);
    }
    if (step >= 21 && step <= 27) {
      after_new += start;
      after_old += residual(old_predicted[old_best - 1]);
    }
    // this step's change of u, the order that would have predicted it best (and dv_free's
    // for the rule before), the history
    const auto closest_order = [](const Eigen::VectorXd (&predictions)[3],
                                  const Eigen::VectorXd& actual) {
      int order = 1;
      for (int k = 2; k <= 3; ++k)
        if ((predictions[k - 1] - actual).norm() <= (predictions[order - 1] - actual).norm())
          order = k;
      return order;
    };
    const Eigen::VectorXd change = v + dv - u;
    best = closest_order(predicted, change);
    old_best = closest_order(old_predicted, dv);
    u += change;
    c2 = c1;
    c1 = c0;
    c0 = change;
    dv3 = dv2;
    dv2 = dv1;
    dv1 = dv;
    solver.CommitStep(state, correction_at(step));
  }
  std::printf("initial residual, smooth steps: parabola %.2e, line %.2e; steps 21-27 after the "
              "corrections: %.3f, extrapolating dv_free (by the same rule) %.3f\n",
              smooth_parabola, smooth_line, after_new, after_old);
  EXPECT_LT(smooth_parabola, 0.5 * smooth_line);
  EXPECT_LT(after_new, after_old);
}

// under gravity, with the bottom fixed: (a) every dynamic step satisfies the discrete momentum
// balance sum(reactions) + weight + sum(f_ext) = sum(M dv)/h + alpha sum(M v+), and (b) at static
// equilibrium the reactions carry exactly the weight
TEST(FemSolverTest, ReactionsBalanceMomentumAndWeight) {
  TetMesh mesh = MakeBoxTetMesh({5, 4, 6}, {0.08, 0.06, 0.1});
  FemConfig config;
  config.linear_solver = FemLinearSolver::kDirect;
  config.rayleigh_mass = 2.0;
  config.rayleigh_stiffness = 0.02;
  config.time_step = 0.01;
  const FemModel model(mesh, config, {NodesWhere(mesh, 2, 0.0), {}});
  FemSolver solver(model);
  FemState state(model);
  const Eigen::Vector3d weight = model.get_total_mass() * config.gravity;
  state.external_forces.col(mesh.num_nodes() - 1) = Eigen::Vector3d(0.01, 0.0, 0.0);
  for (int step = 0; step < 30; ++step) {
    const Eigen::Matrix3Xd v_before = state.v;
    solver.Step(state);
    const Eigen::Matrix3Xd dv = state.v - v_before;
    Eigen::Vector3d momentum_rate = Eigen::Vector3d::Zero();
    for (int i = 0; i < mesh.num_nodes(); ++i)
      momentum_rate += model.get_lumped_mass()[i] * (dv.col(i) / config.time_step + config.rayleigh_mass * state.v.col(i));
    const Eigen::Vector3d balance = state.reaction_forces.rowwise().sum() + weight +
                                    state.external_forces.rowwise().sum() - momentum_rate;
    EXPECT_LT(balance.norm(), kDirectTol * weight.norm()) << "step " << step;
  }
  // static equilibrium (quasi-static steps)
  FemConfig static_config = config;
  static_config.time_step = 1e3;
  static_config.rayleigh_mass = 0.0;
  static_config.rayleigh_stiffness = 0.0;
  const FemModel static_model(mesh, static_config, {NodesWhere(mesh, 2, 0.0), {}});
  FemSolver static_solver(static_model);
  FemState static_state(static_model);
  ASSERT_GT(SolveStatic(static_solver, static_state, 1e-12), 0);
  const Eigen::Vector3d total = static_state.reaction_forces.rowwise().sum();
  EXPECT_LT((total + weight).norm(), kDirectTol * weight.norm())
      << total.transpose() << " vs weight " << weight.transpose();
  // each fixed node's reaction equals minus the (elastic + gravity) force the body puts on it
  const Eigen::Matrix3Xd elastic = CalcElasticForces(static_model, static_state);
  for (size_t j = 0; j < static_model.get_dirichlet_nodes().size(); ++j) {
    const int i = static_model.get_dirichlet_nodes()[j];
    const Eigen::Vector3d expected = -(elastic.col(i) + static_model.get_lumped_mass()[i] * static_config.gravity);
    EXPECT_LT((static_state.reaction_forces.col(j) - expected).norm(), 1e-7 * weight.norm()) << i;
  }
}

// energy: with Rayleigh damping the total energy (kinetic + elastic + gravitational) decreases
// monotonically. Without damping, implicit Euler still dissipates (amplification 1/sqrt(1 + (w h)^2)
// per mode): energy never increases, the loss is first order in h (halving h halves it), linear
// momentum of a free body is conserved
double TotalEnergy(const FemModel& model, const FemState& state) {
  return CalcKineticEnergy(model, state) + CalcElasticEnergy(model, state) +
         CalcGravitationalEnergy(model, state);
}

TEST(FemSolverTest, DampedEnergyDecreasesMonotonically) {
  TetMesh mesh = MakeBoxTetMesh({4, 4, 8}, {0.03, 0.03, 0.1});
  FemConfig config;
  config.rayleigh_mass = 0.5;
  config.rayleigh_stiffness = 0.01;
  config.linear_solver = FemLinearSolver::kDirect;
  const FemModel model(mesh, config, {NodesWhere(mesh, 2, 0.0), {}});
  FemSolver solver(model);
  FemState state(model);
  double previous = TotalEnergy(model, state);
  for (int step = 0; step < 100; ++step) {
    solver.Step(state);
    const double energy = TotalEnergy(model, state);
    EXPECT_LT(energy, previous) << "step " << step;
    previous = energy;
  }
}

double FreeBodyEnergyLoss(double h, int steps, Eigen::Vector3d* momentum_drift) {
  // a free bar (nu = 0: no lateral coupling), stretched uniformly by 1 % and translating; the
  // stretch puts 8 / pi^2 = 81 % of the elastic energy in the first axial mode
  TetMesh mesh = MakeBoxTetMesh({9, 3, 3}, {0.1, 0.02, 0.02});
  FemConfig config;
  config.gravity.setZero();
  config.time_step = h;
  config.poisson_ratio = 0.0;
  config.linear_solver = FemLinearSolver::kDirect;
  const FemModel model(mesh, config);
  FemSolver solver(model);
  FemState state(model);
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    state.x(0, i) = 0.05 + 1.01 * (state.x(0, i) - 0.05);
    state.v.col(i) = Eigen::Vector3d(0.01, 0.02, -0.01);
  }
  const Eigen::Vector3d p0 = state.v * model.get_lumped_mass();
  const double e0 = CalcKineticEnergy(model, state) + CalcElasticEnergy(model, state);
  double previous = e0;
  for (int step = 0; step < steps; ++step) {
    solver.Step(state);
    const double energy = CalcKineticEnergy(model, state) + CalcElasticEnergy(model, state);
    EXPECT_LE(energy, previous * (1 + 1e-12)) << "h " << h << " step " << step;
    previous = energy;
  }
  *momentum_drift = state.v * model.get_lumped_mass() - p0;
  return (e0 - previous) / e0;
}

TEST(FemSolverTest, UndampedFreeBodyDissipationIsFirstOrderAndBounded) {
  // first axial mode of the free bar: w1 = pi c / L, c = sqrt(E / rho) = 2.28 m/s, period 88 ms.
  // Implicit Euler multiplies a mode's energy by 1 / (1 + (w h)^2) a step, so over a time T the
  // first mode loses 1 - exp(-T w1^2 h) (first order in h); higher modes lose more.
  const double w1 = M_PI * std::sqrt(5500.0 / 1060.0) / 0.1;
  const double T = 0.1;
  Eigen::Vector3d drift;
  const double loss_coarse = FreeBodyEnergyLoss(1e-4, 1000, &drift);
  EXPECT_LT(drift.norm(), 1e-12);  // linear momentum: internal forces sum to zero
  const double loss_fine = FreeBodyEnergyLoss(0.5e-4, 2000, &drift);
  EXPECT_LT(drift.norm(), 1e-12);
  const double mode1_fine = 1.0 - std::exp(-T * w1 * w1 * 0.5e-4);
  std::printf("undamped free bar over %.1f s: energy loss %.3f %% at h = 0.1 ms, %.3f %% at "
              "0.05 ms (first-mode estimate %.3f %%)\n",
              T, 100 * loss_coarse, 100 * loss_fine, 100 * mode1_fine);
  EXPECT_GT(loss_fine, 0.0);
  // first order: the exponent -ln(1 - loss) halves with h (ratio 2 for a single mode; the faster
  // decaying higher modes saturate, which pulls the ratio of the mixture somewhat below 2)
  const double ratio = std::log(1.0 - loss_coarse) / std::log(1.0 - loss_fine);
  EXPECT_GT(ratio, 1.6);
  EXPECT_LT(ratio, 2.2);
  // stated bound: the loss stays within twice the first-mode estimate (higher modes, and the
  // mesh's stiffer-than-continuum first mode, add to it)
  EXPECT_LT(loss_fine, 2.0 * mode1_fine);
}

// a body rotated rigidly by a large angle and released: no elastic force, no motion (a
// small-strain linear FEM would produce ghost forces and start to move)
TEST(FemSolverTest, RigidRotationAndTranslationProduceNoMotion) {
  TetMesh mesh = MakeBoxTetMesh({5, 4, 4}, {0.05, 0.04, 0.03});
  FemConfig config;
  config.gravity.setZero();
  const FemModel model(mesh, config);
  FemSolver solver(model);
  FemState state(model);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  state.x = (R * model.get_rest_positions()).colwise() + Eigen::Vector3d(1.0, -2.0, 3.0);
  const Eigen::Matrix3Xd x0 = state.x;
  EXPECT_LT(CalcElasticEnergy(model, state), 1e-20);
  solver.Step(state);
  EXPECT_LT((state.x - x0).norm(), 1e-12 * 0.05);
  // ghost force of the same state with R = I (small-strain FEM)
  double ghost = 0.0;
  for (int e = 0; e < model.num_tets(); ++e) {
    Matrix34d xe;
    for (int a = 0; a < 4; ++a) xe.col(a) = x0.col(mesh.tets[e][a]);
    const Eigen::Matrix3d F = CalcDeformationGradient(model.get_rest_shapes()[e], xe);
    ghost += CalcCorotatedEnergy(model.get_rest_shapes()[e], model.get_lame(), Eigen::Matrix3d::Identity(), F);
  }
  EXPECT_GT(ghost, 1.0 * model.get_lame().mu * 0.05 * 0.04 * 0.03);  // O(E V) ghost energy
}

// the engine is scale-free: meshes of 1e-3 and 1e3 times the size, with forces scaled by s^2,
// gravity by 1/s and time by s (same wave speed), follow the same trajectory scaled by s
TEST(FemSolverTest, InvariantOverScales) {
  auto run = [](double s, FemLinearSolver kind) {
    const Scene scene = Block({5, 4, 4}, 0.1 * s);
    FemConfig config;
    config.time_step = 0.02 * s;
    config.gravity = Eigen::Vector3d(0, 0, -9.81) / s;
    config.rayleigh_mass = 0.2 / s;
    config.rayleigh_stiffness = 0.01 * s;
    config.linear_solver = kind;
    config.cg_relative_tolerance = 1e-10;
    const FemModel model(scene.mesh, config, scene.boundary);
    FemSolver solver(model);
    FemState state(model);
    state.external_forces.col(40) = Eigen::Vector3d(0.01, 0.02, 0.0) * s * s;
    for (int step = 0; step < 15; ++step) {
      Prescribe(model, state, (state.time + config.time_step) / s, 2.0 * s);
      solver.Step(state);
    }
    return Eigen::Matrix3Xd(state.x / s);
  };
  for (FemLinearSolver kind : {FemLinearSolver::kDirect, FemLinearSolver::kPcgCachedFactor}) {
    const Eigen::Matrix3Xd unit = run(1.0, kind);
    const Eigen::Matrix3Xd rest = MakeBoxTetMesh({5, 4, 4}, {0.1, 0.08, 0.06}).X;
    const double motion = (unit - rest).norm();
    for (double s : {1e-3, 1e3})
      EXPECT_LT((run(s, kind) - unit).norm(), 1e-7 * motion) << "scale " << s;
  }
}

TEST(FemSolverTest, ConstraintApiCorrectionAndBadInput) {
  const Scene scene = Block({5, 4, 4}, 0.1);
  FemConfig config;
  config.linear_solver = FemLinearSolver::kDirect;
  const FemModel model(scene.mesh, config, scene.boundary);
  FemSolver solver(model);
  FemState state(model);
  const int n = model.num_nodes();
  solver.BeginStep(state);
  // an impulse at one free node: dv = A^-1 impulse; positions move by h dv
  const int node = model.get_free_nodes()[10];
  Eigen::SparseMatrix<double> Ht(3 * n, 1);
  Ht.insert(3 * node + 2, 0) = 1.0;
  Eigen::MatrixXd AinvHt, cached;
  solver.ApplyInverse(Ht, AinvHt);
  solver.ApplyInverse(Ht, cached, FemInverse::kCachedFactor);  // direct path: identical
  EXPECT_LT((AinvHt - cached).norm(), 1e-14 * AinvHt.norm());
  const double impulse = 1e-3;  // N s
  const Eigen::VectorXd dv_c = AinvHt.col(0) * impulse;
  const Eigen::Matrix3Xd x_free = state.x_free;
  const FemState before = state;
  solver.CommitStep(state, dv_c);
  const Eigen::Matrix3Xd moved = state.x - x_free;
  EXPECT_LT((Eigen::Map<const Eigen::VectorXd>(moved.data(), 3 * n) - config.time_step * dv_c).norm(),
            1e-14 * x_free.norm());
  EXPECT_GT(moved(2, node), 0.0);
  // bad input: correction at a Dirichlet node, wrong size, NaN prescription; a NaN correction
  FemState bad = before;
  Eigen::VectorXd wrong = Eigen::VectorXd::Zero(3 * n);
  wrong[3 * model.get_dirichlet_nodes()[0]] = 1.0;
  EXPECT_THROW(solver.CommitStep(bad, wrong), InputError);
  wrong.setZero();
  wrong[3 * node] = std::nan("");
  // a non-finite correction comes from a diverged constraint solve: a runtime failure
  EXPECT_THROW(solver.CommitStep(bad, wrong), SolverError);
  EXPECT_THROW(solver.CommitStep(bad, Eigen::VectorXd::Zero(5)), InputError);
  bad.prescribed_positions(0, 0) = std::nan("");
  EXPECT_THROW(solver.BeginStep(bad), InputError);
}

// large prescribed compression: elements invert; the solver stays finite and counts them
TEST(FemSolverTest, SurvivesInvertingCompression) {
  const Scene scene = Block({5, 4, 4}, 0.1);
  FemConfig config;
  config.gravity.setZero();
  const FemModel model(scene.mesh, config, scene.boundary);
  FemSolver solver(model);
  FemState state(model);
  int max_inverted = 0;
  for (int step = 0; step < 20; ++step) {
    // push the top layer down to 5 % of the height, then back
    const double squash = step < 10 ? 0.095 * (step + 1) : 0.095 * (20 - step - 1);
    for (size_t k = 0; k < model.get_prescribed_nodes().size(); ++k)
      state.prescribed_positions.col(k) =
          model.get_rest_positions().col(model.get_prescribed_nodes()[k]) - Eigen::Vector3d(0, 0, squash * 0.06);
    const FemStepStats stats = solver.Step(state);
    max_inverted = std::max(max_inverted, stats.inverted_tets);
    ASSERT_TRUE(state.x.allFinite()) << step;
    EXPECT_LE(stats.relative_residual, config.cg_relative_tolerance);
  }
  std::printf("inverting compression: up to %d of %d tets inverted or degenerate\n", max_inverted,
              model.num_tets());
  EXPECT_GT(max_inverted, 0);
}

TEST(FemSolverTest, BackgroundRefactorizationIsAdopted) {
  const Scene scene = Block({6, 5, 4}, 0.1);
  FemConfig config;
  config.background_refactor = true;
  config.refactor_iteration_threshold = 1;  // every step with > 1 iteration asks for a refresh
  const FemModel model(scene.mesh, config, scene.boundary);
  FemSolver solver(model);
  FemState state(model);
  int swapped = 0;
  for (int step = 0; step < 20; ++step) {
    Prescribe(model, state, state.time + config.time_step, 3.0);
    const FemStepStats stats = solver.Step(state);
    EXPECT_LE(stats.relative_residual, config.cg_relative_tolerance);
    EXPECT_FALSE(stats.refactorized);  // never on this thread
    swapped += stats.factor_swapped;
    solver.WaitForBackgroundFactorization();
  }
  EXPECT_GT(swapped, 0);
  // the rest factorization, the adopted ones, and possibly one finished but not yet adopted
  EXPECT_GE(solver.get_factorization_count(), 1 + swapped);
  EXPECT_LE(solver.get_factorization_count(), 2 + swapped);
}

}  // namespace
}  // namespace nsim
