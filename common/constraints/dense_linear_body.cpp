#include "common/constraints/dense_linear_body.h"

#include <atomic>
#include <cmath>

#include "common/core/error.h"

namespace nsim {

namespace {

// versions are unique across bodies so that a recycled cache slot can never match
std::atomic<std::uint64_t> version_counter{0};
std::uint64_t NextVersion() { return ++version_counter; }

}  // namespace

DenseLinearBody::DenseLinearBody(const DenseLinearBodyConfig& config)
    : m_(config.masses),
      X_(config.rest_positions),
      h_(config.time_step),
      alpha_(config.rayleigh_mass),
      beta_(config.rayleigh_stiffness),
      g_(config.gravity) {
  const int n = static_cast<int>(X_.cols());
  if (n < 1) throw InputError("dense body: expected at least one node, got 0");
  if (m_.size() != n) throw InputError(Str("dense body: expected ", n, " masses, got ", m_.size()));
  for (int i = 0; i < n; ++i) {
    if (!(m_[i] > 0.0) || !std::isfinite(m_[i]))
      throw InputError(Str("dense body: masses must be > 0 (kg), got ", m_[i]));
  }
  if (!X_.allFinite()) throw InputError("dense body: rest positions must be finite");
  if (config.stiffness.size() == 0) {
    K_.setZero(3 * n, 3 * n);
  } else {
    K_ = config.stiffness;
    if (K_.rows() != 3 * n || K_.cols() != 3 * n)
      throw InputError(Str("dense body: expected a ", 3 * n, " x ", 3 * n, " stiffness, got ",
                           K_.rows(), " x ", K_.cols()));
    if (!K_.allFinite() || !K_.isApprox(K_.transpose(), 1e-12))
      throw InputError("dense body: stiffness must be finite and symmetric");
  }
  if (!(alpha_ >= 0.0) || !(beta_ >= 0.0))
    throw InputError(
        Str("dense body: Rayleigh coefficients must be >= 0, got ", alpha_, ", ", beta_));
  if (!g_.allFinite()) throw InputError("dense body: gravity must be finite");
  x_ = X_;
  v_.setZero(3, n);
  x_start_ = x_;
  x_free_ = x_;
  f_ext_.setZero(3, n);
  set_time_step(h_);
}

void DenseLinearBody::set_time_step(double h) {
  if (!(h > 0.0) || !std::isfinite(h))
    throw InputError(Str("dense body: time_step must be > 0 (s), got ", h));
  h_ = h;
  Factorize();
}

void DenseLinearBody::Factorize() {
  const int n = num_nodes();
  Eigen::VectorXd M(3 * n);
  for (int i = 0; i < n; ++i) M.segment<3>(3 * i).setConstant(m_[i]);
  A_ = (h_ * beta_ + h_ * h_) * K_;
  A_.diagonal() += (1.0 + h_ * alpha_) * M;
  llt_.compute(A_);
  if (llt_.info() != Eigen::Success)
    throw InputError("dense body: A = M + h C + h^2 K is not positive definite (check K >= 0)");
  version_ = NextVersion();
}

void DenseLinearBody::set_positions(const Eigen::Matrix3Xd& x) {
  if (x.cols() != x_.cols()) throw InputError("dense body: positions have the wrong size");
  x_ = x;
}

void DenseLinearBody::set_velocities(const Eigen::Matrix3Xd& v) {
  if (v.cols() != v_.cols()) throw InputError("dense body: velocities have the wrong size");
  v_ = v;
}

void DenseLinearBody::SolveFreeMotion() {
  const int n = num_nodes();
  x_start_ = x_;
  Eigen::Map<const Eigen::VectorXd> x(x_.data(), 3 * n), X(X_.data(), 3 * n), v(v_.data(), 3 * n),
      fe(f_ext_.data(), 3 * n);
  Eigen::VectorXd M(3 * n);
  for (int i = 0; i < n; ++i) M.segment<3>(3 * i).setConstant(m_[i]);
  // f = -K (x - X) - C v + M g + f_ext, C = alpha M + beta K
  Eigen::VectorXd f = -K_ * (x - X) - beta_ * (K_ * v) - alpha_ * M.cwiseProduct(v) + fe;
  for (int i = 0; i < n; ++i) f.segment<3>(3 * i) += m_[i] * g_;
  // free motion: A dv = h (f + h K v)
  const Eigen::VectorXd dv = llt_.solve(h_ * (f + h_ * (K_ * v)));
  Eigen::Map<Eigen::VectorXd>(v_.data(), 3 * n) += dv;
  x_ = x_start_ + h_ * v_;
  x_free_ = x_;
}

void DenseLinearBody::ApplyCompliance(const Eigen::SparseMatrix<double>& forces,
                                      Eigen::MatrixXd& displacements) const {
  NSIM_CHECK(forces.rows() == 3 * num_nodes(), "compliance rhs has ", forces.rows(),
             " rows, expected ", 3 * num_nodes());
  displacements = llt_.solve(Eigen::MatrixXd(forces));
  displacements *= h_ * h_;
}

void DenseLinearBody::ApplyCorrection(const Eigen::Matrix3Xd& dx) {
  NSIM_CHECK(dx.cols() == x_.cols(), "correction has ", dx.cols(), " columns, expected ",
             x_.cols());
  x_ += dx;
  v_ += dx / h_;
}

Eigen::Vector3d DenseLinearBody::CalcMomentum() const { return v_ * m_; }

}  // namespace nsim
