#include "direct_sim/dds_patient.h"

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/core/thread_priority.h"
#include "common/scene/lockstep_targets.h"
#include "direct_sim/controller_watch.h"
#include "direct_sim/ros2_wait.h"

namespace nsim {
namespace {

// longest wait for a controller's "running" status once its readers and writer are matched,
// and for its acknowledgement of frame 0 (s)
constexpr double kPeerSettle_s = 2.0;

class PatientPump {
 public:
  PatientPump(PatientLoop& loop, PatientOutputs& outputs, const RunConfig& run,
              const transport::TransportConfig& transport,
              const std::optional<transport::Ros2Config>& ros2, uint64_t scenario_hash, bool quiet,
              PatientRunInfo* info)
      : loop_(loop),
        outputs_(outputs),
        run_(run),
        quiet_(quiet),
        info_(*info),
        participant_(transport),
        // lockstep: every frame is kept until acknowledged (frame k + 1 is written before
        // frame k is acknowledged; with keep-last 1 a frame lost on the wire could not be
        // resent); realtime: only the newest state matters
        frames_(participant_, run.mode == RunMode::kLockstep ? transport::Qos::kLossless
                                                             : transport::Qos::kStateStream),
        status_out_(participant_, transport::Qos::kStatus),
        delay_(run.latency_steps) {
    if (loop.config().controller) {
      // lockstep: every answer is kept until taken (the controller may answer frame k - 1
      // before this process took the answer to k - 2)
      targets_ = std::make_unique<transport::Reader<RobotTarget>>(
          participant_,
          run.mode == RunMode::kLockstep ? transport::Qos::kLossless : transport::Qos::kTarget);
      status_in_ =
          std::make_unique<transport::Reader<SimStatus>>(participant_, transport::Qos::kStatus);
      watch_ = std::make_unique<ControllerWatch>(
          *targets_, *status_in_, loop_, run.mode == RunMode::kLockstep ? &delay_ : nullptr, run_,
          scenario_hash, info_, [this](const std::string& message) {
            message_ = message;
            PublishStatus(RunState::kRunning, message_);
          });
    }
    if (ros2) {
      transport::Ros2MirrorTopics topics;
      topics.frames = topics.distance = true;
      mirror_ = std::make_unique<transport::Ros2Mirror>(*ros2, topics);
      ros2_wait_ = ros2->wait_subscribers;
    }
    status_.sender = "direct_sim";
    status_.scenario_hash = scenario_hash;
  }

  int Run() {
    const bool controller = loop_.config().controller;
    PublishStatus(RunState::kStarting, controller ? "waiting for the controller" : "no controller");
    if (controller) {
      if (const int code = Handshake(); code != 0) {
        info_.exit = code == 2 ? "scenario_mismatch" : "no_controller";
        PublishStatus(RunState::kFailed, info_.exit);
        status_out_.WaitForAcks(1.0);
        return code;
      }
    }
    if (mirror_ && !WaitForRos2Subscribers(*mirror_, ros2_wait_, Ros2FrameTopics(),
                                           run_.start_timeout, kPeerSettle_s, "direct_sim run")) {
      info_.exit = "no_ros2_subscriber";
      PublishStatus(RunState::kFailed, info_.exit);
      status_out_.WaitForAcks(1.0);
      return 1;
    }
    PublishStatus(RunState::kRunning, "running");
    // the loop's thread in the realtime class for the steps (run.rt_priority); the DDS threads
    // and the liver's refresh worker, started before, keep theirs
    const FifoScope fifo(run_.mode == RunMode::kRealtime ? run_.rt_priority : 0);
    if (!fifo.error().empty())
      std::cerr << "direct_sim run: run.rt_priority: " << fifo.error()
                << "; the loop runs in the normal class\n";
    info_.loop_class = ThisThreadPolicyName();
    const int64_t steps = StepCount();
    const double start = MonotonicSeconds();
    double next_status = start + run_.status_period;
    for (int64_t k = 0; k < steps && info_.exit == "completed"; ++k) {
      if (InterruptRequested()) {
        info_.exit = "interrupted";
        break;
      }
      if (!PublishFrame()) break;
      if (k == 0 && controller) frames_.WaitForAcks(kPeerSettle_s);
      if (!StepOnce(k)) break;
      loop_.Prefetch();  // the frame of this step goes out at the next period: this is off it
      outputs_.OnStep(loop_, steps);
      if (const double now = MonotonicSeconds(); now >= next_status) {
        PublishStatus(RunState::kRunning, message_);
        next_status = now + run_.status_period;
      }
      if (run_.mode == RunMode::kRealtime)
        SleepUntilMonotonic(start + (k + 1) * loop_.config().scene.time_step);
    }
    if (info_.exit == "completed") PublishFrame();  // the final state
    if (info_.exit == "completed" && watch_ && (watch_->given_up() || watch_->waiting()))
      info_.exit = "controller_lost";
    info_.wall_time = MonotonicSeconds() - start;
    const bool ok = info_.exit == "completed";
    PublishStatus(ok ? RunState::kFinished : RunState::kFailed, ok ? "finished" : info_.exit);
    frames_.WaitForAcks(2.0);
    status_out_.WaitForAcks(2.0);
    if (mirror_) mirror_->WaitForAcks(1.0);
    if (targets_) info_.transport_invalid = targets_->health().invalid;
    return ok ? 0 : 1;
  }

