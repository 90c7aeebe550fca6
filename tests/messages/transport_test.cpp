// In-process checks of the transport over loopback: delivery and order, QoS profiles,
// late-joiner status, the peer's running status, dropped invalid samples, and health when a
// writer goes away.
#include "messages/transport.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <future>
#include <limits>

#include "common/core/clock.h"
#include "common/core/error.h"

namespace nsim::transport {
namespace {

TransportConfig LoopbackConfig() {
  TransportConfig c;
  c.config_file = NSIM_SOURCE_DIR "/configs/dds/local.xml";
  c.domain_id = 17;
  c.partition = "transport_test_" + std::to_string(getpid());
  c.liveliness_lease_s = 0.3;
  return c;
}

template <typename Sample>
std::vector<Sample> TakeUntil(Reader<Sample>& reader, size_t count, double timeout_s) {
  std::vector<Sample> out;
  const double end = MonotonicSeconds() + timeout_s;
  while (out.size() < count && MonotonicSeconds() < end) {
    reader.Wait(0.05);
    reader.Take(out);
  }
  return out;
}

TEST(Transport, BadConfigIsAnInputError) {
  TransportConfig c = LoopbackConfig();
  c.config_file = "/nonexistent/cyclone.xml";
  EXPECT_THROW(Participant{c}, InputError);
  c = LoopbackConfig();
  c.domain_id = 500;
  EXPECT_THROW(Participant{c}, InputError);
  c = LoopbackConfig();
  c.liveliness_lease_s = -1;
  EXPECT_THROW(Participant{c}, InputError);
  // a 65,535-character partition crashed dds_create_writer: refused before DDS sees it
  for (const std::string& partition : {std::string(65535, 'p'), std::string(65, 'p'),
                                       std::string("a*"), std::string("a b"), std::string()}) {
    c = LoopbackConfig();
    c.partition = partition;
    EXPECT_THROW(Participant{c}, InputError) << partition.size();
  }
  c = LoopbackConfig();
  c.partition = std::string(64, 'p');
  EXPECT_NO_THROW(c.Validate());
  c.liveliness_lease_s = 1e300;
  EXPECT_THROW(c.Validate(), InputError);
}

TEST(Transport, FramesArriveInOrderAndWallTimeIsStamped) {
  Participant p(LoopbackConfig());
  Reader<SensorFrame> reader(p, Qos::kLossless);
  Writer<SensorFrame> writer(p, Qos::kStateStream);
  ASSERT_TRUE(writer.WaitForReaders(1, 10.0));
  const int64_t before = WallTimeNs();
  for (int k = 0; k < 50; ++k) {
    SensorFrame f;
    f.stamp.seq = k;
    f.stamp.sim_time = 0.01 * k;
    f.p_WM = {{k * 1e-3, 0, 0}};
    writer.Write(f);
  }
  const auto got = TakeUntil(reader, 50, 10.0);
  ASSERT_EQ(got.size(), 50u);
  for (int k = 0; k < 50; ++k) {
    EXPECT_EQ(got[k].stamp.seq, static_cast<uint64_t>(k));
    EXPECT_EQ(got[k].p_WM[0].x(), k * 1e-3);
    EXPECT_GE(got[k].stamp.wall_time_ns, before);
  }
  EXPECT_TRUE(writer.WaitForAcks(5.0));
}

// A wait of 0 (or less) polls: it once meant "forever" (the duration's "none"), and a caller
// whose deadline had just passed blocked until the next sample, or for good after the last
// one (inverse_sim --link-delay hung at the end of a run). A wait still blocked after 10 s is
// released by a sample, so that the test ends either way.
TEST(Transport, AWaitOfZeroOrLessDoesNotBlock) {
  Participant p(LoopbackConfig());
  Reader<SensorFrame> reader(p, Qos::kLossless);
  Writer<SensorFrame> writer(p, Qos::kStateStream);
  ASSERT_TRUE(writer.WaitForReaders(1, 10.0));
  // the match and the writer's liveliness trigger the wait until health() reads them
  int triggers = 0;
  while (reader.Wait(0.2) && ++triggers < 20) reader.health();
  ASSERT_LT(triggers, 20) << "the reader's wait stays triggered";
  for (const double timeout : {0.0, -1.0}) {
    auto waited = std::async(std::launch::async, [&reader, timeout] { return reader.Wait(timeout); });
    const bool returned = waited.wait_for(std::chrono::seconds(10)) == std::future_status::ready;
    if (!returned) writer.Write(SensorFrame{});
    EXPECT_TRUE(returned) << "Wait(" << timeout << ") blocked with no sample to take";
    EXPECT_FALSE(waited.get()) << "Wait(" << timeout << ") saw a sample";
  }
}

TEST(Transport, LateJoinerGetsTheLastStatus) {
  Participant p(LoopbackConfig());
  Writer<SimStatus> writer(p, Qos::kStatus);
  SimStatus s;
  s.sender = "direct_sim";
  s.state = RunState::kRunning;
  writer.Write(s);
  s.state = RunState::kFinished;
  s.last_seq = 12;
  writer.Write(s);
  Reader<SimStatus> reader(p, Qos::kStatus);  // created after both writes
  const auto got = TakeUntil(reader, 1, 10.0);
  ASSERT_EQ(got.size(), 1u);  // keep-last 1: only the newest
  EXPECT_EQ(got[0].state, RunState::kFinished);
  EXPECT_EQ(got[0].last_seq, 12u);
}

TEST(Transport, PeerRunningIsAnotherProcessSayingRunning) {
  Participant p(LoopbackConfig());
  Writer<SimStatus> writer(p, Qos::kStatus);
  Reader<SimStatus> reader(p, Qos::kStatus);
  ASSERT_TRUE(writer.WaitForReaders(1, 10.0));
  SimStatus s;
  s.sender = "direct_sim";
  s.state = RunState::kRunning;
  writer.Write(s);  // our own status does not count
  EXPECT_FALSE(WaitForPeerRunning(reader, "direct_sim", 0.2));
  s.sender = "inverse_sim";
  s.state = RunState::kStarting;  // its readers have not matched yet
  writer.Write(s);
  EXPECT_FALSE(WaitForPeerRunning(reader, "direct_sim", 0.2));
  s.state = RunState::kRunning;
  s.scenario_hash = 77;
  writer.Write(s);
  const double start = MonotonicSeconds();
  const std::optional<SimStatus> peer = WaitForPeerRunning(reader, "direct_sim", 5.0);
  ASSERT_TRUE(peer.has_value());
  EXPECT_EQ(peer->scenario_hash, 77u);  // the caller checks the peer runs its scenario
  EXPECT_LT(MonotonicSeconds() - start, 5.0);
}

TEST(Transport, InvalidSamplesAreDroppedAndCounted) {
  Participant p(LoopbackConfig());
  Reader<SensorFrame> reader(p, Qos::kLossless);
  Writer<SensorFrame> writer(p, Qos::kStateStream);
  ASSERT_TRUE(writer.WaitForReaders(1, 10.0));
  SensorFrame f;
  f.p_WM = {{std::numeric_limits<double>::quiet_NaN(), 0, 0}};
  writer.Write(f);
  f.stamp.seq = 1;
  f.p_WM = {{1, 2, 3}};
  writer.Write(f);
  const auto got = TakeUntil(reader, 1, 10.0);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].stamp.seq, 1u);
  const ReaderHealth h = reader.health();
  EXPECT_EQ(h.invalid, 1u);
  EXPECT_NE(h.last_invalid.find("not finite"), std::string::npos);
}

TEST(Transport, ReaderSeesWriterComeAndGo) {
  Participant p(LoopbackConfig());
  Reader<RobotTarget> reader(p, Qos::kTarget);
  {
    Writer<RobotTarget> writer(p, Qos::kTarget);
    ASSERT_TRUE(writer.WaitForReaders(1, 10.0));
    writer.Write(RobotTarget{});
    ASSERT_EQ(TakeUntil(reader, 1, 10.0).size(), 1u);
    EXPECT_EQ(reader.health().writers_alive, 1);
  }
  const double end = MonotonicSeconds() + 5.0;
  ReaderHealth h = reader.health();
  while (h.writers_matched > 0 && MonotonicSeconds() < end) {
    reader.Wait(0.05);
    h = reader.health();
  }
  EXPECT_EQ(h.writers_matched, 0);
  EXPECT_EQ(h.writers_alive, 0);
  EXPECT_GE(h.writers_gone, 1u);
}

}  // namespace
}  // namespace nsim::transport
