#pragma once
// The section readers of the direct scenario loader (internal to direct_sim). Each reads the
// keys of one section into its config and rejects unknown keys; none validates the values, and
// none applies the shared part: scenario_loader.cpp does both once every section is read.

#include <cstdint>
#include <string>

#include "common/core/yaml_reader.h"
#include "direct_sim/scenario_loader.h"

namespace nsim::direct_sections {

/// patient: scene settings, liver and skin (their meshes relative to `base_dir`), ribs,
/// diaphragm, anchors.
void ReadPatient(const YamlReader& node, const std::string& base_dir, DirectScenario* s);
/// breathing (possibly absent); `seed` unless breathing.random_seed is given.
void ReadBreathing(const YamlReader& node, uint64_t seed, BreathingConfig* b);
/// needle: kind, material, tissue coupling, bevel.
void ReadNeedle(const YamlReader& node, SceneNeedleConfig* n);
/// robot: kind, Cartesian speed, acceleration and workspace limits.
void ReadRobot(const YamlReader& node, RobotDriverConfig* r);
/// insertion: speed and overshoot.
void ReadInsertion(const YamlReader& node, InsertionConfig* ins);
/// safety: the gate's own settings (its limits are the robot's, copied by the loader).
void ReadSafety(const YamlReader& node, TargetGateConfig* safety);
/// run: duration, mode, timeouts, outputs.
void ReadRun(const YamlReader& node, RunConfig* run);
/// watchdog: the plausible bounds of the state (PhysicsWatchdog).
void ReadWatchdog(const YamlReader& node, WatchdogConfig* w);
/// tracker: the measurement noise on the published markers (marker_noise, m).
void ReadTracker(const YamlReader& node, TrackerNoiseConfig* t);
/// view: camera and image.
void ReadView(const YamlReader& node, ViewerConfig* v);
/// dds: domain and partition.
void ReadDds(const YamlReader& node, int* domain, std::string* partition);

}  // namespace nsim::direct_sections
