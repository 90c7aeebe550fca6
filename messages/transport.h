#pragma once
// A thin RAII layer over the Cyclone DDS C API: a participant (domain, partition, config file),
// typed writers and readers of the internal sample structs (common/core/samples.h), and the QoS
// profiles of the project. This header does not include Cyclone: only messages/ knows the C
// types; conversion between them and the samples happens in messages/convert.cpp.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/core/samples.h"

namespace nsim::transport {

/// DDS Security (OMG DDS Security 1.1 with Cyclone's builtin plugins: PKI-DH authentication,
/// access control by signed governance and permissions documents, AES-GCM encryption): the
/// credentials of one identity in a folder written by scripts/make_credentials.sh. A secured
/// participant only talks to participants authenticated by the same CA, and only on the topics
/// its and their permissions allow; an unsecured one does not see it at all.
struct SecurityConfig {
  std::string dir;       ///< the credentials folder; empty: no security
  std::string identity;  ///< whose credentials: dir/<identity>.{cert,key}.pem and
                         ///< dir/<identity>.permissions.p7s; at most 64 of [A-Za-z0-9_-]

  bool enabled() const { return !dir.empty(); }
  std::string ca() const;           ///< dir/ca.pem: the identity CA and permissions CA
  std::string governance() const;   ///< dir/governance.p7s (signed by the CA)
  std::string certificate() const;  ///< dir/<identity>.cert.pem (signed by the CA)
  std::string private_key() const;  ///< dir/<identity>.key.pem
  std::string permissions() const;  ///< dir/<identity>.permissions.p7s (signed by the CA)

  /// Throws InputError naming the file when a credential is missing, unreadable or not what it
  /// should be (a PEM certificate or key, an S/MIME-signed document); nothing when disabled.
  void Validate() const;
};

/// How a process joins the DDS data space.
struct TransportConfig {
  int domain_id = 0;               ///< DDS domain id, 0..232
  std::string partition = "nsim";  ///< DDS partition; processes only talk within one partition
  std::string config_file;         ///< Cyclone XML file; empty: Cyclone's default (CYCLONEDDS_URI)
  /// Writers assert liveliness within this lease (s); a reader reports a writer dead when it
  /// expires. Not much below 1 s on a loaded machine: a starved process may miss a short lease
  /// (seen at 0.5 s with both simulations and a build on 2 cores). The robot does not depend on
  /// it to stop: it holds on its own when no valid target came for safety.hold_timeout.
  double liveliness_lease_s = 2.0;
  double deadline_s = 2.0;    ///< max period between samples of a stream (s); 0 = no deadline
  int lossless_depth = 4096;  ///< history depth of the kLossless profile (samples)
  SecurityConfig security;    ///< DDS Security credentials; disabled by default

  /// Throws InputError naming the field when a value is out of range or the file is missing.
  void Validate() const;
};

/// QoS profiles.
enum class Qos {
  kStateStream,  ///< SensorFrame: reliable, keep-last 1
  kTarget,       ///< RobotTarget: reliable, keep-last 1 written, kTargetReaderDepth read
  kStatus,       ///< SimStatus: reliable, keep-last 1 (readers: 32), transient-local (late
                 ///< joiners get the last of each writer)
  kLossless,     ///< a stream where every sample matters (replay, recording): reliable,
                 ///< keep-last lossless_depth on both sides, transient-local, so a sample lost
                 ///< on the wire or written before the reader synchronized can still be resent;
                 ///< a kLossless reader also matches kStateStream writers
};
/// History depth of a kTarget reader: the targets of one step, from every writer.
inline constexpr int kTargetReaderDepth = 32;
/// Every writer offers transient-local durability (its last sample, or lossless_depth, for a
/// reader that asks); kStateStream and kTarget readers do not ask for it.

/// A DDS participant with one publisher and one subscriber in the configured partition.
class Participant {
 public:
  /// Creates the domain from config.config_file (if given) and the participant. Throws
  /// InputError for a bad config or credentials that DDS Security refuses (with Cyclone's
  /// reason and the file it concerns), std::runtime_error if DDS refuses otherwise.
  explicit Participant(const TransportConfig& config);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  const TransportConfig& config() const { return config_; }
  int32_t handle() const { return participant_; }
  int32_t publisher() const { return publisher_; }
  int32_t subscriber() const { return subscriber_; }
  /// The topic of a message type (created once per participant).
  int32_t TopicFor(const void* descriptor, const char* name);

