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

// the force bound b of an axial friction group at the multipliers lambda (N)
double CalcAxialBound(const ConstraintGroup& group, const std::vector<ConstraintGroup>& groups,
                      const Eigen::VectorXd& lambda) {
  const ConstraintGroup& normal = groups[group.normal_group];
  double force = 0.0;  // |lambda of the normal group|
  for (int i = normal.first_row; i < normal.first_row + normal.num_rows; ++i)
    force = std::hypot(force, lambda[i]);
  return group.mu * force + group.stiction;
}

// the force tolerance of the active set and of the reports at the multipliers lambda (N)
double CalcForceTolerance(const ConstraintSolverConfig& config, const Eigen::VectorXd& lambda) {
  return config.force_tolerance * (1.0 + (lambda.size() > 0 ? lambda.cwiseAbs().maxCoeff() : 0.0));
}

ConstraintMethod ChooseMethod(ConstraintMethod method, const std::vector<ConstraintGroup>& groups) {
  bool bilateral_only = true, cone = false, axial = false;
  for (const ConstraintGroup& g : groups) {
    bilateral_only = bilateral_only && g.law == ConstraintLaw::kBilateral;
    cone = cone || g.law == ConstraintLaw::kFriction;
    axial = axial || g.law == ConstraintLaw::kAxialFriction;
  }
  if (method == ConstraintMethod::kAuto) {
    if (bilateral_only) return ConstraintMethod::kDirect;
    return axial && !cone ? ConstraintMethod::kActiveSet : ConstraintMethod::kPgs;
  }
  if (method == ConstraintMethod::kDirect && !bilateral_only)
    throw InputError(
        "constraints: the direct method needs bilateral rows only; use kPgs or "
        "kAuto for contact and friction");
  if (method == ConstraintMethod::kActiveSet && cone)
    throw InputError(
        "constraints: the active set takes bilateral, unilateral and axial friction rows; use "
        "kPgs or kAuto for Coulomb friction contacts");
  return method;
}

// LDLT of ws.W_free, solution of ws.rhs into ws.solution: always regularized for the active set,
// only when singular for the direct method (see the file comment)
void SolveFreeBlock(const ConstraintSolverConfig& config, ConstraintMethod method,
                    ConstraintWorkspace& ws, ConstraintSolveReport& report) {
  const double scale = ws.W_free.diagonal().maxCoeff();
  if (method == ConstraintMethod::kActiveSet) {
    ws.W_free.diagonal().array() += config.active_set_regularization * scale;
    ws.ldlt.compute(ws.W_free);
    ws.solution = ws.ldlt.solve(ws.rhs);
    return;
  }
  ws.ldlt.compute(ws.W_free);
  if (ws.ldlt.info() != Eigen::Success ||
      !(ws.ldlt.vectorD().minCoeff() > config.singular_pivot_ratio * scale)) {
    // redundant rows: regularize (consistent rows are then met to ~eps |lambda|)
    ws.W_free.diagonal().array() += config.regularization * scale;
    ws.ldlt.compute(ws.W_free);
    report.regularized = true;
  }
  ws.solution = ws.ldlt.solve(ws.rhs);
}

