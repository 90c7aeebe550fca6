// ReadInputFile: a regular file is read whole; a device, a fifo, a directory, a missing or an
// oversized file is an InputError naming the path, and nothing blocks or grows without bound.
#include "common/core/input_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "common/core/error.h"

namespace nsim {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("input_file_test_" + std::to_string(getpid()) + "_" + name))
      .string();
}

std::string ErrorOf(const std::string& path, uint64_t max_bytes = kMaxInputFileBytes) {
  try {
    ReadInputFile(path, "test file", max_bytes);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(InputFileTest, ReadsARegularFileWhole) {
  const std::string path = TempPath("ok.txt");
  std::ofstream(path) << "line 1\nline 2\n";
  EXPECT_EQ(ReadInputFile(path, "test file"), "line 1\nline 2\n");
  std::ofstream(path, std::ios::trunc).close();
  EXPECT_EQ(ReadInputFile(path, "test file"), "");
  std::filesystem::remove(path);
}

TEST(InputFileTest, RefusesDevicesFifosAndDirectoriesWithThePathNamed) {
  const std::string zero = ErrorOf("/dev/zero");
  EXPECT_NE(zero.find("/dev/zero: expected a regular file as the test file, got a character "
                      "device"),
            std::string::npos)
      << zero;
  const std::string dir = TempPath("dir");
  std::filesystem::create_directory(dir);
  const std::string dir_error = ErrorOf(dir);
  EXPECT_NE(dir_error.find(dir + ":"), std::string::npos) << dir_error;
  EXPECT_NE(dir_error.find("a directory"), std::string::npos) << dir_error;
  std::filesystem::remove(dir);
  // a fifo without a writer: refused at once, not waited on
  const std::string fifo = TempPath("fifo");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string fifo_error = ErrorOf(fifo);
  EXPECT_NE(fifo_error.find(fifo + ": expected a regular file"), std::string::npos) << fifo_error;
  EXPECT_NE(fifo_error.find("a fifo"), std::string::npos) << fifo_error;
  std::filesystem::remove(fifo);
}

TEST(InputFileTest, RefusesMissingAndOversizedFiles) {
  const std::string missing = TempPath("missing.txt");
  const std::string error = ErrorOf(missing);
  EXPECT_EQ(error, missing + ": cannot open the test file");
  const std::string big = TempPath("big.txt");
  std::ofstream(big) << std::string(100, 'x');
  EXPECT_EQ(ReadInputFile(big, "test file", 100).size(), 100u);
  const std::string too_big = ErrorOf(big, 99);
  EXPECT_NE(too_big.find(big + ": the test file is 100 bytes, more than the limit of 99"),
            std::string::npos)
      << too_big;
  std::filesystem::remove(big);
  EXPECT_NE(ErrorOf("").find("empty path"), std::string::npos);
}

}  // namespace
}  // namespace nsim
