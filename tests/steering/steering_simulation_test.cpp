// The inverse model and its frozen-step perturbation solves: the solve at the unperturbed pose
// reproduces the committed step, and a perturbed solve equals a full re-simulation of the same
// step with the perturbed needle (the two paths DESIGN.md "Speed" says must agree), for the
// frictionless model, with the needle's axial friction, with anchored nodes and with the bevel;
// a model built mid-insertion catches up with one that followed the insertion. The bevel's load
// on the model liver (rigid needle) and on the beam (flexible needle); the flexible model needle's
// frozen step against full re-simulations (translations, rotations), against the rigid model
// for a very stiff beam.

#include "common/steering/steering_simulation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "common/core/error.h"
#include "common/mesh/oriented_box.h"
#include "common/needle/bevel_tip.h"
#include "common/robot/pose_math.h"
#include "tests/steering/steering_test_scene.h"

namespace nsim {
namespace {

using steering_test::LoadLiver;
using steering_test::MakeModelConfig;
using steering_test::MakePathConfig;

constexpr double kAdvancePerStep = 0.002;  // needle advance per step (m)

// flange pose after `step` steps of a straight insertion along the path
Eigen::Isometry3d InsertionPose(const Eigen::Isometry3d& X_WF0, const Eigen::Vector3d& dir,
                                int step) {
  Eigen::Isometry3d X = X_WF0;
  X.translation() += kAdvancePerStep * step * dir;
  return X;
}

std::vector<Eigen::Vector3d> RestMarkers(const InverseModelConfig& c) { return c.markers_W; }

class SteeringSimulationTest : public ::testing::Test {
 protected:
  SteeringSimulationTest()
      : mesh_(LoadLiver("liver_700")),
        model_(MakeModelConfig()),
        path_(MakePathConfig()),
        X_WF0_(SteeringSimulation::CalcStartFlangePose(model_.needle, path_)),
        dir_((path_.target_W - path_.entry_W).normalized()) {}

  // a model advanced by `steps` insertion steps
  std::unique_ptr<SteeringSimulation> Advance(int steps) const {
    auto sim = std::make_unique<SteeringSimulation>(model_, path_, mesh_, X_WF0_);
    for (int i = 1; i <= steps; ++i)
      sim->Step(RestMarkers(model_), InsertionPose(X_WF0_, dir_, i), bevel_angle_);
    return sim;
  }

  // the path targets of a model that has not moved (m)
  std::vector<Eigen::Vector3d> RestPath() const {
    return SteeringSimulation(model_, path_, mesh_, X_WF0_).CalcPathPositions();
  }

