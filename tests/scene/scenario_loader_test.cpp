#include "direct_sim/scenario_loader.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "common/core/error.h"
#include "tests/scene/scene_test_util.h"

namespace nsim {
namespace {

using testing::SourcePath;

std::string DefaultText() {
  std::ifstream in(SourcePath("configs/scenarios/liver_breathing.yaml"));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// replaces the first occurrence of `from` in the default scenario
std::string Edited(const std::string& from, const std::string& to) {
  std::string text = DefaultText();
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

std::string LoadError(const std::string& text) {
  try {
    ParseDirectScenario(YamlReader::LoadString(text, "scenario.yaml"),
                        SourcePath("configs/scenarios"));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ScenarioLoaderTest, LoadsTheDefaultScenario) {
  const DirectScenario s = LoadDirectScenario(SourcePath("configs/scenarios/liver_breathing.yaml"));
  EXPECT_EQ(s.scene.liver.young_modulus, 5500.0);
  EXPECT_EQ(s.scene.liver.poisson_ratio, 0.45);
  EXPECT_EQ(s.scene.liver.density, 1060.0);
  EXPECT_EQ(s.liver_mesh.num_nodes(), 2656);
  EXPECT_EQ(s.skin_mesh.num_nodes(), 144);
  EXPECT_EQ(s.scene.ribs.size(), 2u);
  EXPECT_EQ(s.scene.markers_W.size(), 5u);
  EXPECT_EQ(s.scene.breathing.random_seed, 1u);  // from the top-level random_seed
  EXPECT_EQ(s.scene.needle.kind, NeedleKind::kRigid);
  EXPECT_TRUE(s.scene.liver.background_refactor);
  EXPECT_EQ(s.scene.liver.refactor_adopt_delay, 3);
  EXPECT_EQ(s.scene.liver.refactor_slice, 0.0);
  EXPECT_EQ(s.scene.liver.refactor_hold_steps, 10);
  EXPECT_TRUE(s.scene.liver_rest_compliance);
  EXPECT_EQ(s.robot.kind, RobotKind::kCartesian);
  EXPECT_EQ(s.run.mode, RunMode::kRealtime);
  EXPECT_EQ(s.run.rt_priority, 0);  // the normal class unless asked
  EXPECT_EQ(s.safety.max_linear_speed, s.robot.cartesian.max_linear_speed);  // gate = robot limits
}

TEST(ScenarioLoaderTest, BadValuesNameTheKey) {
  EXPECT_EQ(LoadError(Edited("young_modulus: 5500", "young_modulus: abc")),
            "scenario.yaml: patient.liver.young_modulus: expected a number, got 'abc'");
  EXPECT_EQ(LoadError(Edited("young_modulus: 5500", "young_modulus: -3")),
            "scenario.yaml: patient.liver.young_modulus must be > 0 (Pa), got -3");
  EXPECT_EQ(LoadError(Edited("period: 4.0", "period: -1")),
            "scenario.yaml: breathing.period must be > 0 (s), got -1");
  EXPECT_EQ(LoadError(Edited("type: rigid", "type: bendy")),
            "scenario.yaml: needle.type: expected one of rigid, flexible, got 'bendy'");
  EXPECT_EQ(LoadError(Edited("mode: realtime", "mode: fast")),
            "scenario.yaml: run.mode: expected one of realtime, lockstep, got 'fast'");
  EXPECT_EQ(LoadError(Edited("max_age: 0.5", "max_age: 0")),
            "scenario.yaml: safety.max_age must be > 0 (s), got 0");
  EXPECT_EQ(LoadError(Edited("refactor_adopt_delay: 3", "refactor_adopt_delay: 0")),
            "scenario.yaml: patient.liver.refactor_adopt_delay must be >= 1 (steps), got 0");
  EXPECT_EQ(LoadError(Edited("refactor_adopt_delay: 3", "refactor_adopt_delay: 1.5")),
            "scenario.yaml: patient.liver.refactor_adopt_delay: expected an integer, got '1.5'");
  EXPECT_EQ(LoadError(Edited("refactor_slice: 0", "refactor_slice: 5")),
            "scenario.yaml: patient.liver.refactor_slice must be in [0, 1] (s), got 5");
  EXPECT_EQ(LoadError(Edited("refactor_hold_steps: 10", "refactor_hold_steps: -1")),
            "scenario.yaml: patient.liver.refactor_hold_steps must be >= 0 (steps), got -1");
  EXPECT_EQ(LoadError(Edited("refactor_hold_steps: 10", "refactor_hold_steps: 2.5")),
            "scenario.yaml: patient.liver.refactor_hold_steps: expected an integer, got '2.5'");
  EXPECT_EQ(LoadError(Edited("constraint_compliance: rest", "constraint_compliance: current")),
            "scenario.yaml: patient.constraint_compliance: expected one of rest, last_factor, got "
            "'current'");
  EXPECT_EQ(LoadError(Edited("refactor_adopt_delay: 3",
                             "refactor_adopt_delay: 3\n    preconditioner_precision: half")),
            "scenario.yaml: patient.liver.preconditioner_precision: expected one of single, "
            "double, got 'half'");
  const std::string mesh = LoadError(Edited("liver_2660.msh", "no_such.msh"));
  EXPECT_EQ(mesh.rfind("scenario.yaml: patient.liver.mesh: ", 0), 0u) << mesh;
}

// patient.constraint_compliance selects the liver's compliance: rest (the default scenarios)
// or last_factor
TEST(ScenarioLoaderTest, ConstraintComplianceChoices) {
  const auto load = [](const std::string& text) {
    return ParseDirectScenario(YamlReader::LoadString(text, "scenario.yaml"),
                               SourcePath("configs/scenarios"));
  };
  EXPECT_TRUE(load(DefaultText()).scene.liver_rest_compliance);
  EXPECT_FALSE(
      load(Edited("constraint_compliance: rest", "constraint_compliance: last_factor"))
          .scene.liver_rest_compliance);
}

// needle.<tissue>.tip_hold selects where the tip is held after a seeded point: quarter (the
// default), ramp or handover; anything else is named
TEST(ScenarioLoaderTest, TipHoldChoices) {
  const auto liver_hold = [](const std::string& text) {
    return ParseDirectScenario(YamlReader::LoadString(text, "scenario.yaml"),
                               SourcePath("configs/scenarios"))
        .scene.needle.coupling.tissues[kLiverTissue]
        .tip_hold;
  };
  const std::string liver = "liver: {puncture_force: 0.3, friction_coefficient: 0.1, ";
  EXPECT_EQ(liver_hold(DefaultText()), TipHold::kQuarter);
  EXPECT_EQ(liver_hold(Edited(liver, liver + "tip_hold: handover, ")), TipHold::kHandover);
  EXPECT_EQ(liver_hold(Edited(liver, liver + "tip_hold: ramp, ")), TipHold::kRamp);
  EXPECT_EQ(LoadError(Edited(liver, liver + "tip_hold: always, ")),
            "scenario.yaml: needle.liver.tip_hold: expected one of quarter, ramp, handover, got "
            "'always'");
  // needle.<tissue>.seed_distance: depth (the default) or last_point; anything else is named
  const auto liver_measure = [](const std::string& text) {
    return ParseDirectScenario(YamlReader::LoadString(text, "scenario.yaml"),
                               SourcePath("configs/scenarios"))
        .scene.needle.coupling.tissues[kLiverTissue]
        .seed_distance;
  };
  EXPECT_EQ(liver_measure(DefaultText()), SeedDistance::kDepth);
  EXPECT_EQ(liver_measure(Edited(liver, liver + "seed_distance: last_point, ")),
            SeedDistance::kLastPoint);
  EXPECT_EQ(LoadError(Edited(liver, liver + "seed_distance: entry, ")),
            "scenario.yaml: needle.liver.seed_distance: expected one of depth, last_point, got "
            "'entry'");
}

// patient.prefetch_ahead and patient.prefetch_rib_margin: read, and bounded like the other
// lengths
TEST(ScenarioLoaderTest, TrackerNoise) {
  const auto load = [](const std::string& text) {
    return ParseDirectScenario(YamlReader::LoadString(text, "scenario.yaml"),
                               SourcePath("configs/scenarios"));
  };
  EXPECT_EQ(load(DefaultText()).tracker.marker_std, 0.0);
  const DirectScenario s = load(Edited("marker_noise: 0.0 ", "marker_noise: 0.0002 "));
  EXPECT_EQ(s.tracker.marker_std, 0.0002);
  // seeded by the run's seed, whatever the section says
  EXPECT_EQ(s.LoopConfig(true).tracker.random_seed, s.random_seed);
  EXPECT_EQ(LoadError(Edited("marker_noise: 0.0 ", "marker_noise: -0.001 ")),
            "scenario.yaml: tracker.marker_noise must be a standard deviation in [0, 0.01] m, "
            "got -0.001");
  EXPECT_EQ(LoadError(Edited("marker_noise: 0.0 ", "marker_noise: loud ")),
            "scenario.yaml: tracker.marker_noise: expected a number, got 'loud'");
  EXPECT_NE(LoadError(Edited("marker_noise: 0.0 ", "marker_nois: 0.0 ")).find("marker_nois"),
            std::string::npos);
}

TEST(ScenarioLoaderTest, PrefetchDistances) {
  const auto load = [](const std::string& text) {
    return ParseDirectScenario(YamlReader::LoadString(text, "scenario.yaml"),
                               SourcePath("configs/scenarios"));
  };
  const DirectScenario s = load(DefaultText());
  EXPECT_EQ(s.scene.prefetch_ahead, 0.004);
  EXPECT_EQ(s.scene.prefetch_rib_margin, 0.010);
  EXPECT_EQ(load(Edited("prefetch_ahead: 0.004", "prefetch_ahead: 0")).scene.prefetch_ahead, 0.0);
  EXPECT_EQ(LoadError(Edited("prefetch_ahead: 0.004", "prefetch_ahead: -0.001")),
            "scenario.yaml: patient.prefetch_ahead must be >= 0 (m), got -0.001");
  EXPECT_EQ(LoadError(Edited("prefetch_rib_margin: 0.010", "prefetch_rib_margin: 0.5"))
                .rfind("scenario.yaml: patient.prefetch_rib_margin", 0),
            0u);
}

// patient.liver.refactor_adoption chooses for realtime runs; a lockstep run's patient loop
// always adopts on schedule (deterministic), whatever the file says, with its refresh worker
// in the normal class
TEST(ScenarioLoaderTest, RefactorAdoptionIsScheduledInLockstep) {
  const auto load = [](const std::string& text) {
    return ParseDirectScenario(YamlReader::LoadString(text, "scenario.yaml"),
                               SourcePath("configs/scenarios"));
  };
  DirectScenario ready = load(DefaultText());  // the default scenario asks for when_ready
  EXPECT_EQ(ready.scene.liver.refactor_adoption, FactorAdoption::kWhenReady);
  const DirectScenario scheduled =
      load(Edited("refactor_adoption: when_ready", "refactor_adoption: scheduled"));
  EXPECT_EQ(scheduled.scene.liver.refactor_adoption, FactorAdoption::kScheduled);
  ready.run.mode = RunMode::kRealtime;
  EXPECT_EQ(ready.LoopConfig(true).scene.liver.refactor_adoption, FactorAdoption::kWhenReady);
  EXPECT_TRUE(ready.LoopConfig(true).scene.liver.RefreshWorkerIdle());
  ready.run.mode = RunMode::kLockstep;
  EXPECT_EQ(ready.LoopConfig(true).scene.liver.refactor_adoption, FactorAdoption::kScheduled);
  // the scheduled adoptions wait for the worker: not in the idle class, which a busy machine
  // starves
  EXPECT_FALSE(ready.LoopConfig(true).scene.liver.RefreshWorkerIdle());
  DirectScenario realtime_scheduled = scheduled;
  realtime_scheduled.run.mode = RunMode::kRealtime;
  EXPECT_FALSE(realtime_scheduled.LoopConfig(true).scene.liver.RefreshWorkerIdle());
  EXPECT_NE(LoadError(Edited("refactor_adoption: when_ready", "refactor_adoption: soon"))
                .find("refactor_adoption"),
            std::string::npos);
}

TEST(ScenarioLoaderTest, TyposAreUnknownKeys) {
  const std::string typo = LoadError(Edited("young_modulus: 5500", "youngs_modulus: 5500"));
  EXPECT_EQ(typo.rfind("scenario.yaml: patient.liver.youngs_modulus: unknown key (known keys: ", 0),
            0u)
      << typo;
  const std::string section = LoadError(DefaultText() + "\ncontroler:\n  gain: 0.5\n");
  EXPECT_EQ(section.rfind("scenario.yaml: controler: unknown key", 0), 0u) << section;
}

TEST(ScenarioLoaderTest, SectionsOfTheOtherProcessAreSkipped) {
  // the default scenario's own inverse_sim sections are replaced (a second "controller:" in
  // the same file is a duplicate key, see below)
  const std::string text = DefaultText();
  const std::string direct_part = text.substr(0, text.find("# ---- inverse_sim"));
  EXPECT_EQ(LoadError(direct_part + "\ncontroller:\n  anything: [1, 2]\nprediction:\n  x: y\n"),
            "");
}

TEST(ScenarioLoaderTest, DuplicateSectionsAndKeysAreErrors) {
  const std::string section =
      LoadError(DefaultText() + "\ncontroller:\n  anything: [1, 2]\n");
  EXPECT_EQ(section.rfind("scenario.yaml:", 0), 0u) << section;
  EXPECT_NE(section.find(": duplicate key controller (first at line "), std::string::npos)
      << section;
  const std::string key = LoadError(Edited("young_modulus: 5500", "young_modulus: 5500\n    young_modulus: 1"));
  EXPECT_NE(key.find(": duplicate key patient.liver.young_modulus"), std::string::npos) << key;
}

TEST(ScenarioLoaderTest, PhysicalValuesAreBounded) {
  EXPECT_EQ(LoadError(Edited("gravity: [0, 0, 0]", "gravity: [0, 0, -1.0e6]")),
            "scenario.yaml: patient.gravity must be finite with a norm of at most 100 (m/s^2), "
            "got [0, 0, -1e+06]");
  EXPECT_EQ(LoadError(Edited("time_step: 0.02", "time_step: 1.0e-9")),
            "scenario.yaml: patient.time_step must be in [0.0001, 0.1] (s), got 1e-09");
  // 0.1 ms for 200 s: 2e6 steps (each value alone is within its bounds)
  std::string long_run = Edited("duration: 26.0", "duration: 200");
  long_run.replace(long_run.find("time_step: 0.02"), 15, "time_step: 0.0001");
  const std::string steps = LoadError(long_run);
  EXPECT_NE(steps.find("run.duration / patient.time_step must be at most 1e+06 steps"),
            std::string::npos)
      << steps;
  EXPECT_EQ(LoadError(Edited("max_linear_speed: 0.05", "max_linear_speed: 1000")),
            "scenario.yaml: robot.max_linear_speed must be <= 2 (m/s), got 1000");
  EXPECT_EQ(LoadError(Edited("speed: 0.01", "speed: 30")),
            "scenario.yaml: insertion.speed must be <= 0.5 (m/s), got 30");
  EXPECT_EQ(LoadError(Edited("period: 4.0", "period: 1.0e5")),
            "scenario.yaml: breathing.period must be in [0.5, 30] (s), got 100000");
  EXPECT_EQ(LoadError(Edited("young_modulus: 5500", "young_modulus: 1.0e15")),
            "scenario.yaml: patient.liver.young_modulus must be <= 1e+12 (Pa), got 1e+15");
  const std::string partition = LoadError(Edited("partition: nsim", "partition: " + std::string(65535, 'p')));
  EXPECT_EQ(partition.rfind("scenario.yaml: dds.partition must be 1..64 characters of [A-Za-z0-9_-]", 0), 0u)
      << partition.substr(0, 200);
  EXPECT_EQ(LoadError(Edited("partition: nsim", "partition: 'a b'")).rfind(
                "scenario.yaml: dds.partition must be", 0),
            0u);
}

}  // namespace
}  // namespace nsim
