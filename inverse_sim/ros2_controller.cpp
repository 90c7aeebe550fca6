#include "inverse_sim/ros2_controller.h"

#include <cstdio>
#include <vector>

#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"

namespace nsim {
namespace {

class Ros2ControllerPump {
 public:
  Ros2ControllerPump(ControllerLoop& loop, ControllerRecorder& recorder,
                     const ControllerRos2Options& options, ControllerRunInfo* info)
      : loop_(loop),
        recorder_(recorder),
        options_(options),
        info_(*info),
        input_(options.ros2, options.entry_normal_W, options.joints_required),
        output_(options.ros2, Targets()) {}

  int Run() {
    const double start = MonotonicSeconds();
    double last_frame_at = -1, next_report = start + 1.0;
    while (true) {
      input_.Wait(0.02);
      frames_.clear();
      input_.Take(frames_);
      const double now = MonotonicSeconds();
      if (!frames_.empty()) {
        last_frame_at = now;
        if (const int code = AnswerNewest(); code >= 0) return Finish(code);
      }
      if (now >= next_report) {
        Report();
        next_report = now + 1.0;
      }
      if (InterruptRequested()) return Finish(1, "interrupted");
      if (last_frame_at < 0 && now - start > options_.start_timeout) {
        std::fprintf(stderr,
                     "inverse_sim run: no complete frame (%s and %s%s) after %.0f s on ROS 2 "
                     "domain %d\n",
                     transport::ros2_topic::kMarkers, transport::ros2_topic::kRobotPose,
                     options_.joints_required > 0
                         ? Str(" and ", transport::ros2_topic::kJointStates).c_str()
                         : "",
                     options_.start_timeout, options_.ros2.domain_id);
        return Finish(1, "timeout");
      }
      if (last_frame_at >= 0 && now - last_frame_at > options_.idle_timeout)
        return Finish(0, "input_idle");
      if (now - start > options_.timeout) return Finish(1, "timeout");
    }
  }

 private:
  static transport::Ros2MirrorTopics Targets() {
    transport::Ros2MirrorTopics t;
    t.targets = t.joint_command = true;
    return t;
  }

  // realtime: the newest frame is answered, the older ones only feed the predictor; an exit
  // code to stop with, or -1
  int AnswerNewest() {
    try {
      for (size_t i = 0; i + 1 < frames_.size(); ++i) {
        loop_.Observe(frames_[i]);
        ++info_.frames_skipped;
      }
      const SensorFrame& frame = frames_.back();
      const uint64_t answered_before = loop_.counts().answered;
      const std::optional<RobotTarget> target = loop_.Step(frame);
      if (loop_.counts().answered > answered_before) recorder_.AddAnswer(loop_);
      if (!target) return -1;
      output_.PublishTarget(*target);
      info_.frame_to_target.Add(1e-9 *
                                static_cast<double>(WallTimeNs() - frame.stamp.wall_time_ns));
    } catch (const InputError& e) {  // the model cannot be built from this scenario
      std::fprintf(stderr, "inverse_sim run: %s\n", e.what());
      info_.ending = "bad_model";
      return 2;
    } catch (const SolverError& e) {
      std::fprintf(stderr, "inverse_sim run: runtime failure: %s\n", e.what());
      info_.ending = "solver_failed";
      return 1;
    }
    return -1;
  }

  void Report() {
    if (options_.quiet) return;
    const transport::Ros2InputCounts c = input_.counts();
    std::printf("inverse_sim: %lu frames (%lu incomplete, %lu invalid), %lu targets, %.1f Hz\n",
                static_cast<unsigned long>(c.frames), static_cast<unsigned long>(c.incomplete),
                static_cast<unsigned long>(c.invalid),
                static_cast<unsigned long>(loop_.counts().targets), loop_.loop_period().rate());
    if (!c.last_invalid.empty()) std::printf("inverse_sim: last invalid: %s\n", c.last_invalid.c_str());
    std::fflush(stdout);
  }

  int Finish(int code, const char* ending = nullptr) {
    if (ending) info_.ending = ending;
    output_.WaitForAcks(1.0);
    const transport::Ros2InputCounts c = input_.counts();
    info_.frames_received = c.frames;
    if (!options_.quiet)
      std::printf("inverse_sim: %s, %lu frames, %lu targets, %lu invalid messages\n",
                  info_.ending.c_str(), static_cast<unsigned long>(c.frames),
                  static_cast<unsigned long>(loop_.counts().targets),
                  static_cast<unsigned long>(c.invalid));
    return code;
  }

  ControllerLoop& loop_;
  ControllerRecorder& recorder_;
  const ControllerRos2Options& options_;
  ControllerRunInfo& info_;
  transport::Ros2Input input_;
  transport::Ros2Mirror output_;
  std::vector<SensorFrame> frames_;
};

}  // namespace

int RunControllerOverRos2(ControllerLoop& loop, ControllerRecorder& recorder,
                          const ControllerRos2Options& options, ControllerRunInfo* info) {
  Ros2ControllerPump pump(loop, recorder, options, info);
  return pump.Run();
}

}  // namespace nsim