// the active set (and the direct method) of the file comment; leaves ws.r = delta + W lambda
void SolveActiveSet(const Eigen::MatrixXd& W, const Eigen::VectorXd& delta,
                    const std::vector<ConstraintGroup>& groups,
                    const ConstraintSolverConfig& config, ConstraintWorkspace& ws,
                    Eigen::VectorXd& lambda, ConstraintSolveReport& report) {
  const int m = static_cast<int>(W.rows());
  ws.clamped.assign(ws.degenerate.begin(), ws.degenerate.end());
  ws.clamp_value.setZero(m);
  const double tol_g = config.position_tolerance;
  bool converged = false;
  int it = 0;
  for (; it < config.active_set_max_iterations && !converged; ++it) {
    // solve the free rows given the clamped forces
    ws.free_rows.clear();
    ws.clamped_nonzero.clear();
    for (int i = 0; i < m; ++i) {
      if (!ws.clamped[i]) {
        ws.free_rows.push_back(i);
        continue;
      }
      lambda[i] = ws.clamp_value[i];
      if (lambda[i] != 0.0) ws.clamped_nonzero.push_back(i);
    }
    const int nf = static_cast<int>(ws.free_rows.size());
    if (nf == m) {
      ws.W_free = W;
      ws.rhs = -delta;
    } else if (nf > 0) {
      ws.W_free.resize(nf, nf);
      ws.rhs.resize(nf);
      for (int b = 0; b < nf; ++b)
        for (int a = 0; a < nf; ++a) ws.W_free(a, b) = W(ws.free_rows[a], ws.free_rows[b]);
      for (int a = 0; a < nf; ++a) {
        const int i = ws.free_rows[a];
        double s = -delta[i];
        for (int j : ws.clamped_nonzero) s -= W(i, j) * lambda[j];
        ws.rhs[a] = s;
      }
    }
    if (nf > 0) {
      SolveFreeBlock(config, report.method, ws, report);
      for (int a = 0; a < nf; ++a) lambda[ws.free_rows[a]] = ws.solution[a];
    }
    ws.r.noalias() = W * lambda;
    ws.r += delta;
    const double tol_f = CalcForceTolerance(config, lambda);

    // switch rows whose law is violated; refresh slipping bounds
    converged = true;
    for (const ConstraintGroup& g : groups) {
      const int i = g.first_row;
      if (ws.degenerate[i]) continue;
      if (g.law == ConstraintLaw::kUnilateral) {
        if (!ws.clamped[i] && lambda[i] < -tol_f) {
          ws.clamped[i] = 1;
          ws.clamp_value[i] = 0.0;
          converged = false;
        } else if (ws.clamped[i] && ws.r[i] < -tol_g) {
          ws.clamped[i] = 0;
          converged = false;
        }
      } else if (g.law == ConstraintLaw::kAxialFriction) {
        const double b = CalcAxialBound(g, groups, lambda);
        if (!ws.clamped[i]) {
          if (std::abs(lambda[i]) > b + tol_f) {
            ws.clamped[i] = 1;
            ws.clamp_value[i] = lambda[i] > 0.0 ? b : -b;
            converged = false;
          }
        } else {
          // slipping: the force opposes the slip; a slip along the force means it sticks
          const double direction = ws.clamp_value[i] >= 0.0 ? 1.0 : -1.0;
          if (b > tol_f && direction * ws.r[i] > tol_g) {
            ws.clamped[i] = 0;
            converged = false;
          } else if (std::abs(ws.clamp_value[i] - direction * b) > tol_f) {
            ws.clamp_value[i] = direction * b;
            converged = false;
          }
        }
      }
    }
  }
  report.iterations = it;
  report.converged = converged;
}

// the natural-map residual of ConstraintSolveReport::residual
double CalcResidual(const Eigen::MatrixXd& W, const std::vector<ConstraintGroup>& groups,
                    const ConstraintWorkspace& ws, const Eigen::VectorXd& lambda,
                    const Eigen::VectorXd& r) {
  double res = 0.0;
  for (const ConstraintGroup& grp : groups) {
    const int f = grp.first_row;
    bool skip = false;
    for (int i = 0; i < grp.num_rows; ++i) skip = skip || ws.degenerate[f + i];
    if (skip) continue;
    switch (grp.law) {
      case ConstraintLaw::kBilateral:
        for (int i = 0; i < grp.num_rows; ++i) res = std::max(res, std::abs(r[f + i]));
        break;
      case ConstraintLaw::kUnilateral:
        res = std::max(res, std::abs(std::min(W(f, f) * lambda[f], r[f])));
        break;
      case ConstraintLaw::kFriction: {
        res = std::max(res, std::abs(std::min(W(f, f) * lambda[f], r[f])));
        const double wt = 0.5 * (W(f + 1, f + 1) + W(f + 2, f + 2));
        const Eigen::Vector2d lt = lambda.segment<2>(f + 1);
        const Eigen::Vector2d q = lt - r.segment<2>(f + 1) / wt;
        const double R = grp.mu * std::max(0.0, lambda[f]);
        res = std::max(res, wt * (lt - ProjectDisk(q, R)).norm());
        break;
      }
      case ConstraintLaw::kAxialFriction: {
        const double w = W(f, f);
        const double b = CalcAxialBound(grp, groups, lambda);
        res = std::max(res, w * std::abs(lambda[f] - std::clamp(lambda[f] - r[f] / w, -b, b)));
        break;
      }
    }
  }
  if (!std::isfinite(res)) return std::numeric_limits<double>::infinity();
  return res;
}

