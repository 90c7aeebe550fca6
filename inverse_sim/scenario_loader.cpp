#include "inverse_sim/scenario_loader.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <iostream>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/core/yaml_reader.h"
#include "common/fem/fem_solver.h"
#include "common/scenario/box_reader.h"
#include "common/scenario/fem_reader.h"
#include "common/scenario/needle_reader.h"
#include "common/scenario/robot_reader.h"
#include "common/scenario/shared_scenario.h"
#include "common/scene/scene_config.h"

namespace nsim {
namespace {

// the model liver's FEM keys, and its own time step
void ReadFem(const YamlReader& y, FemConfig* c) {
  std::vector<std::string> keys = FemConfigKeys();
  keys.push_back("time_step");
  y.CheckKeys(keys);
  ReadFemConfig(y, c);
  y.Read("time_step", &c->time_step);
}

template <int N>
void ReadFixedVector(const YamlReader& y, const std::string& key,
                     Eigen::Matrix<double, N, 1>* value) {
  if (!y.Has(key)) return;
  const std::vector<double> v = y.Child(key).AsDoubles();
  if (static_cast<int>(v.size()) != N) y.Fail(key, Str("expected ", N, " numbers, got ", v.size()));
  for (int i = 0; i < N; ++i) (*value)[i] = v[i];
}

// the shared facts into the inverse configs: one source for both processes
void ApplyShared(const SharedScenario& shared, InverseScenario* s) {
  s->loop.model.markers_W = shared.markers_W;
  s->loop.model.needle.length = shared.needle_length;
  s->loop.model.needle.radius = shared.needle_radius;
  s->loop.model.needle.p_FBase = shared.tool_offset_F;
  s->loop.model.needle.axis_F = shared.axis_F;
  s->loop.path.entry_W = shared.entry_W;
  s->loop.path.target_W = shared.target_W;
  s->loop.path.approach_distance = shared.approach_distance;
  s->loop.control.iiwa.X_WB = shared.X_WB;
}

// Upper (and tighter lower) bounds of the model's values, beyond InverseModelConfig's checks.
void CheckInverseBounds(const InverseScenario& s) {
  // the controller's model steps once per frame: 0.1 ms .. 0.1 s (patient.time_step's range)
  CheckRange(s.loop.model.liver.time_step, 1e-4, 0.1, "inverse.liver.time_step", "s");
  CheckTissueBounds(s.loop.model.liver, "inverse.liver");
  // the model's stiffness error: the experiments draw +-13 %; a factor of 10 is no model
  CheckRange(s.loop.model.young_modulus_factor, 0.1, 10.0, "inverse.young_modulus_factor", "",
             false);
}

// Upper bounds of the path and the Jacobian steps, beyond SteeringPathConfig's and
// SteeringControlConfig's checks.
void CheckControllerBounds(const InverseScenario& s) {
  // path points mm apart along a needle at most 2 m long
  CheckAtMost(s.loop.path.spacing, 2.0, "controller.path.spacing", "m");
  CheckAtMost(s.loop.path.switching.switch_distance, 1.0, "controller.path.switch_distance", "m");
  // finite-difference steps: um..mm; 10 cm or 1 rad is no derivative
  for (int j = 0; j < 6; ++j)
    CheckAtMost(s.loop.control.pose_steps[j], j < 3 ? 0.1 : 1.0, Str("controller.pose_steps[", j, "]"),
                j < 3 ? "m" : "rad");
  for (int j = 0; j < 7; ++j)
    CheckAtMost(s.loop.control.joint_steps[j], 1.0, Str("controller.joint_steps[", j, "]"), "rad");
}

// inverse.bevel: a bevel map, or `patient`: the patient's needle.bevel of the same file (its
// defaults, a symmetric tip, when the file has none)
void ReadModelBevel(const YamlReader& inv, const YamlReader& root, BevelConfig* bevel) {
  if (!inv.Has("bevel")) return;
  const YamlReader node = inv.Child("bevel");
  if (node.IsScalar()) {
    if (node.AsString() != "patient")
      inv.Fail("bevel", Str("expected a bevel map or 'patient', got '", node.AsString(), "'"));
    const YamlReader needle = root.OptionalChild("needle");
    if (!needle.IsNull() && needle.Has("bevel")) ReadBevel(needle.Child("bevel"), bevel);
    return;
  }
  ReadBevel(node, bevel);
}

// inverse.needle: rigid | flexible | patient, or {type: rigid | flexible, <material keys of the
// patient's needle section>}; `patient` takes the type and material of this file's needle
// section (the patient's defaults where it has none: a rigid needle)
void ReadModelNeedle(const YamlReader& inv, const YamlReader& root, InverseModelConfig* model) {
  if (!inv.Has("needle")) return;
  const YamlReader node = inv.Child("needle");
  auto kind_of = [](int choice) {
    return choice == 1 ? ModelNeedleKind::kFlexible : ModelNeedleKind::kRigid;
  };
  if (node.IsScalar()) {
    const std::string text = node.AsString();
    if (text == "rigid" || text == "flexible") {
      model->needle_kind = kind_of(text == "flexible" ? 1 : 0);
      return;
    }
    if (text != "patient")
      inv.Fail("needle", Str("expected rigid, flexible, patient or a map, got '", text, "'"));
    const YamlReader patient = root.OptionalChild("needle");
    model->needle_kind = ModelNeedleKind::kRigid;
    if (patient.IsNull()) return;
    const int type = patient.ReadChoice("type", {"rigid", "flexible"});
    if (type >= 0) model->needle_kind = kind_of(type);
    // the patient's flexible needle starts from the same defaults as the model's
    ReadNeedleMaterial(patient, &model->flexible.needle, &model->flexible);
    return;
  }
  RejectKeysMovedToShared(node, "inverse.needle");  // its geometry is the shared needle's
  std::vector<std::string> keys = {"type"};
  keys.insert(keys.end(), NeedleMaterialKeys().begin(), NeedleMaterialKeys().end());
  node.CheckKeys(keys);
  const int type = node.ReadChoice("type", {"rigid", "flexible"});
  if (type >= 0) model->needle_kind = kind_of(type);
  ReadNeedleMaterial(node, &model->flexible.needle, &model->flexible);
}

// inverse: the liver model; the mesh path relative to the scenario file
void ReadInverse(const YamlReader& inv, const YamlReader& root, const std::string& path,
                 InverseScenario* s) {
  RejectKeysMovedToShared(inv, "inverse");
  std::vector<std::string> keys = {"mesh",
                                   "liver",
                                   "young_modulus_factor",
                                   "jacobian_friction",
                                   "constraint_compliance",
                                   "anchors",
                                   "bevel",
                                   "needle"};
  keys.insert(keys.end(), TissueCouplingKeys().begin(), TissueCouplingKeys().end());
  inv.CheckKeys(keys);
  const int compliance = inv.ReadChoice("constraint_compliance", ConstraintComplianceNames());
  if (compliance >= 0) s->loop.model.rest_compliance = compliance == 0;
  std::filesystem::path mesh = inv.Child("mesh").AsString();
  if (mesh.is_relative()) mesh = std::filesystem::path(path).parent_path() / mesh;
  s->mesh_path = mesh.lexically_normal().string();
  if (inv.Has("liver")) ReadFem(inv.Child("liver"), &s->loop.model.liver);
  inv.Read("young_modulus_factor", &s->loop.model.young_modulus_factor);
  ReadTissueCoupling(inv, &s->loop.model.coupling);
  const int jacobian_friction = inv.ReadChoice("jacobian_friction", {"held", "solved"});
  if (jacobian_friction >= 0) s->loop.model.jacobian_friction_held = jacobian_friction == 0;
  s->loop.model.anchors = ReadOrientedBoxes(inv, "anchors");
  ReadModelBevel(inv, root, &s->loop.model.bevel);
  ReadModelNeedle(inv, root, &s->loop.model);
  ValidateAs([&] { s->loop.model.Validate(); }, path, "inverse.", "inverse.");
  ValidateAs([&] { CheckInverseBounds(*s); }, path, "", "");
}

// controller: the path, the Jacobian steps, the gains and the law
void ReadController(const YamlReader& ctl, const std::string& path, InverseScenario* s) {
  RejectKeysMovedToShared(ctl, "controller");
  ctl.CheckKeys({"dof", "path", "pose_steps", "joint_steps", "gains", "regularization",
                 "max_translation_step", "max_rotation_step", "max_joint_step",
                 "liver_entry_objective", "compensate_in_flight", "null_space_gain",
                 "joint_limit_margin", "alignment", "max_needle_tilt", "max_insertion_step",
                 "free_stretch_step", "free_stretch_tolerance", "liver_alignment", "liver_load"});
  const int alignment = ctl.ReadChoice("alignment", {"tip", "base"});
  if (alignment >= 0)
    s->loop.control.alignment = alignment == 0 ? AlignmentReference::kTip : AlignmentReference::kBase;
  ctl.Read("null_space_gain", &s->loop.control.null_space_gain);
  ctl.Read("joint_limit_margin", &s->loop.control.joint_limit_margin);
  ctl.Read("max_needle_tilt", &s->loop.control.max_needle_tilt);
  ctl.Read("max_insertion_step", &s->loop.control.max_insertion_step);
  ctl.Read("free_stretch_step", &s->loop.control.free_stretch_step);
  ctl.Read("free_stretch_tolerance", &s->loop.control.free_stretch_tolerance);
  ctl.Read("liver_load", &s->loop.control.liver_load);
  const int liver_alignment = ctl.ReadChoice("liver_alignment", {"auto", "none", "base"});
  if (liver_alignment >= 0)
    s->loop.control.liver_alignment = std::array<LiverAlignment, 3>{
        LiverAlignment::kAuto, LiverAlignment::kNone, LiverAlignment::kBase}[liver_alignment];
  std::string dof;
  if (ctl.Read("dof", &dof)) s->loop.control.dof = ParseSteeringDof(dof, ctl.Where("dof"));
  const YamlReader p = ctl.Child("path");
  RejectKeysMovedToShared(p, "controller.path");
  p.CheckKeys({"spacing", "switch_distance", "advance"});
  const int advance = p.ReadChoice("advance", {"measured", "commanded"});
  if (advance >= 0)
    s->loop.path.advance = advance == 0 ? PathAdvance::kMeasured : PathAdvance::kCommanded;
  p.Read("spacing", &s->loop.path.spacing);
  p.Read("switch_distance", &s->loop.path.switching.switch_distance);
  ReadFixedVector<6>(ctl, "pose_steps", &s->loop.control.pose_steps);
  ReadFixedVector<7>(ctl, "joint_steps", &s->loop.control.joint_steps);
  if (ctl.Has("gains")) {
    const YamlReader g = ctl.Child("gains");
    g.CheckKeys({"position", "angle", "entry", "load"});
    g.Read("position", &s->loop.control.gains.position);
    g.Read("angle", &s->loop.control.gains.angle);
    g.Read("entry", &s->loop.control.gains.entry);
    g.Read("load", &s->loop.control.gains.load);
  }
  ctl.Read("regularization", &s->loop.control.law.regularization);
  ctl.Read("max_translation_step", &s->loop.control.law.max_translation_step);
  ctl.Read("max_rotation_step", &s->loop.control.law.max_rotation_step);
  ctl.Read("max_joint_step", &s->loop.control.law.max_joint_step);
  ctl.Read("liver_entry_objective", &s->loop.control.liver_entry_objective);
  ctl.Read("compensate_in_flight", &s->loop.control.compensate_in_flight);
  ValidateAs([&] { s->loop.path.Validate(); }, path, "controller.", "controller.");
  ValidateAs([&] { s->loop.control.Validate(); }, path, "controller.", "controller.");
  ValidateAs([&] { CheckControllerBounds(*s); }, path, "", "");
}

// prediction (optional): the marker predictor and the horizon; the search lead resolved
void ReadPrediction(const YamlReader& pred, const std::string& path, InverseScenario* s) {
  if (!pred.IsNull()) {
    pred.CheckKeys({"enabled", "filter", "order", "window", "optimize_window", "window_max",
                    "pca_window", "search_lead", "search_interval", "horizon_window",
                    "localization_delay", "displacement", "measure_latency", "model_pose",
                    "preparation", "shrink"});
    pred.Read("displacement", &s->loop.prediction_displacement);
    pred.Read("shrink", &s->loop.prediction_shrink);
    pred.Read("measure_latency", &s->loop.measure_latency);
    const int preparation = pred.ReadChoice("preparation", {"none", "buffer", "exhale"});
    if (preparation >= 0) s->loop.preparation = static_cast<Preparation>(preparation);
    const int pose = pred.ReadChoice("model_pose", {"measured", "commanded", "expected", "auto"});
    if (pose >= 0) s->loop.model_pose = static_cast<ModelPose>(pose);
    pred.Read("enabled", &s->loop.prediction_enabled);
    std::string filter;
    if (pred.Read("filter", &filter)) s->loop.prediction.filter = ParsePredictionFilter(filter);
    pred.Read("order", &s->loop.prediction.order);
    pred.Read("window", &s->loop.prediction.window);
    pred.Read("optimize_window", &s->loop.prediction.optimize_window);
    pred.Read("window_max", &s->loop.prediction.window_max);
    pred.Read("pca_window", &s->loop.prediction.pca_window);
    pred.Read("search_interval", &s->loop.prediction.search_interval);
    if (pred.Has("search_lead") && pred.Child("search_lead").AsString() != "auto") {
      pred.Read("search_lead", &s->loop.prediction.search_lead);
      s->loop.search_lead_auto = false;
    }
    pred.Read("horizon_window", &s->loop.horizon.window);
    pred.Read("localization_delay", &s->loop.horizon.localization_delay);
  }
  ResolveSearchLead(s);
  ValidateAs([&] { s->loop.prediction.Validate(); }, path, "prediction.", "prediction.");
  ValidateAs([&] { s->loop.horizon.Validate(); }, path, "horizon.", "prediction.");
}

// the shared dds section (optional)
void ReadDds(const YamlReader& dds, InverseScenario* s) {
  if (dds.IsNull()) return;
  dds.CheckKeys({"domain", "partition"});
  dds.Read("domain", &s->dds_domain);
  dds.Read("partition", &s->dds_partition);
  if (dds.Has("partition"))
    ValidateAs([&] { CheckName(s->dds_partition, kMaxPartitionLength, "dds.partition"); },
               dds.source(), "", "");
}

// run.mode of the direct side (optional): lockstep or not; the other run keys are direct_sim's
void ReadRunMode(const YamlReader& run, InverseScenario* s) {
  if (run.IsNull()) return;
  std::string mode;
  if (run.Read("mode", &mode)) {
    if (mode != "realtime" && mode != "lockstep")
      run.Fail("mode", Str("expected realtime or lockstep, got '", mode, "'"));
    s->lockstep = mode == "lockstep";
  }
}

}  // namespace

InverseScenario LoadInverseScenario(const std::string& path) {
  const YamlReader root = YamlReader::LoadFile(path);
  // every top-level section of a scenario file (both processes'), so a typo is caught here too
  root.CheckKeys({"random_seed", "shared", "patient", "breathing", "needle", "robot", "insertion",
                  "safety", "watchdog", "tracker", "run", "view", "dds", "inverse", "controller",
                  "prediction"});
  InverseScenario s;
  s.source = path;
  s.shared = ReadSharedScenario(root);
  s.scenario_hash = ScenarioHash(s.shared);
  ApplyShared(s.shared, &s);
  ReadInverse(root.Child("inverse"), root, path, &s);
  ReadController(root.Child("controller"), path, &s);
  ReadPrediction(root.OptionalChild("prediction"), path, &s);
  // the robot's limits: where the commands in flight take it (prediction.model_pose: expected)
  if (root.Has("robot")) ReadRobotLimits(root.Child("robot"), &s.loop.robot.cartesian);
  ValidateAs([&] { s.loop.robot.cartesian.Validate(); }, path, "", "");
  ReadDds(root.OptionalChild("dds"), &s);
  ReadRunMode(root.OptionalChild("run"), &s);
  return s;
}

void ResolveSearchLead(InverseScenario* scenario) {
  if (!scenario->loop.search_lead_auto) return;
  const double frame = scenario->loop.model.liver.time_step;
  const double frames = (scenario->loop.horizon.localization_delay + frame) / frame;
  scenario->loop.prediction.search_lead =
      std::isfinite(frames) ? std::max(1, static_cast<int>(std::lround(frames))) : 1;
}

}  // namespace nsim
