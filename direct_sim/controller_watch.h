#pragma once
// Who may move the robot, and whether it is still there (direct_sim's side of DESIGN.md "one
// controller owns the robot"): the owner is the process whose running status opened the run
// (bound at the start handshake; a controller that sends no status is bound by its first
// target), and a target of any other process is rejected and counted by writer before it
// reaches the gate. The owner's liveliness is watched: a loss makes the robot hold; an owner
// that comes back within run.takeover_timeout (it was stalled, not killed) owns the robot
// again; after that the loss is final.

#include <cstdint>
#include <functional>
#include <map>
#include <string>

#include "common/results/patient_recorder.h"
#include "common/scene/patient_loop.h"
#include "direct_sim/scenario_loader.h"
#include "messages/transport.h"

namespace nsim {

class ControllerWatch {
 public:
  /// `report` publishes a status message (the pump's SimStatus).
  ControllerWatch(transport::Reader<RobotTarget>& targets, PatientLoop& loop, const RunConfig& run,
                  PatientRunInfo& info, std::function<void(const std::string&)> report);

  /// The owner's ParticipantId (transport::ParticipantId), e.g. from the handshake.
  uint64_t* owner() { return &owner_; }
  /// True when the target's writer belongs to the owner (then a lost owner is back); false
  /// counts and reports a foreign target.
  bool FromOwner(uint64_t writer);
  /// Polls the owner's liveliness: loss, comeback, or the loss made final.
  void Check();

  bool lost() const { return lost_; }
  bool given_up() const { return given_up_; }

 private:
  void Regain();

  transport::Reader<RobotTarget>& targets_;
  PatientLoop& loop_;
  const RunConfig& run_;
  PatientRunInfo& info_;
  std::function<void(const std::string&)> report_;
  uint64_t owner_ = 0;
  std::map<uint64_t, uint64_t> writer_participant_;  // writer -> its participant
  bool seen_alive_ = false, lost_ = false, given_up_ = false;
  double lost_at_ = 0.0;  // monotonic time of the current loss (s)
};

}  // namespace nsim
