// The ROS 2 mirror against Fast DDS, an independent DDS implementation (ros2_fastdds_peer,
// built from the same ROS 2 IDL by fastddsgen): the Fast DDS peer receives every frame of
// direct_sim replay --ros2 value for value; it records direct_sim run --ros2 (markers, robot
// pose, joints, distance) and, as a tracker and a robot, plays that record to inverse_sim run
// --ros2-io and receives its targets. Every process is bounded in time and killed by PID.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "child_process.h"
#include "common/markers/marker_csv.h"
#include "test_util.h"

namespace nsim::testing {
namespace {

const std::string kBin = NSIM_BIN_DIR;
const std::string kLocalXml = NSIM_SOURCE_DIR "/configs/dds/local.xml";

// one line of a ros2_fastdds_peer record: kind, header stamp and frame_id, values
struct Line {
  char kind = ' ';
  int64_t sec = 0, nanosec = 0;
  std::string frame_id;
  std::vector<std::string> names;  // J, C
  std::vector<double> values;      // M: n then 7 per pose; P, T: 7; J, C: positions; E: 3; D: 1
  double t() const { return sec + 1e-9 * nanosec; }
};

std::vector<Line> ReadRecord(const std::filesystem::path& path) {
  std::vector<Line> lines;
  std::ifstream in(path);
  for (std::string text; std::getline(in, text);) {
    std::istringstream s(text);
    Line l;
    s >> l.kind;
    if (l.kind != 'D') s >> l.sec >> l.nanosec >> l.frame_id;
    if (l.kind == 'J' || l.kind == 'C') {
      size_t n;
      s >> n;
      l.names.resize(n);
      for (auto& name : l.names) s >> name;
      s >> n;  // then the positions
    }
    for (std::string v; s >> v;) l.values.push_back(std::strtod(v.c_str(), nullptr));
    lines.push_back(l);
  }
  return lines;
}

std::vector<Line> OfKind(const std::vector<Line>& lines, char kind) {
  std::vector<Line> out;
  for (const Line& l : lines)
    if (l.kind == kind) out.push_back(l);
  return out;
}

std::vector<std::string> PeerArgs(const std::string& mode, int domain) {
  return {NSIM_FASTDDS_PEER, mode, "--domain", std::to_string(domain), "--profile",
          NSIM_FASTDDS_PROFILE};
}

std::vector<std::string> NsimArgs(int domain) {
  return {"--dds-config", kLocalXml, "--domain", std::to_string(domain), "--partition",
          "ros2_interop_" + std::to_string(getpid())};
}

TEST(Ros2Interop, FastDdsReceivesEveryReplayedFrameValueForValue) {
  const auto dir = TempDir("ros2_interop_replay");
  const auto csv = dir / "markers.csv";
  ChildProcess breathe({kBin + "/direct_sim", "breathe", "--out", csv.string(), "--duration", "3",
                        "--rate", "30", "--markers", "5", "--seed", "3"},
                       (dir / "breathe.log").string());
  ASSERT_EQ(breathe.Wait(30), 0) << breathe.Output();
  const MarkerStream stream = ReadMarkerCsv(csv.string());
  ASSERT_EQ(stream.frames.size(), 91u);  // t = 0 .. 3 s

  const int domain = 63;
  ChildProcess peer(Cat(PeerArgs("record", domain),
                        {"--out", (dir / "record.txt").string(), "--count", "91", "--timeout", "60"}),
                    (dir / "peer.log").string());
  ChildProcess replay(Cat({kBin + "/direct_sim", "replay", "--markers", csv.string(),
                           "--rate-scale", "2", "--wait-readers", "0", "--ros2", "--ros2-wait",
                           "1", "--wait-timeout", "30", "--quiet"},
                          NsimArgs(domain)),
                      (dir / "replay.log").string());
  ASSERT_EQ(replay.Wait(90), 0) << replay.Output();
  ASSERT_EQ(peer.Wait(30), 0) << peer.Output();

  const std::vector<Line> lines = ReadRecord(dir / "record.txt");
  const std::vector<Line> markers = OfKind(lines, 'M');
  EXPECT_EQ(markers.size(), lines.size()) << "a replay has no robot";
  ASSERT_EQ(markers.size(), stream.frames.size());
  for (size_t k = 0; k < markers.size(); ++k) {
    const Line& m = markers[k];
    const MarkerFrame& f = stream.frames[k];
    const double sec = std::floor(f.stamp.sim_time);
    EXPECT_EQ(m.sec, static_cast<int64_t>(sec)) << k;
    EXPECT_EQ(m.nanosec, std::llround((f.stamp.sim_time - sec) * 1e9)) << k;
    EXPECT_EQ(m.frame_id, "world");
    ASSERT_EQ(m.values.size(), 1 + 7 * f.p_WM.size()) << k;
    EXPECT_EQ(m.values[0], static_cast<double>(f.p_WM.size()));
    for (size_t i = 0; i < f.p_WM.size(); ++i) {
      const double* pose = &m.values[1 + 7 * i];
      for (int c = 0; c < 3; ++c) EXPECT_EQ(pose[c], f.p_WM[i][c]) << k << " " << i << " " << c;
      EXPECT_EQ(pose[3], 0.0);
      EXPECT_EQ(pose[4], 0.0);
      EXPECT_EQ(pose[5], 0.0);
      EXPECT_EQ(pose[6], 1.0);  // identity orientation
    }
  }
}

// the iiwa on the coarse liver, so that joints and joint commands travel too
std::filesystem::path IiwaScenario(const std::filesystem::path& dir) {
  return WriteEditedScenario(dir, "iiwa.yaml", "liver_test_coarse.yaml",
                             {{"type: cartesian ", "type: iiwa "},
                              {"dof: cartesian6 ", "dof: joint7 "}});
}

// the robot pose line with stamp `t`, or nothing
const Line* AtStamp(const std::vector<Line>& lines, const Line& at) {
  for (const Line& l : lines)
    if (l.sec == at.sec && l.nanosec == at.nanosec) return &l;
  return nullptr;
}

TEST(Ros2Interop, FastDdsTrackerAndRobotDriveTheController) {
  const auto dir = TempDir("ros2_interop_loop");
  const auto scenario = IiwaScenario(dir);
  const int domain = 64;

  // 1. direct_sim run --ros2 without a controller, recorded by Fast DDS from its first frame
  // (--ros2-wait: each topic of a frame is discovered on its own, at its own time)
  ChildProcess recorder(Cat(PeerArgs("record", domain),
                            {"--out", (dir / "record.txt").string(), "--idle", "3", "--timeout",
                             "120"}),
                        (dir / "recorder.log").string());
  ChildProcess direct(Cat({kBin + "/direct_sim", "run", "--config", scenario.string(),
                           "--no-controller", "--mode", "realtime", "--duration", "2",
                           "--no-video", "--quiet", "--ros2", "--ros2-wait", "1", "--out",
                           (dir / "direct").string()},
                          NsimArgs(domain)),
                      (dir / "direct.log").string());
  ASSERT_EQ(direct.Wait(150), 0) << direct.Output();
  ASSERT_EQ(recorder.Wait(30), 0) << recorder.Output();
  const std::vector<Line> record = ReadRecord(dir / "record.txt");
  const std::vector<Line> markers = OfKind(record, 'M'), poses = OfKind(record, 'P'),
                          joints = OfKind(record, 'J'), distances = OfKind(record, 'D');
  ASSERT_EQ(markers.size(), 101u);  // 100 steps and the final state
  EXPECT_EQ(poses.size(), markers.size());
  EXPECT_EQ(joints.size(), markers.size());
  EXPECT_EQ(distances.size(), markers.size());
  for (const Line& m : markers) {
    EXPECT_EQ(m.frame_id, "world");
    const Line* p = AtStamp(poses, m);
    ASSERT_NE(p, nullptr) << "a robot pose at every frame's stamp";
    const Line* j = AtStamp(joints, m);
    ASSERT_NE(j, nullptr);
    EXPECT_EQ(j->names, (std::vector<std::string>{"a1", "a2", "a3", "a4", "a5", "a6", "a7"}));
    EXPECT_EQ(j->values.size(), 7u);
    const double qn = std::hypot(std::hypot(p->values[3], p->values[4]),
                                 std::hypot(p->values[5], p->values[6]));
    EXPECT_NEAR(qn, 1.0, 1e-12);
  }
  for (const Line& d : distances) EXPECT_TRUE(d.values.at(0) > 0 && d.values[0] < 0.5);

  // 2. that record played by Fast DDS to inverse_sim run --ros2-io, its targets received
  ChildProcess inverse(Cat({kBin + "/inverse_sim", "run", "--config", scenario.string(),
                            "--ros2-io", "--ros2-idle", "3", "--start-timeout", "60", "--quiet",
                            "--out", (dir / "inverse").string()},
                           NsimArgs(domain)),
                       (dir / "inverse.log").string());
  ChildProcess player(Cat(PeerArgs("play", domain),
                          {"--in", (dir / "record.txt").string(), "--out",
                           (dir / "targets.txt").string(), "--idle", "3", "--timeout", "120"}),
                      (dir / "player.log").string());
  ASSERT_EQ(player.Wait(150), 0) << player.Output();
  ASSERT_EQ(inverse.Wait(60), 0) << inverse.Output();
  const auto summary = nlohmann::json::parse(ReadText(dir / "inverse" / "summary.json"));
  EXPECT_EQ(summary["ending"], "input_idle");
  EXPECT_EQ(summary["transport"], "ros2");
  EXPECT_GE(summary["frames_received"].get<int>(), 1);

  const std::vector<Line> answers = ReadRecord(dir / "targets.txt");
  const std::vector<Line> targets = OfKind(answers, 'T'), commands = OfKind(answers, 'C');
  ASSERT_GE(targets.size(), 5u) << inverse.Output();
  EXPECT_EQ(commands.size(), targets.size());
  // each answers a frame that was sent; the recorded robot never follows the targets (it was
  // inserting on its own), so only the first is near its robot pose, the next ones step on
  // from the previous command
  for (size_t k = 0; k < targets.size(); ++k) {
    const Line& t = targets[k];
    EXPECT_EQ(t.frame_id, "world");
    const Line* p = AtStamp(poses, t);
    ASSERT_NE(p, nullptr) << "target at t = " << t.t();
    ASSERT_EQ(t.values.size(), 7u);
    const std::vector<double>& from = k == 0 ? p->values : targets[k - 1].values;
    const double step = std::hypot(std::hypot(t.values[0] - from[0], t.values[1] - from[1]),
                                   t.values[2] - from[2]);
    EXPECT_LT(step, k == 0 ? 0.02 : 0.01) << "target at t = " << t.t();
    const double qn = std::hypot(std::hypot(t.values[3], t.values[4]),
                                 std::hypot(t.values[5], t.values[6]));
    EXPECT_NEAR(qn, 1.0, 1e-12);
  }
  for (const Line& c : commands) {
    EXPECT_EQ(c.names.size(), 7u);
    EXPECT_EQ(c.values.size(), 7u);
    for (double q : c.values) EXPECT_TRUE(std::isfinite(q) && std::abs(q) < 3.1);
  }
}

}  // namespace
}  // namespace nsim::testing
