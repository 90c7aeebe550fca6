#include "direct_sim/replay.h"

#include <cstdio>
#include <iostream>

#include "common/core/cli.h"
#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/markers/marker_csv.h"
#include "messages/transport.h"
#include "messages/transport_options.h"

namespace nsim {
namespace {

constexpr double kSettleTimeout_s = 1.0;

}  // namespace

int RunReplay(int argc, char** argv) {
  CommandLine cli("direct_sim replay --markers IN.csv [options]",
                  "Publish a recorded marker stream (SensorFrame, markers only) at its recorded timing.");
  cli.Option("markers", "IN.csv", "marker stream (t,m0_x,m0_y,m0_z,...)", "", true)
      .Option("rate-scale", "X", "play X times faster than recorded", "1")
      .Option("wait-readers", "N", "wait for N SensorFrame readers before streaming", "1")
      .Option("wait-timeout", "S", "give up waiting for readers after S seconds", "30")
      .Flag("quiet", "no progress lines");
  transport::AddTransportOptions(cli);
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  const double rate_scale = cli.GetDouble("rate-scale");
  if (!(rate_scale > 0)) throw InputError(Str("--rate-scale must be > 0, got ", rate_scale));
  const long wait_readers = cli.GetInt("wait-readers");
  if (wait_readers < 0) throw InputError(Str("--wait-readers must be >= 0, got ", wait_readers));
  const double wait_timeout = cli.GetDouble("wait-timeout");
  const bool quiet = cli.GetFlag("quiet");

  const MarkerStream stream = ReadMarkerCsv(cli.GetString("markers"));
  if (stream.num_markers > 64)
    throw InputError(
        Str("a SensorFrame carries at most 64 markers, the stream has ", stream.num_markers));
  const transport::TransportConfig tc = transport::TransportFromCli(cli);
  InstallInterruptHandler();

  transport::Participant participant(tc);
  transport::Writer<SensorFrame> markers(participant, transport::Qos::kLossless);
  transport::Writer<SimStatus> status_writer(participant, transport::Qos::kStatus);
  transport::Reader<SimStatus> status_reader(participant, transport::Qos::kStatus);
  SimStatus status;
  status.sender = "direct_sim";
  status.message = "replay";
  auto publish_status = [&] {
    status_writer.Write(status);
    status.stamp.seq++;
  };
  publish_status();

  if (wait_readers > 0) {
    if (!markers.WaitForReaders(static_cast<int>(wait_readers), wait_timeout)) {
      std::cerr
          << "direct_sim replay: no SensorFrame reader after " << wait_timeout
          << " s (is inverse_sim running with the same --domain, --partition and DDS config?)\n";
      return 1;
    }
    // the writer knowing the reader is not enough: the reader must know the writer too, or the
    // first frames are dropped; inverse_sim says so with a "running" status, other readers get
    // a fixed settle time
    if (!transport::WaitForPeerRunning(status_reader, "direct_sim", kSettleTimeout_s) && !quiet)
      std::printf("replay: no status from the reader's process; streaming after %.1f s\n",
                  kSettleTimeout_s);
  }
  const auto& frames = stream.frames;
  const double t0 = frames.front().stamp.sim_time;
  const double start = MonotonicSeconds();
  double max_lateness = 0, next_progress = start + 1.0;
  status.state = RunState::kRunning;
  publish_status();
  for (size_t k = 0; k < frames.size(); ++k) {
    if (InterruptRequested()) break;
    const double due = start + (frames[k].stamp.sim_time - t0) / rate_scale;
    SleepUntilMonotonic(due);
    max_lateness = std::max(max_lateness, MonotonicSeconds() - due);
    SensorFrame frame;
    frame.stamp = frames[k].stamp;
    frame.p_WM = frames[k].p_WM;
    frame.has_robot = false;
    markers.Write(frame);
    status.frames_sent = k + 1;
    status.last_seq = frames[k].stamp.seq;
    status.stamp.sim_time = frames[k].stamp.sim_time;
    if (const double now = MonotonicSeconds(); now >= next_progress) {
      status.rate_hz = status.frames_sent / (now - start);
      publish_status();
      if (!quiet)
        std::printf("replay: %zu/%zu frames, t = %.2f s\n", k + 1, frames.size(),
                    frames[k].stamp.sim_time);
      next_progress = now + 1.0;
    }
  }
  const double elapsed = MonotonicSeconds() - start;
  const bool interrupted = InterruptRequested();
  status.state = interrupted ? RunState::kFailed : RunState::kFinished;
  status.message = interrupted ? "replay interrupted" : "end of stream";
  status.rate_hz = elapsed > 0 ? status.frames_sent / elapsed : 0;
  publish_status();
  // let reliable readers receive the tail of the stream and the final status before leaving
  const bool acked = markers.WaitForAcks(5.0) && status_writer.WaitForAcks(5.0);
  std::printf(
      "replay: sent %lu frames of %d markers in %.3f s (%.1f Hz), max lateness %.2f ms%s%s\n",
      static_cast<unsigned long>(status.frames_sent), stream.num_markers, elapsed, status.rate_hz,
      1e3 * max_lateness, acked ? "" : ", not all acknowledged",
      interrupted ? ", interrupted" : "");
  return interrupted ? 1 : 0;
}

}  // namespace nsim
