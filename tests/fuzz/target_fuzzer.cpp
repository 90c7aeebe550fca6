// A DDS injector of robot targets for the fuzz suite (tests/fuzz/fuzz_test.py): it joins a
// running direct_sim as its controller (role "owner": the start handshake with the scenario's
// hash, then answers to every frame) or as a stranger (role "foreign": no handshake), and
// writes raw nsim_msgs_RobotTarget samples, so that it can send what the typed transport
// would refuse to build: NaN and infinite fields, huge and out-of-workspace positions,
// non-unit quaternions, unknown modes, wrong joint counts, stale, duplicate and future
// sequence numbers, too fast jumps. Every sample's kind is drawn from a seeded generator; the
// counts by kind are printed as one JSON object on stdout at the end. The owner's first
// targets are good ones, so that the run has a controller to hold on to.
//
//   target_fuzzer --role owner|foreign --seed S --duration SEC --domain D --partition P
//                 [--dds-config FILE] [--per-frame N]

#include <dds/dds.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "common/core/cli.h"
#include "common/core/clock.h"
#include "messages/transport.h"
#include "messages/transport_options.h"
#include "nsim_msgs.h"

namespace nsim {
namespace {

int Main(int argc, char** argv);

const std::vector<std::string> kKinds = {
    "good",     "nan",        "inf",    "huge",      "zero_quaternion", "long_quaternion",
    "bad_mode", "joints",     "stale",  "duplicate", "future",          "jump",
    "far",      "bad_stamp"};

class Fuzzer {
 public:
  Fuzzer(transport::Participant& participant, uint64_t seed, int per_frame, bool owner)
      : participant_(participant), rng_(seed), per_frame_(per_frame), owner_(owner) {
    dds_qos_t* q = dds_create_qos();
    dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
    dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 64);
    dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
    // offered deadline and lease within what the readers request
    dds_qset_deadline(q, DDS_MSECS(500));
    dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, DDS_SECS(2));
    writer_ = dds_create_writer(
        participant.publisher(),
        participant.TopicFor(&nsim_msgs_RobotTarget_desc, "nsim_RobotTarget"), q, nullptr);
    dds_delete_qos(q);
    if (writer_ < 0) throw std::runtime_error("cannot create the RobotTarget writer");
  }
  ~Fuzzer() { dds_delete(writer_); }

  // answers one frame with per_frame samples (the owner's first 25 frames: one good one each)
  void Answer(const SensorFrame& frame) {
    const int n = owner_ && answered_ < 25 ? 1 : per_frame_;
    for (int i = 0; i < n; ++i) {
      const std::string kind =
          !owner_ ? "jump" : answered_ < 25 ? "good" : kKinds[Pick(kKinds.size())];
      Send(kind, frame);
    }
    ++answered_;
  }

  void Print() const {
    std::printf("{\"role\": \"%s\", \"frames\": %llu, \"sent\": %llu, \"by_kind\": {",
                owner_ ? "owner" : "foreign", static_cast<unsigned long long>(answered_),
                static_cast<unsigned long long>(sent_));
    bool first = true;
    for (const auto& [kind, count] : by_kind_) {
      std::printf("%s\"%s\": %llu", first ? "" : ", ", kind.c_str(),
                  static_cast<unsigned long long>(count));
      first = false;
    }
    std::printf("}}\n");
  }

 private:
  size_t Pick(size_t n) { return std::uniform_int_distribution<size_t>(0, n - 1)(rng_); }
  double Uniform(double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(rng_); }

