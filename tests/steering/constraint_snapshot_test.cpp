// The frozen-step solve (ConstraintSnapshot) with every law it takes: a held point (bilateral),
// needle rows that turn with the needle (lateral bilateral rows and axial friction bounded by
// the lateral force) and a contact on the needle tip (unilateral, its normal fixed). At the
// captured pose it gives the multipliers and corrected positions of the step's own solve; at a
// perturbed pose those of a full solve of the same step with the needle moved, and the
// resultant force on the needle that solve's.

#include "common/steering/constraint_snapshot.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <vector>

#include "common/constraints/constraint_solver.h"
#include "common/constraints/dense_linear_body.h"
#include "common/core/error.h"
#include "tests/steering/constraint_test_problem.h"

namespace nsim::constraint_test {
namespace {

// the rows of a step whose needle was at X_capture when the rows were made (start positions
// and targets) and is at X_WN at the step end (end positions and the needle rows' directions):
// what a ConstraintSnapshot captured at X_capture solves at X_WN. Needle points are given in
// the needle frame.
struct Step {
  DenseLinearBody body;
  ConstraintSet set;
  std::vector<char> moves_with_needle;

  Step() : body(ChainConfig()) {
    body.external_forces().col(3) = Eigen::Vector3d(0.0, -0.05, -0.1);
    body.SolveFreeMotion();
  }

  void Build(const Eigen::Isometry3d& X_WN, const Eigen::Isometry3d& X_capture) {
    set.Clear();
    const int b = set.AddBody(body);
    const Eigen::Vector3d x0 = body.start_positions().col(0);
    set.AddBilateral(set.AddNodePoint(b, 0, 1), set.AddKinematicPoint(x0, x0),
                     Eigen::Matrix3d::Identity());
    const int first_needle_point = set.num_points();
    Eigen::Matrix<double, 3, 2> lateral;
    lateral << X_WN.linear() * Eigen::Vector3d::UnitY(), X_WN.linear() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d axis = X_WN.linear() * Eigen::Vector3d::UnitX();
    const Eigen::Vector3d axis_capture = X_capture.linear() * Eigen::Vector3d::UnitX();
    // the needle slides by 0.1 mm (points 1, 3: friction holds) or 2 mm (point 2: slips)
    const double slide[4] = {0.0, 0.0001, 0.002, 0.0001};
    for (int k = 1; k <= 3; ++k) {
      const int pt =
          set.AddBodyPoint(b, std::vector<int>{k, k + 1}, std::vector<double>{0.7, 0.3}, 10 + k);
      const Eigen::Vector3d p_N(0.01 * k + 0.003, 0.0004 * k, -0.0002);
      const Eigen::Vector3d start = X_capture * (p_N - Eigen::Vector3d(slide[k], 0.0, 0.0));
      const int pn = set.AddKinematicPoint(start, X_WN * p_N);
      const int lateral_group = set.AddBilateral(pt, pn, lateral);
      // target: the axial offset at the step start, along the captured axis
      const double target = axis_capture.dot(set.CalcStartPosition(pt) - start);
      set.AddAxialFriction(pt, pn, axis, lateral_group, 0.4, 0.001, axis * target);
    }
    const Eigen::Vector3d tip = X_WN * Eigen::Vector3d(0.05, 0.0, 0.0);
    set.AddContact(set.AddNodePoint(b, 5, 20), set.AddKinematicPoint(tip, tip),
                   Eigen::Vector3d(0.0, 1.0, 0.5));
    moves_with_needle.assign(set.num_points(), 0);
    for (int p = first_needle_point; p < set.num_points(); ++p)
      moves_with_needle[p] = set.point(p).body < 0;
  }
};

// corrected positions of the probes after a full solve of `step`
std::vector<Eigen::Vector3d> SolveFully(Step& step, ConstraintSolver& solver,
                                        ConstraintSolveReport* report) {
  solver.Assemble(step.set);
  *report = solver.SolveMultipliers(step.set);
  Eigen::Matrix3Xd x = step.body.free_positions();
  solver.ApplyCorrections(step.set);
  x += solver.corrections()[0];
  std::vector<Eigen::Vector3d> out;
  for (const SnapshotProbe& probe : Probes()) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < probe.nodes.size(); ++k) p += probe.weights[k] * x.col(probe.nodes[k]);
    out.push_back(p);
  }
  return out;
}

