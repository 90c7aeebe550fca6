#include "inverse_sim/dds_controller.h"

#include <algorithm>
#include <cstdio>
#include <deque>
#include <iostream>
#include <memory>

#include "common/core/clock.h"
#include "common/core/delay_line.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/core/sequence_tracker.h"

namespace nsim {
namespace {

class ControllerPump {
 public:
  ControllerPump(ControllerLoop& loop, ControllerRecorder& recorder,
                 const ControllerPumpOptions& options, ControllerRunInfo* info)
      : loop_(loop),
        recorder_(recorder),
        options_(options),
        info_(*info),
        participant_(options.transport),
        // every frame is received: the predictor needs the whole marker stream
        frames_(participant_, transport::Qos::kLossless),
        status_in_(participant_, transport::Qos::kStatus),
        // lockstep: every answer is delivered (an unacknowledged answer is not replaced)
        targets_(participant_,
                 options.lockstep ? transport::Qos::kLossless : transport::Qos::kTarget),
        status_out_(participant_, transport::Qos::kStatus) {
    if (options.ros2) {
      transport::Ros2MirrorTopics topics;
      topics.targets = true;
      mirror_ = std::make_unique<transport::Ros2Mirror>(*options.ros2, topics);
    }
    own_.sender = "inverse_sim";
    own_.scenario_hash = options.scenario_hash;
    // "starting" until the frame reader has matched direct_sim's writer
    Publish(RunState::kStarting, "waiting for direct_sim");
  }

  int Run() {
    const double start = MonotonicSeconds();
    while (true) {
      if (queue_.empty()) frames_.Wait(WaitTime(MonotonicSeconds()));
      const double now = MonotonicSeconds();
      if (own_.state == RunState::kStarting && frames_.health().writers_matched > 0)
        Publish(RunState::kRunning, "readers matched");
      TakeFrames(now);
      if (const int code = AnswerFrames(); code >= 0) return Finish(code);
      SendDueTargets(MonotonicSeconds());
      if (const int code = ReadStatus(now); code >= 0) return Finish(code);
      if (now - last_status_at_ > 0.5) Report(now);
      if (finishing_ && (last_answered_ >= static_cast<int64_t>(final_seq_) ||
                         now > finish_deadline_)) {
        info_.ending = "direct_finished";
        return Finish(0);
      }
      // direct_sim is lost when its writers stay not alive for direct_timeout: it may be
      // stalled, and a process that was itself stopped (SIGSTOP) sees the leases expire when
      // it resumes, before the writers' next messages arrive
      if (seen_direct_ && frames_.health().writers_alive == 0 && !finishing_) {
        if (direct_gone_since_ < 0) {
          direct_gone_since_ = now;
          ++info_.direct_losses;
          std::fprintf(stderr,
                       "inverse_sim: direct_sim not alive (liveliness lease expired); waiting "
                       "up to %.0f s\n",
                       options_.direct_timeout);
        }
        if (now - direct_gone_since_ > options_.direct_timeout) {
          std::fprintf(stderr, "inverse_sim: direct_sim lost (not alive for %.1f s)\n",
                       now - direct_gone_since_);
          info_.ending = "direct_lost";
          return Finish(1);
        }
      } else if (direct_gone_since_ >= 0) {
        std::fprintf(stderr, "inverse_sim: direct_sim back after %.2f s\n",
                     now - direct_gone_since_);
        direct_gone_since_ = -1.0;
      }
      if (InterruptRequested()) {
        info_.ending = "interrupted";
        return Finish(1);
      }
      if (now - start > options_.timeout ||
          (!seen_direct_ && now - start > options_.start_timeout)) {
        info_.ending = "timeout";
        return Finish(1);
      }
    }
  }

 private:
  void Publish(RunState state, const std::string& message) {
    own_.state = state;
    own_.message = message.substr(0, 255);
    own_.frames_sent = loop_.counts().targets;
    own_.rate_hz = loop_.loop_period().rate();
    own_.phase = static_cast<uint8_t>(std::max(0, loop_.phase()));
    status_out_.Write(own_);
    own_.stamp.seq++;
  }

  // the frame reader's wait: at most 20 ms, and not past the next delayed frame or target
  double WaitTime(double now) const {
    return std::min({0.02, arriving_.TimeToNext(now), leaving_.TimeToNext(now)});
  }

  // the received frames join the queue, after options_.link_delay when there is one
  void TakeFrames(double now) {
    received_.clear();
    frames_.Take(received_);
    for (const SensorFrame& f : received_) {
      if (seqs_.Observe(f.stamp.seq) == SequenceTracker::Verdict::kLate) {
        ++late_;
        continue;
      }
      if (options_.link_delay > 0)
        arriving_.Push(now + options_.link_delay, f);
      else
        queue_.push_back(f);
    }
    arriving_.Release(now, [this](SensorFrame f) { queue_.push_back(std::move(f)); });
  }

  // writes a target answering a frame sent at `frame_wall_time_ns`
  void Send(const RobotTarget& target, int64_t frame_wall_time_ns) {
    targets_.Write(target);
    if (mirror_) mirror_->PublishTarget(target);
    info_.frame_to_target.Add(1e-9 * static_cast<double>(WallTimeNs() - frame_wall_time_ns));
  }

  void SendDueTargets(double now) {
    leaving_.Release(now, [this](const Leaving& l) { Send(l.target, l.frame_wall_time_ns); });
  }