  TetMesh mesh_;
  InverseModelConfig model_;
  SteeringPathConfig path_;
  Eigen::Isometry3d X_WF0_;
  Eigen::Vector3d dir_;
  double bevel_angle_ = 0.0;  // bevel roll passed to every Step (rad)
};

// steps that put the tip ~3 cm into the liver (10 mm approach + puncture + 30 mm)
constexpr int kInsideSteps = 25;

// the region of liver_700 the anchored variant holds: its posterior-inferior part (the default
// scenario's patient.anchors), away from the markers and the path
OrientedBox PosteriorAnchor() {
  OrientedBox box;
  box.center = {0.0, -0.06, -0.045};
  box.half_size = {0.12, 0.015, 0.045};
  return box;
}

// The model variants the frozen-step solves must handle: frictionless and held by the markers
// alone (the default); with the needle's axial friction (then the active set decides stick or
// slip in the perturbation solves too); with an anchored region (fixed nodes).
struct ModelVariant {
  const char* name;
  double friction_coefficient;
  bool anchored;
  bool bevel = false;  // the bevel tip load on (roll 0.7 rad)
  bool friction_held = false;  // the Jacobian's frozen step holds the friction forces
};

class SteeringSimulationVariantTest : public SteeringSimulationTest,
                                      public ::testing::WithParamInterface<ModelVariant> {
 protected:
  SteeringSimulationVariantTest() {
    model_.coupling.friction_coefficient = GetParam().friction_coefficient;
    model_.jacobian_friction_held = GetParam().friction_held;
    if (GetParam().anchored) model_.anchors = {PosteriorAnchor()};
    model_.bevel.enabled = GetParam().bevel;
    bevel_angle_ = 0.7;
  }
};

INSTANTIATE_TEST_SUITE_P(Models, SteeringSimulationVariantTest,
                         ::testing::Values(ModelVariant{"plain", 0.0, false},
                                           ModelVariant{"friction", 0.1, false},
                                           ModelVariant{"friction_held", 0.1, false, false, true},
                                           ModelVariant{"anchored", 0.0, true},
                                           ModelVariant{"bevel", 0.0, false, true}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST_F(SteeringSimulationTest, PuncturesTheLiverAndSeedsPoints) {
  auto sim = Advance(kInsideSteps);
  EXPECT_TRUE(sim->liver_punctured());
  EXPECT_GE(sim->liver_coupling().points.size(), 2u);
  Eigen::Vector3d entry;
  ASSERT_TRUE(sim->CalcLiverEntryPoint(&entry));
  EXPECT_LT((entry - path_.entry_W).norm(), 0.01);
}

TEST_P(SteeringSimulationVariantTest, UnperturbedSolveReproducesTheCommittedStep) {
  auto sim = Advance(kInsideSteps);
  SnapshotWorkspace ws;
  const SteeringEvaluation eval = sim->EvaluateAt(InsertionPose(X_WF0_, dir_, kInsideSteps), ws);
  const std::vector<Eigen::Vector3d> committed = sim->CalcPathPositions();
  ASSERT_EQ(eval.p_WPath.size(), committed.size());
  // positions are O(0.1 m); the correction goes through the same columns: round-off level
  constexpr double kTolerance = 1e-10;  // m
  for (size_t i = 0; i < committed.size(); ++i) {
    EXPECT_LT((eval.p_WPath[i] - committed[i]).norm(), kTolerance) << "path point " << i;
  }
  EXPECT_LT(eval.solve.max_violation, 1e-9);
  // the path moved with the tissue (the needle pushes it): the check is not trivial
  double moved = 0.0;
  const std::vector<Eigen::Vector3d> rest = RestPath();
  for (size_t i = 0; i < committed.size(); ++i) moved = std::max(moved, (committed[i] - rest[i]).norm());
  EXPECT_GT(moved, 1e-5);
}

TEST_P(SteeringSimulationVariantTest, PerturbedSolveEqualsFullResimulation) {
  if (GetParam().friction_held)
    GTEST_SKIP() << "held friction forces are not the re-simulated law (see "
                    "HeldFrictionLetsThePerturbedNeedleSlide)";
  auto sim = Advance(kInsideSteps);
  const Eigen::Isometry3d X_nominal = InsertionPose(X_WF0_, dir_, kInsideSteps);
  const SteeringEvaluation nominal = [&] {
    SnapshotWorkspace ws;
    return sim->EvaluateAt(X_nominal, ws);
  }();
  // a lateral translation and a rotation, as large as the Jacobian's perturbations (x 2)
  Vector6d translate = Vector6d::Zero();
  translate[0] = 2e-3;
  Vector6d rotate = Vector6d::Zero();
  rotate[5] = 1e-2;
  for (const Vector6d& delta : {translate, rotate}) {
    const Eigen::Isometry3d X = ApplyPoseIncrement(X_nominal, delta, PoseIncrementFrame::kWorldAligned);
    SnapshotWorkspace ws;
    const SteeringEvaluation fast = sim->EvaluateAt(X, ws);
    // full path: the same history, the last step with the perturbed flange
    auto full = Advance(kInsideSteps - 1);
    full->Step(RestMarkers(model_), X, bevel_angle_);
    const std::vector<Eigen::Vector3d> reference = full->CalcPathPositions();
    double moved = 0.0;
    for (size_t i = 0; i < reference.size(); ++i) {
      moved = std::max(moved, (reference[i] - nominal.p_WPath[i]).norm());
      // rows turn identically in both paths, so they agree to round-off (m)
      EXPECT_LT((fast.p_WPath[i] - reference[i]).norm(), 1e-9)
          << "path point " << i << ", perturbation " << delta.transpose();
    }
    // the perturbation did move the tissue
    EXPECT_GT(moved, 1e-6) << delta.transpose();
  }
}

TEST_F(SteeringSimulationTest, EvaluationHasNoSideEffects) {
  auto sim = Advance(kInsideSteps);
  const Eigen::Isometry3d X = InsertionPose(X_WF0_, dir_, kInsideSteps);
  SnapshotWorkspace ws;
  const SteeringEvaluation before = sim->EvaluateAt(X, ws);
  Vector6d delta;
  delta << 3e-3, -2e-3, 1e-3, 0.02, -0.01, 0.03;
  sim->EvaluateAt(ApplyPoseIncrement(X, delta, PoseIncrementFrame::kWorldAligned), ws);
  const SteeringEvaluation after = sim->EvaluateAt(X, ws);
  for (size_t i = 0; i < before.p_WPath.size(); ++i) {
    EXPECT_EQ(before.p_WPath[i], after.p_WPath[i]);
  }
}

std::vector<Eigen::Vector3d> BreathingMarkers(const InverseModelConfig& c, int step);

// A disabled bevel changes nothing, whatever roll the steps pass: bit-identical to the model
// without the option
TEST_F(SteeringSimulationTest, DisabledBevelIsBitIdentical) {
  auto plain = Advance(kInsideSteps);
  InverseModelConfig off = model_;
  off.bevel.enabled = false;
  off.bevel.tissue_stiffness = 3e5;  // parameters of a bevel that does not act
  SteeringSimulation rolled(off, path_, mesh_, X_WF0_);
  for (int i = 1; i <= kInsideSteps; ++i) {
    const SteeringStepReport r = rolled.Step(RestMarkers(off), InsertionPose(X_WF0_, dir_, i), 1.3);
    EXPECT_FALSE(r.bevel_active);
  }
  EXPECT_EQ(plain->liver_positions(), rolled.liver_positions());
  EXPECT_EQ(plain->liver_coupling().points.size(), rolled.liver_coupling().points.size());
}

// The bevel's transverse load Q y_B (CalcBevelLoads) on the model liver at the tip, rigid
// needle: the tissue at the tip takes -Q y_B, so it moves along -y_B (the needle, relative to
// the tissue, towards the bevel side +y_B), by about the point compliance of the liver times Q;
// rolling the bevel by pi reverses the deflection; with the lateral tip constraint the rows at
// the same material point take the load, and the tip's material point does not move laterally.
TEST_F(SteeringSimulationTest, BevelPushesTheTissueAtTheTipAgainstTheBevelSide) {
  // (a) the tip point free laterally: no tip constraint
  model_.coupling.tip_constraint = false;
  auto plain = Advance(kInsideSteps);
  ASSERT_GE(plain->liver_coupling().tip.tet, 0) << "the tip must be in the liver";
  const TetPoint tip = plain->liver_coupling().tip;
  const Eigen::Vector3d p_plain = EvalTetPoint(mesh_, plain->liver_positions(), tip);
  const Eigen::Matrix3d R_WN = plain->X_WN().linear();
  model_.bevel.enabled = true;
  const BevelLoads loads = CalcBevelLoads(model_.bevel);
  ASSERT_GT(loads.q, 0.0);
  auto deflection = [&](double roll) {
    bevel_angle_ = roll;
    auto sim = Advance(kInsideSteps);
    return Eigen::Vector3d(EvalTetPoint(mesh_, sim->liver_positions(), tip) - p_plain);
  };
  const Eigen::Vector3d d0 = deflection(0.0), d_pi = deflection(M_PI);
  const Eigen::Vector3d y_B = CalcBevelFrame(R_WN, 0.0).col(1);
  // mostly along -y_B (the force's direction); the needle's rows and the tissue's shape
  // give the rest
  EXPECT_LT(d0.dot(y_B), -0.8 * d0.norm()) << d0.transpose();
  // order of magnitude: a point load Q on an elastic body over a region of the tip tet's size
  // r moves it by ~ Q (1 + nu) / (2 pi E r) (Boussinesq-Kelvin); within a factor of 10
  double r = 0.0;
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b)
      r += (mesh_.X.col(mesh_.tets[tip.tet][a]) - mesh_.X.col(mesh_.tets[tip.tet][b])).norm() / 6;
  const double E = model_.liver.young_modulus, nu = model_.liver.poisson_ratio;
  const double estimate = loads.q * (1 + nu) / (2 * M_PI * E * r);
  EXPECT_GT(d0.norm(), 0.1 * estimate) << "estimate " << estimate << " m";
  EXPECT_LT(d0.norm(), 10.0 * estimate) << "estimate " << estimate << " m";
  // the roll by pi reverses it (to the nonlinearity of the response: 20 %)
  EXPECT_LT((d0 + d_pi).norm(), 0.2 * d0.norm()) << d0.transpose() << " / " << d_pi.transpose();

  // (b) with the tip constraint the load is taken at the same material point by its rows
  model_.coupling.tip_constraint = true;
  model_.bevel.enabled = false;
  bevel_angle_ = 0.0;
  auto held_plain = Advance(kInsideSteps);
  model_.bevel.enabled = true;
  auto held = Advance(kInsideSteps);
  const TetPoint held_tip = held_plain->liver_coupling().tip;
  ASSERT_GE(held_tip.tet, 0);
  const Eigen::Vector3d d_held = EvalTetPoint(mesh_, held->liver_positions(), held_tip) -
                                 EvalTetPoint(mesh_, held_plain->liver_positions(), held_tip);
  EXPECT_LT(std::abs(d_held.dot(y_B)), 0.1 * d0.norm()) << d_held.transpose();
}

// The needle's axial friction drags the model's tissue along the needle: the coupling reports
// friction forces within the Coulomb bound of each point, and the path targets end elsewhere
// than in the frictionless model
TEST_F(SteeringSimulationTest, AxialFrictionDragsTheTissueAlongTheNeedle) {
  auto plain = Advance(kInsideSteps);
  InverseModelConfig friction = model_;
  friction.coupling.friction_coefficient = 0.1;
  SteeringSimulation rubbed(friction, path_, mesh_, X_WF0_);
  for (int i = 1; i <= kInsideSteps; ++i) rubbed.Step(RestMarkers(friction), InsertionPose(X_WF0_, dir_, i));
  double total = 0.0;
  int slipping = 0;
  for (const NeedlePathPoint& p : rubbed.liver_coupling().points) {
    total += std::abs(p.axial_force);
    slipping += p.slipping ? 1 : 0;
    // |f_axial| <= mu |f_lateral| (Coulomb), to the solver's tolerance
    EXPECT_LE(std::abs(p.axial_force), 0.1 * p.lateral_force.norm() + 1e-9);
  }
  for (const NeedlePathPoint& p : plain->liver_coupling().points) EXPECT_EQ(p.axial_force, 0.0);
  EXPECT_GT(total, 1e-4) << "no friction force: the coefficient did not reach the coupling";
  EXPECT_GT(slipping, 0) << "an advancing needle slips through the tissue";
  // along the insertion, the tissue ahead of the tip is pushed further than without friction
  const Eigen::Vector3d with = rubbed.CalcPathPositions().back() - path_.target_W;
  const Eigen::Vector3d without = plain->CalcPathPositions().back() - path_.target_W;
  EXPECT_GT(with.dot(dir_), without.dot(dir_));
}

// With held friction (the default with friction) the Jacobian's frozen step lets a perturbed
// needle slide through the tissue under the step's friction load. A needle at rest in the
// tissue (the steady state of a controlled insertion) sticks: with the law solved again, a
// small axial perturbation drags the tissue around the needle along (the friction changes
// within its cone), and the Jacobian would see the tip move with its target rather than
// against it. Held, the tissue does not follow. (Over a step in which the needle advances, the
// rows slip and a perturbation smaller than the advance does not reverse them: both agree.)
TEST_F(SteeringSimulationTest, HeldFrictionLetsThePerturbedNeedleSlide) {
  const Eigen::Isometry3d X = InsertionPose(X_WF0_, dir_, kInsideSteps);
  double dragged[2] = {0.0, 0.0};  // largest axial motion of a path target (m)
  int sticking = 0;
  for (bool held : {false, true}) {
    InverseModelConfig friction = model_;
    friction.coupling.friction_coefficient = 0.1;
    friction.jacobian_friction_held = held;
    SteeringSimulation sim(friction, path_, mesh_, X_WF0_);
    // the liver moves under the needle as the markers breathe: lateral loads, so friction
    for (int i = 1; i <= kInsideSteps; ++i)
      sim.Step(BreathingMarkers(friction, 4 * i), InsertionPose(X_WF0_, dir_, i));
    for (int i = 0; i < 3; ++i) sim.Step(BreathingMarkers(friction, 4 * kInsideSteps), X);  // at rest
    if (!held)
      for (const NeedlePathPoint& p : sim.liver_coupling().points) sticking += p.slipping ? 0 : 1;
    SnapshotWorkspace ws;
    const SteeringEvaluation nominal = sim.EvaluateAt(X, ws);
    const std::vector<Eigen::Vector3d> committed = sim.CalcPathPositions();
    for (size_t i = 0; i < committed.size(); ++i)  // the step itself either way
      EXPECT_LT((nominal.p_WPath[i] - committed[i]).norm(), 1e-10) << held << " " << i;
    for (double shift : {-0.3e-3, 0.3e-3}) {  // a Jacobian perturbation's order
      Eigen::Isometry3d perturbed = X;
      perturbed.translation() += shift * dir_;
      const SteeringEvaluation moved = sim.EvaluateAt(perturbed, ws);
      EXPECT_TRUE(moved.solve.converged);
      for (size_t i = 0; i < committed.size(); ++i)
        dragged[held] = std::max(dragged[held],
                                 std::abs((moved.p_WPath[i] - nominal.p_WPath[i]).dot(dir_)));
      EXPECT_NEAR((moved.p_WTip - nominal.p_WTip).dot(dir_), shift, 1e-12);  // rigid needle
    }
  }
  std::printf("0.3 mm axial perturbations of a needle at rest (%d of its points sticking): the "
              "path targets move up to %.4f mm with the friction law solved, %.6f mm with the "
              "forces held\n",
              sticking, 1e3 * dragged[0], 1e3 * dragged[1]);
  EXPECT_GT(sticking, 0);
  EXPECT_GT(dragged[0], 0.02e-3) << "the solved law should drag the tissue along";
  EXPECT_LT(dragged[1], 0.05 * dragged[0]);
}

// Anchored nodes never move; the rest of the model does; bad boxes are refused by name
TEST_F(SteeringSimulationTest, AnchorsHoldTheirNodesAndAreChecked) {
  InverseModelConfig anchored = model_;
  anchored.anchors = {PosteriorAnchor()};
  SteeringSimulation sim(anchored, path_, mesh_, X_WF0_);
  for (int i = 1; i <= kInsideSteps; ++i)
    sim.Step(BreathingMarkers(anchored, i), InsertionPose(X_WF0_, dir_, i));
  int held = 0;
  double moved = 0.0;
  for (int n = 0; n < mesh_.num_nodes(); ++n) {
    const double d = (sim.liver_positions().col(n) - mesh_.X.col(n)).norm();
    if (PosteriorAnchor().Contains(mesh_.X.col(n))) {
      ++held;
      EXPECT_EQ(d, 0.0) << "anchored node " << n;
    } else {
      moved = std::max(moved, d);
    }
  }
  EXPECT_GT(held, 10);
  EXPECT_GT(moved, 1e-3);  // the markers moved the rest by millimetres

  auto message = [&](const InverseModelConfig& c) -> std::string {
    try {
      SteeringSimulation s(c, path_, mesh_, X_WF0_);
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  InverseModelConfig empty = model_;
  OrientedBox far = PosteriorAnchor();
  far.center = {1.0, 1.0, 1.0};
  empty.anchors = {PosteriorAnchor(), far};
  EXPECT_NE(message(empty).find("inverse.anchors[1] encloses no node"), std::string::npos)
      << message(empty);
  InverseModelConfig on_marker = model_;
  OrientedBox around = PosteriorAnchor();
  around.center = model_.markers_W[3];
  around.half_size = {0.015, 0.015, 0.015};
  on_marker.anchors = {around};
  EXPECT_NE(message(on_marker).find("inverse.anchors[0] contains marker 3"), std::string::npos)
      << message(on_marker);
  InverseModelConfig flat = model_;
  flat.anchors = {PosteriorAnchor()};
  flat.anchors[0].half_size.y() = 0.0;
  EXPECT_NE(message(flat).find("inverse.anchors[0].half_size"), std::string::npos) << message(flat);
  InverseModelConfig negative = model_;
  negative.coupling.friction_coefficient = -0.1;
  EXPECT_NE(message(negative).find("inverse.friction_coefficient must be >= 0, got -0.1"),
            std::string::npos)
      << message(negative);
  InverseModelConfig pulling = model_;
  pulling.coupling.lateral_compliance = -1e-3;
  EXPECT_NE(message(pulling).find("inverse.lateral_compliance must be >= 0 (m/N)"),
            std::string::npos)
      << message(pulling);
  InverseModelConfig loose = model_;
  loose.coupling.tip_compliance = 2.0;
  EXPECT_NE(message(loose).find("inverse.tip_compliance must be <= 1 (m/N), got 2"),
            std::string::npos)
      << message(loose);
}

// markers of a liver breathing along z (SI, 5 mm) and y (AP, 1.5 mm), period 4 s (200 steps)
std::vector<Eigen::Vector3d> BreathingMarkers(const InverseModelConfig& c, int step) {
  const double phase = 2.0 * M_PI * step / 200.0;
  const Eigen::Vector3d offset(0.0, 0.0015 * std::sin(phase),
                               -0.005 * (1.0 - std::cos(phase)) / 2);
  std::vector<Eigen::Vector3d> p = c.markers_W;
  for (Eigen::Vector3d& m : p) m += offset;
  return p;
}

// how far two models are apart (m)
struct Difference {
  double entry = 0.0, target = 0.0, path = 0.0, nodes = 0.0;
};

Difference Compare(const SteeringSimulation& a, const SteeringSimulation& b) {
  Difference d;
  Eigen::Vector3d ea, eb;
  if (a.CalcLiverEntryPoint(&ea) && b.CalcLiverEntryPoint(&eb)) d.entry = (ea - eb).norm();
  const std::vector<Eigen::Vector3d> pa = a.CalcPathPositions(), pb = b.CalcPathPositions();
  for (size_t i = 0; i < pa.size(); ++i) d.path = std::max(d.path, (pa[i] - pb[i]).norm());
  d.target = (pa.back() - pb.back()).norm();
  d.nodes = (a.liver_positions() - b.liver_positions()).colwise().norm().maxCoeff();
  return d;
}

// A model built at a deep pose and caught up vs a model that followed the insertion step by
// step (0.4 mm per step, the tip 50 mm past the start, 40 mm into the liver), in a static liver
// and in a breathing one that the needle follows (as a controller tracking the path does): the
// same phase, the same number of coupling points, the same needle pose; the entry point, the
// path targets and the liver's nodes within tolerances of 3 to 10 times the measured
// differences (static: 0.001, 0.001, 0.004, 0.018 mm; breathing: 0.000, 0.009, 0.041, 0.044).
TEST_F(SteeringSimulationTest, CatchUpToADeepPoseMatchesAStepByStepInsertion) {
  struct Tolerance {
    double entry, target, path, nodes;
  };
  for (const bool breathing : {false, true}) {
    constexpr double kAdvance = 4e-4;
    constexpr int kSteps = 125;
    auto markers = [&](int step) {
      return breathing ? BreathingMarkers(model_, step) : RestMarkers(model_);
    };
    auto pose = [&](int step) {
      Eigen::Isometry3d X = X_WF0_;
      X.translation() += kAdvance * step * dir_;
      if (breathing) X.translation() += markers(step)[0] - model_.markers_W[0];
      return X;
    };
    SteeringSimulation inserted(model_, path_, mesh_, X_WF0_);
    for (int i = 1; i <= kSteps; ++i) inserted.Step(markers(i), pose(i));
    SteeringSimulation caught(model_, path_, mesh_, pose(kSteps));
    const CatchUpReport report = caught.CatchUp(markers(kSteps), pose(kSteps));
    const Difference d = Compare(inserted, caught);
    std::printf("breathing %d: catch-up %.1f mm deep, %d model steps, %.2f s; points %zu vs %zu; "
                "apart: entry %.3f mm, target %.3f mm, path %.3f mm, nodes %.3f mm\n",
                breathing, 1e3 * report.depth, report.steps, report.wall_time,
                inserted.liver_coupling().points.size(), caught.liver_coupling().points.size(),
                1e3 * d.entry, 1e3 * d.target, 1e3 * d.path, 1e3 * d.nodes);
    EXPECT_TRUE(report.done);
    EXPECT_NEAR(report.depth, kAdvance * kSteps, breathing ? 3e-3 : 1e-9);
    EXPECT_EQ(report.liver_phase, TissuePhase::kInside);
    EXPECT_EQ(caught.liver_coupling().phase, inserted.liver_coupling().phase);
    EXPECT_EQ(caught.liver_coupling().points.size(), inserted.liver_coupling().points.size());
    EXPECT_LT((caught.X_WN().matrix() - inserted.X_WN().matrix()).cwiseAbs().maxCoeff(), 1e-12);
    const Tolerance tol = breathing ? Tolerance{0.01e-3, 0.05e-3, 0.15e-3, 0.15e-3}
                                    : Tolerance{0.01e-3, 0.01e-3, 0.02e-3, 0.1e-3};
    EXPECT_LT(d.entry, tol.entry) << "breathing " << breathing;
    EXPECT_LT(d.target, tol.target) << "breathing " << breathing;
    EXPECT_LT(d.path, tol.path) << "breathing " << breathing;
    EXPECT_LT(d.nodes, tol.nodes) << "breathing " << breathing;
  }
}

// At the start of an insertion (the tip at the path's start) a catch-up does nothing: the model
// is the one built, bit for bit, after the same steps
TEST_F(SteeringSimulationTest, CatchUpAtTheStartDoesNothing) {
  SteeringSimulation plain(model_, path_, mesh_, X_WF0_);
  SteeringSimulation caught(model_, path_, mesh_, X_WF0_);
  const CatchUpReport report = caught.CatchUp(RestMarkers(model_), X_WF0_);
  EXPECT_FALSE(report.done);
  EXPECT_EQ(report.steps, 0);
  for (int i = 1; i <= 3; ++i) {
    plain.Step(RestMarkers(model_), InsertionPose(X_WF0_, dir_, i));
    caught.Step(RestMarkers(model_), InsertionPose(X_WF0_, dir_, i));
  }
  EXPECT_TRUE(plain.liver_positions() == caught.liver_positions());
  // once stepped, too late; and the input is checked
  EXPECT_THROW(caught.CatchUp(RestMarkers(model_), X_WF0_), std::logic_error);
  SteeringSimulation fresh(model_, path_, mesh_, X_WF0_);
  EXPECT_THROW(fresh.CatchUp({Eigen::Vector3d::Zero()}, InsertionPose(X_WF0_, dir_, 20)),
               InputError);
  CatchUpConfig bad;
  bad.advance_per_step = 0.0;
  EXPECT_THROW(fresh.CatchUp(RestMarkers(model_), InsertionPose(X_WF0_, dir_, 20), bad),
               InputError);
}

TEST_F(SteeringSimulationTest, BadInputNamesTheProblem) {
  SteeringSimulation sim(model_, path_, mesh_, X_WF0_);
  try {
    sim.Step({Eigen::Vector3d::Zero()}, X_WF0_);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("expected 5 markers, got 1"), std::string::npos);
  }
  InverseModelConfig bad = model_;
  bad.young_modulus_factor = -1.0;
  try {
    SteeringSimulation s(bad, path_, mesh_, X_WF0_);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("inverse.young_modulus_factor must be > 0"),
              std::string::npos)
        << e.what();
  }
  InverseModelConfig outside = model_;
  outside.markers_W[2] = Eigen::Vector3d(1.0, 1.0, 1.0);
  EXPECT_THROW(SteeringSimulation(outside, path_, mesh_, X_WF0_), InputError);
}

}  // namespace
}  // namespace nsim

namespace nsim {
namespace {

// The flexible model needle: the scene's 13 cm needle as a 20-element beam, steel as the
// default scenario's needle (E 200 GPa, 7850 kg/m^3) unless a test says otherwise.
class FlexibleSimulationTest : public SteeringSimulationTest {
 protected:
  FlexibleSimulationTest() {
    model_.needle_kind = ModelNeedleKind::kFlexible;
    model_.flexible.needle.young_modulus = 200e9;
    model_.flexible.needle.density = 7850.0;
  }

