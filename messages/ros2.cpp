#include "messages/ros2.h"

#include <dds/dds.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "common/core/clock.h"
#include "common/core/error.h"
#include "messages/dds_util.h"
#include "messages/ros2_convert.h"

namespace nsim::transport {
namespace {

// ROS 2's default QoS profile (rmw_qos_profile_default): reliable, volatile, keep last 10; the
// same on both sides, so any ROS 2 node with default QoS matches
dds_qos_t* MakeRos2Qos() {
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 10);
  return q;
}

// A participant on the ROS 2 domain; its default publisher and subscriber have no partition
// (ROS 2 uses none).
class Ros2Participant {
 public:
  explicit Ros2Participant(const Ros2Config& config) : config_(config) {
    config_.Validate();
    domain_ = CreateDomain(config_.domain_id, config_.config_file);
    participant_ =
        Checked(dds_create_participant(config_.domain_id, nullptr, nullptr), "create participant");
  }
  ~Ros2Participant() {
    dds_delete(participant_);
    if (domain_ > 0) dds_delete(domain_);
  }
  Ros2Participant(const Ros2Participant&) = delete;
  Ros2Participant& operator=(const Ros2Participant&) = delete;

  const Ros2Config& config() const { return config_; }
  dds_entity_t handle() const { return participant_; }

  // a writer (or reader) on the DDS topic of ROS 2 topic `name`; nothing when !enabled
  dds_entity_t Writer(const dds_topic_descriptor_t& type, const char* name, bool enabled = true) {
    if (!enabled) return 0;
    dds_qos_t* q = MakeRos2Qos();
    const dds_entity_t w = dds_create_writer(participant_, Topic(type, name), q, nullptr);
    dds_delete_qos(q);
    return Checked(w, "create ROS 2 writer");
  }
  dds_entity_t Reader(const dds_topic_descriptor_t& type, const char* name) {
    dds_qos_t* q = MakeRos2Qos();
    const dds_entity_t r = dds_create_reader(participant_, Topic(type, name), q, nullptr);
    dds_delete_qos(q);
    return Checked(r, "create ROS 2 reader");
  }

 private:
  dds_entity_t Topic(const dds_topic_descriptor_t& type, const char* name) {
    const std::string dds_name = std::string("rt") + name;  // the ROS 2 topic prefix
    return Checked(dds_create_topic(participant_, &type, dds_name.c_str(), nullptr, nullptr),
                   "create ROS 2 topic");
  }

  Ros2Config config_;
  dds_entity_t domain_ = 0, participant_ = 0;
};

void Write(dds_entity_t writer, const void* msg) {
  if (writer > 0) Checked(dds_write(writer, msg), "ROS 2 write");
}

// Takes every valid sample of `reader` (message type Msg) and calls on(msg) for each.
template <typename Msg, typename F>
void TakeAll(dds_entity_t reader, F&& on) {
  constexpr int kBatch = 16;
  while (true) {
    void* buf[kBatch] = {};  // loaned take needs null pointers
    dds_sample_info_t info[kBatch];
    const int n = dds_take(reader, buf, info, kBatch, kBatch);
    if (n < 0) throw std::runtime_error(Str("DDS: take failed: ", dds_strretcode(n)));
    for (int i = 0; i < n; ++i)
      if (info[i].valid_data) on(*static_cast<const Msg*>(buf[i]));
    if (n > 0) dds_return_loan(reader, buf, n);
    if (n < kBatch) break;
  }
}

}  // namespace

const std::vector<std::string>& Ros2JointNames() {
  static const std::vector<std::string> names = {"a1", "a2", "a3", "a4", "a5", "a6", "a7"};
  return names;
}

