#include "inverse_sim/record.h"

#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/core/cli.h"
#include "common/core/clock.h"
#include "common/core/error.h"
#include "common/core/interrupt.h"
#include "common/core/sequence_tracker.h"
#include "common/markers/marker_csv.h"
#include "common/results/atomic_file.h"
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

// the command-line settings of a recording
struct RecordOptions {
  std::string out_path;
  std::optional<std::string> summary_path;
  double timeout = 600, start_timeout = 60, end_grace = 1;
  bool quiet = false;
};

// Writes the frames of one stream to a marker CSV until the stream ends or the recording gives
// up, and counts what arrived.
class Recorder {
 public:
  Recorder(const RecordOptions& options, const transport::TransportConfig& transport)
      : options_(options),
        liveliness_lease_s_(transport.liveliness_lease_s),
        participant_(transport),
        reader_(participant_, transport::Qos::kLossless),
        status_reader_(participant_, transport::Qos::kStatus),
        status_writer_(participant_, transport::Qos::kStatus) {
    own_status_.sender = "inverse_sim";
    own_status_.message = "recording";
    status_writer_.Write(own_status_);
  }

  // the exit code
  int Run() {
    start_ = MonotonicSeconds();
    last_frame_at_ = start_;
    next_progress_ = start_ + 1.0;
    std::vector<SensorFrame> frames;
    std::vector<SimStatus> statuses;
    std::optional<Ending> ending;
    while (!ending) {
      reader_.Wait(0.05);
      frames.clear();
      reader_.Take(frames);
      const double now = MonotonicSeconds();
      for (const SensorFrame& f : frames) HandleFrame(f, now);
      statuses.clear();
      status_reader_.Take(statuses);
      for (const SimStatus& s : statuses) HandleStatus(s, now);
      ending = CheckProgress(now);
    }
    return Finish(*ending);
  }

 private:
  void HandleFrame(const SensorFrame& f, double now) {
    last_frame_at_ = now;
    if (seqs_.Observe(f.stamp.seq) == SequenceTracker::Verdict::kLate) return;
    if (csv_ && (static_cast<int>(f.p_WM.size()) != csv_->num_markers() ||
                 !(f.stamp.sim_time > last_time_))) {
      ++invalid_;
      last_invalid_ =
          Str("frame ", f.stamp.seq, ": ", f.p_WM.size(), " markers at t = ", f.stamp.sim_time,
              " (expected ", csv_->num_markers(), " markers and t > ", last_time_, ")");
      return;
    }
    if (f.p_WM.empty() || f.p_WM.size() > 64) {
      ++invalid_;
      last_invalid_ = Str("frame ", f.stamp.seq, " has ", f.p_WM.size(), " markers");
      return;
    }
    if (!csv_)
      csv_ = std::make_unique<MarkerCsvWriter>(options_.out_path, static_cast<int>(f.p_WM.size()));
    csv_->Write(f.markers());
    last_time_ = f.stamp.sim_time;
    ++written_;
  }

  // the publisher's end-of-stream status: the last sequence number to wait for
  void HandleStatus(const SimStatus& s, double now) {
    if (s.sender == "inverse_sim") return;
    if (s.state == RunState::kFinished || s.state == RunState::kFailed) {
      if (!end_seen_) end_seen_at_ = now;
      end_seen_ = true;
      last_seq_ = s.last_seq;
      if (s.frames_sent == 0) last_seq_ = 0;
      if (s.frames_sent > 0) seqs_.EndAt(last_seq_);
    }
  }

  // announces this reader, prints the progress, and says whether (and how) the recording ends
  std::optional<Ending> CheckProgress(double now) {
    const transport::ReaderHealth health = reader_.health();
    if (health.writers_alive > 0) seen_alive_ = true;
    if (!announced_ && health.writers_matched > 0) {
      // tell the publisher that this reader knows it, so its first frame is not lost
      own_status_.state = RunState::kRunning;
      own_status_.stamp.seq++;
      status_writer_.Write(own_status_);
      announced_ = true;
    }
    if (!options_.quiet && now >= next_progress_) {
      std::printf("record: %lu frames, %d publisher(s) alive\n",
                  static_cast<unsigned long>(written_), health.writers_alive);
      std::fflush(stdout);
      next_progress_ = now + 1.0;
    }
    if (end_seen_ &&
        ((seqs_.any() && seqs_.newest() >= last_seq_) || now - end_seen_at_ > options_.end_grace))
      return Ending::kEndOfStream;
    if (!end_seen_ && health.liveliness_lost > 0) return Ending::kPublisherLost;
    if (!end_seen_ && seen_alive_ && health.writers_matched == 0 && health.writers_alive == 0) {
      // give the final status a moment: it may still be in flight behind the last frame
      if (left_at_ == 0) left_at_ = now;
      if (now - left_at_ > 0.5) return Ending::kPublisherLeft;
    }
    if (InterruptRequested()) return Ending::kInterrupted;
    if (now - start_ > options_.timeout || (!seqs_.any() && now - start_ > options_.start_timeout))
      return Ending::kTimeout;
    return std::nullopt;
  }

