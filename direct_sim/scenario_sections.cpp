#include "direct_sim/scenario_sections.h"

#include "common/core/error.h"
#include "common/fem/fem_solver.h"
#include "common/mesh/gmsh_reader.h"
#include "common/scenario/box_reader.h"
#include "common/scenario/fem_reader.h"
#include "common/scenario/needle_reader.h"
#include "common/scenario/robot_reader.h"
#include "common/scenario/shared_scenario.h"

namespace nsim::direct_sections {
namespace {

std::string Join(const std::string& dir, const std::string& path) {
  if (path.empty() || path[0] == '/' || dir.empty()) return path;
  return dir + "/" + path;
}

// the FEM keys of a tissue section, and its mesh
std::vector<std::string> TissueKeys() {
  std::vector<std::string> keys = FemConfigKeys();
  keys.push_back("mesh");
  return keys;
}

TetMesh ReadMesh(const YamlReader& node, const std::string& base_dir, std::string* path) {
  *path = Join(base_dir, node.Child("mesh").AsString());
  try {
    return ReadGmshMesh(*path);
  } catch (const InputError& e) {
    throw InputError(Str(node.Where("mesh"), ": ", e.what()));
  }
}

// needle.<tissue>: the coupling's keys, and no other
void ReadTissueSection(const YamlReader& node, TissueCouplingConfig* t) {
  node.CheckKeys(TissueCouplingKeys());
  ReadTissueCoupling(node, t);
}

}  // namespace

void ReadPatient(const YamlReader& node, const std::string& base_dir, DirectScenario* s) {
  RejectKeysMovedToShared(node, "patient");
  node.CheckKeys({"time_step", "gravity", "constraint_compliance", "liver", "skin", "ribs",
                  "rib_contact_margin", "prefetch_ahead", "prefetch_rib_margin", "diaphragm",
                  "anchors"});
  PatientSceneConfig& c = s->scene;
  node.Read("time_step", &c.time_step);
  node.Read("gravity", &c.gravity);
  const int compliance = node.ReadChoice("constraint_compliance", ConstraintComplianceNames());
  if (compliance >= 0) c.liver_rest_compliance = compliance == 0;
  const YamlReader liver = node.Child("liver");
  liver.CheckKeys(TissueKeys());
  ReadFemConfig(liver, &c.liver);
  const YamlReader skin = node.Child("skin");
  std::vector<std::string> skin_keys = TissueKeys();
  skin_keys.push_back("pose");
  skin_keys.push_back("attach_distance");
  skin.CheckKeys(skin_keys);
  ReadFemConfig(skin, &c.skin.fem);
  skin.Read("pose", &c.skin.X_WS);
  skin.Read("attach_distance", &c.skin.attach_distance);
  node.Read("rib_contact_margin", &c.rib_contact_margin);
  node.Read("prefetch_ahead", &c.prefetch_ahead);
  node.Read("prefetch_rib_margin", &c.prefetch_rib_margin);
  c.ribs = ReadOrientedBoxes(node, "ribs");
  c.diaphragm = ReadOrientedBox(node.Child("diaphragm"));
  c.anchors = ReadOrientedBoxes(node, "anchors");
  // meshes last: the cheap key checks come first
  s->liver_mesh = ReadMesh(liver, base_dir, &s->liver_mesh_path);
  s->skin_mesh = ReadMesh(skin, base_dir, &s->skin_mesh_path);
}

void ReadBreathing(const YamlReader& node, uint64_t seed, BreathingConfig* b) {
  node.CheckKeys({"period", "period_cv", "amplitude_cv", "si_amplitude", "ap_amplitude",
                  "lr_amplitude", "shape_exponent", "start_phase", "axis_si", "axis_ap", "axis_lr",
                  "drift_velocity", "horizon", "random_seed"});
  b->random_seed = seed;
  node.Read("period", &b->period);
  node.Read("period_cv", &b->period_cv);
  node.Read("amplitude_cv", &b->amplitude_cv);
  node.Read("si_amplitude", &b->si_amplitude);
  node.Read("ap_amplitude", &b->ap_amplitude);
  node.Read("lr_amplitude", &b->lr_amplitude);
  node.Read("shape_exponent", &b->shape_exponent);
  node.Read("start_phase", &b->start_phase);
  node.Read("axis_si", &b->axis_si);
  node.Read("axis_ap", &b->axis_ap);
  node.Read("axis_lr", &b->axis_lr);
  node.Read("drift_velocity", &b->drift_velocity);
  node.Read("horizon", &b->horizon);
  node.Read("random_seed", &b->random_seed);
}

void ReadNeedle(const YamlReader& node, SceneNeedleConfig* n) {
  RejectKeysMovedToShared(node, "needle");
  std::vector<std::string> keys = {"type"};
  keys.insert(keys.end(), NeedleMaterialKeys().begin(), NeedleMaterialKeys().end());
  keys.insert(keys.end(), {"skin", "liver", "bevel"});
  node.CheckKeys(keys);
  const int type = node.ReadChoice("type", {"rigid", "flexible"});
  if (type >= 0) n->kind = type == 0 ? NeedleKind::kRigid : NeedleKind::kFlexible;
  NeedleConfig& g = n->kind == NeedleKind::kRigid ? n->rigid : n->flexible.needle;
  ReadNeedleMaterial(node, &g, &n->flexible);
  if (node.Has("skin")) ReadTissueSection(node.Child("skin"), &n->coupling.tissues[kSkinTissue]);
  if (node.Has("liver")) ReadTissueSection(node.Child("liver"), &n->coupling.tissues[kLiverTissue]);
  if (node.Has("bevel")) ReadBevel(node.Child("bevel"), &n->coupling.bevel);
}

void ReadRobot(const YamlReader& node, RobotDriverConfig* r) {
  RejectKeysMovedToShared(node, "robot");
  std::vector<std::string> keys = RobotLimitKeys();
  keys.push_back("type");
  node.CheckKeys(keys);
  const int type = node.ReadChoice("type", {"cartesian", "iiwa"});
  if (type >= 0) r->kind = type == 0 ? RobotKind::kCartesian : RobotKind::kIiwa;
  ReadRobotLimits(node, &r->cartesian);
}

void ReadRun(const YamlReader& node, RunConfig* run) {
  node.CheckKeys({"duration", "mode", "latency_steps", "lockstep_timeout", "start_timeout",
                  "vtk_every", "video", "view_every", "status_period", "takeover_timeout",
                  "rt_priority"});
  node.Read("duration", &run->duration);
  const int mode = node.ReadChoice("mode", {"realtime", "lockstep"});
  if (mode >= 0) run->mode = mode == 0 ? RunMode::kRealtime : RunMode::kLockstep;
  node.Read("latency_steps", &run->latency_steps);
  node.Read("lockstep_timeout", &run->lockstep_timeout);
  node.Read("start_timeout", &run->start_timeout);
  node.Read("vtk_every", &run->vtk_every);
  node.Read("video", &run->video);
  node.Read("view_every", &run->view_every);
  node.Read("status_period", &run->status_period);
  node.Read("takeover_timeout", &run->takeover_timeout);
  node.Read("rt_priority", &run->rt_priority);
}

void ReadView(const YamlReader& node, ViewerConfig* v) {
  node.CheckKeys({"width", "height", "eye", "look_at", "up", "fov_deg", "ortho_height", "fps"});
  node.Read("width", &v->width);
  node.Read("height", &v->height);
  node.Read("eye", &v->eye);
  node.Read("look_at", &v->look_at);
  node.Read("up", &v->up);
  node.Read("fov_deg", &v->fov_deg);
  node.Read("ortho_height", &v->ortho_height);
  node.Read("fps", &v->fps);
}

void ReadInsertion(const YamlReader& node, InsertionConfig* ins) {
  RejectKeysMovedToShared(node, "insertion");
  node.CheckKeys({"speed", "overshoot"});
  node.Read("speed", &ins->speed);
  node.Read("overshoot", &ins->overshoot);
}

void ReadSafety(const YamlReader& node, TargetGateConfig* safety) {
  node.CheckKeys({"max_age", "hold_timeout", "speed_horizon", "over_limit"});
  node.Read("max_age", &safety->max_age);
  node.Read("hold_timeout", &safety->hold_timeout);
  node.Read("speed_horizon", &safety->speed_horizon);
  const int action = node.ReadChoice("over_limit", {"clamp", "reject"});
  if (action >= 0)
    safety->over_limit = action == 0 ? OverLimitAction::kClamp : OverLimitAction::kReject;
}

void ReadWatchdog(const YamlReader& node, WatchdogConfig* w) {
  node.CheckKeys({"enabled", "max_displacement", "max_kinetic_energy", "inversion_check_every"});
  node.Read("enabled", &w->enabled);
  node.Read("max_displacement", &w->max_displacement);
  node.Read("max_kinetic_energy", &w->max_kinetic_energy);
  node.Read("inversion_check_every", &w->inversion_check_every);
}

void ReadTracker(const YamlReader& node, TrackerNoiseConfig* t) {
  node.CheckKeys({"marker_noise"});
  node.Read("marker_noise", &t->marker_std);
}

void ReadDds(const YamlReader& node, int* domain, std::string* partition) {
  node.CheckKeys({"domain", "partition"});
  node.Read("domain", domain);
  node.Read("partition", partition);
}

}  // namespace nsim::direct_sections
