#include "direct_sim/replay.h"

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "common/core/cli.h"
#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/markers/marker_csv.h"
#include "direct_sim/ros2_wait.h"
#include "messages/ros2.h"
#include "messages/transport.h"
#include "messages/transport_options.h"

namespace nsim {
namespace {

constexpr double kSettleTimeout_s = 1.0;
// Waits are taken in slices of at most this (s), checking for SIGINT/SIGTERM between them, so
// a replay stops within 0.1 s of being asked to, whatever the stream's timing.
constexpr double kSleepSlice_s = 0.1;
// The longest pause between two frames of a replayed stream: a recorded stream with a few
// lost frames has gaps of 2..3 frame intervals; 100 intervals, or 10 s (more than two
// breathing cycles), is a broken time column, not a recording (a 1e6 s gap would sleep for
// days).
constexpr double kMaxGapRatio = 100.0;
constexpr double kMaxGap_s = 10.0;

// sleeps until `due` (monotonic s) in slices; false when interrupted first
bool SleepUntilOrInterrupted(double due) {
  while (!InterruptRequested()) {
    const double left = due - MonotonicSeconds();
    if (left <= 0) return true;
    SleepUntilMonotonic(MonotonicSeconds() + std::min(left, kSleepSlice_s));
  }
  return false;
}

// the command-line settings of a replay
struct ReplayOptions {
  std::string markers;
  double rate_scale = 1;
  long wait_readers = 1;
  double wait_timeout = 30;
  bool quiet = false;
};

// Publishes one marker stream at its recorded timing, with a SimStatus before, during and after.
class Replayer {
 public:
  Replayer(const MarkerStream& stream, const ReplayOptions& options,
           const transport::TransportConfig& transport,
           const std::optional<transport::Ros2Config>& ros2)
      : stream_(stream),
        options_(options),
        participant_(transport),
        markers_(participant_, transport::Qos::kLossless),
        status_writer_(participant_, transport::Qos::kStatus),
        status_reader_(participant_, transport::Qos::kStatus) {
    if (ros2) {
      transport::Ros2MirrorTopics topics;
      topics.frames = true;
      mirror_ = std::make_unique<transport::Ros2Mirror>(*ros2, topics);
      wait_ros2_ = ros2->wait_subscribers;
    }
    status_.sender = "direct_sim";
    status_.message = "replay";
    PublishStatus();
  }

  // the exit code
  int Run() {
    if (options_.wait_readers > 0 && !WaitForReaders()) return 1;
    if (mirror_ && !WaitForRos2Subscribers(*mirror_, wait_ros2_, {transport::ros2_topic::kMarkers},
                                           options_.wait_timeout, kSettleTimeout_s,
                                           "direct_sim replay"))
      return 1;
    Stream();
    return Finish();
  }

 private:
  void PublishStatus() {
    status_writer_.Write(status_);
    status_.stamp.seq++;
  }

  // false (after a message) when no reader came in time
  bool WaitForReaders() {
    const double timeout = options_.wait_timeout;
    const double give_up = MonotonicSeconds() + timeout;
    bool matched = false;
    while (!matched && !InterruptRequested() && MonotonicSeconds() < give_up)
      matched = markers_.WaitForReaders(static_cast<int>(options_.wait_readers),
                                        std::min(kSleepSlice_s, give_up - MonotonicSeconds()));
    if (InterruptRequested()) {
      std::cerr << "direct_sim replay: interrupted while waiting for readers\n";
      return false;
    }
    if (!matched) {
      std::cerr
          << "direct_sim replay: no SensorFrame reader after " << timeout
          << " s (is inverse_sim running with the same --domain, --partition and DDS config?)\n";
      return false;
    }
    // the writer knowing the reader is not enough: the reader must know the writer too, or the
    // first frames are dropped; inverse_sim says so with a "running" status, other readers get
    // a fixed settle time
    if (!transport::WaitForPeerRunning(status_reader_, "direct_sim", kSettleTimeout_s) &&
        !options_.quiet)
      std::printf("replay: no status from the reader's process; streaming after %.1f s\n",
                  kSettleTimeout_s);
    return true;
  }

  // every frame at its due time (until interrupted), with a status and a progress line a second
  void Stream() {
    const auto& frames = stream_.frames;
    const double t0 = frames.front().stamp.sim_time;
    start_ = MonotonicSeconds();
    double next_progress = start_ + 1.0;
    status_.state = RunState::kRunning;
    PublishStatus();
    for (size_t k = 0; k < frames.size(); ++k) {
      if (InterruptRequested()) break;
      const double due = start_ + (frames[k].stamp.sim_time - t0) / options_.rate_scale;
      if (!SleepUntilOrInterrupted(due)) break;
      max_lateness_ = std::max(max_lateness_, MonotonicSeconds() - due);
      SensorFrame frame;
      frame.stamp = frames[k].stamp;
      frame.p_WM = frames[k].p_WM;
      frame.has_robot = false;
      markers_.Write(frame);
      if (mirror_) mirror_->PublishFrame(frame);
      status_.frames_sent = k + 1;
      status_.last_seq = frames[k].stamp.seq;
      status_.stamp.sim_time = frames[k].stamp.sim_time;
      if (const double now = MonotonicSeconds(); now >= next_progress) {
        status_.rate_hz = status_.frames_sent / (now - start_);
        PublishStatus();
        if (!options_.quiet)
          std::printf("replay: %zu/%zu frames, t = %.2f s\n", k + 1, frames.size(),
                      frames[k].stamp.sim_time);
        next_progress = now + 1.0;
      }
    }
  }

