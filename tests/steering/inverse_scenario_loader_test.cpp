// The inverse side's scenario loader (inverse_sim/scenario_loader.h) on the model's needle
// options: inverse.bevel (a bevel map with the patient's keys, or `patient`), by default off,
// and bad values named by their YAML key.
#include "inverse_sim/scenario_loader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "common/core/error.h"

namespace nsim {
namespace {

const std::string kScenarioDir = std::string(NSIM_SOURCE_DIR) + "/configs/scenarios";

std::string DefaultText() {
  std::ifstream in(kScenarioDir + "/liver_breathing.yaml");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// the default scenario with `from` (first occurrence) replaced by `to`
std::string Edited(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

// loads `text` as a scenario file beside the default one (its mesh paths are relative)
InverseScenario Load(const std::string& text) {
  const std::string path = kScenarioDir + "/.inverse_loader_test_" +
                           std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
                           "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name() +
                           ".yaml";
  {
    std::ofstream out(path);
    out << text;
  }
  struct Remove {
    std::string path;
    ~Remove() { std::filesystem::remove(path); }
  } remove{path};
  return LoadInverseScenario(path);
}

std::string LoadError(const std::string& text) {
  try {
    Load(text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const std::string kInverseKey = "  constraint_compliance: rest  # h^2 A_0^-1";

// inverse.liver shares the patient's FEM keys (common/scenario/fem_reader.h)
TEST(InverseScenarioLoaderTest, ReadsTheModelLiversSolverKeys) {
  EXPECT_TRUE(Load(DefaultText()).loop.model.liver.single_precision_preconditioner);
  const std::string solver =
      "    linear_solver: pcg_cached_factor  # PCG on the cached factor; `direct` refactorizes each "
      "step";
  const InverseScenario s = Load(Edited(DefaultText(), solver,
                                        solver + "\n    preconditioner_precision: double\n"
                                                 "    refactor_iteration_threshold: 4"));
  EXPECT_FALSE(s.loop.model.liver.single_precision_preconditioner);
  EXPECT_EQ(s.loop.model.liver.refactor_iteration_threshold, 4);
  const std::string bad =
      LoadError(Edited(DefaultText(), solver, solver + "\n    preconditioner_precision: half"));
  EXPECT_NE(bad.find("inverse.liver.preconditioner_precision: expected one of single, double, got "
                     "'half'"),
            std::string::npos)
      << bad;
}

// the model's refresh worker's class: the lowest only in realtime with adoptions when ready
// (the control step goes first); the normal class in lockstep and with scheduled adoptions
// (the default), which wait for the worker: a busy machine starves the idle class
TEST(InverseScenarioLoaderTest, ScheduledAdoptionsKeepTheRefreshWorkerInTheNormalClass) {
  InverseScenario s = Load(DefaultText());  // run.mode: realtime
  EXPECT_FALSE(s.lockstep);
  EXPECT_EQ(s.loop.model.liver.refactor_adoption, FactorAdoption::kScheduled);
  EXPECT_FALSE(s.LoopConfig().model.liver.RefreshWorkerIdle());
  s.loop.model.liver.refactor_adoption = FactorAdoption::kWhenReady;
  EXPECT_TRUE(s.LoopConfig().model.liver.RefreshWorkerIdle());
  s = Load(Edited(DefaultText(), "  mode: realtime ", "  mode: lockstep "));
  EXPECT_TRUE(s.lockstep);
  EXPECT_FALSE(s.LoopConfig().model.liver.RefreshWorkerIdle());
  s.loop.model.liver.refactor_adoption = FactorAdoption::kWhenReady;  // lockstep: normal too
  EXPECT_FALSE(s.LoopConfig().model.liver.RefreshWorkerIdle());
  EXPECT_TRUE(s.loop.model.liver.idle_refresh_worker);  // the loaded config is as read
}

// the model's needle coupling and prediction options: defaults, values, and bad choices by key
TEST(InverseScenarioLoaderTest, ReadsTheCouplingAndPoseOptions) {
  const InverseScenario plain = Load(DefaultText());
  EXPECT_EQ(plain.loop.model.coupling.tip_hold, TipHold::kQuarter);
  EXPECT_TRUE(plain.loop.model.jacobian_friction_held);
  EXPECT_EQ(plain.loop.model_pose, ModelPose::kAuto);       // the default scenario's
  EXPECT_EQ(plain.loop.preparation, Preparation::kExhale);  // the default scenario's
  EXPECT_TRUE(plain.loop.prediction_shrink);                // the default scenario's
  EXPECT_EQ(plain.loop.model.coupling.seed_distance,
            SeedDistance::kLastPoint);  // the default scenario's
  std::string text = Edited(DefaultText(), kInverseKey,
                            "  tip_hold: handover\n  jacobian_friction: solved\n" + kInverseKey);
  text = Edited(text, "  seed_distance: last_point ", "  seed_distance: depth ");
  text = Edited(text, "  model_pose: auto ", "  model_pose: measured ");
  text = Edited(text, "  preparation: exhale ", "  preparation: buffer ");
  text = Edited(text, "  shrink: true ", "  shrink: false ");
  const InverseScenario s = Load(text);
  EXPECT_EQ(s.loop.model.coupling.tip_hold, TipHold::kHandover);
  EXPECT_EQ(s.loop.model.coupling.seed_distance, SeedDistance::kDepth);
  EXPECT_FALSE(s.loop.model.jacobian_friction_held);
  EXPECT_EQ(s.loop.model_pose, ModelPose::kMeasured);
  EXPECT_EQ(s.loop.preparation, Preparation::kBuffer);
  EXPECT_FALSE(s.loop.prediction_shrink);
  const std::string preparation = LoadError(
      Edited(DefaultText(), "  preparation: exhale ", "  preparation: maybe "));
  EXPECT_NE(preparation.find(
                "prediction.preparation: expected one of none, buffer, exhale, got 'maybe'"),
            std::string::npos)
      << preparation;
  const std::string shrink = LoadError(Edited(DefaultText(), "  shrink: true ", "  shrink: maybe "));
  EXPECT_NE(shrink.find("prediction.shrink: expected true or false, got 'maybe'"), std::string::npos)
      << shrink;
  const std::string friction =
      LoadError(Edited(DefaultText(), kInverseKey, "  jacobian_friction: sticky\n" + kInverseKey));
  EXPECT_NE(friction.find("inverse.jacobian_friction: expected one of held, solved, got 'sticky'"),
            std::string::npos)
      << friction;
  const std::string pose = LoadError(
      Edited(DefaultText(), "  model_pose: auto ", "  model_pose: future "));
  EXPECT_NE(pose.find("prediction.model_pose: expected one of measured, commanded, expected, auto, got 'future'"),
            std::string::npos)
      << pose;
  EXPECT_EQ(Load(Edited(DefaultText(), "  model_pose: auto ", "  model_pose: expected "))
                .loop.model_pose,
            ModelPose::kExpected);
  EXPECT_EQ(Load(Edited(DefaultText(), "  model_pose: auto ", "  model_pose: commanded "))
                .loop.model_pose,
            ModelPose::kCommanded);
}

// the model's coupling takes every key of the patient's needle.<tissue> section, with the
// patient's checks and bounds named by the model's key
TEST(InverseScenarioLoaderTest, CouplingTakesThePatientsTissueKeys) {
  const InverseScenario plain = Load(DefaultText());
  EXPECT_EQ(plain.loop.model.coupling.name, "liver");
  EXPECT_DOUBLE_EQ(plain.loop.model.coupling.puncture_force, 0.3);
  EXPECT_DOUBLE_EQ(plain.loop.model.coupling.friction_coefficient, 0.0);  // frictionless model
  EXPECT_DOUBLE_EQ(plain.loop.model.coupling.friction_force_per_length, 0.0);
  const InverseScenario s = Load(
      Edited(DefaultText(), kInverseKey,
             "  friction_force_per_length: 25\n  contact_margin: 0.003\n  tip_constraint: false\n" +
                 kInverseKey));
  EXPECT_DOUBLE_EQ(s.loop.model.coupling.friction_force_per_length, 25.0);
  EXPECT_DOUBLE_EQ(s.loop.model.coupling.contact_margin, 0.003);
  EXPECT_FALSE(s.loop.model.coupling.tip_constraint);
  const std::string margin =
      LoadError(Edited(DefaultText(), kInverseKey, "  contact_margin: 0.5\n" + kInverseKey));
  EXPECT_NE(margin.find("inverse.contact_margin must be <= 0.1 (m), got 0.5"), std::string::npos)
      << margin;
  const std::string spacing =
      LoadError(Edited(DefaultText(), "  point_spacing: 0.013\n", "  point_spacing: 0\n"));
  EXPECT_NE(spacing.find("inverse.point_spacing must be > 0 (m), got 0"), std::string::npos)
      << spacing;
  // handover holds the tip at every depth: without the tip's row there is nothing to hand over
  const std::string handover = LoadError(Edited(
      DefaultText(), kInverseKey, "  tip_hold: handover\n  tip_constraint: false\n" + kInverseKey));
  EXPECT_NE(handover.find("inverse.tip_hold: handover needs inverse.tip_constraint: true"),
            std::string::npos)
      << handover;
}

// the robot's limits, for the forecast of where the commands in flight take it: the scenario's
// robot section, and a bad value refused by its key
TEST(InverseScenarioLoaderTest, ReadsTheRobotsLimits) {
  const InverseScenario plain = Load(DefaultText());
  EXPECT_EQ(plain.loop.robot.cartesian.max_linear_acceleration, 0.5);
  EXPECT_EQ(plain.loop.robot.cartesian.max_angular_speed, 0.5);
  const InverseScenario s = Load(Edited(DefaultText(), "  max_linear_acceleration: 0.5\n",
                                        "  max_linear_acceleration: 0.25\n"));
  EXPECT_EQ(s.loop.robot.cartesian.max_linear_acceleration, 0.25);
  const std::string bad = LoadError(Edited(DefaultText(), "  max_linear_acceleration: 0.5\n",
                                           "  max_linear_acceleration: -1\n"));
  EXPECT_NE(bad.find("robot.max_linear_acceleration must be > 0 (m/s^2), got -1"),
            std::string::npos)
      << bad;
}

TEST(InverseScenarioLoaderTest, BevelIsOffByDefault) {
  const InverseScenario s = Load(DefaultText());
  EXPECT_FALSE(s.loop.model.bevel.enabled);
}

TEST(InverseScenarioLoaderTest, ReadsTheModelBevel) {
  const InverseScenario s = Load(Edited(
      DefaultText(), kInverseKey,
      "  bevel: {enabled: true, diameter: 0.001, tissue_stiffness: 100000, mode: force}\n" +
          kInverseKey));
  EXPECT_TRUE(s.loop.model.bevel.enabled);
  EXPECT_EQ(s.loop.model.bevel.diameter, 0.001);
  EXPECT_EQ(s.loop.model.bevel.tissue_stiffness, 100000);
  EXPECT_EQ(s.loop.model.bevel.mode, BevelLoadMode::kForce);
  EXPECT_EQ(s.loop.model.bevel.bevel_angle, BevelConfig().bevel_angle);  // absent: default
}

TEST(InverseScenarioLoaderTest, PatientBevelCopiesTheNeedleSection) {
  std::string text = Edited(DefaultText(), "bevel: {enabled: false, diameter: 0.0012",
                            "bevel: {enabled: true, diameter: 0.0011");
  text = Edited(text, kInverseKey, "  bevel: patient\n" + kInverseKey);
  const InverseScenario s = Load(text);
  EXPECT_TRUE(s.loop.model.bevel.enabled);
  EXPECT_EQ(s.loop.model.bevel.diameter, 0.0011);
  EXPECT_EQ(s.loop.model.bevel.tissue_stiffness, 150000);
}

TEST(InverseScenarioLoaderTest, BadBevelValuesNameTheKey) {
  const std::string negative = LoadError(
      Edited(DefaultText(), kInverseKey, "  bevel: {enabled: true, diameter: -1}\n" + kInverseKey));
  EXPECT_NE(negative.find("inverse.bevel.diameter must be > 0"), std::string::npos) << negative;
  const std::string typo = LoadError(
      Edited(DefaultText(), kInverseKey, "  bevel: {enabeld: true}\n" + kInverseKey));
  EXPECT_NE(typo.find("enabeld"), std::string::npos) << typo;
  const std::string word =
      LoadError(Edited(DefaultText(), kInverseKey, "  bevel: patients\n" + kInverseKey));
  EXPECT_NE(word.find("expected a bevel map or 'patient'"), std::string::npos) << word;
}

TEST(InverseScenarioLoaderTest, NeedleIsRigidByDefault) {
  const InverseScenario s = Load(DefaultText());
  EXPECT_EQ(s.loop.model.needle_kind, ModelNeedleKind::kRigid);
}

TEST(InverseScenarioLoaderTest, ReadsTheFlexibleModelNeedle) {
  const InverseScenario word = Load(Edited(DefaultText(), kInverseKey, "  needle: flexible\n" + kInverseKey));
  EXPECT_EQ(word.loop.model.needle_kind, ModelNeedleKind::kFlexible);
  EXPECT_EQ(word.loop.model.flexible.needle.young_modulus, MakeFlexibleNeedleConfig().young_modulus);
  const InverseScenario map = Load(Edited(
      DefaultText(), kInverseKey,
      "  needle: {type: flexible, young_modulus: 2.0e11, elements: 12, rayleigh_mass: 0.5}\n" +
          kInverseKey));
  EXPECT_EQ(map.loop.model.needle_kind, ModelNeedleKind::kFlexible);
  EXPECT_EQ(map.loop.model.flexible.needle.young_modulus, 2e11);
  EXPECT_EQ(map.loop.model.flexible.num_elements, 12);
  EXPECT_EQ(map.loop.model.flexible.rayleigh_mass, 0.5);
  // the beam's geometry and step are the shared needle's and the model liver's
  const BeamNeedleConfig beam = CalcModelBeamConfig(map.loop.model);
  EXPECT_EQ(beam.needle.length, map.shared.needle_length);
  EXPECT_EQ(beam.time_step, map.loop.model.liver.time_step);
}

TEST(InverseScenarioLoaderTest, PatientNeedleCopiesTheNeedleSection) {
  std::string text = Edited(DefaultText(), "  type: rigid                # rigid", "  type: flexible  # rigid");
  text = Edited(text, kInverseKey, "  needle: patient\n" + kInverseKey);
  const InverseScenario s = Load(text);
  EXPECT_EQ(s.loop.model.needle_kind, ModelNeedleKind::kFlexible);
  EXPECT_EQ(s.loop.model.flexible.needle.young_modulus, 200e9);  // needle.young_modulus
}

TEST(InverseScenarioLoaderTest, ReadsTheAlignmentReference) {
  EXPECT_EQ(Load(DefaultText()).loop.control.alignment, AlignmentReference::kTip);
  const std::string key = "  compensate_in_flight: true";
  EXPECT_EQ(Load(Edited(DefaultText(), key, "  alignment: base\n" + key)).loop.control.alignment,
            AlignmentReference::kBase);
  const std::string bad = LoadError(Edited(DefaultText(), key, "  alignment: middle\n" + key));
  EXPECT_NE(bad.find("alignment"), std::string::npos) << bad;
}

// controller.max_needle_tilt: the default scenario's 0.35 rad, none (pi) without the key, and
// values outside (0, pi] named by their key
TEST(InverseScenarioLoaderTest, ReadsTheNeedleTiltBound) {
  const std::string key = "  max_needle_tilt: 0.35        # (rad, 20 degrees)";
  EXPECT_EQ(Load(DefaultText()).loop.control.max_needle_tilt, 0.35);
  EXPECT_EQ(Load(Edited(DefaultText(), key, "")).loop.control.max_needle_tilt, M_PI);
  EXPECT_EQ(Load(Edited(DefaultText(), key, "  max_needle_tilt: 0.2")).loop.control.max_needle_tilt,
            0.2);
  for (const char* value : {"0", "-0.1", "4", ".nan"}) {
    const std::string bad =
        LoadError(Edited(DefaultText(), key, std::string("  max_needle_tilt: ") + value));
    EXPECT_NE(bad.find("controller.max_needle_tilt"), std::string::npos) << value << ": " << bad;
  }
}

// controller.max_insertion_step: none (0) in the default scenario and without the key, the value
// given, and values outside [0, 0.1] m named by their key
TEST(InverseScenarioLoaderTest, ReadsTheInsertionStepBound) {
  const std::string key = "  max_insertion_step: 0\n";
  EXPECT_EQ(Load(DefaultText()).loop.control.max_insertion_step, 0.0);
  EXPECT_EQ(Load(Edited(DefaultText(), key, "")).loop.control.max_insertion_step, 0.0);
  EXPECT_EQ(Load(Edited(DefaultText(), key, "  max_insertion_step: 0.0002\n"))
                .loop.control.max_insertion_step,
            0.0002);
  for (const char* value : {"-0.001", "0.2", ".nan"}) {
    const std::string bad = LoadError(
        Edited(DefaultText(), key, "  max_insertion_step: " + std::string(value) + "\n"));
    EXPECT_NE(bad.find("controller.max_insertion_step"), std::string::npos) << value << ": " << bad;
  }
}

// controller.free_stretch_step and free_stretch_tolerance: 0.2 mm a step and 0.1 mm in the
// default scenario and without the keys, the values given (0 turns the bound off), and bad
// values named by their key
TEST(InverseScenarioLoaderTest, ReadsTheFreeStretchBound) {
  const std::string keys = "  free_stretch_step: 0.0002\n  free_stretch_tolerance: 0.0001\n";
  for (const std::string& text : {DefaultText(), Edited(DefaultText(), keys, "")}) {
    const SteeringControlConfig c = Load(text).loop.control;
    EXPECT_EQ(c.free_stretch_step, 0.0002);
    EXPECT_EQ(c.free_stretch_tolerance, 0.0001);
  }
  const SteeringControlConfig off =
      Load(
          Edited(DefaultText(), keys, "  free_stretch_step: 0\n  free_stretch_tolerance: 0.0005\n"))
          .loop.control;
  EXPECT_EQ(off.free_stretch_step, 0.0);
  EXPECT_EQ(off.free_stretch_tolerance, 0.0005);
  for (const char* value : {"-0.001", "0.2", ".nan"}) {
    const std::string bad =
        LoadError(Edited(DefaultText(), keys, "  free_stretch_step: " + std::string(value) + "\n"));
    EXPECT_NE(bad.find("controller.free_stretch_step"), std::string::npos) << value << ": " << bad;
  }
  for (const char* value : {"-0.001", ".inf", ".nan"}) {
    const std::string bad = LoadError(
        Edited(DefaultText(), keys, "  free_stretch_tolerance: " + std::string(value) + "\n"));
    EXPECT_NE(bad.find("controller.free_stretch_tolerance"), std::string::npos)
        << value << ": " << bad;
  }
}

// controller.liver_alignment: the default scenario's auto, auto without the key, the three
// choices, and a bad one named by its key
TEST(InverseScenarioLoaderTest, ReadsTheLiverAlignment) {
  const std::string key = "  liver_alignment: auto";
  EXPECT_EQ(Load(DefaultText()).loop.control.liver_alignment, LiverAlignment::kAuto);
  const auto with = [&](const std::string& line) {
    return Load(Edited(DefaultText(), key, line)).loop.control.liver_alignment;
  };
  EXPECT_EQ(with(""), LiverAlignment::kAuto);
  EXPECT_EQ(with("  liver_alignment: none"), LiverAlignment::kNone);
  EXPECT_EQ(with("  liver_alignment: base"), LiverAlignment::kBase);
  const std::string bad = LoadError(Edited(DefaultText(), key, "  liver_alignment: tip"));
  EXPECT_NE(bad.find("liver_alignment"), std::string::npos) << bad;
}

TEST(InverseScenarioLoaderTest, ReadsTheLiverLoadWeightAndGain) {
  const std::string key = "  liver_load: 0.1";
  const InverseScenario defaults = Load(DefaultText());
  EXPECT_EQ(defaults.loop.control.liver_load, 0.1);
  EXPECT_EQ(defaults.loop.control.gains.load, 0.2);
  EXPECT_EQ(Load(Edited(DefaultText(), key, "")).loop.control.liver_load, 0.0);  // off
  EXPECT_EQ(Load(Edited(DefaultText(), key, "  liver_load: 0.05")).loop.control.liver_load, 0.05);
  const std::string negative = LoadError(Edited(DefaultText(), key, "  liver_load: -0.1"));
  EXPECT_NE(negative.find("controller.liver_load must be finite and >= 0, got -0.1"),
            std::string::npos)
      << negative;
  const std::string word = LoadError(Edited(DefaultText(), key, "  liver_load: yes"));
  EXPECT_NE(word.find("liver_load"), std::string::npos) << word;
  const std::string gain = LoadError(Edited(DefaultText(), "load: 0.2}", "load: 0}"));
  EXPECT_NE(gain.find("gains.load must be in (0, 1]"), std::string::npos) << gain;
}

TEST(InverseScenarioLoaderTest, ReadsWhoseTipAdvancesThePath) {
  const std::string key = "    advance: commanded";
  auto with = [&](const std::string& line) { return Edited(DefaultText(), key, line); };
  EXPECT_EQ(Load(DefaultText()).loop.path.advance, PathAdvance::kCommanded);
  EXPECT_EQ(Load(with("    advance: measured")).loop.path.advance, PathAdvance::kMeasured);
  EXPECT_EQ(Load(with("")).loop.path.advance, PathAdvance::kCommanded);  // the default
  const std::string bad = LoadError(with("    advance: ahead"));
  EXPECT_NE(bad.find("advance"), std::string::npos) << bad;
}

TEST(InverseScenarioLoaderTest, BadNeedleValuesNameTheKey) {
  auto error = [&](const std::string& value) {
    return LoadError(Edited(DefaultText(), kInverseKey, "  needle: " + value + "\n" + kInverseKey));
  };
  const std::string word = error("bendy");
  EXPECT_NE(word.find("expected rigid, flexible, patient or a map"), std::string::npos) << word;
  const std::string elements = error("{type: flexible, elements: 0}");
  EXPECT_NE(elements.find("inverse.needle.elements must be >= 1"), std::string::npos)
      << elements;
  const std::string modulus = error("{type: flexible, young_modulus: -1}");
  EXPECT_NE(modulus.find("inverse.needle.young_modulus"), std::string::npos) << modulus;
  const std::string moved = error("{length: 0.2}");
  EXPECT_NE(moved.find("moved to shared.needle.length"), std::string::npos) << moved;
  const std::string typo = error("{type: flexible, elemnts: 3}");
  EXPECT_NE(typo.find("elemnts"), std::string::npos) << typo;
}

}  // namespace
}  // namespace nsim
