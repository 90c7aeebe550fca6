#pragma once
// A FEM body whose constraint compliance is the precomputed rest compliance
// C_0 = h^2 A_0^-1 (A_0 = (1 + h alpha) M + (h beta + h^2) K_0, the co-rotational system at rest),
// factorized once (SOFA's PrecomputedConstraintCorrection idea, DESIGN.md "Speed"). Positions,
// free motion and the commit of the correction are the wrapped FemConstraintBody's.
//
// Why: the liver's contact and needle rows change every step, and the exact (or warped cached
// factor) compliance costs one CHOLMOD solve per new column every step (~1.4 ms a column on the
// 2660-node liver, so ~30 ms for 20 rib contacts). C_0 never changes, so compliance_version()
// is constant and the constraint solver's cache keeps the columns of keyed points (rib-contact
// nodes, needle path points) from step to step: only new points cost a solve.
// Accuracy: the constraints are met exactly by the corrected state (the correction uses the
// same C_0 as W); the dynamics of the correction ignore the current element rotations (small in
// a breathing liver), as with any precomputed compliance.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>

#include "common/constraints/fem_body.h"
#include "common/fem/cholmod_factor.h"

namespace nsim {

class RestComplianceBody : public ConstraintBody {
 public:
  /// Factorizes the rest system of `solver`'s model. Call before the solver's first step (its
  /// system matrix must still be the rest one). `body` must outlive this object.
  RestComplianceBody(FemConstraintBody& body, FemSolver& solver);
  ~RestComplianceBody() override;

  int num_nodes() const override { return body_.num_nodes(); }
  const Eigen::Matrix3Xd& start_positions() const override { return body_.start_positions(); }
  const Eigen::Matrix3Xd& free_positions() const override { return body_.free_positions(); }
  /// C_0 forces (m), rows of Dirichlet nodes zero.
  void ApplyCompliance(const Eigen::SparseMatrix<double>& forces,
                       Eigen::MatrixXd& displacements) const override;
  /// Constant: C_0 never changes.
  std::uint64_t compliance_version() const override { return 1; }
  void ApplyCorrection(const Eigen::Matrix3Xd& dx) override { body_.ApplyCorrection(dx); }

 private:
  FemConstraintBody& body_;
  const FemModel& model_;
  double h2_;
  std::unique_ptr<CholmodFactor> factor_;
  mutable Eigen::MatrixXd in_, out_;  // reduced right-hand sides and solutions
};

}  // namespace nsim
