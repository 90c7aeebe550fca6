#include "common/core/yaml_reader.h"

#include <gtest/gtest.h>

#include <string>

#include "common/core/error.h"

namespace nsim {
namespace {

// the InputError text of `fn`, or "" when it does not throw
template <typename Fn>
std::string ErrorOf(Fn&& fn) {
  try {
    fn();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const char* kDoc = R"(
patient:
  liver:
    young_modulus: 5500
    bad_number: abc
    flag: yes
    name: liver_2660
  markers:
    - [0.1, 0.2, 0.3]
    - [1, 2]
pose: {position: [1, 2, 3], rpy: [0, 0, 1.5707963267948966]}
seed: 42
negative: -3
)";

TEST(YamlReaderTest, ReadsTypedValuesAndKeepsDefaults) {
  const YamlReader root = YamlReader::LoadString(kDoc, "scenario.yaml");
  const YamlReader liver = root.Child("patient").Child("liver");
  EXPECT_EQ(liver.key_path(), "patient.liver");
  double E = 0, absent = 7.5;
  EXPECT_TRUE(liver.Read("young_modulus", &E));
  EXPECT_EQ(E, 5500.0);
  EXPECT_FALSE(liver.Read("poisson_ratio", &absent));
  EXPECT_EQ(absent, 7.5);  // default kept
  bool flag = false;
  EXPECT_TRUE(liver.Read("flag", &flag));
  EXPECT_TRUE(flag);
  std::string name;
  EXPECT_TRUE(liver.Read("name", &name));
  EXPECT_EQ(name, "liver_2660");
  uint64_t seed = 0;
  EXPECT_TRUE(root.Read("seed", &seed));
  EXPECT_EQ(seed, 42u);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  EXPECT_TRUE(root.Read("pose", &X));
  EXPECT_TRUE(X.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  // yaw pi/2 about z: x -> y
  EXPECT_TRUE((X.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
}

TEST(YamlReaderTest, ErrorsNameTheFileAndTheKeyPath) {
  const YamlReader root = YamlReader::LoadString(kDoc, "scenario.yaml");
  const YamlReader liver = root.Child("patient").Child("liver");
  double value = 0;
  EXPECT_EQ(ErrorOf([&] { liver.Read("bad_number", &value); }),
            "scenario.yaml: patient.liver.bad_number: expected a number, got 'abc'");
  EXPECT_EQ(ErrorOf([&] { liver.Child("missing_key"); }),
            "scenario.yaml: patient.liver.missing_key: missing");
  std::vector<Eigen::Vector3d> points;
  EXPECT_EQ(
      ErrorOf([&] { root.Child("patient").Read("markers", &points); }),
      "scenario.yaml: patient.markers[1]: expected a list of 3 numbers [x, y, z], got a list of 2");
  uint64_t seed = 0;
  EXPECT_EQ(ErrorOf([&] { root.Read("negative", &seed); }),
            "scenario.yaml: negative: expected a non-negative integer, got '-3'");
  int choice = 0;
  EXPECT_EQ(ErrorOf([&] {
              choice = liver.ReadChoice("name", {"rigid", "flexible"});
            }),
            "scenario.yaml: patient.liver.name: expected one of rigid, flexible, got 'liver_2660'");
  EXPECT_EQ(choice, 0);
}

TEST(YamlReaderTest, UnknownKeysAreCaught) {
  const YamlReader root = YamlReader::LoadString(kDoc, "scenario.yaml");
  const YamlReader liver = root.Child("patient").Child("liver");
  EXPECT_EQ(ErrorOf([&] { liver.CheckKeys({"young_modulus", "bad_number", "flag", "name"}); }), "");
  EXPECT_EQ(ErrorOf([&] {
              liver.CheckKeys({"young_modulus", "flag", "name"});
            }),
            "scenario.yaml: patient.liver.bad_number: unknown key (known keys: young_modulus, "
            "flag, name)");
}

TEST(YamlReaderTest, SyntaxErrorsGiveTheLine) {
  const std::string error =
      ErrorOf([] { YamlReader::LoadString("a: 1\nb: [1, 2\nc: 3\n", "broken.yaml"); });
  EXPECT_EQ(error.rfind("broken.yaml:", 0), 0u) << error;
  EXPECT_EQ(ErrorOf([] { YamlReader::LoadFile("/nonexistent/x.yaml"); }),
            "/nonexistent/x.yaml: cannot open the file");
}

TEST(YamlReaderTest, ValidateAsRenamesTheKey) {
  const std::string error = ErrorOf([] {
    ValidateAs([] { throw InputError("fem.young_modulus must be > 0 (Pa), got -3"); },
               "scenario.yaml", "fem.", "patient.liver.");
  });
  EXPECT_EQ(error, "scenario.yaml: patient.liver.young_modulus must be > 0 (Pa), got -3");
}

TEST(YamlReaderTest, DuplicateKeysAreErrorsNamingTheLineAndThePath) {
  // yaml-cpp alone keeps the first of two equal keys; the reader refuses the second
  EXPECT_EQ(ErrorOf([] { YamlReader::LoadString("a: 1\nb: 2\na: 3\n", "dup.yaml"); }),
            "dup.yaml:3: duplicate key a (first at line 1)");
  const char* nested =
      "patient:\n"
      "  liver:\n"
      "    young_modulus: 5500\n"
      "    density: 1060\n"
      "    young_modulus: 1\n";
  EXPECT_EQ(ErrorOf([&] { YamlReader::LoadString(nested, "s.yaml"); }),
            "s.yaml:5: duplicate key patient.liver.young_modulus (first at line 3)");
  // in a flow map, inside a list element
  EXPECT_EQ(ErrorOf([] {
              YamlReader::LoadString("ribs:\n  - {center: [0, 0, 0]}\n  - {center: 1, center: 2}\n",
                                     "f.yaml");
            }),
            "f.yaml:3: duplicate key ribs[1].center (first at line 3)");
  // a duplicated section (a map value) is caught too
  EXPECT_EQ(ErrorOf([] { YamlReader::LoadString("run:\n  a: 1\nrun:\n  b: 2\n", "r.yaml"); }),
            "r.yaml:3: duplicate key run (first at line 1)");
  // equal keys in different maps, and list elements that repeat, are fine
  EXPECT_EQ(ErrorOf([] {
              YamlReader::LoadString("a: {x: 1}\nb: {x: 1}\nc: [x, x]\nd: [{x: 1}, {x: 2}]\n",
                                     "ok.yaml");
            }),
            "");
  EXPECT_EQ(ErrorOf([] { YamlReader::LoadString(kDoc, "scenario.yaml"); }), "");
}

TEST(YamlReaderTest, DevicesAndDirectoriesAreRefusedAsScenarioFiles) {
  const std::string error = ErrorOf([] { YamlReader::LoadFile("/dev/zero"); });
  EXPECT_EQ(error.rfind("/dev/zero: expected a regular file", 0), 0u) << error;
  const std::string dir = ErrorOf([] { YamlReader::LoadFile("/tmp"); });
  EXPECT_EQ(dir.rfind("/tmp: expected a regular file", 0), 0u) << dir;
}

}  // namespace
}  // namespace nsim