 private:
  // the ROS 2 topics of every frame (the entry point comes later, after the puncture)
  std::vector<const char*> Ros2FrameTopics() const {
    namespace topic = transport::ros2_topic;
    std::vector<const char*> topics = {topic::kMarkers, topic::kRobotPose, topic::kTipToTarget};
    if (!loop_.frame().q.empty()) topics.push_back(topic::kJointStates);
    return topics;
  }

  int64_t StepCount() const {
    return static_cast<int64_t>(std::llround(run_.duration / loop_.config().scene.time_step));
  }

  // The controller reads our frames and we its targets, then its "running" status: its reader
  // knows our writer, so frame 0 is not dropped. A controller that never says so (not
  // inverse_sim) gets kPeerSettle_s. 0 ready, 1 no controller, 2 another scenario.
  int Handshake() {
    const double end = MonotonicSeconds() + run_.start_timeout;
    bool matched = frames_.WaitForReaders(1, run_.start_timeout);
    while (matched && watch_->Poll().writers_matched == 0) {
      if (MonotonicSeconds() > end || InterruptRequested())
        matched = false;
      else
        targets_->Wait(0.05);
    }
    if (!matched) {
      std::cerr << "direct_sim run: no controller (SensorFrame reader and RobotTarget writer) "
                   "after "
                << run_.start_timeout
                << " s (is inverse_sim running with the same --domain, --partition and DDS "
                   "config? use --no-controller to run the scene alone)\n";
      return 1;
    }
    uint64_t owner = 0;
    const std::optional<SimStatus> peer =
        transport::WaitForPeerRunning(*status_in_, "direct_sim", kPeerSettle_s, &owner);
    if (!peer) {
      if (!quiet_)
        std::printf("run: the controller sent no running status; starting after %.1f s\n",
                    kPeerSettle_s);
      return 0;
    }
    if (peer->state == RunState::kFailed && peer->scenario_hash == status_.scenario_hash) {
      std::cerr << "direct_sim run: the controller failed before the start: " << peer->message
                << "\n";
      return 1;
    }
    if (peer->scenario_hash != 0 && peer->scenario_hash != status_.scenario_hash) {
      std::cerr << "direct_sim run: the controller runs another scenario (shared-part hash "
                << std::hex << peer->scenario_hash << ", ours " << status_.scenario_hash << std::dec
                << "): give both processes the same shared: section\n";
      return 2;
    }
    watch_->Bind(owner);
    return 0;
  }

  void PublishStatus(RunState state, const std::string& message) {
    status_.state = state;
    status_.message = message.substr(0, 255);
    status_.stamp.sim_time = loop_.time();
    status_.phase = static_cast<uint8_t>(loop_.record().phase);
    status_.frames_sent = frames_sent_;
    status_.last_seq = frames_sent_ > 0 ? frames_sent_ - 1 : 0;
    const double median = outputs_.recorder().median_step_ms();
    status_.rate_hz = median > 0 ? 1e3 / median : 0.0;
    status_out_.Write(status_);
    status_.stamp.seq++;
  }

  // publishes the loop's current frame and logs it; false when the state is not plausible
  bool PublishFrame() {
    if (!loop_.healthy()) {
      ReportFault(loop_, &info_);
      return false;
    }
    const SensorFrame& frame = loop_.frame();
    frames_.Write(frame);
    if (mirror_) {
      mirror_->PublishFrame(frame);
      mirror_->PublishDistance(loop_.record().distance);  // the truth of the same state
    }
    if (sent_at_.size() <= frame.stamp.seq) sent_at_.resize(frame.stamp.seq + 1, 0.0);
    sent_at_[frame.stamp.seq] = MonotonicSeconds();
    frames_sent_ = frame.stamp.seq + 1;
    outputs_.OnFrame(loop_);
    return true;
  }

