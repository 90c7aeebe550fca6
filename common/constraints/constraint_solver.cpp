#include "common/constraints/constraint_solver.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "common/core/error.h"

namespace nsim {

namespace {

// rows whose diagonal compliance is below this fraction of the largest one cannot be moved by
// their multiplier (no compliant point): they are left at lambda = 0 and counted
constexpr double kDegenerateRatio = 1e-14;

// the slip magnitude s >= 0 with |(a B + s I)^-1 c| = 1 (B 2x2 SPD, a > 0), by Newton on
// 1 / |u(s)| - 1, which is monotone from s = 0 when |u(0)| > 1 (trust-region secular equation)
Eigen::Vector2d SolveSlipDirection(const Eigen::Matrix2d& B, double a, const Eigen::Vector2d& c) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(B);
  const Eigen::Vector2d alpha = a * eig.eigenvalues();
  const Eigen::Vector2d cq = eig.eigenvectors().transpose() * c;
  double s = 0.0;
  for (int it = 0; it < 50; ++it) {
    const Eigen::Vector2d den = (alpha.array() + s).matrix();
    const double n2 = (cq.array().square() / den.array().square()).sum();
    const double n = std::sqrt(n2);
    if (!(n > 0.0)) break;
    if (std::abs(n - 1.0) < 1e-14) break;
    const double f = 1.0 / n - 1.0;
    const double df = (cq.array().square() / den.array().cube()).sum() / (n2 * n);
    if (!(df > 0.0)) break;
    const double s_next = s - f / df;
    s = std::max(s_next, 0.0);
  }
  const Eigen::Vector2d uq = (cq.array() / (alpha.array() + s)).matrix();
  const Eigen::Vector2d u = eig.eigenvectors() * uq;
  const double norm = u.norm();
  return norm > 0.0 ? Eigen::Vector2d(u / norm) : Eigen::Vector2d::Zero();
}

// projection of q on the disk of radius R
Eigen::Vector2d ProjectDisk(const Eigen::Vector2d& q, double R) {
  const double n = q.norm();
  return n <= R ? q : Eigen::Vector2d(q * (R / n));
}

}  // namespace

ConstraintSolver::ConstraintSolver(const ConstraintSolverConfig& config) : config_(config) {
  NSIM_CHECK(config.pgs_tolerance > 0.0, "pgs_tolerance must be > 0 (m), got ",
             config.pgs_tolerance);
  NSIM_CHECK(config.pgs_max_iterations > 0, "pgs_max_iterations must be > 0");
  NSIM_CHECK(config.singular_pivot_ratio > 0.0 && config.regularization > 0.0,
             "singular_pivot_ratio and regularization must be > 0");
}

ConstraintSolveReport ConstraintSolver::Solve(const ConstraintSet& set) {
  Assemble(set);
  ConstraintSolveReport report = SolveMultipliers(set);
  ApplyCorrections(set);
  return report;
}

void ConstraintSolver::Assemble(const ConstraintSet& set) {
  compliance_.Assemble(set, W_);
  RecomputeDelta(set);
}

void ConstraintSolver::RecomputeDelta(const ConstraintSet& set) {
  const int m = set.num_rows();
  delta_.resize(m);
  for (int i = 0; i < m; ++i) {
    const ConstraintRow& r = set.row(i);
    double g = -r.target;
    for (int t = r.first_term; t < r.first_term + r.num_terms; ++t)
      g += set.term(t).direction.dot(set.CalcFreePosition(set.term(t).point));
    delta_[i] = g;
  }
}

ConstraintSolveReport ConstraintSolver::SolveMultipliers(const ConstraintSet& set) {
  const int m = set.num_rows();
  NSIM_CHECK(W_.rows() == m && delta_.size() == m,
             "SolveMultipliers needs the Assemble of the "
             "same set (",
             m, " rows, W has ", W_.rows(), ")");
  int grouped = 0;
  for (int g = 0; g < set.num_groups(); ++g) grouped += set.group(g).num_rows;
  if (grouped != m)
    throw InputError(
        Str("constraints: every row must belong to a group, ", m - grouped, " rows are ungrouped"));
  ConstraintSolveReport report;
  report.num_rows = m;
  lambda_.setZero(m);
  if (m == 0) {
    report.method =
        config_.method == ConstraintMethod::kAuto ? ConstraintMethod::kDirect : config_.method;
    return report;
  }
  ConstraintMethod method = config_.method;
  if (method == ConstraintMethod::kAuto)
    method = set.all_bilateral() ? ConstraintMethod::kDirect : ConstraintMethod::kPgs;
  if (method == ConstraintMethod::kDirect && !set.all_bilateral())
    throw InputError(
        "constraints: the direct method needs bilateral rows only; use kPgs or "
        "kAuto for contact and friction");
  report.method = method;
  if (method == ConstraintMethod::kDirect)
    SolveDirect(report);
  else
    SolvePgs(set, report);
  const Eigen::VectorXd r = delta_ + W_ * lambda_;
  report.residual = CalcResidual(set, r);
  report.max_violation = CalcViolation(set, r);
  return report;
}

