#include "common/needle/needle_tissue.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

#include "common/core/error.h"
#include "tests/needle/test_scene.h"

namespace nsim {
namespace {

using testing::DownwardFlange;
using testing::FemBlock;

// a 4 x 4 x 4 cm block of 5 kPa tissue, 8 mm elements; a 10 cm rigid needle above its centre
constexpr double kSide = 0.04;
constexpr double kNeedleLength = 0.10;
constexpr double kGap = 1e-3;           // tip to the top face at the start (m)
constexpr double kStepAdvance = 0.5e-3; // needle travel per 20 ms step (m)
// bilateral rows are met to round-off by the direct solve: 1e-7 of the element size
constexpr double kLineTol = 1e-9;
// friction bounds hold to the solver's force tolerance (1e-9 relative to 1 + max |lambda|, N)
constexpr double kForceTol = 2e-9;

struct Scene {
  FemBlock block{Eigen::Vector3i(6, 6, 6), Eigen::Vector3d(kSide, kSide, kSide),
                 Eigen::Vector3d::Zero()};
  RigidNeedleModel needle_model{[] {
    NeedleConfig c;
    c.length = kNeedleLength;
    return c;
  }()};
  RigidNeedleState needle;
  std::unique_ptr<NeedleTissueCoupling> coupling;
  NeedleCouplingState state;
  std::unique_ptr<NeedleInsertionStepper> stepper;
  Eigen::Vector3d base0;
  double travel = 0.0;  // needle travel along -Z so far (m)