  // the full re-simulation of the last of `kInsideSteps` steps with the flange at X
  std::unique_ptr<SteeringSimulation> Resimulate(const Eigen::Isometry3d& X) const {
    auto full = Advance(kInsideSteps - 1);
    full->Step(RestMarkers(model_), X, bevel_angle_);
    return full;
  }

  // largest distance between the evaluation and a model's state: tip and path targets (m)
  static double Gap(const SteeringEvaluation& eval, const SteeringSimulation& sim) {
    double gap = (eval.p_WTip - sim.CalcTipPosition()).norm();
    const std::vector<Eigen::Vector3d> path = sim.CalcPathPositions();
    for (size_t i = 0; i < path.size(); ++i) gap = std::max(gap, (eval.p_WPath[i] - path[i]).norm());
    return gap;
  }
  static double Moved(const SteeringEvaluation& a, const SteeringEvaluation& b) {
    double moved = (a.p_WTip - b.p_WTip).norm();
    for (size_t i = 0; i < a.p_WPath.size(); ++i)
      moved = std::max(moved, (a.p_WPath[i] - b.p_WPath[i]).norm());
    return moved;
  }

  Eigen::Isometry3d Nominal() const { return InsertionPose(X_WF0_, dir_, kInsideSteps); }
};

// (c) the frozen step at the committed flange pose is the committed step: tip, tip frame and
// path targets, without and with the bevel
TEST_F(FlexibleSimulationTest, UnperturbedSolveReproducesTheCommittedStep) {
  for (const bool bevel : {false, true}) {
    model_.bevel.enabled = bevel;
    bevel_angle_ = 0.7;
    auto sim = Advance(kInsideSteps);
    ASSERT_NE(sim->beam_needle(), nullptr);
    ASSERT_TRUE(sim->liver_punctured());
    SnapshotWorkspace ws;
    const SteeringEvaluation eval = sim->EvaluateAt(Nominal(), ws);
    // positions O(0.1 m) through the same columns: round-off
    constexpr double kTolerance = 1e-10;  // m, rad
    EXPECT_LT(Gap(eval, *sim), kTolerance) << "bevel " << bevel;
    EXPECT_LT((eval.R_WTip - sim->CalcTipFrame()).norm(), kTolerance) << "bevel " << bevel;
    EXPECT_LT(eval.solve.max_violation, 1e-9);
    // the needle is bent: its tip is off the straight needle of the flange pose (not trivial)
    const Eigen::Vector3d straight = CalcTipPosition(eval.X_WN, sim->needle().length());
    EXPECT_GT((eval.p_WTip - straight).norm(), 1e-7) << "bevel " << bevel;
  }
}

// (a) a translation of the flange: the frozen step with the beam's free-motion sensitivity
// equals a full re-simulation of the step. Exact when the beam's free shape translates with its
// base (its inertia negligible against h^2 K: a needle of 1e-6 x steel's density; measured
// 1e-12 m); for steel the rows' directions miss the beam's inertia lag (constraint_snapshot.h):
// ~ the lag fraction (~3 %) x the perturbation's tangent change (<= 2 mm / 13 cm) x the
// needle's slip over the step (2 mm), ~1e-6 m (measured 1.1e-6 m lateral, 5e-10 m axial); 5e-6
// m allowed.
TEST_F(FlexibleSimulationTest, TranslationEqualsFullResimulation) {
  struct Case {
    double density, tolerance;
  };
  for (const Case c : {Case{7850e-6, 1e-9}, Case{7850.0, 5e-6}}) {
    model_.flexible.needle.density = c.density;
    auto sim = Advance(kInsideSteps);
    SnapshotWorkspace ws;
    const SteeringEvaluation nominal = sim->EvaluateAt(Nominal(), ws);
    Vector6d lateral = Vector6d::Zero(), axial = Vector6d::Zero();
    lateral[0] = 2e-3;
    axial.head<3>() = 1e-3 * dir_;
    for (const Vector6d& delta : {lateral, axial}) {
      const Eigen::Isometry3d X =
          ApplyPoseIncrement(Nominal(), delta, PoseIncrementFrame::kWorldAligned);
      const SteeringEvaluation fast = sim->EvaluateAt(X, ws);
      auto full = Resimulate(X);
      EXPECT_LT(Gap(fast, *full), c.tolerance)
          << "density " << c.density << ", perturbation " << delta.transpose();
      EXPECT_GT(Moved(fast, nominal), 1e-5) << delta.transpose();  // not trivial
    }
  }
}

// (b) a rotation of the flange. In a step that does not turn the needle the base's free motion
// is linear in the rotation and the rows turn as the low-inertia beam's free shape does: the
// frozen step equals a full re-simulation (measured 5e-7 of the motion: round-off). In a step that turns the needle by
// 0.02 rad, log(R_target R_0^T) makes the base's free motion first order in the perturbation,
// and the free shape turns by J_l^-1 dtheta where the rows turn by dtheta: a remainder of
// O(|0.02 rad| dtheta) (measured 6e-5 of the motion the rotation causes); steel's inertia lag
// adds a first-order direction error (measured 3e-3 of it). Central differences of both, the
// Jacobian column the controller takes, agree to the same relative level.
TEST_F(FlexibleSimulationTest, RotationAgreesToFirstOrder) {
  struct Case {
    double density, turn, relative;  // kg/m^3, rad, gap / motion
  };
  for (const Case c : {Case{7850e-6, 0.0, 1e-5}, Case{7850e-6, 0.02, 2e-4},
                       Case{7850.0, 0.02, 1e-2}}) {
    model_.flexible.needle.density = c.density;
    Vector6d turn = Vector6d::Zero();
    turn[3] = c.turn;
    const Eigen::Isometry3d X_step =
        ApplyPoseIncrement(Nominal(), turn, PoseIncrementFrame::kWorldAligned);
    auto sim = Advance(kInsideSteps - 1);
    sim->Step(RestMarkers(model_), X_step, bevel_angle_);
    SnapshotWorkspace ws;
    const SteeringEvaluation nominal = sim->EvaluateAt(X_step, ws);
    Eigen::Vector3d fast_tip[2], full_tip[2];
    for (const double angle : {2e-3, -2e-3}) {
      Vector6d delta = Vector6d::Zero();
      delta[3] = angle;  // about world x, at the flange: the tip swings ~ angle x 15 cm
      const Eigen::Isometry3d X = ApplyPoseIncrement(X_step, delta, PoseIncrementFrame::kWorldAligned);
      const SteeringEvaluation fast = sim->EvaluateAt(X, ws);
      auto full = Resimulate(X);
      EXPECT_LT(Gap(fast, *full), c.relative * Moved(fast, nominal))
          << "density " << c.density << ", turn " << c.turn << ", angle " << angle;
      fast_tip[angle > 0 ? 0 : 1] = fast.p_WTip;
      full_tip[angle > 0 ? 0 : 1] = full->CalcTipPosition();
    }
    // d p_WTip / d theta_x by central differences (m/rad)
    const Eigen::Vector3d d_fast = (fast_tip[0] - fast_tip[1]) / 4e-3;
    const Eigen::Vector3d d_full = (full_tip[0] - full_tip[1]) / 4e-3;
    EXPECT_LT((d_fast - d_full).norm(), c.relative * d_full.norm())
        << d_fast.transpose() << " vs " << d_full.transpose();
  }
}

// (d) a very stiff beam is the rigid needle: the tip and the path targets agree with the
// rigid model within the stiff beam's own bending under the tissue's lateral forces,
// F L^3 / (3 E I) for the sum F of the coupling's lateral forces (a cantilever bound, 0.18 mm
// here), times 3 for the discretized tip and the inertia lag of the beam's free motion (at
// E = 1e12 Pa, the validator's bound, 5 x steel: ~0.5 % of a step's motion), plus 1 um
// (measured: 0.02 mm at the tip).
TEST_F(FlexibleSimulationTest, StiffBeamMatchesTheRigidNeedle) {
  InverseModelConfig rigid = model_;
  rigid.needle_kind = ModelNeedleKind::kRigid;
  model_.flexible.needle.young_modulus = 1e12;  // the validator's bound: 5 x steel
  auto stiff = Advance(kInsideSteps);
  SteeringSimulation straight(rigid, path_, mesh_, X_WF0_);
  for (int i = 1; i <= kInsideSteps; ++i)
    straight.Step(RestMarkers(rigid), InsertionPose(X_WF0_, dir_, i));
  double force = 0.0;
  for (const NeedlePathPoint& p : stiff->liver_coupling().points) force += p.lateral_force.norm();
  force += stiff->liver_coupling().report.tip_force;
  const double L = model_.needle.length;
  const double EI = 1e12 * CalcSecondMomentOfArea(model_.needle.radius);
  const double bound = 3.0 * force * L * L * L / (3.0 * EI) + 1e-6;
  EXPECT_LT((stiff->CalcTipPosition() - straight.CalcTipPosition()).norm(), bound)
      << "bound " << bound << " m, lateral forces " << force << " N";
  const std::vector<Eigen::Vector3d> a = stiff->CalcPathPositions(), b = straight.CalcPathPositions();
  for (size_t i = 0; i < a.size(); ++i) EXPECT_LT((a[i] - b[i]).norm(), bound) << "path " << i;
  EXPECT_EQ(stiff->liver_coupling().points.size(), straight.liver_coupling().points.size());
}

// (e) the bevel bends the flexible needle towards its bevel side +y_B (Misra's torque M x_B,
// M < 0, on the tip node): the tip ends on the +y_B side of the needle without the bevel, and
// rolling the bevel by pi sends it to the other side. The thesis's 5 GPa needle.
TEST_F(FlexibleSimulationTest, BevelBendsTheNeedleTowardsTheBevelSide) {
  model_.flexible.needle.young_modulus = 5e9;
  auto plain = Advance(kInsideSteps);
  model_.bevel.enabled = true;
  ASSERT_LT(CalcBevelLoads(model_.bevel).m, 0.0);
  const Eigen::Vector3d y_B = CalcBevelFrame(plain->X_WN().linear(), 0.0).col(1);
  auto offset = [&](double roll) {
    bevel_angle_ = roll;
    auto sim = Advance(kInsideSteps);
    return Eigen::Vector3d(sim->CalcTipPosition() - plain->CalcTipPosition());
  };
  const Eigen::Vector3d d0 = offset(0.0), d_pi = offset(M_PI);
  EXPECT_GT(d0.dot(y_B), 0.8 * d0.norm()) << d0.transpose();
  EXPECT_GT(d0.norm(), 1e-5) << d0.transpose();
  EXPECT_LT(d_pi.dot(y_B), -0.8 * d_pi.norm()) << d_pi.transpose();
  EXPECT_LT((d0 + d_pi).norm(), 0.3 * d0.norm()) << d0.transpose() << " / " << d_pi.transpose();
}

// a flexible model caught up mid-insertion steps on (CatchUp's steps drive the beam)
TEST_F(FlexibleSimulationTest, CatchUpDrivesTheBeamIn) {
  SteeringSimulation sim(model_, path_, mesh_, X_WF0_);
  const CatchUpReport report = sim.CatchUp(RestMarkers(model_), Nominal());
  EXPECT_TRUE(report.done);
  EXPECT_TRUE(sim.liver_punctured());
  const Eigen::Isometry3d X_WN = sim.needle().CalcNeedlePose(Nominal());
  EXPECT_LT((sim.beam_needle()->x.col(0) - X_WN.translation()).norm(), 1e-12);
  EXPECT_LT((sim.CalcTipPosition() - CalcTipPosition(X_WN, sim.needle().length())).norm(), 1e-3);
  sim.Step(RestMarkers(model_), InsertionPose(X_WF0_, dir_, kInsideSteps + 1));
  EXPECT_TRUE(sim.liver_punctured());
}

}  // namespace
}  // namespace nsim
