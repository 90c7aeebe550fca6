#pragma once
// Who may move the robot, and whether it is still there (direct_sim's side of DESIGN.md "one
// controller owns the robot"): the owner is the process whose running status opened the run
// (bound at the start handshake; a controller that sends no status is bound by its first
// target), and a target of any other process is rejected and counted by writer before it
// reaches the gate. The owner's liveliness is watched, writer by writer (another process's
// writers do not keep it alive):
//   - owned: the owner is alive; a controller that says "running" now is refused (counted);
//   - lost: its lease expired; the robot holds (in lockstep the insertion waits). An owner that
//     comes back (it was stalled: alive again, or a target of it) owns the robot again; a NEW
//     controller that publishes a running status with this scenario's hash takes over (a
//     re-handshake): it becomes the owner, the old owner's last command and pending answers
//     are dropped, and from then on the old owner's targets are foreign;
//   - taking over: the new owner catches up (in lockstep it answers the frames it missed, or
//     its model catches up from the newest); the robot holds until it is served: in lockstep
//     when its answers let the waiting step go on (Served), in realtime at its first target;
//   - given up: lost, or taking over, for longer than run.takeover_timeout; the robot holds to
//     the end.
// A process that never says "running" (an injector) never takes the robot.

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "common/results/patient_recorder.h"
#include "common/scene/lockstep_targets.h"
#include "common/scene/patient_loop.h"
#include "direct_sim/scenario_loader.h"
#include "messages/transport.h"

namespace nsim {

class ControllerWatch {
 public:
  enum class State { kOwned, kLost, kTakingOver, kGivenUp };

  /// `statuses` is the controller's status stream (read after the start handshake); `lockstep`
  /// the pump's pending answers (null in realtime); `report` publishes a status message.
  ControllerWatch(transport::Reader<RobotTarget>& targets, transport::Reader<SimStatus>& statuses,
                  PatientLoop& loop, LockstepTargets* lockstep, const RunConfig& run,
                  uint64_t scenario_hash, PatientRunInfo& info,
                  std::function<void(const std::string&)> report);

  /// Polls the target reader's health; every poll of it must go through here (the liveliness
  /// changes it reports are tracked per writer).
  const transport::ReaderHealth& Poll();
  /// Binds the owner found at the start handshake (ParticipantId; 0: none, bound by the first
  /// target).
  void Bind(uint64_t participant);
  /// True when the target's writer belongs to the owner (a lost owner is then back; in
  /// realtime a taking-over owner is served); false counts and reports a foreign target. While
  /// the owner is lost, a target of a controller that said "running" (refused before, the owner
  /// alive then) makes it take over. The last foreign targets of each process are kept: in
  /// lockstep a new owner's answers that came before its takeover are handed to the pending
  /// answers at the takeover (it would not answer those frames again).
  bool FromOwner(uint64_t writer, const RobotTarget& target);
  /// Polls the owner's liveliness and the controllers' statuses: loss, comeback, takeover,
  /// refusal, or the loss made final.
  void Check();
  /// Lockstep: the waiting step has the owner's answer; a takeover is complete.
  void Served();
  /// Counts a target the robot carried out (PatientRecorder's rule: a held one once).
  void NoteApplied(uint64_t applied_seq);

  State state() const { return state_; }
  /// The robot holds and the lockstep insertion waits (lost or taking over).
  bool waiting() const { return state_ == State::kLost || state_ == State::kTakingOver; }
  bool taking_over() const { return state_ == State::kTakingOver; }
  bool given_up() const { return state_ == State::kGivenUp; }

 private:
  struct WriterInfo {
    uint64_t participant = 0;
    bool alive = true;
  };
  uint64_t ParticipantOf(uint64_t writer);
  // the matched writers now (new ones alive, unmatched ones dropped)
  void RefreshWriters();
  bool OwnerAlive() const;
  // a new owner, recorded
  void SetOwner(uint64_t participant);
  void ReadStatuses();
  void Lose(const transport::ReaderHealth& health);
  void Regain();
  void TakeOver(uint64_t participant);
  void Resume();
  void GiveUp(const std::string& message);

  transport::Reader<RobotTarget>& targets_;
  transport::Reader<SimStatus>& statuses_;
  PatientLoop& loop_;
  LockstepTargets* lockstep_;
  const RunConfig& run_;
  uint64_t scenario_hash_;
  PatientRunInfo& info_;
  std::function<void(const std::string&)> report_;
  transport::ReaderHealth health_;
  State state_ = State::kOwned;
  uint64_t owner_ = 0;
  std::map<uint64_t, WriterInfo> writers_;       // matched target writers
  std::map<uint64_t, uint64_t> participant_of_;  // every writer seen -> its participant
  std::set<uint64_t> refused_;                   // controllers refused (participants)
  std::set<uint64_t> standby_;  // refused only because the owner was alive: may take over
  std::map<uint64_t, std::map<uint64_t, RobotTarget>> foreign_;  // participant -> last targets
  std::vector<SimStatus> status_buffer_;
  std::vector<uint64_t> status_writers_;
  bool seen_alive_ = false;
  double since_ = 0.0;  // monotonic time of the loss, or of the takeover (s)
  uint64_t last_applied_ = SensorFrame::kNoTarget;
};

}  // namespace nsim