// the step built at the captured pose, solved, and captured in `snapshot`
void SolveAndCapture(Step& step, ConstraintSolver& solver, ConstraintSnapshot& snapshot) {
  step.Build(CapturedPose(), CapturedPose());
  solver.Assemble(step.set);
  solver.SolveMultipliers(step.set);
  snapshot.Capture(step.set, solver, 0, step.moves_with_needle, CapturedPose(), Probes());
}

TEST(ConstraintSnapshotTest, CapturedPoseGivesTheStepSolve) {
  Step step;
  step.Build(CapturedPose(), CapturedPose());
  ConstraintSolver solver;
  solver.Assemble(step.set);
  const ConstraintSolveReport full = solver.SolveMultipliers(step.set);
  ASSERT_EQ(full.method, ConstraintMethod::kActiveSet);
  ASSERT_TRUE(full.converged);
  ConstraintSnapshot snapshot;
  snapshot.Capture(step.set, solver, 0, step.moves_with_needle, CapturedPose(), Probes());
  SnapshotWorkspace ws;
  std::vector<Eigen::Vector3d> probes;
  const ConstraintSolveReport r = snapshot.Solve(CapturedPose(), ws, &probes);
  EXPECT_EQ(r.method, ConstraintMethod::kActiveSet);
  EXPECT_TRUE(r.converged);
  // the problem exercises every law: friction holds two points, one slips, the contact pushes
  EXPECT_EQ(r.num_slipping, 1);
  EXPECT_EQ(r.num_separated, 0);
  EXPECT_EQ(r.num_slipping, full.num_slipping);
  const double scale = solver.lambda().cwiseAbs().maxCoeff();
  EXPECT_LE((ws.lambda - solver.lambda()).cwiseAbs().maxCoeff(), 1e-10 * scale);
  ConstraintSolveReport again;
  Step reference;
  reference.Build(CapturedPose(), CapturedPose());
  ConstraintSolver reference_solver;
  const std::vector<Eigen::Vector3d> expected = SolveFully(reference, reference_solver, &again);
  for (size_t q = 0; q < probes.size(); ++q)
    EXPECT_LT((probes[q] - expected[q]).norm(), 1e-12) << "probe " << q;
}

TEST(ConstraintSnapshotTest, PerturbedPoseGivesTheFullSolveWithTheNeedleMoved) {
  Step step;
  ConstraintSolver solver;
  ConstraintSnapshot snapshot;
  SolveAndCapture(step, solver, snapshot);
  const Eigen::Isometry3d X_new = PerturbedPose();
  SnapshotWorkspace ws;
  std::vector<Eigen::Vector3d> probes;
  const ConstraintSolveReport r = snapshot.Solve(X_new, ws, &probes);
  EXPECT_TRUE(r.converged);

  Step moved;
  moved.Build(X_new, CapturedPose());
  ConstraintSolver full_solver;
  ConstraintSolveReport full;
  const std::vector<Eigen::Vector3d> expected = SolveFully(moved, full_solver, &full);
  ASSERT_TRUE(full.converged);
  EXPECT_EQ(r.num_slipping, full.num_slipping);
  const double scale = full_solver.lambda().cwiseAbs().maxCoeff();
  EXPECT_LE((ws.lambda - full_solver.lambda()).cwiseAbs().maxCoeff(), 1e-10 * scale);
  for (size_t q = 0; q < probes.size(); ++q)
    EXPECT_LT((probes[q] - expected[q]).norm(), 1e-12) << "probe " << q;
  // the perturbation changed the answer (the comparison is not trivial)
  EXPECT_GT((ws.lambda - solver.lambda()).cwiseAbs().maxCoeff(), 1e-3 * scale);
  // the needle's load (SnapshotWorkspace::needle_force) is the full solve's force on the points
  // that move with the needle: each row's multiplier times its needle terms' directions
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  for (int i = 0; i < moved.set.num_rows(); ++i) {
    const ConstraintRow& row = moved.set.rows()[i];
    for (int t = row.first_term; t < row.first_term + row.num_terms; ++t)
      if (moved.moves_with_needle[moved.set.term(t).point])
        force += full_solver.lambda()[i] * moved.set.term(t).direction;
  }
  ASSERT_GT(force.norm(), 1e-3) << "no load on the needle: the comparison is trivial";
  EXPECT_LT((ws.needle_force - force).norm(), 1e-10 * force.norm());
}

