#include "inverse_sim/scenario_loader.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>

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
  if (y.Read("linear_solver", &solver))
    c->linear_solver = ParseFemLinearSolver(solver, y.Where("linear_solver"));
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

bool Near(double a, double b) {
  return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(a) + std::abs(b));
}
bool Near(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).norm() <= 1e-12; }

std::string Text(const Eigen::Vector3d& v) {
  return Str("[", v.x(), ", ", v.y(), ", ", v.z(), "]");
}

// Compares what both processes must agree on with the direct sections of the same file (when
// present): geometric mismatches go to `errors`, nominal material mismatches to `warnings`.
void CheckAgainstDirect(const YamlReader& root, const InverseScenario& s,
                        std::vector<std::string>* errors, std::vector<std::string>* warnings) {
  auto vec = [&](const YamlReader& node, const std::string& key, const Eigen::Vector3d& mine,
                 const std::string& my_key, std::vector<std::string>* out) {
    Eigen::Vector3d theirs;
    if (!node.Read(key, &theirs)) return;
    if (!Near(theirs, mine))
      out->push_back(
          Str(my_key, " ", Text(mine), " differs from ", node.Where(key), " ", Text(theirs)));
  };
  auto num = [&](const YamlReader& node, const std::string& key, double mine,
                 const std::string& my_key, std::vector<std::string>* out) {
    double theirs;
    if (!node.Read(key, &theirs)) return;
    if (!Near(theirs, mine))
      out->push_back(Str(my_key, " ", mine, " differs from ", node.Where(key), " ", theirs));
  };
  const YamlReader patient = root.OptionalChild("patient");
  if (!patient.IsNull()) {
    std::vector<Eigen::Vector3d> markers;
    if (patient.Read("markers", &markers)) {
      bool same = markers.size() == s.model.markers_W.size();
      for (size_t i = 0; same && i < markers.size(); ++i)
        same = Near(markers[i], s.model.markers_W[i]);
      if (!same)
        errors->push_back(
            "inverse.markers differ from patient.markers (the marker rest positions)");
    }
    vec(patient, "entry", s.path.entry_W, "controller.path.entry", errors);
    vec(patient, "target", s.path.target_W, "controller.path.target", errors);
    const YamlReader liver = patient.OptionalChild("liver");
    if (!liver.IsNull()) {
      num(liver, "young_modulus", s.model.liver.young_modulus, "inverse.liver.young_modulus",
          warnings);
      num(liver, "poisson_ratio", s.model.liver.poisson_ratio, "inverse.liver.poisson_ratio",
          warnings);
      num(liver, "density", s.model.liver.density, "inverse.liver.density", warnings);
    }
    num(patient, "time_step", s.model.liver.time_step, "inverse.liver.time_step", warnings);
  }
  const YamlReader needle = root.OptionalChild("needle");
  if (!needle.IsNull()) {
    num(needle, "length", s.model.needle.length, "inverse.needle.length", errors);
    num(needle, "radius", s.model.needle.radius, "inverse.needle.radius", errors);
    // the direct default tool offset is zero and the axis +z_F, like the inverse defaults
    Eigen::Vector3d offset = Eigen::Vector3d::Zero(), axis = Eigen::Vector3d::UnitZ();
    needle.Read("tool_offset", &offset);
    needle.Read("axis", &axis);
    if (!Near(offset, s.model.needle.p_FBase))
      errors->push_back(Str("inverse.needle.p_FBase ", Text(s.model.needle.p_FBase),
                            " differs from needle.tool_offset ", Text(offset)));
    if (!Near(axis.normalized(), s.model.needle.axis_F.normalized()))
      errors->push_back(Str("inverse.needle.axis_F ", Text(s.model.needle.axis_F),
                            " differs from needle.axis ", Text(axis)));
  }
  const YamlReader insertion = root.OptionalChild("insertion");
  if (!insertion.IsNull())
    num(insertion, "approach_distance", s.path.approach_distance,
        "controller.path.approach_distance", errors);
  const YamlReader robot = root.OptionalChild("robot");
  if (!robot.IsNull() && robot.Has("base_pose")) {
    const Eigen::Isometry3d theirs = robot.Child("base_pose").AsPose();
    if (!theirs.matrix().isApprox(s.control.iiwa.X_WB.matrix(), 1e-12))
      errors->push_back("controller.iiwa_base differs from robot.base_pose");
  }
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
                    "pca_window", "search_lead", "search_interval", "horizon_window",
                    "localization_delay", "displacement"});
    pred.Read("displacement", &s.prediction_displacement);
    pred.Read("enabled", &s.prediction_enabled);
    std::string filter;
    if (pred.Read("filter", &filter)) s.prediction.filter = ParsePredictionFilter(filter);
    pred.Read("order", &s.prediction.order);
    pred.Read("window", &s.prediction.window);
    pred.Read("optimize_window", &s.prediction.optimize_window);
    pred.Read("window_max", &s.prediction.window_max);
    pred.Read("pca_window", &s.prediction.pca_window);
    pred.Read("search_interval", &s.prediction.search_interval);
    if (pred.Has("search_lead") && pred.Child("search_lead").AsString() != "auto") {
      pred.Read("search_lead", &s.prediction.search_lead);
      s.prediction_search_lead_auto = false;
    }
    pred.Read("horizon_window", &s.horizon.window);
    pred.Read("localization_delay", &s.horizon.localization_delay);
  }
  ResolveSearchLead(&s);
  ValidateAs([&] { s.prediction.Validate(); }, path, "prediction.", "prediction.");
  ValidateAs([&] { s.horizon.Validate(); }, path, "horizon.", "prediction.");

  const YamlReader dds = root.OptionalChild("dds");
  if (!dds.IsNull()) {
    dds.CheckKeys({"domain", "partition"});
    dds.Read("domain", &s.dds_domain);
    dds.Read("partition", &s.dds_partition);
  }

  const YamlReader run = root.OptionalChild("run");
  if (!run.IsNull()) {
    std::string mode;
    if (run.Read("mode", &mode)) {
      if (mode != "realtime" && mode != "lockstep")
        run.Fail("mode", Str("expected realtime or lockstep, got '", mode, "'"));
      s.lockstep = mode == "lockstep";
    }
  }

  std::vector<std::string> errors, warnings;
  CheckAgainstDirect(root, s, &errors, &warnings);
  for (const std::string& w : warnings)
    std::cerr << "inverse_sim: warning: " << path << ": " << w << "\n";
  if (!errors.empty()) {
    std::string all;
    for (const std::string& e : errors) all += (all.empty() ? "" : "; ") + e;
    throw InputError(Str(path, ": the inverse sections disagree with the direct ones: ", all));
  }
  return s;
}

void ResolveSearchLead(InverseScenario* scenario) {
  if (!scenario->prediction_search_lead_auto) return;
  const double frame = scenario->model.liver.time_step;
  const double frames = (scenario->horizon.localization_delay + frame) / frame;
  scenario->prediction.search_lead =
      std::isfinite(frames) ? std::max(1, static_cast<int>(std::lround(frames))) : 1;
}

}  // namespace nsim
