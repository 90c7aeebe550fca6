#include "direct_sim/controller_watch.h"

#include <iostream>

#include "common/core/clock.h"
#include "common/core/error.h"

namespace nsim {

ControllerWatch::ControllerWatch(transport::Reader<RobotTarget>& targets, PatientLoop& loop,
                                 const RunConfig& run, PatientRunInfo& info,
                                 std::function<void(const std::string&)> report)
    : targets_(targets), loop_(loop), run_(run), info_(info), report_(std::move(report)) {}

bool ControllerWatch::FromOwner(uint64_t writer) {
  auto it = writer_participant_.find(writer);
  if (it == writer_participant_.end())
    it = writer_participant_.emplace(writer, targets_.ParticipantOfWriter(writer)).first;
  if (owner_ == 0 && it->second != 0) owner_ = it->second;
  if (it->second != 0 && it->second == owner_) {
    if (lost_ && !given_up_) Regain();  // its target: the owner is alive
    return true;
  }
  ++info_.foreign_targets;
  ++info_.foreign_by_writer[Str(std::hex, writer)];
  if (info_.foreign_targets == 1)
    std::cerr << "direct_sim run: rejecting targets from a process that does not own the robot "
                 "(writer "
              << std::hex << writer << std::dec << ")\n";
  return false;
}

void ControllerWatch::Check() {
  if (given_up_) return;
  const transport::ReaderHealth health = targets_.health();
  const bool alive = health.writers_alive > 0;
  if (alive) seen_alive_ = true;
  const double now = MonotonicSeconds();
  if (!lost_ && seen_alive_ && !alive) {
    lost_ = true;
    lost_at_ = now;
    ++info_.controller_losses;
    if (!info_.controller_lost_time) info_.controller_lost_time = loop_.time();
    loop_.set_controller_lost(true);
    const std::string message = health.liveliness_lost > 0
                                    ? "inverse_sim lost (liveliness lease expired); robot holds"
                                    : "inverse_sim left; robot holds";
    std::cerr << "direct_sim run: " << message << " at t = " << loop_.time() << " s\n";
    report_(message);
  } else if (lost_ && alive) {
    Regain();
  } else if (lost_ && now - lost_at_ > run_.takeover_timeout) {
    given_up_ = true;
    const std::string message = "inverse_sim did not come back; robot holds to the end";
    std::cerr << "direct_sim run: " << message << "\n";
    report_(message);
  }
}

void ControllerWatch::Regain() {
  lost_ = false;
  ++info_.controller_returns;
  loop_.set_controller_lost(false);
  const std::string message = "inverse_sim back; it owns the robot again";
  std::cerr << "direct_sim run: " << message << " at t = " << loop_.time() << " s (after "
            << MonotonicSeconds() - lost_at_ << " s)\n";
  report_(message);
}

}  // namespace nsim