void Ros2Config::Validate() const {
  if (domain_id < 0 || domain_id > 232)
    throw InputError(Str("ROS 2 domain id must be in 0..232, got ", domain_id));
  if (!config_file.empty() && !std::filesystem::is_regular_file(config_file))
    throw InputError(Str("dds.config_file: no such file '", config_file, "'"));
  if (frame_id.empty()) throw InputError("ROS 2 frame_id must not be empty");
  if (wait_subscribers < 0 || wait_subscribers > 1000)
    throw InputError(Str("--ros2-wait must be in 0..1000, got ", wait_subscribers));
}

Ros2Config Ros2ConfigFor(const TransportConfig& transport, bool domain_given) {
  Ros2Config c;
  c.config_file = transport.config_file;
  if (domain_given) {
    c.domain_id = transport.domain_id;
  } else if (const char* env = std::getenv("ROS_DOMAIN_ID"); env && *env) {
    char* end = nullptr;
    const long id = std::strtol(env, &end, 10);
    if (*end != '\0' || id < 0 || id > 232)
      throw InputError(Str("ROS_DOMAIN_ID must be a domain id 0..232, got '", env, "'"));
    c.domain_id = static_cast<int>(id);
  }
  c.Validate();
  return c;
}

struct Ros2Mirror::Impl {
  Impl(const Ros2Config& config, const Ros2MirrorTopics& t)
      : participant(config),
        markers(participant.Writer(geometry_msgs_msg_dds__PoseArray__desc, ros2_topic::kMarkers,
                                   t.frames)),
        robot_pose(participant.Writer(geometry_msgs_msg_dds__PoseStamped__desc,
                                      ros2_topic::kRobotPose, t.frames)),
        joint_states(participant.Writer(sensor_msgs_msg_dds__JointState__desc,
                                        ros2_topic::kJointStates, t.frames)),
        entry_point(participant.Writer(geometry_msgs_msg_dds__PointStamped__desc,
                                       ros2_topic::kEntryPoint, t.frames)),
        target_pose(participant.Writer(geometry_msgs_msg_dds__PoseStamped__desc,
                                       ros2_topic::kTargetPose, t.targets)),
        joint_command(participant.Writer(sensor_msgs_msg_dds__JointState__desc,
                                         ros2_topic::kJointCommand,
                                         t.targets && t.joint_command)),
        distance(participant.Writer(std_msgs_msg_dds__Float64__desc, ros2_topic::kTipToTarget,
                                    t.distance)) {}

  // the writer of ROS 2 topic `topic`, 0 when there is none
  dds_entity_t WriterOf(std::string_view topic) const {
    const std::pair<const char*, dds_entity_t> writers[] = {
        {ros2_topic::kMarkers, markers},         {ros2_topic::kRobotPose, robot_pose},
        {ros2_topic::kJointStates, joint_states}, {ros2_topic::kEntryPoint, entry_point},
        {ros2_topic::kTargetPose, target_pose},   {ros2_topic::kJointCommand, joint_command},
        {ros2_topic::kTipToTarget, distance}};
    for (const auto& [name, writer] : writers)
      if (topic == name) return writer;
    return 0;
  }

  Ros2Participant participant;
  dds_entity_t markers, robot_pose, joint_states, entry_point, target_pose, joint_command,
      distance;
  Ros2Scratch scratch;
};

Ros2Mirror::Ros2Mirror(const Ros2Config& config, const Ros2MirrorTopics& topics)
    : impl_(std::make_unique<Impl>(config, topics)) {}

Ros2Mirror::~Ros2Mirror() = default;

