#include "messages/transport.h"

#include <dds/dds.h>

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "common/core/clock.h"
#include "common/core/bounds.h"
#include "common/core/error.h"
#include "messages/convert.h"
#include "messages/dds_util.h"
#include "messages/security.h"

namespace nsim::transport {

dds_duration_t ToDuration(double seconds) {
  return seconds > 0 ? static_cast<dds_duration_t>(seconds * 1e9) : DDS_INFINITY;
}

int32_t Checked(int32_t rc, const char* what) {
  if (rc < 0) throw std::runtime_error(Str("DDS: ", what, " failed: ", dds_strretcode(rc)));
  return rc;
}

dds_entity_t CreateDomain(int domain_id, const std::string& config_file) {
  if (config_file.empty()) return 0;
  const std::string uri =
      "file://" + std::filesystem::absolute(config_file).lexically_normal().string();
  const dds_entity_t domain = dds_create_domain(domain_id, uri.c_str());
  // a domain already created in this process (another participant) is reused as it is
  if (domain < 0 && domain != DDS_RETCODE_PRECONDITION_NOT_MET)
    throw std::runtime_error(Str("DDS: cannot create domain ", domain_id, " from '",
                                 config_file, "': ", dds_strretcode(domain)));
  return domain > 0 ? domain : 0;
}

namespace {

/// QoS of a profile; `writer` selects the offered (writer) or requested (reader) side.
dds_qos_t* MakeQos(const TransportConfig& c, Qos profile, bool writer) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  // a target reader keeps the targets of a whole step (kTargetReaderDepth): every target that
  // arrives is checked and counted, and a stranger's flood cannot push the owner's target out
  // of a history of one (RobotTarget has no key: all writers share one instance); a status
  // reader keeps the last few: every process writes on the (keyless) status topic, and with
  // several controllers (one taking over, or a standby) one's status would otherwise replace
  // another's before it is read (a controller missed direct_sim's "finished")
  constexpr int kStatusReaderDepth = 32;
  const int depth = profile == Qos::kLossless                 ? c.lossless_depth
                    : profile == Qos::kTarget && !writer ? kTargetReaderDepth
                    : profile == Qos::kStatus && !writer ? kStatusReaderDepth
                                                              : 1;
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, depth);
  // Writers offer transient-local; status and lossless readers request it. A volatile reader
  // may drop a sample that arrives before the writer's first heartbeat even though the two are
  // matched (it then starts at the heartbeat's next sequence number): frame 0 of a run could be
  // lost. A transient-local reader asks for what it missed instead. Offering it on every
  // writer keeps every reader-writer pair compatible.
  const bool transient_local = writer || profile == Qos::kStatus || profile == Qos::kLossless;
  dds_qset_durability(q,
                      transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  // what a lossless writer keeps for a reader that joins late (Cyclone's default: the last
  // sample): the whole history, so a controller restarted mid-run gets the frames from the
  // start (up to lossless_depth) and its model replays the insertion
  if (writer && profile == Qos::kLossless)
    dds_qset_durability_service(q, 0, DDS_HISTORY_KEEP_LAST, depth, DDS_LENGTH_UNLIMITED,
                                DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
  // a writer asserts liveliness within its lease; a reader accepts any lease, so processes
  // with different leases still match and each writer's own lease decides when it is dead
  dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC,
                      writer ? ToDuration(c.liveliness_lease_s) : DDS_INFINITY);
  // likewise a writer offers the configured deadline and a reader requests it, except for the
  // status topic, which is written on change only
  if (profile != Qos::kStatus) dds_qset_deadline(q, ToDuration(c.deadline_s));
  return q;
}

}  // namespace

void TransportConfig::Validate() const {
  if (domain_id < 0 || domain_id > 232)
    throw InputError(Str("dds.domain_id must be in 0..232, got ", domain_id));
  if (partition.empty()) throw InputError("dds.partition must not be empty");
  CheckName(partition, kMaxPartitionLength, "dds.partition");
  if (!config_file.empty() && !std::filesystem::is_regular_file(config_file))
    throw InputError(Str("dds.config_file: no such file '", config_file, "'"));
  if (!(liveliness_lease_s > 0))
    throw InputError(Str("dds.liveliness_lease must be > 0 (s), got ", liveliness_lease_s));
  if (!(deadline_s >= 0)) throw InputError(Str("dds.deadline must be >= 0 (s), got ", deadline_s));
  // an hour: a peer silent that long is dead; larger values overflow DDS's ns durations
  CheckAtMost(liveliness_lease_s, 3600.0, "dds.liveliness_lease", "s");
  CheckAtMost(deadline_s, 3600.0, "dds.deadline", "s");
  if (lossless_depth < 1)
    throw InputError(Str("dds.lossless_depth must be >= 1, got ", lossless_depth));
  // Cyclone's access-control plugin reads domain ids up to 230 in governance and permissions
  if (security.enabled() && domain_id > 230)
    throw InputError(Str("dds.domain_id must be in 0..230 with DDS Security, got ", domain_id));
  security.Validate();
}