void ConstraintSolver::SolveDirect(ConstraintSolveReport& report) {
  const int m = static_cast<int>(W_.rows());
  const double max_diag = W_.diagonal().maxCoeff();
  // degenerate rows (no compliant point) are decoupled and left at zero
  Eigen::MatrixXd Wd = W_;
  Eigen::VectorXd rhs = -delta_;
  for (int i = 0; i < m; ++i) {
    if (W_(i, i) > kDegenerateRatio * max_diag) continue;
    ++report.num_degenerate_rows;
    Wd.row(i).setZero();
    Wd.col(i).setZero();
    Wd(i, i) = max_diag > 0.0 ? max_diag : 1.0;
    rhs[i] = 0.0;
  }
  ldlt_.compute(Wd);
  const Eigen::VectorXd D = ldlt_.vectorD();
  const double scale = Wd.diagonal().maxCoeff();
  if (ldlt_.info() != Eigen::Success || !(D.minCoeff() > config_.singular_pivot_ratio * scale)) {
    // redundant rows: regularize (consistent rows are then met to ~eps |lambda|)
    Wd.diagonal().array() += config_.regularization * scale;
    ldlt_.compute(Wd);
    report.regularized = true;
  }
  lambda_ = ldlt_.solve(rhs);
  report.iterations = 0;
  report.converged = true;
}

void ConstraintSolver::SolvePgs(const ConstraintSet& set, ConstraintSolveReport& report) {
  const int num_groups = set.num_groups();
  const double max_diag = W_.diagonal().maxCoeff();
  const double degenerate = kDegenerateRatio * max_diag;
  block_inverse_.resize(num_groups);
  std::vector<char> active(num_groups, 1);
  for (int g = 0; g < num_groups; ++g) {
    const ConstraintGroup& grp = set.group(g);
    const int k = grp.num_rows;
    const Eigen::MatrixXd B = W_.block(grp.first_row, grp.first_row, k, k);
    for (int i = 0; i < k; ++i) {
      if (!(B(i, i) > degenerate)) {
        active[g] = 0;
        report.num_degenerate_rows += 1;
      }
    }
    if (!active[g]) continue;
    // pseudo-inverse of the diagonal block (a bilateral group may have dependent directions)
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(B);
    const double emax = eig.eigenvalues().maxCoeff();
    Eigen::VectorXd inv_e(k);
    for (int i = 0; i < k; ++i) {
      const double e = eig.eigenvalues()[i];
      inv_e[i] = e > 1e-12 * emax ? 1.0 / e : 0.0;
    }
    block_inverse_[g].setZero();
    block_inverse_[g].topLeftCorner(k, k) =
        eig.eigenvectors() * inv_e.asDiagonal() * eig.eigenvectors().transpose();
  }

  Eigen::VectorXd r(delta_.size());
  report.converged = false;
  for (int sweep = 1; sweep <= config_.pgs_max_iterations; ++sweep) {
    for (int g = 0; g < num_groups; ++g) {
      if (!active[g]) continue;
      const ConstraintGroup& grp = set.group(g);
      const int f = grp.first_row;
      const int k = grp.num_rows;
      Eigen::Vector3d r0 = Eigen::Vector3d::Zero();
      Eigen::Vector3d l0 = Eigen::Vector3d::Zero();
      for (int i = 0; i < k; ++i) {
        r0[i] = delta_[f + i] + W_.row(f + i).dot(lambda_);
        l0[i] = lambda_[f + i];
      }
      const Eigen::Matrix3d& Binv = block_inverse_[g];
      switch (grp.law) {
        case ConstraintLaw::kBilateral: {
          const Eigen::Vector3d l = l0 - Binv * r0;
          lambda_.segment(f, k) = l.head(k);
          break;
        }
        case ConstraintLaw::kUnilateral: {
          lambda_[f] = std::max(0.0, l0[0] - r0[0] / W_(f, f));
          break;
        }
        case ConstraintLaw::kFriction: {
          const Eigen::Matrix3d B = W_.block<3, 3>(f, f);
          const double mu = grp.mu;
          // row values this contact would have with zero force on it
          const Eigen::Vector3d r_zero = r0 - B * l0;
          const Eigen::Vector3d trial = l0 - Binv * r0;  // sticking force
          Eigen::Vector3d l;
          if (r_zero[0] >= 0.0) {
            l.setZero();  // separating
          } else if (trial[0] > 0.0 && trial.tail<2>().norm() <= mu * trial[0]) {
            l = trial;  // stick
          } else {
            // slip: alternate the normal force (tangent direction u fixed) and the slip
            // direction (normal force fixed) so that the slip r_t opposes lambda_t = mu ln u
            const Eigen::Matrix2d Btt = B.block<2, 2>(1, 1);
            const Eigen::Vector2d Btn = B.block<2, 1>(1, 0);
            const Eigen::RowVector2d Bnt = B.block<1, 2>(0, 1);
            Eigen::Vector2d u = trial.tail<2>();
            if (!(u.norm() > 0.0)) u = -r_zero.tail<2>();
            u = u.norm() > 0.0 ? Eigen::Vector2d(u.normalized()) : Eigen::Vector2d::UnitX();
            double ln = 0.0;
            for (int it = 0; it < config_.friction_inner_iterations; ++it) {
              const double denom = B(0, 0) + mu * Bnt.dot(u);
              ln = -r_zero[0] / (denom > 0.0 ? denom : B(0, 0));
              if (mu == 0.0) break;
              const Eigen::Vector2d c = -r_zero.tail<2>() - Btn * ln;
              const Eigen::Vector2d stick = Btt.ldlt().solve(c);
              if (stick.norm() <= mu * ln) {
                u = stick / (mu * ln);  // inside the cone for this normal force
                break;
              }
              u = SolveSlipDirection(Btt, mu * ln, c);
            }
            l << ln, mu * ln * u;
          }
          lambda_.segment<3>(f) = l;
          break;
        }
      }
    }
    r.noalias() = W_ * lambda_;
    r += delta_;
    report.iterations = sweep;
    if (CalcResidual(set, r) <= config_.pgs_tolerance) {
      report.converged = true;
      break;
    }
  }
}

