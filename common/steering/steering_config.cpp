#include "common/steering/steering_config.h"

#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/needle/needle_tissue.h"

namespace nsim {
namespace {

void CheckPositive(double value, const std::string& key, const char* unit) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw InputError(Str(key, " must be > 0", unit, ", got ", value));
  }
}

void CheckFinite(const Eigen::Vector3d& v, const std::string& key) {
  if (!v.allFinite()) throw InputError(Str(key, " must be finite (m)"));
}

// rewrites "<from>..." into "<to>..." in an InputError from a nested Validate
template <typename F>
void Nested(F&& validate, const std::string& from, const std::string& to) {
  try {
    validate();
  } catch (const InputError& e) {
    std::string text = e.what();
    if (text.rfind(from, 0) == 0) text = to + text.substr(from.size());
    throw InputError(text);
  }
}

}  // namespace

SteeringDof ParseSteeringDof(const std::string& text, const std::string& key) {
  if (text == "cartesian6") return SteeringDof::kCartesian6;
  if (text == "joint7") return SteeringDof::kJoint7;
  throw InputError(Str(key, " must be one of cartesian6, joint7, got '", text, "'"));
}

const char* ToString(SteeringDof dof) {
  return dof == SteeringDof::kCartesian6 ? "cartesian6" : "joint7";
}

void InverseModelConfig::Validate() const {
  Nested([&] { liver.Validate(); }, "fem.", "inverse.liver.");
  CheckPositive(young_modulus_factor, "inverse.young_modulus_factor", "");
  if (markers_W.empty()) throw InputError("inverse.markers must list >= 1 marker, got 0");
  for (size_t i = 0; i < markers_W.size(); ++i) CheckFinite(markers_W[i], Str("inverse.markers[", i, "]"));
  needle.Validate("inverse.needle");
  coupling.Validate("inverse");  // the patient's checks and bounds, named inverse.<key>
  for (size_t i = 0; i < anchors.size(); ++i) anchors[i].Validate(Str("inverse.anchors[", i, "]"));
  bevel.Validate("inverse.bevel");
  if (needle_kind == ModelNeedleKind::kFlexible)
    Nested([&] { CalcModelBeamConfig(*this).Validate(); }, "needle.", "inverse.needle.");
  // a compliance built on the factor lags a background refresh (fem_config.h): unstable
  if (liver.background_refactor && !rest_compliance)
    throw InputError(
        "inverse.liver.background_refactor: true needs inverse.constraint_compliance: rest (a "
        "compliance built on the liver's factor would lag the refreshed factor)");
}

BeamNeedleConfig CalcModelBeamConfig(const InverseModelConfig& config) {
  BeamNeedleConfig beam = config.flexible;
  beam.needle.length = config.needle.length;
  beam.needle.radius = config.needle.radius;
  beam.needle.p_FBase = config.needle.p_FBase;
  beam.needle.axis_F = config.needle.axis_F;
  beam.time_step = config.liver.time_step;
  return beam;
}

void SteeringPathConfig::Validate() const {
  CheckFinite(entry_W, "controller.path.entry");
  CheckFinite(target_W, "controller.path.target");
  if (!((target_W - entry_W).norm() > 1e-6)) {
    throw InputError("controller.path.target must differ from controller.path.entry");
  }
  if (!(approach_distance >= 0.0) || !std::isfinite(approach_distance)) {
    throw InputError(Str("controller.path.approach_distance must be >= 0 (m), got ",
                         approach_distance));
  }
  CheckPositive(spacing, "controller.path.spacing", " (m)");
  Nested([&] { switching.Validate(); }, "control.path.", "controller.path.");
}

void SteeringControlConfig::Validate() const {
  for (int j = 0; j < 6; ++j) {
    CheckPositive(pose_steps[j], Str("controller.pose_steps[", j, "]"), j < 3 ? " (m)" : " (rad)");
  }
  for (int j = 0; j < 7; ++j) {
    CheckPositive(joint_steps[j], Str("controller.joint_steps[", j, "]"), " (rad)");
  }
  Nested([&] { gains.Validate(); }, "control.", "controller.");
  Nested([&] { law.Validate(); }, "control.", "controller.");
  Nested([&] { iiwa.Validate(); }, "iiwa.", "controller.iiwa.");
  if (!(null_space_gain >= 0.0 && null_space_gain <= 1.0))
    throw InputError(Str("controller.null_space_gain must be in [0, 1] (1/step), got ",
                         null_space_gain));
  if (!(liver_load >= 0.0 && std::isfinite(liver_load)))
    throw InputError(Str("controller.liver_load must be finite and >= 0, got ", liver_load));
  if (!(max_needle_tilt > 0.0 && max_needle_tilt <= M_PI))
    throw InputError(
        Str("controller.max_needle_tilt must be in (0, pi] (rad), got ", max_needle_tilt));
  if (!(max_insertion_step >= 0.0 && max_insertion_step <= 0.1))
    throw InputError(Str("controller.max_insertion_step must be in [0, 0.1] (m per step), got ",
                         max_insertion_step));
  if (!(free_stretch_step >= 0.0 && free_stretch_step <= 0.1))
    throw InputError(Str("controller.free_stretch_step must be in [0, 0.1] (m per step), got ",
                         free_stretch_step));
  if (!(free_stretch_tolerance >= 0.0 && std::isfinite(free_stretch_tolerance)))
    throw InputError(Str("controller.free_stretch_tolerance must be finite and >= 0 (m), got ",
                         free_stretch_tolerance));
  if (!(joint_limit_margin >= 0.0))
    throw InputError(
        Str("controller.joint_limit_margin must be >= 0 (rad), got ", joint_limit_margin));
  for (int j = 0; j < 7; ++j)
    if (!(2 * joint_limit_margin < iiwa.position_upper[j] - iiwa.position_lower[j]))
      throw InputError(Str("controller.joint_limit_margin ", joint_limit_margin,
                           " rad leaves no range for joint ", j + 1));
}

}  // namespace nsim