 private:
  TransportConfig config_;
  int32_t domain_ = 0, participant_ = 0, publisher_ = 0, subscriber_ = 0;
  std::vector<std::pair<const void*, int32_t>> topics_;
};

/// A typed writer of one sample type (SensorFrame, RobotTarget,
/// SimStatus). Write() stamps the wall time of sending.
template <typename Sample>
class Writer {
 public:
  /// Throws InputError when the participant's DDS Security permissions do not allow
  /// publishing the topic, std::runtime_error if DDS refuses otherwise.
  Writer(Participant& participant, Qos qos);
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  /// Publishes `sample`, setting its stamp.wall_time_ns to now. Throws std::runtime_error if
  /// DDS refuses.
  void Write(const Sample& sample);
  /// Number of matched readers now.
  int matched_readers() const;
  /// Waits until at least `count` readers are matched; false on timeout.
  bool WaitForReaders(int count, double timeout_s) const;
  /// Waits until every matched reliable reader acknowledged all samples; false on timeout.
  bool WaitForAcks(double timeout_s) const;

 private:
  struct Scratch;
  int32_t writer_ = 0;
  std::unique_ptr<Scratch> scratch_;
};

/// What a reader knows about the writers it is matched with.
struct ReaderHealth {
  int writers_matched = 0;       ///< writers currently matched
  int writers_alive = 0;         ///< matched writers whose liveliness is asserted
  uint64_t liveliness_lost = 0;  ///< times a writer's lease expired (dead writer)
  uint64_t writers_gone = 0;     ///< times a writer stopped being alive (lost or deleted)
  uint64_t deadline_missed = 0;  ///< times the stream's deadline passed without a sample
  uint64_t invalid = 0;          ///< samples dropped because they failed validation
  std::string last_invalid;      ///< why the last dropped sample was invalid
  /// The liveliness changes since the previous health() call: alive and not-alive counts'
  /// changes, and the writer (instance handle) that changed last. One writer's change is +1/0
  /// (matched), -1/+1 (lease expired), +1/-1 (alive again), -1/0 or 0/-1 (unmatched).
  int alive_change = 0, not_alive_change = 0;
  uint64_t last_changed_writer = 0;
};

/// A typed reader of one sample type.
template <typename Sample>
class Reader {
 public:
  /// Throws InputError when the participant's DDS Security permissions do not allow
  /// subscribing to the topic, std::runtime_error if DDS refuses otherwise.
  Reader(Participant& participant, Qos qos);
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  /// Blocks until data arrives or the reader's liveliness/deadline status changes, at most
  /// `timeout_s` (<= 0: does not block). Returns false on timeout.
  bool Wait(double timeout_s);
  /// Appends every available sample to `out` (in reception order); returns how many. With
  /// `writers`, appends the instance handle of each sample's writer beside it.
  size_t Take(std::vector<Sample>& out, std::vector<uint64_t>* writers = nullptr);
  /// The identity (ParticipantId) of the participant a matched writer belongs to (its
  /// process), 0 when the writer is not (or no longer) matched.
  uint64_t ParticipantOfWriter(uint64_t writer);
  /// The instance handles of the writers matched now.
  std::vector<uint64_t> MatchedWriters();
  /// Polls and accumulates the liveliness, deadline and match statuses.
  ReaderHealth health();

 private:
  int32_t reader_ = 0, waitset_ = 0;
  ReaderHealth health_;
};

/// Waits until a process other than `self` publishes a running status, or a failed one (it
/// will never run: e.g. it refused our scenario), and returns it (its state and scenario_hash
/// are checked by the caller); nothing on timeout. A
/// process says "running" once each of its readers has matched the writer it reads from: a
/// writer matching a reader is not enough, since until the reader knows the writer it drops
/// the writer's samples (the first frames of a run would be lost).
std::optional<SimStatus> WaitForPeerRunning(Reader<SimStatus>& reader, const std::string& self,
                                            double timeout_s, uint64_t* participant = nullptr);

/// A participant's identity: a digest of its GUID (what ParticipantOfWriter returns for its
/// writers, on any machine).
uint64_t ParticipantId(const Participant& participant);

}  // namespace nsim::transport
