#pragma once
// The direct side of a scenario file (YAML -> config structs). The loader owns the sections the
// direct simulation uses and checks every key of them (unknown keys are errors, so typos are
// caught); the sections of the other process (controller, prediction, inverse) are known and
// skipped; any other top-level section is an error. Mesh paths are relative to the scenario
// file's folder. Errors are InputError "<file>: <key path>: <what>".

#include <cstdint>
#include <string>
#include <vector>

#include "common/core/yaml_reader.h"
#include "common/mesh/tet_mesh.h"
#include "common/scenario/shared_scenario.h"
#include "common/scene/patient_loop.h"
#include "common/scene/robot_driver.h"
#include "common/scene/scene_config.h"
#include "common/scene/target_gate.h"
#include "direct_sim/viewer.h"

namespace nsim {

/// How direct_sim paces its steps (DESIGN.md "Time, modes and determinism").
enum class RunMode {
  kRealtime,  ///< wall-clock paced; the latest valid target is applied each step
  kLockstep,  ///< waits for the target answering frame k - latency_steps before step k
};

/// Settings of one run.
struct RunConfig {
  double duration = 20.0;  ///< simulated time to run (s), > 0
  RunMode mode = RunMode::kRealtime;
  int latency_steps = 1;          ///< lockstep: simulated latency d (steps), >= 0
  double lockstep_timeout = 5.0;  ///< lockstep: longest wait for a target (s wall), > 0
  /// With a controller: wait this long (s wall) for the controller's RobotTarget reader
  /// before starting, > 0.
  double start_timeout = 30.0;
  int vtk_every = 0;           ///< write VTK snapshots every N steps (0: never), >= 0
  bool video = true;           ///< render the view (live window or video file)
  int view_every = 2;          ///< render every N steps, >= 1
  double status_period = 0.5;  ///< SimStatus period (s wall), > 0
  /// A controller lost (its liveliness lease expired: killed, hung, stopped) may come back
  /// within this time (s wall), > 0: the robot holds and, in lockstep, the insertion waits for
  /// it; after it the loss is final (the robot holds to the end, exit controller_lost).
  double takeover_timeout = 30.0;
  /// Realtime: the SCHED_FIFO priority (1-99) of the loop's thread, so that no thread of the
  /// normal class (the liver's factor refresh, other programs) preempts a step; 0 (the default):
  /// the normal class. Needs CAP_SYS_NICE or RLIMIT_RTPRIO (`ulimit -r`); when refused, the run
  /// says why and goes on in the normal class. Ignored in lockstep.
  int rt_priority = 0;

  /// Throws InputError "run.<key> ...".
  void Validate() const;
};

/// Everything direct_sim needs from a scenario.
struct DirectScenario {
  std::string source;        ///< the scenario file
  SharedScenario shared;     ///< the `shared:` section, applied to the configs below
  uint64_t scenario_hash = 0;  ///< ScenarioHash(shared), checked at the start handshake
  uint64_t random_seed = 1;  ///< seeds the breathing unless breathing.random_seed is given
  PatientSceneConfig scene;
  TetMesh liver_mesh;  ///< read from patient.liver.mesh (world = liver frame)
  TetMesh skin_mesh;   ///< read from patient.skin.mesh, in the skin frame
  std::string liver_mesh_path, skin_mesh_path;
  RobotDriverConfig robot;
  InsertionConfig insertion;
  /// Safety gate; its speed and workspace limits are the robot's (copied by the loader).
  TargetGateConfig safety;
  RunConfig run;
  WatchdogConfig watchdog;  ///< the plausible bounds of the state
  /// The tracker's noise on the published markers; its seed is random_seed (LoopConfig).
  TrackerNoiseConfig tracker;
  ViewerConfig view;
  int dds_domain = 0;
  std::string dds_partition = "nsim";

  /// The patient loop's config (controller = false: insert along the path without targets).
  /// A lockstep run adopts the liver's factor refreshes on schedule (deterministic), whatever
  /// patient.liver.refactor_adoption says: that key chooses for realtime runs. Its refresh
  /// worker then stays in the normal class (FemConfig::RefreshWorkerIdle), so that the
  /// scheduled adoptions do not wait for an idle machine. The tracker's noise is seeded by
  /// random_seed (--seed), independently of the breathing's draws.
  PatientLoopConfig LoopConfig(bool controller) const {
    PatientSceneConfig run_scene = scene;
    if (run.mode == RunMode::kLockstep) run_scene.liver.refactor_adoption = FactorAdoption::kScheduled;
    TrackerNoiseConfig run_tracker = tracker;
    run_tracker.random_seed = random_seed;
    return {run_scene, robot, insertion, safety, controller, watchdog, run_tracker};
  }
};

/// The most physics steps one run may take (run.duration / patient.time_step).
constexpr double kMaxRunSteps = 1e6;

/// Throws InputError "run.duration / patient.time_step must be at most 1e6 steps, ...".
void CheckStepCount(double duration, double time_step);

/// The upper bounds of the insertion settings (InsertionConfig::Validate checks the lower
/// ones): InputError "insertion.<key> ...".
void CheckInsertion(const InsertionConfig& insertion);

/// Top-level sections of the other process, accepted and skipped.
const std::vector<std::string>& OtherProcessSections();

/// Loads the scenario file and its meshes. InputError on any problem.
DirectScenario LoadDirectScenario(const std::string& path);

/// Parses a scenario already read; mesh paths are relative to `base_dir`.
DirectScenario ParseDirectScenario(const YamlReader& root, const std::string& base_dir);

}  // namespace nsim
