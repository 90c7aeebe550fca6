#include "common/needle/needle_insertion.h"

#include "common/core/error.h"

namespace nsim {

NeedleInsertionStepper::NeedleInsertionStepper(const NeedleTissueCoupling& coupling,
                                               const ConstraintSolverConfig& config)
    : coupling_(coupling), solver_(config) {}

void NeedleInsertionStepper::RemoveTissueLoads(const std::vector<FemConstraintBody*>& tissues) {
  for (const auto& [where, f] : tissue_loads_)
    tissues[where.first]->state().external_forces.col(where.second) -= f;
  tissue_loads_.clear();
}

void NeedleInsertionStepper::Solve(const NeedleView& needle,
                                   const std::vector<FemConstraintBody*>& tissues,
                                   NeedleCouplingState& state, NeedleStepReport& report) {
  coupling_.AddConstraints(needle, tissue_bodies_, set_, state);
  report.num_rows = set_.num_rows();
  report.solve = solver_.Solve(set_);
  for (FemConstraintBody* t : tissues) t->EndStep();
  tissue_x_.clear();
  for (FemConstraintBody* t : tissues) tissue_x_.push_back(&t->state().x);
}

NeedleStepReport NeedleInsertionStepper::StepRigid(const RigidNeedleModel& model,
                                                   RigidNeedleState& needle,
                                                   const Eigen::Isometry3d& X_WF_end,
                                                   const std::vector<FemConstraintBody*>& tissues,
                                                   NeedleCouplingState& state) {
  NSIM_CHECK(static_cast<int>(tissues.size()) == coupling_.num_tissues() && !tissues.empty(),
             "expected ", coupling_.num_tissues(), " tissues, got ", tissues.size());
  NeedleStepReport report;
  // bevel: the tissue at the tip takes -Q (from the state at the step start)
  RemoveTissueLoads(tissues);
  const BevelTipLoad load = coupling_.CalcBevelTipLoad(MakeNeedleView(model, needle), state);
  if (load.active && load.tip_point.tet >= 0) {
    const TetMesh& mesh = coupling_.get_mesh(load.tissue);
    for (int k = 0; k < 4; ++k) {
      const int node = mesh.tets[load.tip_point.tet][k];
      const Eigen::Vector3d f = -load.tip_point.bary[k] * load.force_for_rigid;
      tissues[load.tissue]->state().external_forces.col(node) += f;
      tissue_loads_.push_back({{load.tissue, node}, f});
    }
    report.bevel_active = true;
  }
  SetRigidNeedleTarget(model, X_WF_end, needle);
  for (FemConstraintBody* t : tissues) t->BeginStep();
  set_.Clear();
  tissue_bodies_.clear();
  for (FemConstraintBody* t : tissues) tissue_bodies_.push_back(set_.AddBody(*t));
  const NeedleView view = MakeNeedleView(model, needle);
  Solve(view, tissues, state, report);
  coupling_.Update(view, tissue_x_, solver_.lambda(), tissues[0]->state().time, state);
  AdvanceRigidNeedle(needle);
  return report;
}

NeedleStepReport NeedleInsertionStepper::StepFlexible(
    BeamNeedleBody& needle, const Eigen::Isometry3d& X_WF_end,
    const std::vector<FemConstraintBody*>& tissues, NeedleCouplingState& state) {
  NSIM_CHECK(static_cast<int>(tissues.size()) == coupling_.num_tissues() && !tissues.empty(),
             "expected ", coupling_.num_tissues(), " tissues, got ", tissues.size());
  NeedleStepReport report;
  BeamNeedleState& ns = needle.state();
  const int tip = ns.num_nodes() - 1;
  // bevel: M (or Q) at the tip node, from the state at the step start
  ns.external_forces.col(tip) -= tip_force_;
  ns.external_torques.col(tip) -= tip_torque_;
  const BevelTipLoad load = coupling_.CalcBevelTipLoad(MakeNeedleView(needle, -1), state);
  tip_force_ = load.force_on_needle;
  tip_torque_ = load.torque_on_needle;
  ns.external_forces.col(tip) += tip_force_;
  ns.external_torques.col(tip) += tip_torque_;
  report.bevel_active = load.active;

  SetBeamNeedleTarget(needle.model(), X_WF_end, ns);
  for (FemConstraintBody* t : tissues) t->BeginStep();
  needle.BeginStep();
  set_.Clear();
  tissue_bodies_.clear();
  for (FemConstraintBody* t : tissues) tissue_bodies_.push_back(set_.AddBody(*t));
  const int needle_body = set_.AddBody(needle);
  Solve(MakeNeedleView(needle, needle_body), tissues, state, report);
  needle.EndStep();
  coupling_.Update(MakeNeedleView(needle, needle_body), tissue_x_, solver_.lambda(),
                   tissues[0]->state().time, state);
  return report;
}

}  // namespace nsim
