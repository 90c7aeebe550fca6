#pragma once
// What the controller side writes and reports: inverse.csv, one row per answered frame (the
// model's phase, path index, |e_p|, horizon, whether the markers were predicted, the model's
// tip, and the step timings), and the summary.json of inverse_sim: its rate, timings, frame
// counts and the online prediction score (nRMS per marker, thesis eq. 4.20, PredictionScore).

#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "common/core/line_file.h"
#include "common/steering/controller_loop.h"

namespace nsim {

/// Facts of a run that the controller loop does not know: how it was driven.
struct ControllerRunInfo {
  std::string scenario, mesh;   ///< the scenario file, the model's liver mesh
  uint64_t scenario_hash = 0;   ///< of its shared part
  bool lockstep = true;
  std::string transport = "dds";
  std::string ending = "direct_finished";
  uint64_t frames_received = 0, frames_missing = 0, frames_skipped = 0, frames_out_of_order = 0;
  /// times direct_sim's writers went not alive (it stalled, or this process did)
  uint64_t direct_losses = 0;
  double link_delay = 0.0;      ///< the emulated delay each way (s; inverse_sim --link-delay)
  TimingStat frame_to_target;   ///< wall time from the frame's sending to the target's (s)
  int domain = 0;
  std::string partition;
  std::string dds_identity;  ///< the DDS Security identity (--secure); empty: not secured
};

class ControllerRecorder {
 public:
  /// Opens DIR/inverse.csv (InputError naming the file when it cannot); each row is written
  /// whole with one write (common/core/line_file.h).
  explicit ControllerRecorder(const std::string& out_dir);

  /// The last answered frame of `loop` (its last_record()).
  void AddAnswer(const ControllerLoop& loop);

  nlohmann::json Summary(const ControllerLoop& loop, const ControllerRunInfo& info) const;
  /// Flushes and closes DIR/inverse.csv and writes Summary() to DIR/summary.json atomically.
  void WriteSummary(const ControllerLoop& loop, const ControllerRunInfo& info) const;

 private:
  std::string out_dir_;
  std::unique_ptr<LineFile> csv_;
};

}  // namespace nsim