// soft rows (ConstraintRow::softness and ::compliance) keep their softness in the perturbed
// solves: the same as a full solve of the moved step with the same soft rows
TEST(ConstraintSnapshotTest, SoftRowsStaySoftUnderPerturbation) {
  auto soften = [](Step& step) {
    step.set.SetSoftness(3, 2, 1.5);      // point 1's lateral rows
    step.set.SetCompliance(6, 2, 2e-3);   // point 2's lateral rows: a 500 N/m spring
  };
  Step step;
  step.Build(CapturedPose(), CapturedPose());
  soften(step);
  ConstraintSolver solver;
  solver.Assemble(step.set);
  solver.SolveMultipliers(step.set);
  ConstraintSnapshot snapshot;
  snapshot.Capture(step.set, solver, 0, step.moves_with_needle, CapturedPose(), Probes());
  SnapshotWorkspace ws;
  std::vector<Eigen::Vector3d> probes;
  snapshot.Solve(PerturbedPose(), ws, &probes);
  Step moved, rigid;
  moved.Build(PerturbedPose(), CapturedPose());
  soften(moved);
  rigid.Build(PerturbedPose(), CapturedPose());
  ConstraintSolver full_solver, rigid_solver;
  ConstraintSolveReport full, rigid_report;
  const std::vector<Eigen::Vector3d> expected = SolveFully(moved, full_solver, &full);
  const std::vector<Eigen::Vector3d> stiff = SolveFully(rigid, rigid_solver, &rigid_report);
  ASSERT_TRUE(full.converged);
  double softened = 0.0;
  for (size_t q = 0; q < probes.size(); ++q) {
    EXPECT_LT((probes[q] - expected[q]).norm(), 1e-12) << "probe " << q;
    softened = std::max(softened, (expected[q] - stiff[q]).norm());
  }
  EXPECT_GT(softened, 1e-6) << "the softness changed nothing: the comparison is trivial";
}

// held friction (set_hold_friction): the friction rows leave the problem with the step's
// forces; at the captured pose the other rows' multipliers and the probes are the step's, and a
// perturbed needle is solved without friction rows (bilateral and contact rows only)
TEST(ConstraintSnapshotTest, HeldFrictionReproducesTheStepAndDropsTheFrictionRows) {
  Step step;
  step.Build(CapturedPose(), CapturedPose());
  ConstraintSolver solver;
  ConstraintSolveReport full;
  Step reference;
  reference.Build(CapturedPose(), CapturedPose());
  ConstraintSolver reference_solver;
  const std::vector<Eigen::Vector3d> expected = SolveFully(reference, reference_solver, &full);
  solver.Assemble(step.set);
  solver.SolveMultipliers(step.set);
  ConstraintSnapshot snapshot;
  snapshot.set_hold_friction(true);
  snapshot.Capture(step.set, solver, 0, step.moves_with_needle, CapturedPose(), Probes());
  EXPECT_EQ(snapshot.num_rows(), step.set.num_rows() - 3);  // the three axial rows held
  SnapshotWorkspace ws;
  std::vector<Eigen::Vector3d> probes;
  const ConstraintSolveReport r = snapshot.Solve(CapturedPose(), ws, &probes);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.num_slipping, 0);  // no friction row left to slip
  for (size_t q = 0; q < probes.size(); ++q)
    EXPECT_LT((probes[q] - expected[q]).norm(), 1e-12) << "probe " << q;
  // the remaining rows' multipliers are the step's (rows 0-2 anchor, then 2 lateral + 1 axial per
  // needle point, then the contact)
  const Eigen::VectorXd& step_lambda = solver.lambda();
  const double scale = step_lambda.cwiseAbs().maxCoeff();
  int kept = 0;
  for (int i = 0; i < step.set.num_rows(); ++i) {
    const bool axial = i >= 3 && i < 12 && (i - 3) % 3 == 2;
    if (axial) continue;
    EXPECT_NEAR(ws.lambda[kept], step_lambda[i], 1e-10 * scale) << "row " << i;
    ++kept;
  }
  // perturbed: a solve of the bilateral and contact rows only (the method of contacts)
  const ConstraintSolveReport moved = snapshot.Solve(PerturbedPose(), ws, &probes);
  EXPECT_TRUE(moved.converged);
  EXPECT_EQ(moved.method, ConstraintMethod::kActiveSet);
}

