#pragma once
// Small helpers shared by the integration tests: a fresh temporary folder, reading a file,
// edited copies of a scenario, and building command lines.

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace nsim::testing {

/// Removes the folders of TempDir when the test that made them ends passed; a failed test's
/// are kept for inspection (and named on stderr).
class TempDirCleaner : public ::testing::EmptyTestEventListener {
 public:
  void Add(const std::filesystem::path& dir) { dirs_.push_back(dir); }

  void OnTestEnd(const ::testing::TestInfo& info) override {
    for (const std::filesystem::path& dir : dirs_) {
      if (info.result() != nullptr && info.result()->Passed()) {
        std::error_code ignored;
        std::filesystem::remove_all(dir, ignored);
      } else {
        std::fprintf(stderr, "kept %s (the test failed)\n", dir.c_str());
      }
    }
    dirs_.clear();
  }

 private:
  std::vector<std::filesystem::path> dirs_;
};

/// An empty folder <tmp>/nsim_<name>_<pid> (removed first if it exists), removed again when
/// the test ends passed, kept when it fails.
inline std::filesystem::path TempDir(const std::string& name) {
  // GoogleTest owns the listener once appended
  static TempDirCleaner* const cleaner = [] {
    auto* listener = new TempDirCleaner;
    ::testing::UnitTest::GetInstance()->listeners().Append(listener);
    return listener;
  }();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("nsim_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  cleaner->Add(dir);
  return dir;
}

/// The TempDir of the running test, <tmp>/nsim_<suite>_<test>_<pid>: made empty by the first
/// call in a test, the same folder for the later calls in it.
inline std::filesystem::path TestTempDir() {
  static std::string made_for;
  static std::filesystem::path dir;
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string key =
      info == nullptr ? "no_test" : std::string(info->test_suite_name()) + "_" + info->name();
  for (char& c : key) {
    if (c == '/') c = '_';
  }
  if (key != made_for) {
    dir = TempDir(key);
    made_for = key;
  }
  return dir;
}

/// The whole content of a text file ("" if it cannot be read).
inline std::string ReadText(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Writes dir/name: the scenario configs/scenarios/<scenario> with its mesh paths made absolute
/// and every occurrence of each edit's first string replaced by its second (an edit that
/// matches nothing is a test failure). Returns the path.
inline std::filesystem::path WriteEditedScenario(
    const std::filesystem::path& dir, const std::string& name, const std::string& scenario,
    const std::vector<std::pair<std::string, std::string>>& edits) {
  std::string text = ReadText(NSIM_SOURCE_DIR "/configs/scenarios/" + scenario);
  auto replace_all = [&](const std::string& from, const std::string& to) {
    size_t at = 0, count = 0;
    while ((at = text.find(from, at)) != std::string::npos) {
      text.replace(at, from.size(), to);
      at += to.size();
      ++count;
    }
    return count;
  };
  EXPECT_GE(replace_all("../meshes/", NSIM_SOURCE_DIR "/configs/meshes/"), 2u) << scenario;
  for (const auto& [from, to] : edits) EXPECT_GE(replace_all(from, to), 1u) << from;
  const std::filesystem::path path = dir / name;
  std::ofstream(path) << text;
  return path;
}

/// a followed by b.
inline std::vector<std::string> Cat(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

/// The DDS options of a test: the loopback configuration, a domain and a partition.
inline std::vector<std::string> DdsArgs(int domain, const std::string& partition) {
  return {"--dds-config", NSIM_SOURCE_DIR "/configs/dds/local.xml",
          "--domain",     std::to_string(domain),
          "--partition",  partition};
}

}  // namespace nsim::testing