// projected block Gauss-Seidel; leaves ws.r = delta + W lambda
void SolvePgs(const Eigen::MatrixXd& W, const Eigen::VectorXd& delta,
              const std::vector<ConstraintGroup>& groups, const ConstraintSolverConfig& config,
              ConstraintWorkspace& ws, Eigen::VectorXd& lambda, ConstraintSolveReport& report) {
  const int num_groups = static_cast<int>(groups.size());
  ws.block_inverse.resize(num_groups);
  ws.active.assign(num_groups, 1);
  for (int g = 0; g < num_groups; ++g) {
    const ConstraintGroup& grp = groups[g];
    const int k = grp.num_rows;
    for (int i = 0; i < k; ++i) {
      if (ws.degenerate[grp.first_row + i]) ws.active[g] = 0;
    }
    if (!ws.active[g]) continue;
    // pseudo-inverse of the diagonal block (a bilateral group may have dependent directions)
    const Eigen::MatrixXd B = W.block(grp.first_row, grp.first_row, k, k);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(B);
    const double emax = eig.eigenvalues().maxCoeff();
    Eigen::VectorXd inv_e(k);
    for (int i = 0; i < k; ++i) {
      const double e = eig.eigenvalues()[i];
      inv_e[i] = e > 1e-12 * emax ? 1.0 / e : 0.0;
    }
    ws.block_inverse[g].setZero();
    ws.block_inverse[g].topLeftCorner(k, k) =
        eig.eigenvectors() * inv_e.asDiagonal() * eig.eigenvectors().transpose();
  }

  report.converged = false;
  for (int sweep = 1; sweep <= config.pgs_max_iterations; ++sweep) {
    for (int g = 0; g < num_groups; ++g) {
      if (!ws.active[g]) continue;
      const ConstraintGroup& grp = groups[g];
      const int f = grp.first_row;
      const int k = grp.num_rows;
      Eigen::Vector3d r0 = Eigen::Vector3d::Zero();
      Eigen::Vector3d l0 = Eigen::Vector3d::Zero();
      for (int i = 0; i < k; ++i) {
        r0[i] = delta[f + i] + W.row(f + i).dot(lambda);
        l0[i] = lambda[f + i];
      }
      const Eigen::Matrix3d& Binv = ws.block_inverse[g];
      switch (grp.law) {
        case ConstraintLaw::kBilateral: {
          const Eigen::Vector3d l = l0 - Binv * r0;
          lambda.segment(f, k) = l.head(k);
          break;
        }
        case ConstraintLaw::kUnilateral: {
          lambda[f] = std::max(0.0, l0[0] - r0[0] / W(f, f));
          break;
        }
        case ConstraintLaw::kAxialFriction: {
          const double b = CalcAxialBound(grp, groups, lambda);
          lambda[f] = std::clamp(l0[0] - r0[0] / W(f, f), -b, b);
          break;
        }
        case ConstraintLaw::kFriction: {
          const Eigen::Matrix3d B = W.block<3, 3>(f, f);
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
            for (int it = 0; it < config.friction_inner_iterations; ++it) {
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
          lambda.segment<3>(f) = l;
          break;
        }
      }
    }
    ws.r.noalias() = W * lambda;
    ws.r += delta;
    report.iterations = sweep;
    if (CalcResidual(W, groups, ws, lambda, ws.r) <= config.pgs_tolerance) {
      report.converged = true;
      break;
    }
  }
}

// max_violation, num_slipping and num_separated of the report at lambda, r = delta + W lambda
void ReportLaws(const std::vector<ConstraintGroup>& groups, const ConstraintSolverConfig& config,
                const ConstraintWorkspace& ws, const Eigen::VectorXd& lambda,
                const Eigen::VectorXd& r, ConstraintSolveReport& report) {
  const double tol_f = CalcForceTolerance(config, lambda);
  double v = 0.0;
  for (const ConstraintGroup& grp : groups) {
    const int f = grp.first_row;
    switch (grp.law) {
      case ConstraintLaw::kBilateral:
        for (int i = 0; i < grp.num_rows; ++i) v = std::max(v, std::abs(r[f + i]));
        break;
      case ConstraintLaw::kUnilateral:
        v = std::max(v, -r[f]);
        if (lambda[f] <= 0.0) ++report.num_separated;
        break;
      case ConstraintLaw::kFriction:
        v = std::max(v, -r[f]);
        if (lambda[f] <= 0.0)
          ++report.num_separated;
        else if (lambda.segment<2>(f + 1).norm() >= grp.mu * lambda[f] - tol_f)
          ++report.num_slipping;
        break;
      case ConstraintLaw::kAxialFriction: {
        const double b = CalcAxialBound(grp, groups, lambda);
        if (ws.degenerate[f] || std::abs(lambda[f]) < b - tol_f) {
          v = std::max(v, std::abs(r[f]));  // sticks
        } else {
          ++report.num_slipping;
          const double direction = lambda[f] >= 0.0 ? 1.0 : -1.0;
          if (b > tol_f) v = std::max(v, direction * r[f]);
        }
        break;
      }
    }
  }
  report.max_violation = v;
}

}  // namespace

