#pragma once
// The closed loop as two processes over DDS (configs/dds/local.xml) on the coarse scenario
// configs/scenarios/liver_test_coarse.yaml, for closed_loop_test and closed_loop_takeover_test: the
// scenario with absolute mesh paths, inverse_sim and direct_sim started on their own partition
// (more controllers can join it), their summaries and timeseries.csv, and waiting for a row of
// it. Every process is bounded in time and killed by PID.

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/integration/child_process.h"
#include "tests/integration/test_util.h"

namespace nsim::testing {

inline const std::string kBin = NSIM_BIN_DIR;
inline const std::string kSource = NSIM_SOURCE_DIR;
inline const std::string kDdsConfig = kSource + "/configs/dds/local.xml";

// liver_test_coarse.yaml with absolute mesh paths and the given edits, written into dir
inline std::filesystem::path WriteScenario(
    const std::filesystem::path& dir,
    const std::vector<std::pair<std::string, std::string>>& edits) {
  return WriteEditedScenario(dir, "scenario.yaml", "liver_test_coarse.yaml", edits);
}

// one closed-loop run: inverse_sim and direct_sim on their own partition
struct Loop {
  // A 3 s liveliness lease unless the extra options give one: a 0.5 s lease can expire on a
  // loaded 2-core machine (ctest -j2 next to a build) while both processes are alive.
  Loop(const std::filesystem::path& dir, const std::string& name,
       const std::filesystem::path& scenario, std::vector<std::string> direct_extra,
       std::vector<std::string> inverse_extra, const std::filesystem::path& inverse_scenario = {},
       int domain = 44)
      : out(dir / name) {
    std::filesystem::create_directories(out);
    dds = {"--dds-config", kDdsConfig,  "--domain", std::to_string(domain),
           "--partition",  name + "_" + std::to_string(getpid())};
    if (std::find(direct_extra.begin(), direct_extra.end(), "--lease") == direct_extra.end())
      direct_extra.insert(direct_extra.end(), {"--lease", "3"});
    inverse = StartController("inverse", inverse_scenario.empty() ? scenario : inverse_scenario,
                              inverse_extra);
    direct = std::make_unique<ChildProcess>(
        Cat(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(), "--out",
                 (out / "direct").string(), "--no-video", "--quiet"},
                direct_extra),
            dds),
        (out / "direct.log").string());
  }
  // an inverse_sim on this loop's partition, writing into out/<name> and out/<name>.log
  std::unique_ptr<ChildProcess> StartController(const std::string& name,
                                                const std::filesystem::path& scenario,
                                                std::vector<std::string> extra) const {
    if (std::find(extra.begin(), extra.end(), "--lease") == extra.end())
      extra.insert(extra.end(), {"--lease", "3"});
    return std::make_unique<ChildProcess>(
        Cat(Cat({kBin + "/inverse_sim", "run", "--config", scenario.string(), "--out",
                 (out / name).string(), "--timeout", "85", "--start-timeout", "30", "--quiet"},
                extra),
            dds),
        (out / (name + ".log")).string());
  }
  nlohmann::json DirectSummary() const {
    return nlohmann::json::parse(ReadText(out / "direct/summary.json"));
  }
  nlohmann::json InverseSummary(const std::string& name = "inverse") const {
    return nlohmann::json::parse(ReadText(out / name / "summary.json"));
  }
  // timeseries.csv: states only (wall-clock step times are in step_times.csv)
  std::string Timeseries() const { return ReadText(out / "direct/timeseries.csv"); }

  std::filesystem::path out;
  std::vector<std::string> dds;
  std::unique_ptr<ChildProcess> inverse, direct;
};

// rows of timeseries.csv as numbers (header skipped)
inline std::vector<std::vector<double>> ReadRows(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream s(line);
    std::string cell;
    while (std::getline(s, cell, ',')) row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

// Waits (at most timeout_s) until the last complete row of the csv that is being written
// satisfies `done`; returns whether it did.
inline bool WaitForRow(const std::filesystem::path& csv,
                       const std::function<bool(const std::vector<double>&)>& done,
                       double timeout_s = 60.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    std::string text = ReadText(csv);
    const size_t end_of_last = text.rfind('\n');
    if (end_of_last == std::string::npos || end_of_last == 0) continue;
    text.resize(end_of_last);
    const size_t start = text.rfind('\n');
    if (start == std::string::npos) continue;  // only the header so far
    std::vector<double> row;
    std::stringstream s(text.substr(start + 1));
    std::string cell;
    while (std::getline(s, cell, ',')) row.push_back(std::stod(cell));
    if (done(row)) return true;
  }
  return false;
}

// Waits (at most timeout_s) until the process's output contains `text`.
inline bool WaitForOutput(const ChildProcess& process, const std::string& text,
                          double timeout_s = 30.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (process.Output().find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

}  // namespace nsim::testing