void Ros2Mirror::PublishFrame(const SensorFrame& frame) {
  Impl& m = *impl_;
  const std::string& frame_id = m.participant.config().frame_id;
  const double t = frame.stamp.sim_time;
  geometry_msgs_msg_dds__PoseArray_ markers{};
  ToRos2Markers(t, frame.p_WM, frame_id, markers, m.scratch);
  Write(m.markers, &markers);
  if (!frame.has_robot) return;
  geometry_msgs_msg_dds__PoseStamped_ pose{};
  ToRos2Pose(t, frame.X_WE, frame_id, pose);
  Write(m.robot_pose, &pose);
  if (!frame.q.empty()) {
    sensor_msgs_msg_dds__JointState_ joints{};
    ToRos2Joints(t, frame.q, frame_id, joints, m.scratch);
    Write(m.joint_states, &joints);
  }
  if (frame.entry_punctured) {
    geometry_msgs_msg_dds__PointStamped_ entry{};
    ToRos2Point(t, frame.p_WP, frame_id, entry);
    Write(m.entry_point, &entry);
  }
}

void Ros2Mirror::PublishTarget(const RobotTarget& target) {
  Impl& m = *impl_;
  const std::string& frame_id = m.participant.config().frame_id;
  geometry_msgs_msg_dds__PoseStamped_ pose{};
  ToRos2Pose(target.stamp.sim_time, target.X_WE, frame_id, pose);
  Write(m.target_pose, &pose);
  if (target.mode == TargetMode::kJoint && !target.q.empty()) {
    sensor_msgs_msg_dds__JointState_ joints{};
    ToRos2Joints(target.stamp.sim_time, target.q, frame_id, joints, m.scratch);
    Write(m.joint_command, &joints);
  }
}

void Ros2Mirror::PublishDistance(double distance_m) {
  std_msgs_msg_dds__Float64_ msg{distance_m};
  Write(impl_->distance, &msg);
}

int Ros2Mirror::subscribers(const char* topic) const {
  const dds_entity_t w = impl_->WriterOf(topic);
  if (w <= 0) return 0;
  dds_publication_matched_status_t st;
  Checked(dds_get_publication_matched_status(w, &st), "get matched status");
  return static_cast<int>(st.current_count);
}

std::string Ros2Mirror::WaitForSubscribers(int count, const std::vector<const char*>& topics,
                                           double timeout_s) const {
  const double deadline = MonotonicSeconds() + timeout_s;
  for (const char* topic : topics)
    while (subscribers(topic) < count) {
      if (MonotonicSeconds() > deadline) return topic;
      dds_sleepfor(DDS_MSECS(5));
    }
  return "";
}

bool Ros2Mirror::WaitForAcks(double timeout_s) const {
  const Impl& m = *impl_;
  bool ok = true;
  for (dds_entity_t w : {m.markers, m.robot_pose, m.joint_states, m.entry_point, m.target_pose,
                         m.joint_command, m.distance})
    if (w > 0) ok = dds_wait_for_acks(w, ToDuration(timeout_s)) == DDS_RETCODE_OK && ok;
  return ok;
}

struct Ros2Input::Impl {
  Impl(const Ros2Config& config, const Eigen::Vector3d& normal, size_t joints)
      : participant(config),
        entry_normal(normal),
        joints_required(joints),
        markers(participant.Reader(geometry_msgs_msg_dds__PoseArray__desc, ros2_topic::kMarkers)),
        robot_pose(participant.Reader(geometry_msgs_msg_dds__PoseStamped__desc,
                                      ros2_topic::kRobotPose)),
        joint_states(participant.Reader(sensor_msgs_msg_dds__JointState__desc,
                                        ros2_topic::kJointStates)),
        entry_point(participant.Reader(geometry_msgs_msg_dds__PointStamped__desc,
                                       ros2_topic::kEntryPoint)) {
    waitset = Checked(dds_create_waitset(participant.handle()), "create waitset");
    for (dds_entity_t r : {markers, robot_pose, joint_states, entry_point}) {
      Checked(dds_set_status_mask(r, DDS_DATA_AVAILABLE_STATUS), "set status mask");
      Checked(dds_waitset_attach(waitset, r, r), "attach reader");
    }
  }
  ~Impl() { dds_delete(waitset); }

  void Invalid(const std::string& why) {
    ++counts.invalid;
    counts.last_invalid = why;
  }