  // takes the targets that arrived; notes the loop latency (frame sent -> answer received)
  void TakeTargets() {
    received_.clear();
    writers_.clear();
    targets_->Take(received_, &writers_);
    for (size_t i = 0; i < received_.size(); ++i) {
      const RobotTarget& r = received_[i];
      // a new owner's answers while it catches up (the frames it missed) are no loop latency
      const bool catching_up = watch_->taking_over();
      if (!watch_->FromOwner(writers_[i], r)) continue;
      if (!catching_up && r.answers_seq < sent_at_.size() && sent_at_[r.answers_seq] > 0)
        info_.latency_ms.push_back(1e3 * (MonotonicSeconds() - sent_at_[r.answers_seq]));
      if (run_.mode == RunMode::kLockstep) {
        delay_.Add(r);
      } else {
        const GateDecision d = loop_.Receive(r);
        if (d.reason != GateReason::kCount) message_ = d.detail;
      }
    }
  }

  // the step from frame k: the targets it applies, then the physics; false on a failure
  bool StepOnce(int64_t k) {
    std::optional<RobotTarget> target;
    if (targets_) {
      watch_->Check();
      TakeTargets();
      if (run_.mode == RunMode::kLockstep) {
        const double end = MonotonicSeconds() + run_.lockstep_timeout;
        // a lost controller may come back (a stall), or a new one take over and catch up: the
        // insertion waits for it, up to run.takeover_timeout, before the loss is final
        while (!delay_.Ready(k) && !watch_->given_up() && !InterruptRequested() &&
               (MonotonicSeconds() < end || watch_->waiting())) {
          targets_->Wait(0.05);
          TakeTargets();
          watch_->Check();
          if (!watch_->waiting() && MonotonicSeconds() >= end) break;
        }
        if (delay_.Ready(k))
          watch_->Served();
        else
          ++info_.lockstep_timeouts;
        target = delay_.TakeFor(k);
      }
    }
    // lockstep: the owner's answer for this step is here although its lease has expired since
    // (a stall of either process: one resumed sees the other's lease expire before its next
    // message is read): the step is the one an undisturbed run takes. The robot holds from the
    // next step whose answer is missing, until the owner is back.
    const bool answered_while_lost =
        target && watch_ && watch_->state() == ControllerWatch::State::kLost;
    try {
      if (answered_while_lost) loop_.set_controller_lost(false);
      loop_.Step(target);
      if (answered_while_lost) loop_.set_controller_lost(true);
      if (watch_) watch_->NoteApplied(loop_.frame().applied_seq);
    } catch (const SolverError& e) {
      std::cerr << "direct_sim run: runtime failure at t = " << loop_.time() << " s: " << e.what()
                << "\n";
      info_.exit = "diverged";
      return false;
    }
    return true;
  }

  PatientLoop& loop_;
  PatientOutputs& outputs_;
  const RunConfig& run_;
  bool quiet_;
  PatientRunInfo& info_;
  transport::Participant participant_;
  transport::Writer<SensorFrame> frames_;
  transport::Writer<SimStatus> status_out_;
  std::unique_ptr<transport::Reader<RobotTarget>> targets_;
  std::unique_ptr<transport::Reader<SimStatus>> status_in_;  // the controller's status
  std::unique_ptr<transport::Ros2Mirror> mirror_;  // --ros2; after the participant: deleted first
  int ros2_wait_ = 0;                              // --ros2-wait
  LockstepTargets delay_;
  SimStatus status_;
  uint64_t frames_sent_ = 0;
  std::vector<RobotTarget> received_;
  std::vector<uint64_t> writers_;
  std::unique_ptr<ControllerWatch> watch_;  // the robot's owner and its liveliness
  std::vector<double> sent_at_;             // monotonic time each frame was published (s), by seq
  std::string message_;
};

}  // namespace

int RunPatientOverDds(PatientLoop& loop, PatientOutputs& outputs, const RunConfig& run,
                      const transport::TransportConfig& transport,
                      const std::optional<transport::Ros2Config>& ros2, uint64_t scenario_hash,
                      bool quiet, PatientRunInfo* info) {
  PatientPump pump(loop, outputs, run, transport, ros2, scenario_hash, quiet, info);
  return pump.Run();
}

}  // namespace nsim