  explicit Scene(const TissueCouplingConfig& tissue) {
    NeedleCouplingConfig config;
    config.tissues = {tissue};
    coupling = std::make_unique<NeedleTissueCoupling>(config, std::vector<const TetMesh*>{&block.mesh});
    state = coupling->MakeState();
    stepper = std::make_unique<NeedleInsertionStepper>(*coupling);
    base0 = Eigen::Vector3d(kSide / 2 + 1e-4, kSide / 2 + 2e-4, kSide + kGap + kNeedleLength);
    ResetRigidNeedle(needle_model, DownwardFlange(base0), needle);
  }
  // advances the needle by `ds` along its axis (negative: retracts) and moves it laterally
  NeedleStepReport Step(double ds, const Eigen::Vector3d& lateral = Eigen::Vector3d::Zero()) {
    travel += ds;
    base0 += lateral;
    return stepper->StepRigid(needle_model, needle,
                              DownwardFlange(base0 - travel * Eigen::Vector3d::UnitZ()),
                              {block.body.get()}, state);
  }
  const TissueCouplingReport& report() const { return state.tissues[0].report; }
  const TissueCouplingState& tissue() const { return state.tissues[0]; }
  Eigen::Vector3d tip() const { return CalcTipPosition(needle.X_WN_start, kNeedleLength); }
  // distance of a tissue point (current configuration) to the needle line
  double DistanceToNeedle(const NeedlePathPoint& p) const {
    const Eigen::Vector3d x = EvalTetPoint(block.mesh, block.state->x, p.point);
    const Eigen::Vector3d a = needle.X_WN_start.translation();
    const Eigen::Vector3d z = needle.X_WN_start.linear().col(2);
    return ((x - a) - (x - a).dot(z) * z).norm();
  }
};

TissueCouplingConfig MakeTissue() {
  TissueCouplingConfig t;
  t.name = "block";
  t.puncture_force = 0.05;
  t.point_spacing = 5e-3;
  t.friction_coefficient = 0.0;
  return t;
}

TEST(NeedleTissueTest, StraightInsertionKeepsTissuePointsOnTheNeedleLine) {
  Scene scene(MakeTissue());
  double puncture_travel = -1;
  for (int k = 0; k < 70; ++k) {
    // points held during the step (a point seeded by this step's update is at the tip; the
    // entry point comes from the contact, which held it along the surface normal only)
    const bool was_inside = scene.report().punctured;
    const size_t held = scene.tissue().points.size();
    const NeedleStepReport r = scene.Step(kStepAdvance);
    EXPECT_TRUE(r.solve.converged);
    if (scene.report().punctured && puncture_travel < 0) puncture_travel = scene.travel;
    if (!was_inside) continue;
    ASSERT_GE(scene.tissue().points.size(), held);
    for (size_t i = 0; i < held; ++i)
      ASSERT_LT(scene.DistanceToNeedle(scene.tissue().points[i]), kLineTol) << "step " << k;
  }
  EXPECT_GT(puncture_travel, kGap);
  ASSERT_TRUE(scene.report().punctured);
  EXPECT_EQ(scene.report().phase, TissuePhase::kInside);
  // depth = tip below the entry point along the needle; one point per spacing plus the entry
  const double depth = scene.report().depth;
  EXPECT_GT(depth, 0.015);
  EXPECT_EQ(scene.report().num_points, 1 + static_cast<int>(std::floor(depth / 5e-3 + 1e-9)));
  EXPECT_EQ(scene.tissue().points.front().kind, NeedlePathPoint::Kind::kEntry);
  // an axial insertion of a symmetric tip pushes sideways only by the mesh asymmetry
  EXPECT_LT(scene.report().lateral_force, 0.02 * MakeTissue().puncture_force);
  // the tissue was dragged down at contact and relaxed after the puncture: tip is inside
  EXPECT_LT(scene.tip().z(), kSide - 0.01);
}

TEST(NeedleTissueTest, PunctureHappensAtTheThresholdAndNotBefore) {
  // push 2.5 mm into the surface and hold: the run is deterministic, so the largest axial
  // contact force of a run that cannot puncture bounds every run up to its puncture
  constexpr int kPushSteps = 7, kHoldSteps = 60;
  auto run = [](TissueCouplingConfig tissue, double* max_force, double* force_at_puncture,
                double* force_before) {
    Scene scene(tissue);
    *max_force = 0.0;
    double previous = 0.0;
    for (int k = 0; k < kPushSteps + kHoldSteps; ++k) {
      scene.Step(k < kPushSteps ? kStepAdvance : 0.0);
      const TissueCouplingReport& r = scene.report();
      if (r.punctured) {
        *force_at_puncture = r.axial_contact_force;
        *force_before = previous;
        EXPECT_NEAR(r.puncture_time, scene.block.state->time, 1e-12);
        EXPECT_EQ(r.num_points, 1);
        return true;
      }
      *max_force = std::max(*max_force, r.axial_contact_force);
      previous = r.axial_contact_force;
    }
    return false;
  };
  TissueCouplingConfig tissue = MakeTissue();
  tissue.puncture_force = 1e3;
  double max_force = 0, at = 0, before = 0;
  ASSERT_FALSE(run(tissue, &max_force, &at, &before));
  ASSERT_GT(max_force, 0.0);
  // just above the largest force: no puncture
  tissue.puncture_force = 1.01 * max_force;
  EXPECT_FALSE(run(tissue, &max_force, &at, &before));
  // just below: punctures, at the first step whose force reaches the threshold
  tissue.puncture_force = 0.99 * max_force;
  ASSERT_TRUE(run(tissue, &max_force, &at, &before));
  EXPECT_GE(at, tissue.puncture_force);
  EXPECT_LT(before, tissue.puncture_force);
}

TEST(NeedleTissueTest, ConstantFrictionSaturatesWhileSliding) {
  // mu = 0, stiction 4 N/m: every point slides at f_0 = 4 N/m x 5 mm = 0.02 N while inserting
  TissueCouplingConfig tissue = MakeTissue();
  tissue.friction_force_per_length = 4.0;
  const double f0 = 4.0 * tissue.point_spacing;
  Scene scene(tissue);
  int slipping_seen = 0;
  for (int k = 0; k < 60; ++k) {
    const NeedleStepReport r = scene.Step(kStepAdvance);
    EXPECT_TRUE(r.solve.converged);
    for (const NeedlePathPoint& p : scene.tissue().points) {
      EXPECT_LE(std::abs(p.axial_force), f0 + kForceTol);
      if (p.slipping) {
        ++slipping_seen;
        // the needle drags the tissue inwards: along the needle direction
        EXPECT_NEAR(p.axial_force, f0, kForceTol);
      }
    }
  }
  EXPECT_GT(slipping_seen, 10);
  EXPECT_GT(scene.report().friction_force, 0.0);
}

TEST(NeedleTissueTest, CoulombFrictionIsBoundedByMuTimesTheLateralForce) {
  TissueCouplingConfig tissue = MakeTissue();
  tissue.friction_coefficient = 0.3;
  Scene scene(tissue);
  int slipping = 0, sticking = 0;
  for (int k = 0; k < 70; ++k) {
    // insert while drifting sideways: the tissue presses on the shaft
    const NeedleStepReport r =
        scene.Step(kStepAdvance, k > 20 ? Eigen::Vector3d(2e-5, 0, 0) : Eigen::Vector3d::Zero());
    EXPECT_TRUE(r.solve.converged);
    for (const NeedlePathPoint& p : scene.tissue().points) {
      const double bound = 0.3 * p.lateral_force.norm();
      EXPECT_LE(std::abs(p.axial_force), bound + kForceTol);
      if (p.slipping) ++slipping;
      else if (p.lateral_force.norm() > 0.0) ++sticking;
    }
  }
  EXPECT_GT(slipping, 0);
  EXPECT_GT(scene.report().lateral_force, 0.0);
  (void)sticking;
}

TEST(NeedleTissueTest, RetractionRemovesThePointsBehindTheTip) {
  Scene scene(MakeTissue());
  for (int k = 0; k < 60; ++k) scene.Step(kStepAdvance);
  const int inserted_points = scene.report().num_points;
  ASSERT_GE(inserted_points, 4);
  int previous = inserted_points;
  for (int k = 0; k < 80; ++k) {
    scene.Step(-kStepAdvance);
    const TissueCouplingState& t = scene.tissue();
    EXPECT_LE(static_cast<int>(t.points.size()), previous);
    previous = static_cast<int>(t.points.size());
    // no remaining point is ahead of the tip by more than the slack
    const Eigen::Vector3d z = scene.needle.X_WN_start.linear().col(2);
    for (const NeedlePathPoint& p : t.points) {
      const Eigen::Vector3d x = EvalTetPoint(scene.block.mesh, scene.block.state->x, p.point);
      EXPECT_LE(z.dot(x - scene.tip()), 0.1 * 5e-3 + 1e-12);
    }
  }
  EXPECT_EQ(scene.report().phase, TissuePhase::kOutside);
  EXPECT_FALSE(scene.report().punctured);
  EXPECT_EQ(scene.report().num_points, 0);
  // no needle rows are left once the needle is out and away
  for (int k = 0; k < 5; ++k) scene.Step(-kStepAdvance);
  EXPECT_EQ(scene.stepper->set().num_rows(), 0);
}

// the tip's lateral hold after a seeded point: with tip_hold quarter it is off for a quarter
// spacing and then rigid at once; with it, it holds from 2 % of that on, softened in proportion
// (ConstraintRow::softness), so its force grows with the tip's distance from the point instead of
// jumping from zero
TEST(NeedleTissueTest, TipHoldRampsInAfterASeededPoint) {
  const double quarter = 0.25 * MakeTissue().point_spacing;
  struct Sample {
    double past, force;
  };
  std::vector<Sample> samples[2];
  for (bool ramp : {false, true}) {
    TissueCouplingConfig tissue = MakeTissue();
    tissue.tip_hold = ramp ? TipHold::kRamp : TipHold::kQuarter;
    Scene scene(tissue);
    for (int k = 0; k < 40; ++k) {
      // a slow sideways drift loads the tip's hold
      const double past = scene.report().depth - scene.tissue().last_seed_depth;
      const bool inside = scene.report().phase == TissuePhase::kInside;
      const NeedleStepReport r = scene.Step(0.3e-3, Eigen::Vector3d(2e-5, 0.0, 0.0));
      ASSERT_TRUE(r.solve.converged);
      if (inside && scene.report().depth > 0.004) samples[ramp].push_back({past, scene.report().tip_force});
    }
  }
  int early_without = 0, early_with = 0;
  for (const Sample& s : samples[0])
    if (s.past < quarter) {
      EXPECT_EQ(s.force, 0.0) << "no hold within a quarter spacing without the ramp, past " << s.past;
      ++early_without;
    }
  for (const Sample& s : samples[1])
    if (s.past > 0.02 * quarter && s.past < quarter) {
      EXPECT_GT(s.force, 0.0) << "the ramp holds from 2 % on, past " << s.past;
      ++early_with;
    }
  EXPECT_GE(early_without, 3);
  EXPECT_GE(early_with, 3);
  // the hold grows with the distance: the force close to the point is below the force near a
  // quarter spacing (same drift, consecutive steps)
  double near_point = 0.0, near_quarter = 0.0;
  for (const Sample& s : samples[1]) {
    if (s.past > 0.02 * quarter && s.past < 0.3 * quarter) near_point = std::max(near_point, s.force);
    if (s.past > 0.7 * quarter) near_quarter = std::max(near_quarter, s.force);
  }
  std::printf("tip hold with the ramp: up to %.3g N within 30 %% of a quarter spacing, %.3g N "
              "beyond 70 %%\n", near_point, near_quarter);
  EXPECT_LT(near_point, near_quarter);
}

// the report's past_seed and tip_hold, against what the coupling does in the next step: past_seed
// is the depth since the last seed (seed_distance depth) or past_last_point (last_point); the
// hold is 0 or 1 at a quarter spacing with quarter, past / quarter from 2 % of it with ramp, 1
// with handover; the tip's rows carry force under a sideways drift exactly when the hold is
// above 0, and outside the tissue both are 0
TEST(NeedleTissueTest, TheReportSaysHowTheTipIsHeld) {
  const double quarter = 0.25 * MakeTissue().point_spacing;
  for (TipHold hold : {TipHold::kQuarter, TipHold::kRamp, TipHold::kHandover}) {
    for (SeedDistance seed : {SeedDistance::kDepth, SeedDistance::kLastPoint}) {
      TissueCouplingConfig tissue = MakeTissue();
      tissue.tip_hold = hold;
      tissue.seed_distance = seed;
      Scene scene(tissue);
      int free_steps = 0, partial_steps = 0, held_steps = 0;
      for (int k = 0; k < 45; ++k) {
        const TissueCouplingReport before = scene.report();
        const bool located =
            before.phase == TissuePhase::kInside && scene.tissue().tip.tet >= 0;
        const double past = seed == SeedDistance::kDepth
                                ? before.depth - scene.tissue().last_seed_depth
                                : before.past_last_point;
        if (!located) {
          EXPECT_EQ(before.past_seed, 0.0) << "step " << k;
          EXPECT_EQ(before.tip_hold, 0.0) << "step " << k;
        } else {
          EXPECT_EQ(before.past_seed, past) << "step " << k;
          double expected = 1.0;
          if (hold == TipHold::kQuarter) expected = past >= quarter ? 1.0 : 0.0;
          if (hold == TipHold::kRamp)
            expected = past < 0.02 * quarter ? 0.0 : std::min(1.0, past / quarter);
          EXPECT_NEAR(before.tip_hold, expected, 1e-12) << "step " << k << ", past " << past;
        }
        const NeedleStepReport r = scene.Step(0.3e-3, Eigen::Vector3d(2e-5, 0.0, 0.0));
        ASSERT_TRUE(r.solve.converged);
        if (!located || scene.report().depth < 0.004) continue;
        if (before.tip_hold > 0.0) {
          EXPECT_GT(scene.report().tip_force, 0.0) << "held at step " << k;
        } else {
          EXPECT_EQ(scene.report().tip_force, 0.0) << "free at step " << k;
        }
        free_steps += before.tip_hold == 0.0;
        held_steps += before.tip_hold == 1.0;
        partial_steps += before.tip_hold > 0.0 && before.tip_hold < 1.0;
      }
      EXPECT_GE(held_steps, 3);
      if (hold != TipHold::kHandover) {
        EXPECT_GE(free_steps, 1);
      }
      if (hold == TipHold::kRamp) {
        EXPECT_GE(partial_steps, 3);
      } else {
        EXPECT_EQ(partial_steps, 0);
      }
    }
  }
}

// CalcTipStretch, against what the coupling does: none before the puncture; with tip_hold quarter
// the tip's hold carries force under a sideways drift exactly in the steps that start with no
// free reach left, a point is seeded in exactly the steps whose advance covers the next seed's
// distance, and free_reach + 3 quarters = next_seed inside a stretch; with handover no free reach
TEST(NeedleTissueTest, TheTipStretchTellsWhereTheHoldEngagesAndTheNextPointIsSeeded) {
  constexpr double kAdvance = 0.3e-3;
  const double spacing = MakeTissue().point_spacing;
  for (TipHold hold : {TipHold::kQuarter, TipHold::kHandover}) {
    TissueCouplingConfig tissue = MakeTissue();
    tissue.tip_hold = hold;
    Scene scene(tissue);
    int free_steps = 0, held_steps = 0, seeds = 0;
    for (int k = 0; k < 60; ++k) {
      const std::optional<NeedleTissueCoupling::TipStretch> s =
          scene.coupling->CalcTipStretch(0, scene.state);
      const bool inside = scene.report().phase == TissuePhase::kInside;
      EXPECT_EQ(s.has_value(), inside) << "step " << k;
      const size_t points = scene.tissue().points.size();
      const NeedleStepReport r = scene.Step(kAdvance, Eigen::Vector3d(2e-5, 0.0, 0.0));
      ASSERT_TRUE(r.solve.converged);
      if (!s || scene.tissue().tip.tet < 0) continue;
      if (hold == TipHold::kHandover) {
        EXPECT_EQ(s->free_reach, 0.0);
        EXPECT_EQ(s->free_length, 0.0);
        continue;
      }
      EXPECT_DOUBLE_EQ(s->free_length, 0.25 * spacing);
      if (s->free_reach > 0.0) {
        EXPECT_NEAR(s->free_reach + 0.75 * spacing, s->next_seed, 1e-12);
        EXPECT_EQ(scene.report().tip_force, 0.0) << "free at step " << k;
        ++free_steps;
      } else {
        EXPECT_GT(scene.report().tip_force, 0.0) << "held at step " << k;
        ++held_steps;
      }
      const bool seeded = scene.tissue().points.size() > points;
      seeds += seeded ? 1 : 0;
      // the depth grows by about the advance (the block barely moves along the needle)
      if (s->next_seed > kAdvance + 1e-5) EXPECT_FALSE(seeded) << "step " << k;
      if (s->next_seed < kAdvance - 1e-5) EXPECT_TRUE(seeded) << "step " << k;
    }
    if (hold == TipHold::kQuarter) {
      EXPECT_GE(free_steps, 5);
      EXPECT_GE(held_steps, 5);
      EXPECT_GE(seeds, 1);
    }
  }
}

// seed_distance last_point: the tip's distance past the last seeded point is the arc length
// from that point's projection on the needle to the tip (checked against the axial component of
// tip - point, the rigid needle's axis); the hold engages exactly in the steps that start a
// quarter spacing or more past the point by that measure, the next point is seeded exactly in the
// steps that end a spacing past it, and CalcTipStretch's free reach and next seed follow it. With
// friction the needle drags the tissue, so the measure differs from the depth's
TEST(NeedleTissueTest, TheHoldAndTheSeedsCanMeasureFromTheLastPoint) {
  const double spacing = MakeTissue().point_spacing, quarter = 0.25 * spacing;
  TissueCouplingConfig tissue = MakeTissue();
  tissue.seed_distance = SeedDistance::kLastPoint;
  tissue.friction_coefficient = 0.3;
  tissue.friction_force_per_length = 60.0;
  Scene scene(tissue);
  int free_steps = 0, held_steps = 0, seeds = 0;
  double largest_difference = 0.0;
  for (int k = 0; k < 60; ++k) {
    const TissueCouplingState& ts = scene.tissue();
    const bool inside = scene.report().phase == TissuePhase::kInside && ts.tip.tet >= 0;
    const double past = scene.report().past_last_point;
    const std::optional<NeedleTissueCoupling::TipStretch> s =
        scene.coupling->CalcTipStretch(0, scene.state);
    const size_t points = ts.points.size();
    const TetPoint last = points > 0 ? ts.points.back().point : TetPoint{};
    const NeedleStepReport r = scene.Step(0.3e-3, Eigen::Vector3d(2e-5, 0.0, 0.0));
    ASSERT_TRUE(r.solve.converged);
    if (inside) {
      ASSERT_TRUE(s.has_value());
      EXPECT_NEAR(s->free_reach, std::max(0.0, quarter - past), 1e-15) << "step " << k;
      EXPECT_NEAR(s->next_seed, std::max(0.0, spacing - past), 1e-15) << "step " << k;
      // the next point is seeded when the tip is a spacing past the last one, by this measure
      if (scene.tissue().tip.tet >= 0) {
        const Eigen::Vector3d x_last = EvalTetPoint(scene.block.mesh, scene.block.state->x, last);
        const double past_end = scene.needle.X_WN_start.linear().col(2).dot(scene.tip() - x_last);
        const bool seeded = scene.tissue().points.size() > points;
        if (past_end > spacing + 1e-9) EXPECT_TRUE(seeded) << "step " << k;
        if (past_end < spacing - 1e-9) EXPECT_FALSE(seeded) << "step " << k;
        seeds += seeded ? 1 : 0;
      }
      if (past >= quarter) {
        EXPECT_GT(scene.report().tip_force, 0.0) << "held at step " << k << ", past " << past;
        ++held_steps;
      } else {
        EXPECT_EQ(scene.report().tip_force, 0.0) << "free at step " << k << ", past " << past;
        ++free_steps;
      }
    }
    if (scene.report().phase != TissuePhase::kInside || scene.tissue().tip.tet < 0) {
      EXPECT_EQ(scene.report().past_last_point, 0.0);
      continue;
    }
    const Eigen::Vector3d x_last =
        EvalTetPoint(scene.block.mesh, scene.block.state->x, scene.tissue().points.back().point);
    const Eigen::Vector3d z = scene.needle.X_WN_start.linear().col(2);
    EXPECT_NEAR(scene.report().past_last_point, z.dot(scene.tip() - x_last), 1e-12) << "step " << k;
    largest_difference = std::max(
        largest_difference, std::abs(scene.report().past_last_point -
                                     (scene.report().depth - scene.tissue().last_seed_depth)));
  }
  std::printf("past the last point by the two measures: up to %.3g m apart\n", largest_difference);
  EXPECT_GE(free_steps, 5);
  EXPECT_GE(held_steps, 5);
  EXPECT_GE(seeds, 2);
  EXPECT_GT(largest_difference, 1e-6);
}

// tip_hold handover: the tip is held at every depth past the entry (its force never drops to zero
// under a sideways drift, where without it the hold is off for a quarter spacing after each
// point), and the last seeded point is the one let go at its seed and ramped in: right after
// it is seeded it drifts off the needle line, a quarter spacing later it is back on it
TEST(NeedleTissueTest, TipHandoverHoldsTheTipAndRampsInTheLastPoint) {
  const double quarter = 0.25 * MakeTissue().point_spacing;
  TissueCouplingConfig tissue = MakeTissue();
  tissue.tip_hold = TipHold::kHandover;
  Scene scene(tissue);
  int held = 0, soft = 0, rigid = 0;
  double while_soft = 0.0, once_rigid = 0.0;  // the last point's distance to the needle line
  for (int k = 0; k < 40; ++k) {
    // the hold of a step is set by the tip's depth past the last point at the step start
    const TissueCouplingState& ts = scene.tissue();
    const bool inside = scene.report().phase == TissuePhase::kInside && ts.tip.tet >= 0;
    const double past = scene.report().depth - ts.last_seed_depth;
    const size_t points = ts.points.size();
    const NeedleStepReport r = scene.Step(0.3e-3, Eigen::Vector3d(2e-5, 0.0, 0.0));
    ASSERT_TRUE(r.solve.converged);
    if (!inside) continue;
    EXPECT_GT(scene.report().tip_force, 0.0) << "the tip is held at depth " << scene.report().depth;
    ++held;
    if (points < 2 || ts.points.size() != points) continue;  // a trajectory point, not re-seeded
    const double off_line = scene.DistanceToNeedle(ts.points.back());
    if (past > 0.3 * quarter && past < quarter) while_soft = std::max(while_soft, off_line), ++soft;
    if (past >= quarter) once_rigid = std::max(once_rigid, off_line), ++rigid;
  }
  std::printf("last point off the needle line: up to %.3g m while its hold ramps in, %.3g m "
              "once rigid\n", while_soft, once_rigid);
  EXPECT_GE(held, 20);
  EXPECT_GE(soft, 3);
  EXPECT_GE(rigid, 3);
  EXPECT_GT(while_soft, 1e3 * kLineTol);  // soft: the drift carries it off the line
  EXPECT_LT(once_rigid, kLineTol);        // rigid a quarter spacing past its seed
  // the handover needs the tip hold
  tissue.tip_constraint = false;
  EXPECT_THROW(tissue.Validate(), InputError);
}

// lateral_compliance c: each trajectory point is held by a spring of compliance c in series with
// the tissue, so under a sideways drift the point lags the needle line by c times its lateral
// force (Hooke), where the rigid hold keeps it on the line; the softer hold carries less force
TEST(NeedleTissueTest, LateralComplianceIsASpringBetweenPointAndNeedle) {
  double rigid_force = 0.0, soft_force = 0.0;
  for (double c : {0.0, 0.5}) {  // m/N; the block's own point compliance is ~0.1-1 m/N
    TissueCouplingConfig tissue = MakeTissue();
    tissue.lateral_compliance = c;
    tissue.tip_constraint = false;
    Scene scene(tissue);
    int checked = 0;
    for (int k = 0; k < 40; ++k) {
      const bool was_inside = scene.report().phase == TissuePhase::kInside;
      const size_t held = scene.tissue().points.size();
      ASSERT_TRUE(scene.Step(0.5e-3, Eigen::Vector3d(4e-5, 0.0, 0.0)).solve.converged);
      if (!was_inside) continue;
      for (size_t i = 1; i < held; ++i) {  // trajectory points (the entry is point 0)
        const NeedlePathPoint& p = scene.tissue().points[i];
        const double offset = scene.DistanceToNeedle(p);
        EXPECT_NEAR(offset, c * p.lateral_force.norm(), 1e-6 * offset + kLineTol) << "step " << k;
        if (c > 0 && p.lateral_force.norm() > 0) ++checked;
      }
    }
    (c > 0 ? soft_force : rigid_force) = scene.report().lateral_force;
    if (c > 0) {
      EXPECT_GE(checked, 10);
    }
  }
  std::printf("lateral force after the drift: rigid %.4g N, compliant %.4g N\n", rigid_force, soft_force);
  EXPECT_GT(rigid_force, 0.0);
  EXPECT_LT(soft_force, rigid_force);
}

TEST(NeedleTissueTest, BadConfigNamesTheKey) {
  NeedleCouplingConfig config;
  config.tissues.resize(2);
  config.tissues[1].point_spacing = 0.0;
  try {
    config.Validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("coupling.tissues[1].point_spacing must be > 0"),
              std::string::npos);
  }
  config.tissues[1].point_spacing = 0.01;
  config.tissues[0].friction_coefficient = -1;
  EXPECT_THROW(config.Validate(), InputError);
  config.tissues[0].friction_coefficient = 0;
  config.tissues[0].lateral_compliance = -1e-3;
  EXPECT_THROW(config.Validate(), InputError);
  config.tissues[0].lateral_compliance = 0;
  config.tissues[0].tip_compliance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(config.Validate(), InputError);
  config.tissues[0].tip_compliance = 0;
  const TetMesh mesh = MakeBoxTetMesh(Eigen::Vector3i(2, 2, 2), Eigen::Vector3d(1, 1, 1));
  EXPECT_THROW(NeedleTissueCoupling(config, {&mesh}), InputError);  // one mesh for two tissues
}

// Locate on a concave tissue: a 3 x 1 x 2 block of cubes with the top middle cube removed (a
// notch). From a tet of the left arm, the walk towards a point in the right arm leaves through
// the notch's wall: the point is still found (the global search), while points outside, in
// the notch or beyond the block, are not; every found point is inside its tet to round-off
TEST(NeedleTissueCouplingTest, LocateFindsPointsBeyondAConcavity) {
  const TetMesh box = MakeBoxTetMesh(Eigen::Vector3i(7, 3, 5), Eigen::Vector3d(0.03, 0.01, 0.02));
  TetMesh notched;
  notched.X = box.X;
  for (const Eigen::Vector4i& t : box.tets) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += 0.25 * box.X.col(t[k]);
    if (c.x() > 0.01 && c.x() < 0.02 && c.z() > 0.01) continue;  // the notch
    notched.tets.push_back(t);
  }
  notched.surface = ComputeBoundarySurface(notched.tets);
  NeedleCouplingConfig config;
  config.tissues = {TissueCouplingConfig{}};
  const NeedleTissueCoupling coupling(config, {&notched});
  // a tet of the left arm's top
  int left = -1;
  for (int e = 0; e < notched.num_tets() && left < 0; ++e) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += 0.25 * notched.X.col(notched.tets[e][k]);
    if (c.x() < 0.01 && c.z() > 0.01) left = e;
  }
  ASSERT_GE(left, 0);
  const Eigen::Vector3d right_arm(0.025, 0.005, 0.015), notch(0.015, 0.005, 0.015),
      below_notch(0.015, 0.005, 0.005), outside(0.025, 0.005, 0.0205), far(0.1, 0.1, 0.1);
  for (const Eigen::Vector3d& p : {right_arm, below_notch}) {
    const TetPoint found = coupling.Locate(0, notched.X, p, left);
    ASSERT_GE(found.tet, 0) << p.transpose();
    EXPECT_LT((EvalTetPoint(notched, notched.X, found) - p).norm(), 1e-12) << p.transpose();
    EXPECT_GE(found.bary.minCoeff(), -1e-9) << p.transpose();
  }
  for (const Eigen::Vector3d& p : {notch, outside, far})
    EXPECT_LT(coupling.Locate(0, notched.X, p, left).tet, 0) << p.transpose();
}

}  // namespace
}  // namespace nsim
