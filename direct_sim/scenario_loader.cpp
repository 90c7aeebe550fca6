#include "direct_sim/scenario_loader.h"

#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/scenario/shared_scenario.h"
#include "direct_sim/scenario_sections.h"

namespace nsim {
namespace {

const std::vector<std::string> kOwnSections = {"random_seed", "shared", "patient",   "breathing",
                                               "needle",      "robot",  "insertion", "safety",
                                               "run",         "view",   "dds",       "watchdog",
                                               "tracker"};

std::string DirName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}

// the shared facts into the direct configs: one source for both processes
void ApplyShared(const SharedScenario& shared, DirectScenario* s) {
  PatientSceneConfig& c = s->scene;
  c.markers_W = shared.markers_W;
  c.entry_W = shared.entry_W;
  c.target_W = shared.target_W;
  for (NeedleConfig* g : {&c.needle.rigid, &c.needle.flexible.needle}) {
    g->length = shared.needle_length;
    g->radius = shared.needle_radius;
    g->p_FBase = shared.tool_offset_F;
    g->axis_F = shared.axis_F;
  }
  s->insertion.approach_distance = shared.approach_distance;
  s->robot.iiwa.X_WB = shared.X_WB;
}

// the gate enforces the robot's limits
void CopyRobotLimits(const RobotDriverConfig& robot, TargetGateConfig* safety) {
  safety->max_linear_speed = robot.cartesian.max_linear_speed;
  safety->max_angular_speed = robot.cartesian.max_angular_speed;
  safety->workspace_min_W = robot.cartesian.workspace_min_W;
  safety->workspace_max_W = robot.cartesian.workspace_max_W;
  if (robot.kind == RobotKind::kIiwa) {
    const Iiwa14Config& iiwa = robot.iiwa;
    safety->joint_lower.assign(iiwa.position_lower.data(), iiwa.position_lower.data() + 7);
    safety->joint_upper.assign(iiwa.position_upper.data(), iiwa.position_upper.data() + 7);
    safety->joint_velocity.assign(iiwa.velocity_limit.data(), iiwa.velocity_limit.data() + 7);
  }
}

// every value checked, with the file named
void ValidateScenario(const DirectScenario& s) {
  const std::string& src = s.source;
  ValidateAs([&] { s.scene.Validate(); }, src, "", "");
  ValidateAs([&] { s.robot.Validate(); }, src, "", "");
  ValidateAs([&] { s.insertion.Validate(); }, src, "", "");
  ValidateAs([&] { s.safety.Validate(); }, src, "", "");
  ValidateAs([&] { s.run.Validate(); }, src, "", "");
  ValidateAs([&] { s.watchdog.Validate(); }, src, "", "");
  ValidateAs([&] { s.tracker.Validate(); }, src, "", "");
  ValidateAs([&] { s.view.Validate(); }, src, "", "");
  if (s.dds_domain < 0 || s.dds_domain > 232)
    throw InputError(Str(src, ": dds.domain must be in [0, 232], got ", s.dds_domain));
  ValidateAs([&] { CheckName(s.dds_partition, kMaxPartitionLength, "dds.partition"); }, src, "",
             "");
  ValidateAs([&] { CheckInsertion(s.insertion); }, src, "", "");
  ValidateAs([&] { CheckStepCount(s.run.duration, s.scene.time_step); }, src, "", "");
}

}  // namespace

void CheckInsertion(const InsertionConfig& insertion) {
  // needle insertion speeds are 1..100 mm/s (a biopsy gun fires at ~ 10 m/s but is no robot):
  // 0.5 m/s is above any robot in tissue; overshoot and approach are cm, never half a metre
  CheckAtMost(insertion.speed, 0.5, "insertion.speed", "m/s");
  CheckRange(insertion.overshoot, -0.5, 0.5, "insertion.overshoot", "m");
  CheckAtMost(insertion.approach_distance, 1.0, "insertion.approach_distance", "m");
}

void CheckStepCount(double duration, double time_step) {
  // one run at most 1e6 physics steps: 5.5 h of simulated time at 20 ms, over 2 h of wall
  // time at the 8 ms of a step of the 2656-node liver
  const double steps = duration / time_step;
  if (!(steps <= kMaxRunSteps))
    throw InputError(Str("run.duration / patient.time_step must be at most ", kMaxRunSteps,
                         " steps, got ", duration, " s / ", time_step, " s = ", steps, " steps"));
}