ConstraintSolveReport SolveConstraintLaws(const Eigen::MatrixXd& W, const Eigen::VectorXd& delta,
                                          const std::vector<ConstraintGroup>& groups,
                                          const ConstraintSolverConfig& config,
                                          ConstraintWorkspace& ws, Eigen::VectorXd& lambda) {
  const int m = static_cast<int>(W.rows());
  NSIM_CHECK(W.cols() == m && delta.size() == m, "constraints: W is ", W.rows(), " x ", W.cols(),
             " and delta has ", delta.size(), " rows");
  int grouped = 0;
  for (const ConstraintGroup& g : groups) {
    grouped += g.num_rows;
    NSIM_CHECK(g.law != ConstraintLaw::kAxialFriction ||
                   (g.normal_group >= 0 && g.normal_group < static_cast<int>(groups.size())),
               "constraints: axial friction without a normal group");
  }
  if (grouped != m)
    throw InputError(
        Str("constraints: every row must belong to a group, ", m - grouped, " rows are ungrouped"));
  ConstraintSolveReport report;
  report.num_rows = m;
  report.method = ChooseMethod(config.method, groups);
  lambda.setZero(m);
  if (m == 0) return report;

  const double max_diag = W.diagonal().maxCoeff();
  ws.degenerate.resize(m);
  for (int i = 0; i < m; ++i) {
    ws.degenerate[i] = !(W(i, i) > kDegenerateRatio * max_diag);
    report.num_degenerate_rows += ws.degenerate[i];
  }
  if (report.method == ConstraintMethod::kPgs)
    SolvePgs(W, delta, groups, config, ws, lambda, report);
  else
    SolveActiveSet(W, delta, groups, config, ws, lambda, report);
  report.residual = CalcResidual(W, groups, ws, lambda, ws.r);
  ReportLaws(groups, config, ws, lambda, ws.r, report);
  if (!lambda.allFinite()) report.converged = false;
  return report;
}

ConstraintSolver::ConstraintSolver(const ConstraintSolverConfig& config) : config_(config) {
  NSIM_CHECK(config.pgs_tolerance > 0.0, "pgs_tolerance must be > 0 (m), got ",
             config.pgs_tolerance);
  NSIM_CHECK(config.pgs_max_iterations > 0, "pgs_max_iterations must be > 0");
  NSIM_CHECK(config.position_tolerance > 0.0 && config.force_tolerance > 0.0,
             "active-set tolerances must be > 0");
  NSIM_CHECK(config.active_set_max_iterations > 0, "active_set_max_iterations must be > 0");
  NSIM_CHECK(config.active_set_regularization > 0.0, "active_set_regularization must be > 0");
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
  ApplyRowSoftness(set.rows(), W_);
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
  return SolveConstraintLaws(W_, delta_, set.groups(), config_, workspace_, lambda_);
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