  // the counts (printed, and as JSON with --summary); the exit code
  int Finish(Ending ending) {
    const transport::ReaderHealth health = reader_.health();
    invalid_ += health.invalid;
    if (!health.last_invalid.empty()) last_invalid_ = health.last_invalid;
    const double silent_for = MonotonicSeconds() - last_frame_at_;

    std::printf("record: %s; received=%lu written=%lu missing=%lu out_of_order=%lu invalid=%lu\n",
                EndingName(ending), static_cast<unsigned long>(seqs_.received()),
                static_cast<unsigned long>(written_), static_cast<unsigned long>(seqs_.missing()),
                static_cast<unsigned long>(seqs_.out_of_order()),
                static_cast<unsigned long>(invalid_));
    if (!last_invalid_.empty())
      std::printf("record: last invalid frame: %s\n", last_invalid_.c_str());
    if (ending == Ending::kPublisherLost)
      std::printf(
          "record: publisher lost: its liveliness lease (%.3f s) expired %.3f s after its last "
          "frame\n",
          liveliness_lease_s_, silent_for);
    // the recording replaces an earlier OUT.csv only now (until here it is OUT.csv.partial):
    // whatever the ending, the rows received are whole and in order
    if (csv_) csv_->Close();
    if (!csv_)
      std::printf("record: no frame received; %s not written\n", options_.out_path.c_str());
    if (options_.summary_path) {
      nlohmann::json j = {{"ending", EndingName(ending)},
                          {"received", seqs_.received()},
                          {"written", written_},
                          {"missing", seqs_.missing()},
                          {"out_of_order", seqs_.out_of_order()},
                          {"duplicates", seqs_.duplicates()},
                          {"invalid", invalid_},
                          {"deadline_missed", health.deadline_missed},
                          {"seconds_since_last_frame", silent_for},
                          {"out", options_.out_path}};
      WriteFileAtomically(*options_.summary_path, j.dump(2) + "\n");
    }
    return ending == Ending::kEndOfStream ? 0 : 1;
  }

  const RecordOptions& options_;
  const double liveliness_lease_s_;
  transport::Participant participant_;
  transport::Reader<SensorFrame> reader_;
  transport::Reader<SimStatus> status_reader_;
  transport::Writer<SimStatus> status_writer_;
  SimStatus own_status_;
  bool announced_ = false;

  std::unique_ptr<MarkerCsvWriter> csv_;
  SequenceTracker seqs_;
  uint64_t invalid_ = 0, written_ = 0;
  std::string last_invalid_;
  double last_time_ = 0;  // of the last frame written
  bool end_seen_ = false, seen_alive_ = false;
  double end_seen_at_ = 0, left_at_ = 0;
  uint64_t last_seq_ = 0;  // of the end-of-stream status
  double start_ = 0, last_frame_at_ = 0, next_progress_ = 0;
};

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
  transport::AddTransportOptions(cli, "inverse_sim");
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  RecordOptions options;
  options.out_path = cli.GetString("out");
  options.timeout = cli.GetDouble("timeout");
  options.start_timeout = cli.GetDouble("start-timeout");
  options.end_grace = cli.GetDouble("end-grace");
  if (!(options.timeout > 0) || !(options.start_timeout > 0) || !(options.end_grace >= 0))
    throw InputError("--timeout and --start-timeout must be > 0 and --end-grace >= 0 (s)");
  options.quiet = cli.GetFlag("quiet");
  if (cli.Has("summary")) options.summary_path = cli.GetString("summary");
  {  // fail on an unwritable path now rather than after the first frame, without touching
     // an earlier recording at that path (the recording goes to OUT.csv.partial)
    const std::string probe = options.out_path + ".partial";
    if (!std::ofstream(probe)) throw InputError(Str(probe, ": cannot open for writing"));
    std::remove(probe.c_str());
  }
  const transport::TransportConfig tc = transport::TransportFromCli(cli);
  InstallInterruptHandler();
  return Recorder(options, tc).Run();
}

}  // namespace nsim