  void Send(const std::string& kind, const SensorFrame& frame) {
    nsim_msgs_RobotTarget m{};
    m.stamp.seq = sent_;
    m.stamp.sim_time = frame.stamp.sim_time;
    m.stamp.wall_time_ns = WallTimeNs();
    m.answers_seq = frame.stamp.seq;
    m.mode = 0;
    const Eigen::Vector3d p = frame.X_WE.translation();
    const Eigen::Quaterniond r(frame.X_WE.rotation());
    m.X_WE.p = {p.x() + Uniform(-1e-4, 1e-4), p.y() + Uniform(-1e-4, 1e-4),
                p.z() + Uniform(-1e-4, 1e-4)};
    m.X_WE.qw = r.w();
    m.X_WE.qx = r.x();
    m.X_WE.qy = r.y();
    m.X_WE.qz = r.z();
    double q[7] = {0, 0, 0, 0, 0, 0, 0};
    m.bevel_angle = frame.bevel_angle;
    double* fields[] = {&m.X_WE.p.x, &m.X_WE.p.y, &m.X_WE.p.z, &m.X_WE.qw, &m.X_WE.qx,
                        &m.X_WE.qy,  &m.X_WE.qz,  &m.bevel_angle, &m.stamp.sim_time};
    if (kind == "nan") {
      *fields[Pick(9)] = std::nan("");
    } else if (kind == "inf") {
      *fields[Pick(9)] = Pick(2) ? INFINITY : -INFINITY;
    } else if (kind == "huge") {
      (&m.X_WE.p.x)[Pick(3)] = Pick(2) ? 1e300 : -1e300;
    } else if (kind == "zero_quaternion") {
      m.X_WE.qw = m.X_WE.qx = m.X_WE.qy = m.X_WE.qz = 0.0;
    } else if (kind == "long_quaternion") {
      const double s = Uniform(1.01, 100.0);
      m.X_WE.qw *= s;
      m.X_WE.qx *= s;
      m.X_WE.qy *= s;
      m.X_WE.qz *= s;
    } else if (kind == "bad_mode") {
      m.mode = static_cast<uint8_t>(2 + Pick(254));
    } else if (kind == "joints") {  // a joint target (the robot may be Cartesian), any length
      m.mode = 1;
      const uint32_t length = static_cast<uint32_t>(Pick(8));
      for (uint32_t j = 0; j < length; ++j) q[j] = Pick(8) ? Uniform(-3.0, 3.0) : std::nan("");
      m.q._length = m.q._maximum = length;
      m.q._buffer = length > 0 ? q : nullptr;
    } else if (kind == "stale") {
      m.answers_seq = frame.stamp.seq > 200 ? frame.stamp.seq - 100 - Pick(100) : 0;
    } else if (kind == "duplicate" && has_last_) {
      m = last_;  // the very same sample again
    } else if (kind == "future") {
      m.answers_seq = frame.stamp.seq + 1 + Pick(1000000);
    } else if (kind == "jump") {  // 45 mm away in one step: far beyond the speed limit
      m.X_WE.p.x += 0.045;
    } else if (kind == "far") {  // finite but outside any workspace
      m.X_WE.p.y += Uniform(1.0, 100.0);
    } else if (kind == "bad_stamp") {
      m.stamp.sim_time = Pick(2) ? -1e9 : 1e12;
      m.stamp.wall_time_ns = Pick(2) ? 0 : INT64_MAX;
    }
    if (dds_write(writer_, &m) < 0) {
      ++by_kind_["write_failed"];
      return;
    }
    if (kind != "duplicate" || has_last_) {
      last_ = m;
      last_.q._length = last_.q._maximum = 0;  // q points into this frame's stack
      last_.q._buffer = nullptr;
      has_last_ = true;
    }
    ++sent_;
    ++by_kind_[kind];
  }

  transport::Participant& participant_;
  std::mt19937_64 rng_;
  int per_frame_;
  bool owner_;
  dds_entity_t writer_ = 0;
  nsim_msgs_RobotTarget last_{};
  bool has_last_ = false;
  uint64_t sent_ = 0, answered_ = 0;
  std::map<std::string, uint64_t> by_kind_;
};

int Main(int argc, char** argv) {
  CommandLine cli("target_fuzzer run [options]",
                  "inject fuzzed RobotTargets into a running direct_sim");
  cli.Choice("role", "ROLE", "owner: handshake and answer; foreign: a stranger",
             {"owner", "foreign"}, "owner")
      .Integer("seed", "N", "random seed", "1")
      .Number("duration", "S", "stop after this wall time (s)", "10")
      .Integer("per-frame", "N", "samples per frame received", "3");
  transport::AddTransportOptions(cli, "inverse_sim");  // it plays the controller
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  const transport::TransportConfig tc = transport::TransportFromCli(cli);
  const bool owner = cli.GetString("role") == "owner";
  transport::Participant participant(tc);
  transport::Reader<SensorFrame> frames(participant, transport::Qos::kStateStream);
  transport::Reader<SimStatus> status_in(participant, transport::Qos::kStatus);
  transport::Writer<SimStatus> status_out(participant, transport::Qos::kStatus);
  Fuzzer fuzzer(participant, static_cast<uint64_t>(cli.GetInt("seed")),
                static_cast<int>(cli.GetInt("per-frame")), owner);

  const double end = MonotonicSeconds() + cli.GetDouble("duration");
  SimStatus own;
  own.sender = "target_fuzzer";
  bool running = false, finished = false;
  std::vector<SensorFrame> received;
  std::vector<SimStatus> statuses;
  while (MonotonicSeconds() < end && !finished) {
    frames.Wait(0.02);
    statuses.clear();
    status_in.Take(statuses);
    for (const SimStatus& s : statuses) {
      if (s.sender != "direct_sim") continue;
      if (owner && !running) {  // the handshake: a running status with direct_sim's scenario
        own.state = RunState::kRunning;
        own.scenario_hash = s.scenario_hash;
        own.message = "fuzzing";
        status_out.Write(own);
        running = true;
      }
      finished = s.state == RunState::kFinished || s.state == RunState::kFailed;
    }
    received.clear();
    frames.Take(received);
    if (owner && !running) continue;
    for (const SensorFrame& f : received) fuzzer.Answer(f);
  }
  fuzzer.Print();
  return 0;
}

}  // namespace
}  // namespace nsim

int main(int argc, char** argv) {
  return nsim::RunSubcommands("target_fuzzer", "the fuzz suite's DDS injector of robot targets",
                              {{"run", "inject (see --help)", nsim::Main}}, argc, argv);
}
