#include "inverse_sim/scenario_loader.h"

#include <filesystem>

#include "common/core/error.h"
#include "common/core/yaml_reader.h"

namespace nsim {
namespace {

void ReadFem(const YamlReader& y, FemConfig* c) {
  y.CheckKeys({"young_modulus", "poisson_ratio", "density", "rayleigh_mass", "rayleigh_stiffness",
               "time_step", "linear_solver", "cg_relative_tolerance"});
  y.Read("young_modulus", &c->young_modulus);
  y.Read("poisson_ratio", &c->poisson_ratio);
  y.Read("density", &c->density);
  y.Read("rayleigh_mass", &c->rayleigh_mass);
  y.Read("rayleigh_stiffness", &c->rayleigh_stiffness);
  y.Read("time_step", &c->time_step);
  y.Read("cg_relative_tolerance", &c->cg_relative_tolerance);
  std::string solver;
  if (y.Read("linear_solver", &solver)) c->linear_solver = ParseFemLinearSolver(solver, y.Where("linear_solver"));
}

void ReadNeedle(const YamlReader& y, NeedleConfig* c) {
  y.CheckKeys({"length", "radius", "p_FBase", "axis_F"});
  y.Read("length", &c->length);
  y.Read("radius", &c->radius);
  y.Read("p_FBase", &c->p_FBase);
  y.Read("axis_F", &c->axis_F);
}

template <int N>
void ReadFixedVector(const YamlReader& y, const std::string& key,
                     Eigen::Matrix<double, N, 1>* value) {
  if (!y.Has(key)) return;
  const std::vector<double> v = y.Child(key).AsDoubles();
  if (static_cast<int>(v.size()) != N) y.Fail(key, Str("expected ", N, " numbers, got ", v.size()));
  for (int i = 0; i < N; ++i) (*value)[i] = v[i];
}

}  // namespace

InverseScenario LoadInverseScenario(const std::string& path) {
  const YamlReader root = YamlReader::LoadFile(path);
  InverseScenario s;
  s.source = path;

  const YamlReader inv = root.Child("inverse");
  inv.CheckKeys({"mesh", "liver", "young_modulus_factor", "markers", "needle", "puncture_force",
                 "point_spacing", "tip_constraint"});
  std::filesystem::path mesh = inv.Child("mesh").AsString();
  if (mesh.is_relative()) mesh = std::filesystem::path(path).parent_path() / mesh;
  s.mesh_path = mesh.lexically_normal().string();
  if (inv.Has("liver")) ReadFem(inv.Child("liver"), &s.model.liver);
  inv.Read("young_modulus_factor", &s.model.young_modulus_factor);
  if (!inv.Read("markers", &s.model.markers_W)) inv.Fail("markers", "missing");
  if (inv.Has("needle")) ReadNeedle(inv.Child("needle"), &s.model.needle);
  inv.Read("puncture_force", &s.model.puncture_force);
  inv.Read("point_spacing", &s.model.point_spacing);
  inv.Read("tip_constraint", &s.model.tip_constraint);
  ValidateAs([&] { s.model.Validate(); }, path, "inverse.", "inverse.");

  const YamlReader ctl = root.Child("controller");
  ctl.CheckKeys({"dof", "path", "pose_steps", "joint_steps", "gains", "regularization",
                 "max_translation_step", "max_rotation_step", "max_joint_step",
                 "liver_entry_objective", "iiwa_base"});
  std::string dof;
  if (ctl.Read("dof", &dof)) s.control.dof = ParseSteeringDof(dof, ctl.Where("dof"));
  const YamlReader p = ctl.Child("path");
  p.CheckKeys({"entry", "target", "approach_distance", "spacing", "switch_distance"});
  if (!p.Read("entry", &s.path.entry_W)) p.Fail("entry", "missing");
  if (!p.Read("target", &s.path.target_W)) p.Fail("target", "missing");
  p.Read("approach_distance", &s.path.approach_distance);
  p.Read("spacing", &s.path.spacing);
  p.Read("switch_distance", &s.path.switching.switch_distance);
  ReadFixedVector<6>(ctl, "pose_steps", &s.control.pose_steps);
  ReadFixedVector<7>(ctl, "joint_steps", &s.control.joint_steps);
  if (ctl.Has("gains")) {
    const YamlReader g = ctl.Child("gains");
    g.CheckKeys({"position", "angle", "entry"});
    g.Read("position", &s.control.gains.position);
    g.Read("angle", &s.control.gains.angle);
    g.Read("entry", &s.control.gains.entry);
  }
  ctl.Read("regularization", &s.control.law.regularization);
  ctl.Read("max_translation_step", &s.control.law.max_translation_step);
  ctl.Read("max_rotation_step", &s.control.law.max_rotation_step);
  ctl.Read("max_joint_step", &s.control.law.max_joint_step);
  ctl.Read("liver_entry_objective", &s.control.liver_entry_objective);
  ctl.Read("iiwa_base", &s.control.iiwa.X_WB);
  ValidateAs([&] { s.path.Validate(); }, path, "controller.", "controller.");
  ValidateAs([&] { s.control.Validate(); }, path, "controller.", "controller.");

  const YamlReader pred = root.OptionalChild("prediction");
  if (!pred.IsNull()) {
    pred.CheckKeys({"enabled", "filter", "order", "window", "optimize_window", "window_max",
                    "pca_window", "horizon_window", "localization_delay"});
    pred.Read("enabled", &s.prediction_enabled);
    std::string filter;
    if (pred.Read("filter", &filter)) s.prediction.filter = ParsePredictionFilter(filter);
    pred.Read("order", &s.prediction.order);
    pred.Read("window", &s.prediction.window);
    pred.Read("optimize_window", &s.prediction.optimize_window);
    pred.Read("window_max", &s.prediction.window_max);
    pred.Read("pca_window", &s.prediction.pca_window);
    pred.Read("horizon_window", &s.horizon.window);
    pred.Read("localization_delay", &s.horizon.localization_delay);
  }
  ValidateAs([&] { s.prediction.Validate(); }, path, "prediction.", "prediction.");
  ValidateAs([&] { s.horizon.Validate(); }, path, "horizon.", "prediction.");
  return s;
}

}  // namespace nsim
