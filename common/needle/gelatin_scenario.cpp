#include "common/needle/gelatin_scenario.h"

#include <cmath>

#include "common/constraints/fem_body.h"
#include "common/core/error.h"
#include "common/fem/fem_solver.h"
#include "common/needle/needle_insertion.h"

namespace nsim {

FemConfig MakeGelatinFemConfig() {
  FemConfig c;
  c.young_modulus = 43.26e3;
  c.poisson_ratio = 0.45;
  c.density = 1000.0;
  c.time_step = 0.02;
  c.rayleigh_mass = 1.0;
  c.rayleigh_stiffness = 0.01;
  c.gravity.setZero();
  return c;
}

BevelConfig MakeGelatinBevelConfig() {
  BevelConfig c;
  c.enabled = true;
  c.diameter = 1.2e-3;
  c.bevel_angle = 0.2617;
  c.beta_over_alpha = 0.9;
  c.tissue_stiffness = 150e3;
  c.mode = BevelLoadMode::kTorque;
  return c;
}

TissueCouplingConfig MakeGelatinCouplingConfig() {
  TissueCouplingConfig c;
  c.name = "gelatin";
  c.puncture_force = 0.05;
  c.friction_coefficient = 0.1;
  c.point_spacing = 0.035;
  return c;
}

void GelatinBevelScenarioConfig::Validate() const {
  if (!(block_nodes.array() >= 2).all())
    throw InputError(Str("gelatin.block_nodes must be >= 2 each, got ", block_nodes.transpose()));
  if (!(block_size.array() > 0.0).all() || !block_size.allFinite())
    throw InputError(Str("gelatin.block_size must be > 0 (m), got ", block_size.transpose()));
  gelatin.Validate();
  needle.Validate();
  bevel.Validate("gelatin.bevel");
  coupling.Validate("gelatin.coupling");
  if (!(initial_gap > 0.0) || !std::isfinite(initial_gap))
    throw InputError(Str("gelatin.initial_gap must be > 0 (m), got ", initial_gap));
  if (!(insertion_speed > 0.0) || !std::isfinite(insertion_speed))
    throw InputError(Str("gelatin.insertion_speed must be > 0 (m/s), got ", insertion_speed));
  if (!(insertion_depth > 0.0 && insertion_depth < needle.needle.length))
    throw InputError(Str("gelatin.insertion_depth must be in (0, needle.length = ",
                         needle.needle.length, ") (m), got ", insertion_depth));
  if (!std::isfinite(bevel_angle))
    throw InputError(Str("gelatin.bevel_angle must be finite (rad), got ", bevel_angle));
  if (std::abs(gelatin.time_step - needle.time_step) > 1e-15)
    throw InputError(Str("gelatin.needle.time_step must equal gelatin.gelatin.time_step (",
                         gelatin.time_step, " s), got ", needle.time_step));
}

GelatinBevelResult RunGelatinBevelScenario(const GelatinBevelScenarioConfig& config) {
  config.Validate();
  const TetMesh mesh = MakeBoxTetMesh(config.block_nodes, config.block_size);
  FemBoundary boundary;
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    if (mesh.X(2, i) < 1e-9 || mesh.X(0, i) > config.block_size.x() - 1e-9)
      boundary.fixed_nodes.push_back(i);
  }
  const FemModel fem_model(mesh, config.gelatin, boundary);
  FemSolver fem_solver(fem_model);
  FemState fem_state(fem_model);
  FemConstraintBody tissue(fem_solver, fem_state);

  // needle along +X aimed at the centre of the x = 0 face; flange z = needle axis
  const BeamNeedleModel needle_model(config.needle);
  BeamNeedleState needle_state(needle_model);
  needle_state.bevel_angle = config.bevel_angle;
  const double y0 = config.block_size.y() / 2, z0 = config.block_size.z() / 2;
  Eigen::Isometry3d X_WF = Eigen::Isometry3d::Identity();
  // flange frame: z_F = +X_W, x_F = +Z_W, y_F = +Y_W... chosen so that y_N = +Y_W (bevel side)
  X_WF.linear() << 0, 0, 1,  //
      -0, 1, 0,              //
      -1, 0, 0;
  // columns: x_F = (0, 0, -1), y_F = (0, 1, 0), z_F = (1, 0, 0): right-handed
  const Eigen::Vector3d p_FBase = config.needle.needle.p_FBase;
  const Eigen::Vector3d axis_W = X_WF.linear() * config.needle.needle.axis_F.normalized();
  NSIM_CHECK(axis_W.isApprox(Eigen::Vector3d::UnitX(), 1e-12) && p_FBase.isZero(),
             "the gelatin scenario expects the needle along the flange z axis at the flange");
  const double L = config.needle.needle.length;
  X_WF.translation() = Eigen::Vector3d(-config.initial_gap - L, y0, z0);
  ResetBeamNeedle(needle_model, X_WF, needle_state);
  BeamNeedleBody needle(needle_model, needle_state);

  NeedleCouplingConfig coupling_config;
  coupling_config.tissues = {config.coupling};
  coupling_config.bevel = config.bevel;
  const NeedleTissueCoupling coupling(coupling_config, {&mesh});
  NeedleCouplingState coupling_state = coupling.MakeState();
  NeedleInsertionStepper stepper(coupling);

  GelatinBevelResult result;
  const BevelLoads loads = CalcBevelLoads(config.bevel);
  result.bevel_q = loads.q;
  result.bevel_m = loads.m;
  const double h = config.gelatin.time_step;
  const double travel = config.initial_gap + config.insertion_depth;
  const int steps = static_cast<int>(std::ceil(travel / (config.insertion_speed * h)));
  const Eigen::Vector3d start = X_WF.translation();
  for (int k = 1; k <= steps; ++k) {
    const double s = std::min(travel, k * config.insertion_speed * h);
    X_WF.translation() = start + Eigen::Vector3d(s, 0.0, 0.0);
    const NeedleStepReport report = stepper.StepFlexible(needle, X_WF, {&tissue}, coupling_state);
    result.max_solver_violation = std::max(result.max_solver_violation, report.solve.max_violation);
  }
  // let the needle and gel settle at the final pose
  for (int k = 0; k < 10; ++k) stepper.StepFlexible(needle, X_WF, {&tissue}, coupling_state);

  const Eigen::Vector3d tip = needle_state.x.col(needle_state.num_nodes() - 1);
  const TissueCouplingReport& r = coupling_state.tissues[0].report;
  result.tip_deflection_y = tip.y() - y0;
  result.tip_deflection_z = tip.z() - z0;
  result.depth = r.depth;
  result.punctured = r.punctured;
  result.puncture_time = r.puncture_time;
  result.num_points = r.num_points;
  result.steps = steps + 10;
  return result;
}

}  // namespace nsim
