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
  EXPECT_TRUE(s.scene.liver_rest_compliance);
  EXPECT_EQ(s.robot.kind, RobotKind::kCartesian);
  EXPECT_EQ(s.run.mode, RunMode::kRealtime);
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
  EXPECT_EQ(LoadError(Edited("constraint_compliance: rest", "constraint_compliance: current")),
            "scenario.yaml: patient.constraint_compliance: expected one of rest, last_factor, got "
            "'current'");
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

TEST(ScenarioLoaderTest, TyposAreUnknownKeys) {
  const std::string typo = LoadError(Edited("young_modulus: 5500", "youngs_modulus: 5500"));
  EXPECT_EQ(typo.rfind("scenario.yaml: patient.liver.youngs_modulus: unknown key (known keys: ", 0),
            0u)
      << typo;
  const std::string section = LoadError(DefaultText() + "\ncontroler:\n  gain: 0.5\n");
  EXPECT_EQ(section.rfind("scenario.yaml: controler: unknown key", 0), 0u) << section;
}

TEST(ScenarioLoaderTest, SectionsOfTheOtherProcessAreSkipped) {
  EXPECT_EQ(LoadError(DefaultText() + "\ncontroller:\n  anything: [1, 2]\nprediction:\n  x: y\n"),
            "");
}

}  // namespace
}  // namespace nsim