  // the newest robot state and entry point (their own stamps are not used: a frame is
  // stamped with its markers' time)
  void TakeRobot() {
    const std::string& frame_id = participant.config().frame_id;
    double t = 0;
    TakeAll<geometry_msgs_msg_dds__PoseStamped_>(robot_pose, [&](const auto& msg) {
      Eigen::Isometry3d X;
      if (auto e = FromRos2Pose(msg, frame_id, &t, &X); !e.empty()) return Invalid(e);
      X_WE = X;
      ++counts.robot_poses;
    });
    TakeAll<sensor_msgs_msg_dds__JointState_>(joint_states, [&](const auto& msg) {
      std::vector<double> joints;
      if (auto e = FromRos2Joints(msg, &joints); !e.empty()) return Invalid(e);
      if (joints_required > 0 && joints.size() != joints_required)
        return Invalid(Str(ros2_topic::kJointStates, ": ", joints.size(),
                           " positions, the controller's robot has ", joints_required));
      q = std::move(joints);
      ++counts.joint_states;
    });
    TakeAll<geometry_msgs_msg_dds__PointStamped_>(entry_point, [&](const auto& msg) {
      Eigen::Vector3d p;
      if (auto e = FromRos2Point(msg, frame_id, &t, &p); !e.empty()) return Invalid(e);
      p_WP = p;
      ++counts.entry_points;
    });
  }

  Ros2Participant participant;
  Eigen::Vector3d entry_normal;
  size_t joints_required;
  dds_entity_t markers, robot_pose, joint_states, entry_point, waitset = 0;
  std::optional<Eigen::Isometry3d> X_WE;
  std::vector<double> q;
  std::optional<Eigen::Vector3d> p_WP;
  Ros2InputCounts counts;
};

Ros2Input::Ros2Input(const Ros2Config& config, const Eigen::Vector3d& entry_normal_W,
                     size_t joints_required)
    : impl_(std::make_unique<Impl>(config, entry_normal_W.normalized(), joints_required)) {}

Ros2Input::~Ros2Input() = default;

bool Ros2Input::Wait(double timeout_s) {
  return dds_waitset_wait(impl_->waitset, nullptr, 0, ToDuration(timeout_s)) > 0;
}

size_t Ros2Input::Take(std::vector<SensorFrame>& out) {
  Impl& m = *impl_;
  // the robot first: markers that arrived together with a robot pose get that pose
  m.TakeRobot();
  size_t made = 0;
  TakeAll<geometry_msgs_msg_dds__PoseArray_>(m.markers, [&](const auto& msg) {
    SensorFrame frame;
    if (auto e = FromRos2Markers(msg, m.participant.config().frame_id, &frame.stamp.sim_time,
                                 &frame.p_WM);
        !e.empty())
      return m.Invalid(e);
    ++m.counts.markers;
    if (!m.X_WE || (m.joints_required > 0 && m.q.size() != m.joints_required)) {
      ++m.counts.incomplete;
      return;
    }
    frame.stamp.seq = m.counts.frames++;
    frame.stamp.wall_time_ns = WallTimeNs();
    frame.has_robot = true;
    frame.X_WE = *m.X_WE;
    frame.q = m.q;
    frame.entry_punctured = m.p_WP.has_value();
    if (m.p_WP) frame.p_WP = *m.p_WP;
    frame.n_W = m.entry_normal;
    frame.applied_seq = SensorFrame::kNoTarget;
    out.push_back(std::move(frame));
    ++made;
  });
  return made;
}

Ros2InputCounts Ros2Input::counts() const {
  Ros2InputCounts c = impl_->counts;
  dds_subscription_matched_status_t st;
  Checked(dds_get_subscription_matched_status(impl_->markers, &st), "get matched status");
  c.marker_publishers = static_cast<int>(st.current_count);
  return c;
}

}  // namespace nsim::transport
