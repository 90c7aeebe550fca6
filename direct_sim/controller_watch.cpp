#include "direct_sim/controller_watch.h"

#include <iostream>

#include "common/core/clock.h"
#include "common/core/error.h"

namespace nsim {

ControllerWatch::ControllerWatch(transport::Reader<RobotTarget>& targets,
                                 transport::Reader<SimStatus>& statuses, PatientLoop& loop,
                                 LockstepTargets* lockstep, const RunConfig& run,
                                 uint64_t scenario_hash, PatientRunInfo& info,
                                 std::function<void(const std::string&)> report)
    : targets_(targets),
      statuses_(statuses),
      loop_(loop),
      lockstep_(lockstep),
      run_(run),
      scenario_hash_(scenario_hash),
      info_(info),
      report_(std::move(report)) {}

uint64_t ControllerWatch::ParticipantOf(uint64_t writer) {
  auto it = participant_of_.find(writer);
  if (it != participant_of_.end()) return it->second;
  const uint64_t participant = targets_.ParticipantOfWriter(writer);
  if (participant != 0) participant_of_.emplace(writer, participant);  // else: not matched yet
  return participant;
}

void ControllerWatch::RefreshWriters() {
  std::map<uint64_t, WriterInfo> now;
  for (const uint64_t w : targets_.MatchedWriters()) {
    const auto it = writers_.find(w);
    now[w] = it != writers_.end() ? it->second : WriterInfo{ParticipantOf(w), true};
  }
  writers_.swap(now);
}

const transport::ReaderHealth& ControllerWatch::Poll() {
  health_ = targets_.health();
  if (health_.alive_change == 0 && health_.not_alive_change == 0) return health_;
  RefreshWriters();
  // one writer changed since the last poll: it is the last one; several: the counts settle
  // the cases where all are alive or none is, else the last one's change is applied
  const int alive = health_.writers_alive;
  if (alive == 0 || alive == static_cast<int>(writers_.size())) {
    for (auto& [w, info] : writers_) info.alive = alive > 0;
  } else if (auto it = writers_.find(health_.last_changed_writer); it != writers_.end()) {
    it->second.alive = health_.alive_change > 0;
  }
  return health_;
}

bool ControllerWatch::OwnerAlive() const {
  if (owner_ == 0) return false;
  for (const auto& [w, info] : writers_)
    if (info.participant == owner_ && info.alive) return true;
  return false;
}

void ControllerWatch::SetOwner(uint64_t participant) {
  owner_ = participant;
  info_.owners.push_back({Str(std::hex, participant), loop_.time(), 0});
  last_applied_ = SensorFrame::kNoTarget;
}

void ControllerWatch::Bind(uint64_t participant) {
  if (participant == 0) return;
  SetOwner(participant);
  RefreshWriters();
  seen_alive_ = OwnerAlive();
}

namespace {
constexpr size_t kForeignKept = 16;  // last foreign targets kept per process
}  // namespace

bool ControllerWatch::FromOwner(uint64_t writer, const RobotTarget& target) {
  const uint64_t participant = ParticipantOf(writer);
  if (auto it = writers_.find(writer); it != writers_.end()) it->second.alive = true;  // it wrote
  if (owner_ == 0 && participant != 0 && state_ == State::kOwned) {
    SetOwner(participant);  // a controller without a status: bound by its first target
    seen_alive_ = true;
  }
  // a new controller's target may come before its running status is read; a controller
  // refused while the owner was alive is one already
  if (participant != 0 && participant != owner_ && state_ == State::kLost) {
    if (standby_.count(participant))
      TakeOver(participant);
    else
      ReadStatuses();
  }
  if (participant != 0 && participant == owner_) {
    if (state_ == State::kLost)
      Regain();  // its target: the owner is alive
    else if (state_ == State::kTakingOver && !lockstep_)
      Resume();  // realtime: its first target is the newest it could compute
    return true;
  }
  if (participant != 0) {
    std::map<uint64_t, RobotTarget>& kept = foreign_[participant];
    kept[target.answers_seq] = target;
    if (kept.size() > kForeignKept) kept.erase(kept.begin());
  }
  ++info_.foreign_targets;
  ++info_.foreign_by_writer[Str(std::hex, writer)];
  if (info_.foreign_targets == 1)
    std::cerr << "direct_sim run: rejecting targets from a process that does not own the robot "
                 "(writer "
              << std::hex << writer << std::dec << ")\n";
  return false;
}

void ControllerWatch::ReadStatuses() {
  status_buffer_.clear();
  status_writers_.clear();
  statuses_.Take(status_buffer_, &status_writers_);
  for (size_t i = 0; i < status_buffer_.size(); ++i) {
    const SimStatus& s = status_buffer_[i];
    if (s.sender == "direct_sim" || s.state != RunState::kRunning) continue;
    const uint64_t participant = statuses_.ParticipantOfWriter(status_writers_[i]);
    if (participant == 0 || participant == owner_) continue;
    if (s.scenario_hash != scenario_hash_) {
      if (refused_.insert(participant).second) {
        ++info_.refused_controllers;
        std::cerr << "direct_sim run: a controller (participant " << std::hex << participant
                  << ") runs another scenario (shared-part hash " << s.scenario_hash << ", ours "
                  << scenario_hash_ << std::dec << "): it cannot take the robot\n";
      }
      continue;
    }
    if (state_ == State::kLost) {
      TakeOver(participant);
      continue;
    }
    standby_.insert(participant);
    if (refused_.insert(participant).second) {
      ++info_.refused_controllers;
      const std::string message = Str("a second controller (participant ", std::hex, participant,
                                      std::dec, ") is running; refused: the robot's owner is ",
                                      state_ == State::kTakingOver ? "taking over" : "alive");
      std::cerr << "direct_sim run: " << message << " at t = " << loop_.time() << " s\n";
      report_(message);
    }
  }
}

void ControllerWatch::Check() {
  if (state_ == State::kGivenUp) return;
  Poll();
  ReadStatuses();
  const bool alive = OwnerAlive();
  if (alive) seen_alive_ = true;
  const double now = MonotonicSeconds();
  switch (state_) {
    case State::kOwned:
      if (seen_alive_ && !alive) Lose(health_);
      break;
    case State::kLost:
      if (alive)
        Regain();
      else if (now - since_ > run_.takeover_timeout)
        GiveUp("inverse_sim did not come back; robot holds to the end");
      break;
    case State::kTakingOver:
      if (seen_alive_ && !alive)
        Lose(health_);  // the new owner is gone too
      else if (now - since_ > run_.takeover_timeout)
        GiveUp(
            "the new controller did not catch up within run.takeover_timeout; robot holds "
            "to the end");
      break;
    case State::kGivenUp:
      break;
  }
}

void ControllerWatch::Lose(const transport::ReaderHealth& health) {
  state_ = State::kLost;
  since_ = MonotonicSeconds();
  ++info_.controller_losses;
  if (!info_.controller_lost_time) info_.controller_lost_time = loop_.time();
  loop_.set_controller_lost(true);
  const std::string message = health.liveliness_lost > 0
                                  ? "inverse_sim lost (liveliness lease expired); robot holds"
                                  : "inverse_sim left; robot holds";
  std::cerr << "direct_sim run: " << message << " at t = " << loop_.time() << " s\n";
  report_(message);
}

void ControllerWatch::Regain() {
  state_ = State::kOwned;
  ++info_.controller_returns;
  loop_.set_controller_lost(false);
  const std::string message = "inverse_sim back; it owns the robot again";
  std::cerr << "direct_sim run: " << message << " at t = " << loop_.time() << " s (after "
            << MonotonicSeconds() - since_ << " s)\n";
  report_(message);
}

void ControllerWatch::TakeOver(uint64_t participant) {
  const uint64_t old = owner_;
  SetOwner(participant);
  ++info_.takeovers;
  const double lost_for = MonotonicSeconds() - since_;
  state_ = State::kTakingOver;
  since_ = MonotonicSeconds();
  // the old owner's last command and its answers not yet applied are not the new owner's
  loop_.DropCommand();
  if (lockstep_) {
    lockstep_->Clear();
    // its answers that came before (foreign then): the frames it will not answer again
    for (const auto& [seq, target] : foreign_[participant]) lockstep_->Add(target);
  }
  foreign_.erase(participant);
  standby_.erase(participant);
  loop_.set_controller_lost(true);  // the robot holds until the new owner is served
  RefreshWriters();
  seen_alive_ = OwnerAlive();
  const std::string message = Str("a new controller (participant ", std::hex, participant,
                                  ") takes over the robot from ", old, std::dec, "; robot holds");
  std::cerr << "direct_sim run: " << message << " at t = " << loop_.time() << " s (lost for "
            << lost_for << " s)\n";
  report_(message);
}

void ControllerWatch::Resume() {
  state_ = State::kOwned;
  loop_.set_controller_lost(false);
  const std::string message = "the new controller owns the robot";
  std::cerr << "direct_sim run: " << message << " at t = " << loop_.time() << " s (caught up in "
            << MonotonicSeconds() - since_ << " s)\n";
  report_(message);
}

void ControllerWatch::Served() {
  if (state_ == State::kTakingOver) Resume();
}

void ControllerWatch::GiveUp(const std::string& message) {
  state_ = State::kGivenUp;
  std::cerr << "direct_sim run: " << message << "\n";
  report_(message);
}

void ControllerWatch::NoteApplied(uint64_t applied_seq) {
  if (applied_seq != SensorFrame::kNoTarget && applied_seq != last_applied_ &&
      !info_.owners.empty())
    ++info_.owners.back().targets_applied;
  last_applied_ = applied_seq;
}

}  // namespace nsim
