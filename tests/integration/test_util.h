#pragma once
// Small helpers shared by the integration tests: a fresh temporary folder, reading a file,
// and building command lines.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace nsim::testing {

/// An empty folder <tmp>/nsim_<name>_<pid> (removed first if it exists).
inline std::filesystem::path TempDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("nsim_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// The whole content of a text file ("" if it cannot be read).
inline std::string ReadText(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
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