// CalcNeedleTranslationStiffness is minus the derivative of the needle's force with respect to
// a translation of the needle (central differences of Solve; the friction held, so that the rows
// left are bilateral and a closed contact, and the small translations change no active set),
// symmetric and positive semi-definite
TEST(ConstraintSnapshotTest, NeedleTranslationStiffnessIsMinusTheForceDerivative) {
  Step step;
  ConstraintSolver solver;
  ConstraintSnapshot snapshot;
  snapshot.set_hold_friction(true);
  SolveAndCapture(step, solver, snapshot);
  SnapshotWorkspace ws;
  const Eigen::Matrix3d K = snapshot.CalcNeedleTranslationStiffness(ws);
  std::vector<Eigen::Vector3d> probes;
  const double h = 1e-7;
  Eigen::Matrix3d K_fd;
  for (int j = 0; j < 3; ++j) {
    Eigen::Isometry3d plus = CapturedPose(), minus = CapturedPose();
    plus.translation()[j] += h;
    minus.translation()[j] -= h;
    const ConstraintSolveReport a = snapshot.Solve(plus, ws, &probes);
    const Eigen::Vector3d f_plus = ws.needle_force;
    const ConstraintSolveReport b = snapshot.Solve(minus, ws, &probes);
    ASSERT_TRUE(a.converged && b.converged);
    ASSERT_EQ(a.num_separated, 0);
    ASSERT_EQ(b.num_separated, 0);
    K_fd.col(j) = -(f_plus - ws.needle_force) / (2 * h);
  }
  ASSERT_GT(K.norm(), 1.0);
  EXPECT_LT((K - K_fd).norm(), 1e-6 * K.norm()) << "K\n" << K << "\nfinite differences\n" << K_fd;
  EXPECT_LT((K - K.transpose()).norm(), 1e-12 * K.norm());
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(K).eigenvalues().minCoeff(),
            -1e-9 * K.norm());
  // no rows on the needle: no stiffness
  Step anchor_only;
  anchor_only.set.Clear();
  const int b = anchor_only.set.AddBody(anchor_only.body);
  const Eigen::Vector3d x0 = anchor_only.body.start_positions().col(0);
  anchor_only.set.AddBilateral(anchor_only.set.AddNodePoint(b, 0, 1),
                               anchor_only.set.AddKinematicPoint(x0, x0), Eigen::Matrix3d::Identity());
  ConstraintSolver anchor_solver;
  anchor_solver.Assemble(anchor_only.set);
  anchor_solver.SolveMultipliers(anchor_only.set);
  ConstraintSnapshot none;
  none.Capture(anchor_only.set, anchor_solver, 0, std::vector<char>(2, 0), CapturedPose(), Probes());
  EXPECT_EQ(none.CalcNeedleTranslationStiffness(ws), Eigen::Matrix3d::Zero());
}

TEST(ConstraintSnapshotTest, RejectsCoulombFrictionContacts) {
  Step step;
  step.set.Clear();
  const int b = step.set.AddBody(step.body);
  const int floor = step.set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  step.set.AddFrictionContact(step.set.AddNodePoint(b, 0), floor, Eigen::Vector3d::UnitZ(), 0.3);
  ConstraintSolver solver;
  solver.Assemble(step.set);
  ConstraintSnapshot snapshot;
  EXPECT_THROW(snapshot.Capture(step.set, solver, 0, std::vector<char>(2, 0),
                                Eigen::Isometry3d::Identity(), {}),
               InputError);
}

}  // namespace
}  // namespace nsim::constraint_test