double ConstraintSolver::CalcResidual(const ConstraintSet& set, const Eigen::VectorXd& r) const {
  const double degenerate = kDegenerateRatio * W_.diagonal().maxCoeff();
  double res = 0.0;
  for (int g = 0; g < set.num_groups(); ++g) {
    const ConstraintGroup& grp = set.group(g);
    const int f = grp.first_row;
    bool skip = false;
    for (int i = 0; i < grp.num_rows; ++i) skip = skip || !(W_(f + i, f + i) > degenerate);
    if (skip) continue;
    switch (grp.law) {
      case ConstraintLaw::kBilateral:
        for (int i = 0; i < grp.num_rows; ++i) res = std::max(res, std::abs(r[f + i]));
        break;
      case ConstraintLaw::kUnilateral:
        res = std::max(res, std::abs(std::min(W_(f, f) * lambda_[f], r[f])));
        break;
      case ConstraintLaw::kFriction: {
        res = std::max(res, std::abs(std::min(W_(f, f) * lambda_[f], r[f])));
        const double wt = 0.5 * (W_(f + 1, f + 1) + W_(f + 2, f + 2));
        const Eigen::Vector2d lt = lambda_.segment<2>(f + 1);
        const Eigen::Vector2d q = lt - r.segment<2>(f + 1) / wt;
        const double R = grp.mu * std::max(0.0, lambda_[f]);
        res = std::max(res, wt * (lt - ProjectDisk(q, R)).norm());
        break;
      }
    }
  }
  if (!std::isfinite(res)) return std::numeric_limits<double>::infinity();
  return res;
}

double ConstraintSolver::CalcViolation(const ConstraintSet& set, const Eigen::VectorXd& r) const {
  double v = 0.0;
  for (int g = 0; g < set.num_groups(); ++g) {
    const ConstraintGroup& grp = set.group(g);
    const int f = grp.first_row;
    if (grp.law == ConstraintLaw::kBilateral) {
      for (int i = 0; i < grp.num_rows; ++i) v = std::max(v, std::abs(r[f + i]));
    } else {
      v = std::max(v, -r[f]);
    }
  }
  return v;
}

void ConstraintSolver::ApplyCorrections(const ConstraintSet& set) {
  compliance_.CalcCorrections(set, lambda_, dx_);
  for (int b = 0; b < set.num_bodies(); ++b) set.body(b).ApplyCorrection(dx_[b]);
}

Eigen::Vector3d ConstraintSolver::CalcPointForce(const ConstraintSet& set, int p) const {
  Eigen::Vector3d f = Eigen::Vector3d::Zero();
  for (int i = 0; i < set.num_rows() && i < lambda_.size(); ++i) {
    const ConstraintRow& r = set.row(i);
    for (int t = r.first_term; t < r.first_term + r.num_terms; ++t) {
      if (set.term(t).point == p) f += set.term(t).direction * lambda_[i];
    }
  }
  return f;
}

}  // namespace nsim