Participant::Participant(const TransportConfig& config) : config_(config) {
  config_.Validate();
  domain_ = CreateDomain(config_.domain_id, config_.config_file);
  if (config_.security.enabled()) {
    dds_qos_t* qos = dds_create_qos();
    SetSecurityProperties(config_.security, qos);
    try {
      participant_ = CreateSecureParticipant(config_.domain_id, config_.security, qos);
    } catch (...) {
      dds_delete_qos(qos);
      if (domain_ > 0) dds_delete(domain_);
      throw;
    }
    dds_delete_qos(qos);
  } else {
    participant_ =
        Checked(dds_create_participant(config_.domain_id, nullptr, nullptr), "create participant");
  }
  dds_qos_t* qos = dds_create_qos();
  dds_qset_partition1(qos, config_.partition.c_str());
  publisher_ = dds_create_publisher(participant_, qos, nullptr);
  subscriber_ = dds_create_subscriber(participant_, qos, nullptr);
  dds_delete_qos(qos);
  Checked(publisher_, "create publisher");
  Checked(subscriber_, "create subscriber");
}

Participant::~Participant() {
  dds_delete(participant_);
  if (domain_ > 0) dds_delete(domain_);
}

int32_t Participant::TopicFor(const void* descriptor, const char* name) {
  for (const auto& [d, t] : topics_)
    if (d == descriptor) return t;
  const dds_entity_t topic = dds_create_topic(
      participant_, static_cast<const dds_topic_descriptor_t*>(descriptor), name, nullptr, nullptr);
  if (topic == DDS_RETCODE_NOT_ALLOWED_BY_SECURITY)
    throw InputError(PermissionDenied(config_.security, "using", name));
  Checked(topic, "create topic");
  topics_.emplace_back(descriptor, topic);
  return topic;
}

template <typename Sample>
struct Writer<Sample>::Scratch {
  typename MessageTraits<Sample>::Msg msg{};
  ConvertScratch convert;
};

