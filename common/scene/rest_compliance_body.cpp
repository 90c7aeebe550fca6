#include "common/scene/rest_compliance_body.h"

#include "common/core/error.h"

namespace nsim {

RestComplianceBody::RestComplianceBody(FemConstraintBody& body, FemSolver& solver)
    : body_(body),
      model_(solver.get_model()),
      h2_(solver.get_model().get_config().time_step * solver.get_model().get_config().time_step),
      factor_(std::make_unique<CholmodFactor>()) {
  const Eigen::SparseMatrix<double>& A0 = solver.CalcSystemMatrix();
  factor_->Analyze(A0);
  NSIM_CHECK(factor_->Factorize(A0), "the rest system of the FEM body is not positive definite");
}

RestComplianceBody::~RestComplianceBody() = default;

void RestComplianceBody::ApplyCompliance(const Eigen::SparseMatrix<double>& forces,
                                         Eigen::MatrixXd& displacements) const {
  const int k = static_cast<int>(forces.cols());
  const int free = model_.num_free_nodes();
  in_.setZero(3 * free, k);
  for (int c = 0; c < forces.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(forces, c); it; ++it) {
      const int row = static_cast<int>(it.row());
      const int f = model_.get_free_index(row / 3);
      if (f >= 0) in_(3 * f + row % 3, c) += it.value();
    }
  out_.resize(3 * free, k);
  factor_->Solve(in_, out_);
  displacements.setZero(3 * model_.num_nodes(), k);
  const auto& free_nodes = model_.get_free_nodes();
  for (int c = 0; c < k; ++c)
    for (int j = 0; j < free; ++j)
      displacements.col(c).segment<3>(3 * free_nodes[j]) = h2_ * out_.col(c).segment<3>(3 * j);
}

}  // namespace nsim