void RunConfig::Validate() const {
  if (!(duration > 0) || !std::isfinite(duration))
    throw InputError(Str("run.duration must be > 0 (s), got ", duration));
  if (latency_steps < 0)
    throw InputError(Str("run.latency_steps must be >= 0, got ", latency_steps));
  if (!(lockstep_timeout > 0))
    throw InputError(Str("run.lockstep_timeout must be > 0 (s), got ", lockstep_timeout));
  if (!(start_timeout > 0))
    throw InputError(Str("run.start_timeout must be > 0 (s), got ", start_timeout));
  if (vtk_every < 0) throw InputError(Str("run.vtk_every must be >= 0, got ", vtk_every));
  if (view_every < 1) throw InputError(Str("run.view_every must be >= 1, got ", view_every));
  if (!(status_period > 0))
    throw InputError(Str("run.status_period must be > 0 (s), got ", status_period));
  if (!(takeover_timeout > 0))
    throw InputError(Str("run.takeover_timeout must be > 0 (s), got ", takeover_timeout));
  if (rt_priority < 0 || rt_priority > 99)
    throw InputError(Str("run.rt_priority must be 0 (the normal class) or a SCHED_FIFO priority "
                         "in [1, 99], got ", rt_priority));
  // Upper bounds: a simulated hour is 180,000 steps at 20 ms (the step count is bounded
  // separately); a latency of 1000 steps is 20 s, more than the run's breathing cycles; a
  // peer silent for 10 min (lockstep) or an hour (start) is gone; statuses every minute at
  // least; a snapshot or view every 1e6 steps is never.
  CheckAtMost(duration, 3600.0, "run.duration", "s");
  CheckAtMost(latency_steps, 1000, "run.latency_steps", "steps");
  CheckAtMost(lockstep_timeout, 600.0, "run.lockstep_timeout", "s");
  CheckAtMost(start_timeout, 3600.0, "run.start_timeout", "s");
  CheckAtMost(vtk_every, 1e6, "run.vtk_every", "steps");
  CheckAtMost(view_every, 1e6, "run.view_every", "steps");
  CheckAtMost(status_period, 60.0, "run.status_period", "s");
  CheckAtMost(takeover_timeout, 3600.0, "run.takeover_timeout", "s");
}

const std::vector<std::string>& OtherProcessSections() {
  static const std::vector<std::string> sections = {"controller", "prediction", "inverse"};
  return sections;
}

DirectScenario ParseDirectScenario(const YamlReader& root, const std::string& base_dir) {
  if (!root.IsMap()) root.Fail("expected a map of sections (patient, breathing, needle, ...)");
  std::vector<std::string> known = kOwnSections;
  known.insert(known.end(), OtherProcessSections().begin(), OtherProcessSections().end());
  root.CheckKeys(known);

  DirectScenario s;
  s.source = root.source();
  s.shared = ReadSharedScenario(root);
  s.scenario_hash = ScenarioHash(s.shared);
  root.Read("random_seed", &s.random_seed);
  direct_sections::ReadPatient(root.Child("patient"), base_dir, &s);
  direct_sections::ReadBreathing(root.OptionalChild("breathing"), s.random_seed,
                                 &s.scene.breathing);
  if (root.Has("needle")) direct_sections::ReadNeedle(root.Child("needle"), &s.scene.needle);
  if (root.Has("robot")) direct_sections::ReadRobot(root.Child("robot"), &s.robot);
  if (root.Has("insertion")) direct_sections::ReadInsertion(root.Child("insertion"), &s.insertion);
  if (root.Has("safety")) direct_sections::ReadSafety(root.Child("safety"), &s.safety);
  if (root.Has("run")) direct_sections::ReadRun(root.Child("run"), &s.run);
  if (root.Has("watchdog")) direct_sections::ReadWatchdog(root.Child("watchdog"), &s.watchdog);
  if (root.Has("tracker")) direct_sections::ReadTracker(root.Child("tracker"), &s.tracker);
  if (root.Has("view")) direct_sections::ReadView(root.Child("view"), &s.view);
  if (root.Has("dds")) direct_sections::ReadDds(root.Child("dds"), &s.dds_domain, &s.dds_partition);

  ApplyShared(s.shared, &s);
  CopyRobotLimits(s.robot, &s.safety);
  ValidateScenario(s);
  return s;
}

DirectScenario LoadDirectScenario(const std::string& path) {
  return ParseDirectScenario(YamlReader::LoadFile(path), DirName(path));
}

}  // namespace nsim
