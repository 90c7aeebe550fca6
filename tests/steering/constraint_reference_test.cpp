// The constraint solves of the three former call sites on fixed problems, against the values the
// code gave before they became users of one solver (recorded from commit 250720e, where they
// were ConstraintSolver, NeedleConstraintSolver::Solve and ConstraintSnapshot::Solve):
//   - generic: a bilateral set (direct LDLT) and a Coulomb-friction contact set (PGS);
//   - needle coupling: lateral rows, axial friction rows (sticking and slipping, with and
//     without stiction) and contacts (one pushing, one separated), active set;
//   - frozen step: a captured step (held point, needle rows that turn, a contact on the needle
//     tip) solved at a perturbed needle pose.
// Set NSIM_PRINT_REFERENCE=1 to print the values instead of comparing them.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "common/constraints/constraint_solver.h"
#include "common/constraints/dense_linear_body.h"
#include "common/steering/constraint_snapshot.h"
#include "tests/steering/constraint_test_problem.h"

namespace nsim::constraint_test {
namespace {

// relative to the largest recorded value of each vector. The generic and the needle solves are
// bit-identical to the recorded ones on this machine (Release build); 1e-12 leaves room for
// other compilers and flags.
constexpr double kTolerance = 1e-12;
// the former frozen-step solve regularized its contact active set only when singular; the one
// solver's active set always adds 1e-12 of the largest diagonal entry (as the needle solver
// did), so the multipliers here differ from the recorded ones by 2.2e-12 of the largest force
// (the probes by 1.6e-15 m)
constexpr double kSnapshotTolerance = 1e-11;

bool PrintMode() { return std::getenv("NSIM_PRINT_REFERENCE") != nullptr; }

// prints `values` as a C++ initializer, or compares them with `expected` to `tolerance` times
// the largest |expected| (plus an absolute floor of the same size for the zeros)
void Check(const std::string& name, const Eigen::VectorXd& values,
           const std::vector<double>& expected, double tolerance) {
  if (PrintMode()) {
    std::printf("  const std::vector<double> %s = {", name.c_str());
    for (Eigen::Index i = 0; i < values.size(); ++i)
      std::printf("%s%.17g", i ? ", " : "", values[i]);
    std::printf("};\n");
    return;
  }
  ASSERT_EQ(values.size(), static_cast<Eigen::Index>(expected.size())) << name;
  double scale = 0.0;
  for (double e : expected) scale = std::max(scale, std::abs(e));
  for (size_t i = 0; i < expected.size(); ++i)
    EXPECT_NEAR(values[i], expected[i], tolerance * scale) << name << "[" << i << "]";
}

Eigen::VectorXd Flatten(const Eigen::Matrix3Xd& x) {
  return Eigen::Map<const Eigen::VectorXd>(x.data(), x.size());
}

enum AxialRow { kAxialBilateral, kAxialFriction };

// needle rows on 4 tissue points between nodes k and k + 1: the needle line is offset laterally
// from the points and slides along x over the step by 3 mm at points 1 and 3, by 0.1 and 0.15 mm
// at points 0 and 2 (where the axial friction can hold the tissue). Each point gets 2 lateral
// rows, then an axial row: bilateral, or friction with mu 0.4 and stiction 0, 2, 10, 0 mN
// bounded by the lateral force (the needle coupling's rows).
void AddNeedleRows(ConstraintSet& set, int b, AxialRow axial) {
  Eigen::Matrix<double, 3, 2> lateral;
  lateral << Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ();
  const double slide[4] = {0.0001, 0.003, 0.00015, 0.003};
  const double stiction[4] = {0.0, 0.002, 0.01, 0.0};
  for (int k = 0; k < 4; ++k) {
    const int pt = set.AddBodyPoint(b, std::vector<int>{k, k + 1}, std::vector<double>{0.6, 0.4},
                                    static_cast<std::uint64_t>(k + 1));
    const Eigen::Vector3d xs = set.CalcStartPosition(pt);
    const Eigen::Vector3d start = xs + Eigen::Vector3d(0.0, 0.0005 * (k + 1), 0.0003 * (2 - k));
    const int pn = set.AddKinematicPoint(start, start + Eigen::Vector3d(slide[k], 0.0, 0.0));
    const int lateral_group = set.AddBilateral(pt, pn, lateral);
    if (axial == kAxialBilateral) set.AddBilateral(pt, pn, Eigen::Vector3d::UnitX());
    if (axial == kAxialFriction)
      set.AddAxialFriction(pt, pn, Eigen::Vector3d::UnitX(), lateral_group, 0.4, stiction[k]);
  }
}

// the needle rows as bilateral rows only: one LDLT solve
TEST(ConstraintReferenceTest, GenericDirectBilateral) {
  DenseLinearBody body(ChainConfig());
  body.external_forces().col(2) = Eigen::Vector3d(0.05, 0.02, -0.1);
  body.SolveFreeMotion();
  ConstraintSet set;
  const int b = set.AddBody(body);
  AddNeedleRows(set, b, kAxialBilateral);
  ConstraintSolver solver;
  const ConstraintSolveReport r = solver.Solve(set);
  EXPECT_EQ(r.method, ConstraintMethod::kDirect);
  EXPECT_TRUE(r.converged);
  const std::vector<double> lambda = {
      -0.096796390589589942, 0.64708175347259322, -2.405790598639749,
      0.32691748356873634, 0.11589948679402767, 5.4933563205532563,
      0.025712524211682034, 0.4232643821480237, -5.3848031076425373,
      1.101260704360429, 0.047332613529381756, 3.9953230130708546};
  const std::vector<double> x = {
      -0.0036399067606685417, 0.00019789878416816745, 0.00069836018939474845,
      0.015709860141002809, 0.00095315182374774835, 0.00045245971590787671,
      0.018935209788495787, 0.0010702722643783768, 7.1310426138184412e-05,
      0.031972185317256312, 0.0021445916034324342, -0.00010696563920727727,
      0.044541722024115535, 0.0017831125948513491, -0.00058955154118908422,
      0.051221357626507223, 0.00073644453717820941, -0.00074372197132431777};
  Check("lambda", solver.lambda(), lambda, kTolerance);
  Check("x", Flatten(body.positions()), x, kTolerance);
}

// the chain on a floor with Coulomb friction at every node, pushed sideways: PGS
TEST(ConstraintReferenceTest, GenericPgsFriction) {
  DenseLinearBody body(ChainConfig());
  body.external_forces().col(0) = Eigen::Vector3d(0.3, 0.1, 0.0);
  body.external_forces().col(5) = Eigen::Vector3d(-0.05, 0.2, -0.2);
  body.SolveFreeMotion();
  ConstraintSet set;
  const int b = set.AddBody(body);
  const int floor = set.AddKinematicPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  for (int i = 0; i < body.num_nodes(); ++i)
    set.AddFrictionContact(set.AddNodePoint(b, i), floor, Eigen::Vector3d(0.0, 0.1, 1.0), 0.3);
  ConstraintSolver solver;
  const ConstraintSolveReport r = solver.Solve(set);
  EXPECT_EQ(r.method, ConstraintMethod::kPgs);
  EXPECT_TRUE(r.converged);
  const std::vector<double> lambda = {
      0.18527595413767431, -0.051654145383299634, -0.020525481506343493,
      0.19522630422866633, -0.045380094787845639, -0.037024922480630343,
      0.19522628205075332, -0.045380091259920832, -0.037024916280036117,
      0.19522629268152786, 0.0046167540007386676, -0.043976693217856175,
      0.195226298414726, 0.0048490203668690056, -0.043787191934992198,
      0.37433299135561837, 0.023048450759620528, -0.10990921651587479};
  const std::vector<double> x = {
      0.00077744536359269413, 0.00030739539541947746, -3.0739444902228344e-05,
      0.01000387111089991, 3.1427041086291944e-06, -3.1423948736587597e-07,
      0.020003406584649452, 2.7655875271918873e-06, -2.7657604458769004e-07,
      0.030000000000588053, 1.5978457706261606e-12, -7.4408266007019996e-12,
      0.040000000000014004, -1.2063223683855817e-13, 6.1629477562941126e-13,
      0.049915776408736699, 0.00039963677156448405, -3.9963677156448383e-05};
  Check("lambda", solver.lambda(), lambda, kTolerance);
  Check("x", Flatten(body.positions()), x, kTolerance);
}

// the needle coupling's problem: lateral and axial friction rows on 4 points, a contact that
// pushes (node 5 on a floor 0.2 mm below) and one that is separated (node 0, floor 5 cm below)
TEST(ConstraintReferenceTest, NeedleAxialFrictionAndContacts) {
  DenseLinearBody body(ChainConfig());
  body.external_forces().col(2) = Eigen::Vector3d(0.05, 0.02, -0.1);
  body.SolveFreeMotion();
  ConstraintSet set;
  const int b = set.AddBody(body);
  AddNeedleRows(set, b, kAxialFriction);
  const Eigen::Vector3d x5 = set.CalcStartPosition(set.AddNodePoint(b, 5));
  const Eigen::Vector3d below5 = x5 - Eigen::Vector3d(0.0, 0.0, 0.0002);
  set.AddContact(set.AddNodePoint(b, 5), set.AddKinematicPoint(below5, below5),
                 Eigen::Vector3d::UnitZ());
  const Eigen::Vector3d below0(0.0, 0.0, -0.05);
  set.AddContact(set.AddNodePoint(b, 0), set.AddKinematicPoint(below0, below0),
                 Eigen::Vector3d::UnitZ());
  ConstraintSolver solver;
  const ConstraintSolveReport r = solver.Solve(set);
  EXPECT_EQ(r.method, ConstraintMethod::kActiveSet);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.num_slipping, 3);  // point 0 sticks
  EXPECT_EQ(r.num_separated, 1);
  const std::vector<double> lambda = {
      -0.096796390588097025, 0.64837866369844699, -0.060163343339700796,
      0.32691748356567024, 0.11238210905718299, 0.14027785332267831,
      0.025712524215883645, 0.42994215980859812, -0.18228413493177348,
      1.1012607043562226, -0.020139468578701247, 0.44057793628892422,
      0.17370453156412813, 0};
  const std::vector<double> x = {
      -2.2418718828086106e-05, 0.00019789878417073712, 0.00070118981170609065,
      0.010283628078242634, 0.00095315182374470695, 0.00044821528243541974,
      0.020198438854737915, 0.0010702722643801941, 7.7677076345926931e-05,
      0.030618601448664736, 0.0021445916034294921, -0.00011651561452250111,
      0.040629729787165308, 0.0017831125948465135, -0.00057522657821607905,
      0.050234062106718137, 0.00073644453717675127, -0.00020000000000058339};
  Check("lambda", solver.lambda(), lambda, kTolerance);
  Check("x", Flatten(body.positions()), x, kTolerance);
}

// the frozen step: node 0 held, needle rows on 3 points moving with the needle (they turn with
// it), the needle tip in contact with node 5; captured at X_WN, solved at a pose turned by
// 0.02 rad and shifted by half a millimetre
TEST(ConstraintReferenceTest, SnapshotPerturbedPose) {
  DenseLinearBody body(ChainConfig());
  body.external_forces().col(3) = Eigen::Vector3d(0.0, -0.05, -0.1);
  body.SolveFreeMotion();
  const Eigen::Isometry3d X_WN = CapturedPose();
  ConstraintSet set;
  const int b = set.AddBody(body);
  const Eigen::Vector3d x0 = body.start_positions().col(0);
  set.AddBilateral(set.AddNodePoint(b, 0), set.AddKinematicPoint(x0, x0),
                   Eigen::Matrix3d::Identity());
  const int first_needle_point = set.num_points();
  Eigen::Matrix<double, 3, 2> lateral;
  lateral << Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ();
  for (int k = 1; k <= 3; ++k) {
    const int pt = set.AddBodyPoint(b, std::vector<int>{k, k + 1}, std::vector<double>{0.7, 0.3});
    const Eigen::Vector3d on_needle =
        X_WN * Eigen::Vector3d(set.CalcStartPosition(pt).x(), 0.0, 0.0);
    set.AddBilateral(pt, set.AddKinematicPoint(on_needle, on_needle), lateral);
  }
  const Eigen::Vector3d tip = X_WN * Eigen::Vector3d(0.05, 0.0, 0.0);
  set.AddContact(set.AddNodePoint(b, 5), set.AddKinematicPoint(tip, tip),
                 Eigen::Vector3d(0.0, 1.0, 0.5));
  ConstraintSolver solver;
  solver.Assemble(set);
  std::vector<char> moves(set.num_points(), 0);
  for (int p = first_needle_point; p < set.num_points(); ++p) moves[p] = set.point(p).body < 0;
  ConstraintSnapshot snapshot;
  snapshot.Capture(set, solver, b, moves, X_WN, Probes());
  SnapshotWorkspace ws;
  std::vector<Eigen::Vector3d> p;
  const ConstraintSolveReport r = snapshot.Solve(PerturbedPose(), ws, &p);
  EXPECT_TRUE(r.converged);
  Eigen::VectorXd probe_positions(6);
  probe_positions << p[0], p[1];
  const std::vector<double> lambda = {
      0.0014147051448000995, -0.11418055332943654, 0.12075632067688924,
      0.28986586603710129, 0.54238325553844657, 0.21293331157875034,
      0.26095261271029685, 0.47737499916951598, 0.62342084781190188,
      0.47314913622872706};
  const std::vector<double> probe = {
      0.01998746735136768, 0.00099245554889881436, 0.00056627842774474254,
      0.040989339220899083, 0.0013403589259763562, 0.0003243766651392253};
  Check("lambda", ws.lambda, lambda, kSnapshotTolerance);
  Check("probe", probe_positions, probe, kSnapshotTolerance);
}

}  // namespace
}  // namespace nsim::constraint_test
