#pragma once
// A complete needle-insertion step over FEM tissues (free motion, needle-tissue constraints,
// friction-aware resolution, correction, puncture/seeding/retraction update, bevel load), for
// a rigid or a flexible needle. Scenes with more constraints (ribs, registration) compose the
// same pieces themselves; this is the reference driver used by the tests, the gelatin scenario
// and the benchmark.

#include <Eigen/Geometry>
#include <utility>
#include <vector>

#include "common/constraints/constraint_solver.h"
#include "common/constraints/fem_body.h"
#include "common/needle/beam_needle.h"
#include "common/needle/needle_tissue.h"
#include "common/needle/rigid_needle.h"

namespace nsim {

/// What one insertion step did.
struct NeedleStepReport {
  ConstraintSolveReport solve;
  int num_rows = 0;           ///< constraint rows of the step
  bool bevel_active = false;  ///< the bevel load acted during the step
};

/// Steps needle + tissues. Owns the constraint set and solver (with the compliance cache):
/// keep one per simulation.
///
/// Bevel load (thesis §4.2, a ForceField: constant while the tip is in tissue, taken from the
/// state at the step start): the flexible needle gets M (or Q) at its tip node through
/// BeamNeedleState::external_torques / external_forces; the rigid needle puts -Q on the tissue
/// material point at the tip (FemState::external_forces, spread by barycentric weights). The
/// stepper adds its load to those arrays and removes it again the next step, so other users'
/// external loads are kept.
class NeedleInsertionStepper {
 public:
  /// coupling must outlive the stepper.
  explicit NeedleInsertionStepper(const NeedleTissueCoupling& coupling,
                                  const ConstraintSolverConfig& config = {});

  /// One step with a rigid needle whose flange reaches X_WF_end at the step end. tissues[i] is
  /// the coupling's tissue i (at least one; all with the same time step).
  NeedleStepReport StepRigid(const RigidNeedleModel& model, RigidNeedleState& needle,
                             const Eigen::Isometry3d& X_WF_end,
                             const std::vector<FemConstraintBody*>& tissues,
                             NeedleCouplingState& state);

  /// One step with a flexible needle (its time step must equal the tissues').
  NeedleStepReport StepFlexible(BeamNeedleBody& needle, const Eigen::Isometry3d& X_WF_end,
                                const std::vector<FemConstraintBody*>& tissues,
                                NeedleCouplingState& state);

  const ConstraintSolver& solver() const { return solver_; }
  const ConstraintSet& set() const { return set_; }

 private:
  void RemoveTissueLoads(const std::vector<FemConstraintBody*>& tissues);
  void Solve(const NeedleView& needle, const std::vector<FemConstraintBody*>& tissues,
             NeedleCouplingState& state, NeedleStepReport& report);

  const NeedleTissueCoupling& coupling_;
  ConstraintSolver solver_;
  ConstraintSet set_;
  std::vector<int> tissue_bodies_;
  std::vector<const Eigen::Matrix3Xd*> tissue_x_;
  // bevel loads added last step: (tissue, node, force) and at the needle tip (force, torque)
  std::vector<std::pair<std::pair<int, int>, Eigen::Vector3d>> tissue_loads_;
  Eigen::Vector3d tip_force_ = Eigen::Vector3d::Zero(), tip_torque_ = Eigen::Vector3d::Zero();
};

}  // namespace nsim
