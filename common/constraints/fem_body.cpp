#include "common/constraints/fem_body.h"

#include <atomic>

#include "common/core/error.h"

namespace nsim {

namespace {
std::atomic<std::uint64_t> fem_version_counter{0};
}  // namespace

FemConstraintBody::FemConstraintBody(FemSolver& solver, FemState& state, FemInverse compliance)
    : solver_(solver),
      state_(state),
      which_(compliance),
      h_(solver.get_model().get_config().time_step) {
  NSIM_CHECK(state.num_nodes() == solver.get_model().num_nodes(), "FemState has ",
             state.num_nodes(), " nodes, the solver's model ", solver.get_model().num_nodes());
  dv_.setZero(3 * state.num_nodes());
  version_ = ++fem_version_counter;
  factor_version_ = solver.get_factor_version();
}

FemStepStats FemConstraintBody::BeginStep() {
  NSIM_CHECK(!in_step_, "BeginStep called twice without committing the step");
  const FemStepStats stats = solver_.BeginStep(state_);
  // the rest factor's inverse never changes and the reference factor's only when the factor is
  // replaced, so cached compliance columns stay valid; the other operators change with every
  // step's rotations
  const bool unchanged =
      which_ == FemInverse::kRestFactor ||
      (which_ == FemInverse::kReferenceFactor && solver_.get_factor_version() == factor_version_);
  if (!unchanged) version_ = ++fem_version_counter;
  factor_version_ = solver_.get_factor_version();
  in_step_ = true;
  return stats;
}

void FemConstraintBody::EndStep() {
  if (!in_step_) return;
  solver_.CommitStep(state_);
  in_step_ = false;
}

void FemConstraintBody::ApplyCompliance(const Eigen::SparseMatrix<double>& forces,
                                        Eigen::MatrixXd& displacements) const {
  // the rest factor's inverse does not depend on the step: valid at any time (columns can be
  // computed before the first step); the other operators are the step's
  NSIM_CHECK(in_step_ || which_ == FemInverse::kRestFactor,
             "ApplyCompliance outside a step (call BeginStep first)");
  solver_.ApplyInverse(forces, displacements, which_);
  displacements *= h_ * h_;
}

void FemConstraintBody::ApplyCorrection(const Eigen::Matrix3Xd& dx) {
  NSIM_CHECK(in_step_, "ApplyCorrection outside a step (call BeginStep first)");
  NSIM_CHECK(dx.cols() == state_.num_nodes(), "correction has ", dx.cols(), " columns, expected ",
             state_.num_nodes());
  dv_ = Eigen::Map<const Eigen::VectorXd>(dx.data(), dx.size()) / h_;
  solver_.CommitStep(state_, dv_);
  in_step_ = false;
}

}  // namespace nsim
