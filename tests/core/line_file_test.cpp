// LineFile: rows go to <path>.partial whole, and replace an earlier <path> only on Commit().
#include "common/core/line_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace nsim {
namespace {

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(LineFileTest, AnEarlierFileSurvivesUntilCommit) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("line_file_test_" + std::to_string(getpid()) + ".csv"))
                               .string();
  std::ofstream(path) << "old,run\n1,2\n";
  {
    LineFile file(path);
    file.WriteLine("a,b");
    file.WriteLine("3,4");
    // a run killed here: the earlier file intact, this run's rows whole in the partial file
    EXPECT_EQ(ReadAll(path), "old,run\n1,2\n");
    EXPECT_EQ(ReadAll(file.partial_path()), "a,b\n3,4\n");
  }
  // destroyed without Commit (a failed run): still the earlier file
  EXPECT_EQ(ReadAll(path), "old,run\n1,2\n");
  {
    LineFile file(path);
    file.WriteLine("a,b");
    file.Commit();
    file.Commit();  // idempotent
    EXPECT_THROW(file.WriteLine("late"), std::runtime_error);
  }
  EXPECT_EQ(ReadAll(path), "a,b\n");
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  std::filesystem::remove(path);
}

TEST(LineFileTest, AnUnwritablePathIsAnInputErrorNamingIt) {
  try {
    LineFile file("/nonexistent/dir/x.csv");
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/x.csv.partial: cannot open for writing"),
              std::string::npos)
        << e.what();
  }
}

TEST(LineFileTest, InPlaceRowsAreReadableWhileWriting) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("line_file_in_place_" + std::to_string(getpid()) + ".csv"))
                               .string();
  LineFile file(path, LineFile::Mode::kInPlace);
  file.WriteLine("a,b");
  EXPECT_EQ(ReadAll(path), "a,b\n");  // no buffer: a reader (or a kill) sees whole rows
  file.WriteLine("1,2");
  EXPECT_EQ(ReadAll(path), "a,b\n1,2\n");
  file.Commit();
  EXPECT_EQ(ReadAll(path), "a,b\n1,2\n");
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace nsim