namespace {

// a 64-bit FNV-1a digest of a GUID (16 bytes): the identity of a participant, the same on
// every machine that sees it
uint64_t GuidId(const dds_guid_t& guid) {
  uint64_t h = 14695981039346656037ull;
  for (const uint8_t byte : guid.v) {
    h ^= byte;
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace

template <typename Sample>
Writer<Sample>::Writer(Participant& participant, Qos qos) : scratch_(std::make_unique<Scratch>()) {
  using Traits = MessageTraits<Sample>;
  const int32_t topic = participant.TopicFor(Traits::descriptor(), Traits::kTopic);
  dds_qos_t* q = MakeQos(participant.config(), qos, /*writer=*/true);
  writer_ = dds_create_writer(participant.publisher(), topic, q, nullptr);
  dds_delete_qos(q);
  if (writer_ == DDS_RETCODE_NOT_ALLOWED_BY_SECURITY)
    throw InputError(PermissionDenied(participant.config().security, "publishing", Traits::kTopic));
  Checked(writer_, "create writer");
}

template <typename Sample>
Writer<Sample>::~Writer() {
  dds_delete(writer_);
}

template <typename Sample>
void Writer<Sample>::Write(const Sample& sample) {
  ToMessage(sample, scratch_->msg, scratch_->convert);
  scratch_->msg.stamp.wall_time_ns = WallTimeNs();
  Checked(dds_write(writer_, &scratch_->msg), "write");
}

template <typename Sample>
int Writer<Sample>::matched_readers() const {
  dds_publication_matched_status_t st;
  Checked(dds_get_publication_matched_status(writer_, &st), "get publication matched status");
  return static_cast<int>(st.current_count);
}

template <typename Sample>
bool Writer<Sample>::WaitForReaders(int count, double timeout_s) const {
  const double deadline = MonotonicSeconds() + timeout_s;
  while (matched_readers() < count) {
    if (MonotonicSeconds() > deadline) return false;
    dds_sleepfor(DDS_MSECS(5));
  }
  return true;
}

template <typename Sample>
bool Writer<Sample>::WaitForAcks(double timeout_s) const {
  return dds_wait_for_acks(writer_, ToDuration(timeout_s)) == DDS_RETCODE_OK;
}

template <typename Sample>
Reader<Sample>::Reader(Participant& participant, Qos qos) {
  using Traits = MessageTraits<Sample>;
  const int32_t topic = participant.TopicFor(Traits::descriptor(), Traits::kTopic);
  dds_qos_t* q = MakeQos(participant.config(), qos, /*writer=*/false);
  reader_ = dds_create_reader(participant.subscriber(), topic, q, nullptr);
  dds_delete_qos(q);
  if (reader_ == DDS_RETCODE_NOT_ALLOWED_BY_SECURITY)
    throw InputError(
        PermissionDenied(participant.config().security, "subscribing to", Traits::kTopic));
  Checked(reader_, "create reader");
  Checked(dds_set_status_mask(reader_, DDS_DATA_AVAILABLE_STATUS | DDS_LIVELINESS_CHANGED_STATUS |
                                           DDS_REQUESTED_DEADLINE_MISSED_STATUS |
                                           DDS_SUBSCRIPTION_MATCHED_STATUS),
          "set status mask");
  waitset_ = Checked(dds_create_waitset(participant.handle()), "create waitset");
  Checked(dds_waitset_attach(waitset_, reader_, reader_), "attach reader");
}

template <typename Sample>
Reader<Sample>::~Reader() {
  dds_delete(waitset_);
  dds_delete(reader_);
}

template <typename Sample>
bool Reader<Sample>::Wait(double timeout_s) {
  // not ToDuration: there a duration <= 0 means "none" (infinite); here it means "do not block"
  return dds_waitset_wait(waitset_, nullptr, 0,
                          timeout_s > 0 ? static_cast<dds_duration_t>(timeout_s * 1e9) : 0) > 0;
}

template <typename Sample>
size_t Reader<Sample>::Take(std::vector<Sample>& out, std::vector<uint64_t>* writers) {
  using Msg = typename MessageTraits<Sample>::Msg;
  constexpr int kBatch = 64;
  size_t taken = 0;
  while (true) {
    void* buf[kBatch] = {};  // loaned take needs null pointers
    dds_sample_info_t info[kBatch];
    const int n = dds_take(reader_, buf, info, kBatch, kBatch);
    if (n < 0) throw std::runtime_error(Str("DDS: take failed: ", dds_strretcode(n)));
    for (int i = 0; i < n; ++i) {
      if (!info[i].valid_data) continue;
      Sample sample;
      const std::string error = FromMessage(*static_cast<const Msg*>(buf[i]), sample);
      if (!error.empty()) {
        ++health_.invalid;
        health_.last_invalid = error;
        continue;
      }
      out.push_back(std::move(sample));
      if (writers) writers->push_back(info[i].publication_handle);
      ++taken;
    }
    if (n > 0) dds_return_loan(reader_, buf, n);
    if (n < kBatch) break;
  }
  return taken;
}

template <typename Sample>
uint64_t Reader<Sample>::ParticipantOfWriter(uint64_t writer) {
  dds_builtintopic_endpoint_t* endpoint = dds_get_matched_publication_data(reader_, writer);
  if (!endpoint) return 0;
  const uint64_t participant = GuidId(endpoint->participant_key);
  dds_builtintopic_free_endpoint(endpoint);
  return participant;
}

template <typename Sample>
std::vector<uint64_t> Reader<Sample>::MatchedWriters() {
  std::vector<dds_instance_handle_t> handles(8);
  while (true) {
    const dds_return_t n = dds_get_matched_publications(reader_, handles.data(), handles.size());
    Checked(n, "get matched publications");
    const bool all = static_cast<size_t>(n) <= handles.size();
    handles.resize(static_cast<size_t>(n));
    if (all) return {handles.begin(), handles.end()};
  }
}

template <typename Sample>
ReaderHealth Reader<Sample>::health() {
  dds_liveliness_changed_status_t live;
  Checked(dds_get_liveliness_changed_status(reader_, &live), "get liveliness status");
  health_.writers_alive = static_cast<int>(live.alive_count);
  if (live.not_alive_count_change > 0) health_.liveliness_lost += live.not_alive_count_change;
  if (live.alive_count_change < 0) health_.writers_gone += -live.alive_count_change;
  health_.alive_change = live.alive_count_change;
  health_.not_alive_change = live.not_alive_count_change;
  health_.last_changed_writer = live.last_publication_handle;
  dds_requested_deadline_missed_status_t dl;
  Checked(dds_get_requested_deadline_missed_status(reader_, &dl), "get deadline status");
  health_.deadline_missed = dl.total_count;
  dds_subscription_matched_status_t sm;
  Checked(dds_get_subscription_matched_status(reader_, &sm), "get subscription matched status");
  health_.writers_matched = static_cast<int>(sm.current_count);
  return health_;
}

template class Writer<SensorFrame>;
template class Writer<RobotTarget>;
template class Writer<SimStatus>;
template class Reader<SensorFrame>;
template class Reader<RobotTarget>;
template class Reader<SimStatus>;

std::optional<SimStatus> WaitForPeerRunning(Reader<SimStatus>& reader, const std::string& self,
                                            double timeout_s, uint64_t* participant) {
  const double end = MonotonicSeconds() + timeout_s;
  std::vector<SimStatus> statuses;
  std::vector<uint64_t> writers;
  while (true) {
    statuses.clear();
    writers.clear();
    reader.Take(statuses, &writers);
    for (size_t i = 0; i < statuses.size(); ++i) {
      const SimStatus& s = statuses[i];
      if (s.sender != self && (s.state == RunState::kRunning || s.state == RunState::kFailed)) {
        if (participant) *participant = reader.ParticipantOfWriter(writers[i]);
        return s;
      }
    }
    const double left = end - MonotonicSeconds();
    if (left <= 0) return std::nullopt;
    reader.Wait(std::min(0.02, left));
  }
}

uint64_t ParticipantId(const Participant& participant) {
  dds_guid_t guid;
  Checked(dds_get_guid(participant.handle(), &guid), "get participant GUID");
  return GuidId(guid);
}

}  // namespace nsim::transport