  // lockstep: answers every queued frame in order; realtime: the newest, the older ones only
  // feed the predictor (stale by the time they would be answered). Returns an exit code to
  // stop with, or -1.
  int AnswerFrames() {
    if (queue_.empty()) return -1;
    seen_direct_ = true;
    try {
      while (!queue_.empty()) {
        const SensorFrame frame = queue_.front();
        queue_.pop_front();
        if (!options_.lockstep && !queue_.empty()) {
          loop_.Observe(frame);
          ++info_.frames_skipped;
          continue;
        }
        Answer(frame);
      }
    } catch (const InputError& e) {  // the model cannot be built from this scenario
      std::fprintf(stderr, "inverse_sim run: %s\n", e.what());
      info_.ending = "bad_model";
      last_error_ = e.what();
      return 2;
    } catch (const SolverError& e) {
      std::fprintf(stderr, "inverse_sim run: runtime failure: %s\n", e.what());
      info_.ending = "solver_failed";
      last_error_ = e.what();
      return 1;
    }
    return -1;
  }

  void Answer(const SensorFrame& frame) {
    const uint64_t answered_before = loop_.counts().answered;
    const std::optional<RobotTarget> target = loop_.Step(frame);
    last_answered_ = static_cast<int64_t>(frame.stamp.seq);
    if (loop_.counts().answered > answered_before) recorder_.AddAnswer(loop_);
    if (!target) return;
    if (options_.link_delay > 0)
      leaving_.Push(MonotonicSeconds() + options_.link_delay, {*target, frame.stamp.wall_time_ns});
    else
      Send(*target, frame.stamp.wall_time_ns);
  }

  // direct_sim's status: its scenario must be ours; once it has finished, the frames it sent
  // last are still answered (up to its last sequence number, for at most 1 s)
  int ReadStatus(double now) {
    statuses_.clear();
    status_in_.Take(statuses_);
    for (const SimStatus& s : statuses_) {
      if (s.sender != "direct_sim") continue;
      seen_direct_ = true;
      if (s.scenario_hash != 0 && s.scenario_hash != options_.scenario_hash) {
        std::fprintf(stderr,
                     "inverse_sim run: direct_sim runs another scenario (shared-part hash "
                     "%016llx, ours %016llx): both processes must be given the same shared: "
                     "section\n",
                     static_cast<unsigned long long>(s.scenario_hash),
                     static_cast<unsigned long long>(options_.scenario_hash));
        info_.ending = "scenario_mismatch";
        last_error_ = "scenario mismatch";
        return 2;
      }
      if (!finishing_ && (s.state == RunState::kFinished || s.state == RunState::kFailed)) {
        finishing_ = true;
        final_seq_ = s.last_seq;
        finish_deadline_ = now + 1.0;
      }
    }
    return -1;
  }

  void Report(double now) {
    Publish(own_.state, loop_.counts().last_rejection);
    last_status_at_ = now;
    if (options_.quiet || !loop_.controller()) return;
    std::printf("inverse_sim: %lu targets, %.1f Hz, step %.1f ms, jacobian %.2f ms, phase %d\n",
                static_cast<unsigned long>(loop_.counts().targets), loop_.loop_period().rate(),
                1e3 * loop_.model_time().mean(), 1e3 * loop_.jacobian_time().mean(),
                loop_.phase());
    std::fflush(stdout);
  }

  int Finish(int code) {
    Publish(code == 0 ? RunState::kFinished : RunState::kFailed,
            last_error_.empty() ? info_.ending : last_error_);
    status_out_.WaitForAcks(1.0);
    targets_.WaitForAcks(1.0);
    if (mirror_) mirror_->WaitForAcks(1.0);
    info_.frames_received = seqs_.received();
    info_.frames_missing = seqs_.missing();
    info_.frames_out_of_order = late_;
    if (!options_.quiet)
      std::printf("inverse_sim: %s, %lu targets\n", info_.ending.c_str(),
                  static_cast<unsigned long>(loop_.counts().targets));
    return code;
  }

  ControllerLoop& loop_;
  ControllerRecorder& recorder_;
  const ControllerPumpOptions& options_;
  ControllerRunInfo& info_;
  transport::Participant participant_;
  transport::Reader<SensorFrame> frames_;
  transport::Reader<SimStatus> status_in_;
  transport::Writer<RobotTarget> targets_;
  transport::Writer<SimStatus> status_out_;
  std::unique_ptr<transport::Ros2Mirror> mirror_;  // --ros2; after the participant: deleted first
  SimStatus own_;
  SequenceTracker seqs_;
  std::deque<SensorFrame> queue_;
  // --link-delay: frames not yet taken up and targets not yet written, with their due times
  struct Leaving {
    RobotTarget target;
    int64_t frame_wall_time_ns;  // of the frame it answers
  };
  DelayLine<SensorFrame> arriving_;
  DelayLine<Leaving> leaving_;
  std::vector<SensorFrame> received_;
  std::vector<SimStatus> statuses_;
  uint64_t late_ = 0;
  bool seen_direct_ = false, finishing_ = false;
  uint64_t final_seq_ = 0;
  int64_t last_answered_ = -1;
  double finish_deadline_ = 0.0, last_status_at_ = 0.0, direct_gone_since_ = -1.0;
  std::string last_error_;
};

}  // namespace

int RunControllerOverDds(ControllerLoop& loop, ControllerRecorder& recorder,
                         const ControllerPumpOptions& options, ControllerRunInfo* info) {
  ControllerPump pump(loop, recorder, options, info);
  return pump.Run();
}

}  // namespace nsim