  // the final status, the acknowledgements and the summary line; the exit code
  int Finish() {
    const double elapsed = MonotonicSeconds() - start_;
    const bool interrupted = InterruptRequested();
    status_.state = interrupted ? RunState::kFailed : RunState::kFinished;
    status_.message = interrupted ? "replay interrupted" : "end of stream";
    status_.rate_hz = elapsed > 0 ? status_.frames_sent / elapsed : 0;
    PublishStatus();
    // let reliable readers receive the tail of the stream and the final status before leaving
    const bool acked = markers_.WaitForAcks(5.0) && status_writer_.WaitForAcks(5.0) &&
                       (!mirror_ || mirror_->WaitForAcks(5.0));
    std::printf(
        "replay: sent %lu frames of %d markers in %.3f s (%.1f Hz), max lateness %.2f ms%s%s\n",
        static_cast<unsigned long>(status_.frames_sent), stream_.num_markers, elapsed,
        status_.rate_hz, 1e3 * max_lateness_, acked ? "" : ", not all acknowledged",
        interrupted ? ", interrupted" : "");
    return interrupted ? 1 : 0;
  }

  const MarkerStream& stream_;
  const ReplayOptions& options_;
  transport::Participant participant_;
  transport::Writer<SensorFrame> markers_;
  transport::Writer<SimStatus> status_writer_;
  transport::Reader<SimStatus> status_reader_;
  std::unique_ptr<transport::Ros2Mirror> mirror_;  // --ros2; after the participant: deleted first
  int wait_ros2_ = 0;                              // --ros2-wait
  SimStatus status_;
  double start_ = 0, max_lateness_ = 0;
};

}  // namespace

int RunReplay(int argc, char** argv) {
  CommandLine cli(
      "direct_sim replay --markers IN.csv [options]",
      "Publish a recorded marker stream (SensorFrame, markers only) at its recorded timing.");
  cli.Option("markers", "IN.csv", "marker stream (t,m0_x,m0_y,m0_z,...)", "", true)
      .Option("rate-scale", "X", "play X times faster than recorded", "1")
      .Option("wait-readers", "N", "wait for N SensorFrame readers before streaming", "1")
      .Option("wait-timeout", "S", "give up waiting for readers after S seconds", "30")
      .Flag("quiet", "no progress lines");
  transport::AddTransportOptions(cli, "direct_sim");
  transport::AddRos2Options(cli);
  transport::AddRos2WaitOption(cli, transport::ros2_topic::kMarkers);
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  ReplayOptions options;
  options.markers = cli.GetString("markers");
  options.rate_scale = cli.GetDouble("rate-scale");
  // 100 times slower or 1e4 times faster than recorded: beyond that a replay is a stall or
  // a burst, not a stream at its timing
  if (!(options.rate_scale > 0))
    throw InputError(Str("--rate-scale must be > 0, got ", options.rate_scale));
  if (!(options.rate_scale >= 0.01 && options.rate_scale <= 1e4))
    throw InputError(Str("--rate-scale must be in [0.01, 10000], got ", options.rate_scale));
  options.wait_readers = cli.GetInt("wait-readers");
  if (options.wait_readers < 0 || options.wait_readers > 1000)
    throw InputError(Str("--wait-readers must be in [0, 1000], got ", options.wait_readers));
  options.wait_timeout = cli.GetDouble("wait-timeout");
  if (!(options.wait_timeout >= 0 && options.wait_timeout <= 3600))
    throw InputError(Str("--wait-timeout must be in [0, 3600] (s), got ", options.wait_timeout));
  options.quiet = cli.GetFlag("quiet");

  const MarkerStream stream = ReadMarkerCsv(options.markers);
  CheckMarkerSampling(stream, options.markers, kMaxGapRatio, kMaxGap_s);
  if (stream.num_markers > 64)
    throw InputError(
        Str("a SensorFrame carries at most 64 markers, the stream has ", stream.num_markers));
  const transport::TransportConfig tc = transport::TransportFromCli(cli);
  std::optional<transport::Ros2Config> ros2 = transport::Ros2FromCli(cli, tc);
  transport::ApplyRos2Wait(cli, &ros2);
  InstallInterruptHandler();
  return Replayer(stream, options, tc, ros2).Run();
}

}  // namespace nsim
