#include "common/needle/needle_constraint_solver.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "common/core/error.h"

namespace nsim {

namespace {

enum class RowKind { kBilateral, kUnilateral, kFriction };

}  // namespace

NeedleConstraintSolver::NeedleConstraintSolver(const NeedleSolverConfig& config)
    : config_(config), generic_(config.generic) {
  NSIM_CHECK(config.position_tolerance > 0.0 && config.force_tolerance > 0.0,
             "needle solver tolerances must be > 0");
  NSIM_CHECK(config.max_iterations > 0, "needle solver max_iterations must be > 0");
}

Eigen::VectorXd NeedleConstraintSolver::CalcRowValues() const {
  return generic_.delta_free() + generic_.W() * lambda_;
}

NeedleSolveReport NeedleConstraintSolver::Solve(const ConstraintSet& set,
                                                const std::vector<AxialFrictionRow>& friction) {
  NeedleSolveReport report;
  if (friction.empty()) {
    report.generic = generic_.Solve(set);
    report.used_generic = true;
    report.converged = report.generic.converged;
    report.max_violation = report.generic.max_violation;
    lambda_ = generic_.lambda();
    return report;
  }

  generic_.Assemble(set);
  const Eigen::MatrixXd& W = generic_.W();
  const Eigen::VectorXd& delta = generic_.delta_free();
  const int m = set.num_rows();

  // row laws
  std::vector<RowKind> kind(m, RowKind::kBilateral);
  std::vector<int> friction_of(m, -1);
  for (int g = 0; g < set.num_groups(); ++g) {
    const ConstraintGroup& grp = set.group(g);
    NSIM_CHECK(grp.law != ConstraintLaw::kFriction,
               "NeedleConstraintSolver: contact-friction groups are not supported together with "
               "axial friction rows");
    if (grp.law == ConstraintLaw::kUnilateral) kind[grp.first_row] = RowKind::kUnilateral;
  }
  for (int f = 0; f < static_cast<int>(friction.size()); ++f) {
    const AxialFrictionRow& fr = friction[f];
    NSIM_CHECK(fr.row >= 0 && fr.row < m && fr.lateral_rows[0] >= 0 && fr.lateral_rows[0] < m &&
                   fr.lateral_rows[1] >= 0 && fr.lateral_rows[1] < m,
               "axial friction row indices out of range");
    NSIM_CHECK(kind[fr.row] == RowKind::kBilateral, "axial friction row ", fr.row,
               " must be a bilateral row");
    NSIM_CHECK(fr.mu >= 0.0 && fr.stiction >= 0.0, "friction mu and stiction must be >= 0");
    kind[fr.row] = RowKind::kFriction;
    friction_of[fr.row] = f;
  }

  // rows that no multiplier can move stay at zero
  const double max_diag = m > 0 ? W.diagonal().maxCoeff() : 0.0;
  std::vector<char> clamped(m, 0);
  Eigen::VectorXd clamp_value = Eigen::VectorXd::Zero(m);
  std::vector<char> degenerate(m, 0);
  for (int i = 0; i < m; ++i) {
    if (!(W(i, i) > 1e-14 * max_diag)) {
      degenerate[i] = 1;
      clamped[i] = 1;
    }
  }
  auto bound = [&](int i) {
    const AxialFrictionRow& fr = friction[friction_of[i]];
    return fr.mu * std::hypot(lambda_[fr.lateral_rows[0]], lambda_[fr.lateral_rows[1]]) +
           fr.stiction;
  };

  lambda_.setZero(m);
  Eigen::VectorXd r(m);
  std::vector<int> free_rows;
  Eigen::MatrixXd Wff;
  Eigen::VectorXd rhs;
  Eigen::LDLT<Eigen::MatrixXd> ldlt;
  const double tol_g = config_.position_tolerance;
  bool converged = false;
  int it = 0;
  for (; it < config_.max_iterations && !converged; ++it) {
    // solve the free rows given the clamped forces
    free_rows.clear();
    for (int i = 0; i < m; ++i) {
      if (clamped[i])
        lambda_[i] = clamp_value[i];
      else
        free_rows.push_back(i);
    }
    const int nf = static_cast<int>(free_rows.size());
    if (nf > 0) {
      Wff.resize(nf, nf);
      rhs.resize(nf);
      double diag = 0.0;
      for (int a = 0; a < nf; ++a) {
        const int i = free_rows[a];
        double s = -delta[i];
        for (int j = 0; j < m; ++j)
          if (clamped[j]) s -= W(i, j) * lambda_[j];
        rhs[a] = s;
        for (int b = 0; b < nf; ++b) Wff(a, b) = W(i, free_rows[b]);
        diag = std::max(diag, Wff(a, a));
      }
      Wff.diagonal().array() += config_.regularization * diag;
      ldlt.compute(Wff);
      const Eigen::VectorXd sol = ldlt.solve(rhs);
      for (int a = 0; a < nf; ++a) lambda_[free_rows[a]] = sol[a];
    }
    r = delta + W * lambda_;
    const double tol_f = config_.force_tolerance * (1.0 + lambda_.cwiseAbs().maxCoeff());

    // switch rows whose law is violated; refresh slipping bounds
    converged = true;
    for (int i = 0; i < m; ++i) {
      if (degenerate[i]) continue;
      if (kind[i] == RowKind::kUnilateral) {
        if (!clamped[i] && lambda_[i] < -tol_f) {
          clamped[i] = 1;
          clamp_value[i] = 0.0;
          converged = false;
        } else if (clamped[i] && r[i] < -tol_g) {
          clamped[i] = 0;
          converged = false;
        }
      } else if (kind[i] == RowKind::kFriction) {
        const double b = bound(i);
        if (!clamped[i]) {
          if (std::abs(lambda_[i]) > b + tol_f) {
            clamped[i] = 1;
            clamp_value[i] = lambda_[i] > 0.0 ? b : -b;
            converged = false;
          }
        } else {
          // slipping: the force opposes the slip; a slip along the force means it sticks
          const double direction = clamp_value[i] >= 0.0 ? 1.0 : -1.0;
          if (b > tol_f && direction * r[i] > tol_g) {
            clamped[i] = 0;
            converged = false;
          } else if (std::abs(clamp_value[i] - direction * b) > tol_f) {
            clamp_value[i] = direction * b;
            converged = false;
          }
        }
      }
    }
  }
  report.iterations = it;
  report.converged = converged;

  for (int i = 0; i < m; ++i) {
    double v = 0.0;
    if (kind[i] == RowKind::kBilateral && !degenerate[i]) v = std::abs(r[i]);
    if (kind[i] == RowKind::kUnilateral) {
      v = std::max(0.0, -r[i]);
      if (clamped[i]) ++report.num_separated;
    }
    if (kind[i] == RowKind::kFriction && clamped[i]) ++report.num_slipping;
    if (kind[i] == RowKind::kFriction && !clamped[i]) v = std::abs(r[i]);
    report.max_violation = std::max(report.max_violation, v);
  }

  // corrections to every body
  generic_.compliance().CalcCorrections(set, lambda_, dx_);
  for (int b = 0; b < set.num_bodies(); ++b) set.body(b).ApplyCorrection(dx_[b]);
  return report;
}

}  // namespace nsim
