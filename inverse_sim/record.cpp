#include "inverse_sim/record.h"

#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "common/core/cli.h"
#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/core/sequence_tracker.h"
#include "common/markers/marker_csv.h"
#include "messages/transport.h"
#include "messages/transport_options.h"

namespace nsim {
namespace {

/// How a recording ended.
enum class Ending { kEndOfStream, kPublisherLost, kPublisherLeft, kTimeout, kInterrupted };

const char* EndingName(Ending e) {
  switch (e) {
    case Ending::kEndOfStream:
      return "end_of_stream";
    case Ending::kPublisherLost:
      return "publisher_lost";
    case Ending::kPublisherLeft:
      return "publisher_left";
    case Ending::kTimeout:
      return "timeout";
    case Ending::kInterrupted:
      return "interrupted";
  }
  return "?";
}

}  // namespace

int RunRecord(int argc, char** argv) {
  CommandLine cli(
      "inverse_sim record --out OUT.csv [options]",
      "Record every received SensorFrame's markers into a marker CSV until the end of the stream.");
  cli.Option("out", "OUT.csv", "marker CSV to write", "", true)
      .Option("summary", "FILE.json", "also write the counts as JSON")
      .Option("timeout", "S", "give up after S seconds in all", "600")
      .Option("start-timeout", "S", "give up if no frame arrives within S seconds", "60")
      .Option("end-grace", "S", "after the end-of-stream status, wait S seconds for late frames",
              "1")
      .Flag("quiet", "no progress lines");
  transport::AddTransportOptions(cli);
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  const std::string out_path = cli.GetString("out");
  const double timeout = cli.GetDouble("timeout"), start_timeout = cli.GetDouble("start-timeout");
  const double end_grace = cli.GetDouble("end-grace");
  if (!(timeout > 0) || !(start_timeout > 0) || !(end_grace >= 0))
    throw InputError("--timeout and --start-timeout must be > 0 and --end-grace >= 0 (s)");
  const bool quiet = cli.GetFlag("quiet");
  {  // fail on an unwritable path now rather than after the first frame
    std::ofstream probe(out_path);
    if (!probe) throw InputError(Str(out_path, ": cannot open for writing"));
  }
  const transport::TransportConfig tc = transport::TransportFromCli(cli);
  InstallInterruptHandler();

  transport::Participant participant(tc);
  transport::Reader<SensorFrame> reader(participant, transport::Qos::kLossless);
  transport::Reader<SimStatus> status_reader(participant, transport::Qos::kStatus);
  transport::Writer<SimStatus> status_writer(participant, transport::Qos::kStatus);
  SimStatus own_status;
  own_status.sender = "inverse_sim";
  own_status.message = "recording";
  status_writer.Write(own_status);
  bool announced = false;

  std::unique_ptr<MarkerCsvWriter> csv;
  SequenceTracker seqs;
  uint64_t invalid = 0, written = 0;
  std::string last_invalid;
  double last_time = 0;
  bool end_seen = false, seen_alive = false;
  double end_seen_at = 0, lost_at = 0;
  uint64_t last_seq = 0;
  const double start = MonotonicSeconds();
  double last_frame_at = start, next_progress = start + 1.0;
  Ending ending = Ending::kTimeout;
  std::vector<SensorFrame> frames;
  std::vector<SimStatus> statuses;

  while (true) {
    reader.Wait(0.05);
    frames.clear();
    reader.Take(frames);
    const double now = MonotonicSeconds();
    for (const SensorFrame& f : frames) {
      last_frame_at = now;
      if (seqs.Observe(f.stamp.seq) == SequenceTracker::Verdict::kLate) continue;
      if (csv && (static_cast<int>(f.p_WM.size()) != csv->num_markers() ||
                  !(f.stamp.sim_time > last_time))) {
        ++invalid;
        last_invalid =
            Str("frame ", f.stamp.seq, ": ", f.p_WM.size(), " markers at t = ", f.stamp.sim_time,
                " (expected ", csv->num_markers(), " markers and t > ", last_time, ")");
        continue;
      }
      if (f.p_WM.empty() || f.p_WM.size() > 64) {
        ++invalid;
        last_invalid = Str("frame ", f.stamp.seq, " has ", f.p_WM.size(), " markers");
        continue;
      }
      if (!csv) csv = std::make_unique<MarkerCsvWriter>(out_path, static_cast<int>(f.p_WM.size()));
      csv->Write(f.markers());
      last_time = f.stamp.sim_time;
      ++written;
    }
    statuses.clear();
    status_reader.Take(statuses);
    for (const SimStatus& s : statuses) {
      if (s.sender == "inverse_sim") continue;
      if (s.state == RunState::kFinished || s.state == RunState::kFailed) {
        if (!end_seen) end_seen_at = now;
        end_seen = true;
        last_seq = s.last_seq;
        if (s.frames_sent == 0) last_seq = 0;
        if (s.frames_sent > 0) seqs.EndAt(last_seq);
      }
    }
    const transport::ReaderHealth health = reader.health();
    if (health.writers_alive > 0) seen_alive = true;
    if (!announced && health.writers_matched > 0) {
      // tell the publisher that this reader knows it, so its first frame is not lost
      own_status.state = RunState::kRunning;
      own_status.stamp.seq++;
      status_writer.Write(own_status);
      announced = true;
    }
    if (!quiet && now >= next_progress) {
      std::printf("record: %lu frames, %d publisher(s) alive\n",
                  static_cast<unsigned long>(written), health.writers_alive);
      std::fflush(stdout);
      next_progress = now + 1.0;
    }
    if (end_seen && ((seqs.any() && seqs.newest() >= last_seq) || now - end_seen_at > end_grace)) {
      ending = Ending::kEndOfStream;
      break;
    }
    if (!end_seen && health.liveliness_lost > 0) {
      lost_at = now;
      ending = Ending::kPublisherLost;
      break;
    }
    if (!end_seen && seen_alive && health.writers_matched == 0 && health.writers_alive == 0) {
      // give the final status a moment: it may still be in flight behind the last frame
      if (lost_at == 0) lost_at = now;
      if (now - lost_at > 0.5) {
        ending = Ending::kPublisherLeft;
        break;
      }
    }
    if (InterruptRequested()) {
      ending = Ending::kInterrupted;
      break;
    }
    if (now - start > timeout || (!seqs.any() && now - start > start_timeout)) {
      ending = Ending::kTimeout;
      break;
    }
  }
  const transport::ReaderHealth health = reader.health();
  invalid += health.invalid;
  if (!health.last_invalid.empty()) last_invalid = health.last_invalid;
  const double silent_for = MonotonicSeconds() - last_frame_at;

  std::printf("record: %s; received=%lu written=%lu missing=%lu out_of_order=%lu invalid=%lu\n",
              EndingName(ending), static_cast<unsigned long>(seqs.received()),
              static_cast<unsigned long>(written), static_cast<unsigned long>(seqs.missing()),
              static_cast<unsigned long>(seqs.out_of_order()), static_cast<unsigned long>(invalid));
  if (!last_invalid.empty()) std::printf("record: last invalid frame: %s\n", last_invalid.c_str());
  if (ending == Ending::kPublisherLost)
    std::printf(
        "record: publisher lost: its liveliness lease (%.3f s) expired %.3f s after its last "
        "frame\n",
        tc.liveliness_lease_s, silent_for);
  if (!csv) std::printf("record: no frame received; %s holds no data\n", out_path.c_str());
  if (cli.Has("summary")) {
    nlohmann::json j = {{"ending", EndingName(ending)},
                        {"received", seqs.received()},
                        {"written", written},
                        {"missing", seqs.missing()},
                        {"out_of_order", seqs.out_of_order()},
                        {"duplicates", seqs.duplicates()},
                        {"invalid", invalid},
                        {"deadline_missed", health.deadline_missed},
                        {"seconds_since_last_frame", silent_for},
                        {"out", out_path}};
    std::ofstream(cli.GetString("summary")) << j.dump(2) << "\n";
  }
  return ending == Ending::kEndOfStream ? 0 : 1;
}

}  // namespace nsim
