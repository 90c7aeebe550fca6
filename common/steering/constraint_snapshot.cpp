#include "common/steering/constraint_snapshot.h"

#include <algorithm>
#include <cmath>

#include "common/core/error.h"

namespace nsim {
namespace {

// a W pivot below this times the largest diagonal entry counts as singular (redundant rows),
// and the matrix is then regularized by the same factor (as ConstraintSolverConfig's defaults)
constexpr double kSingularPivotRatio = 1e-12;
constexpr double kRegularization = 1e-10;

// N_a Y: the 3 x 3 block of the rows of Y (3n x 3) gathered at a point's nodes and weights
Eigen::Matrix3d GatherRows(const int* nodes, const double* weights, int count,
                           const Eigen::Matrix<double, Eigen::Dynamic, 3>& Y) {
  Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
  for (int k = 0; k < count; ++k) block += weights[k] * Y.middleRows<3>(3 * nodes[k]);
  return block;
}

}  // namespace

void ConstraintSnapshot::Capture(const ConstraintSet& set, const ConstraintSolver& solver,
                                 int body, const std::vector<char>& moves_with_needle,
                                 const Eigen::Isometry3d& X_WN,
                                 const std::vector<SnapshotProbe>& probes) {
  NSIM_CHECK(static_cast<int>(moves_with_needle.size()) == set.num_points(),
             "moves_with_needle must have one entry per point");
  NSIM_CHECK(solver.W().rows() == set.num_rows(), "Capture needs the Assemble of the same set");
  X_WN_ = X_WN;
  const Eigen::Isometry3d X_NW = X_WN.inverse();

  // body points used by the rows, numbered in order of first use
  std::vector<int> body_point_of(set.num_points(), -1);
  std::vector<int> set_point_of;
  terms_.clear();
  rows_.clear();
  any_unilateral_ = false;
  std::vector<char> row_unilateral(set.num_rows(), 0);
  for (int g = 0; g < set.num_groups(); ++g) {
    const ConstraintGroup& group = set.group(g);
    if (group.law == ConstraintLaw::kFriction) {
      throw InputError("constraint snapshot: Coulomb friction groups are not supported");
    }
    if (group.law == ConstraintLaw::kUnilateral) {
      for (int i = 0; i < group.num_rows; ++i) row_unilateral[group.first_row + i] = 1;
      any_unilateral_ = true;
    }
  }
  for (int i = 0; i < set.num_rows(); ++i) {
    const ConstraintRow& r = set.row(i);
    Row row;
    row.first_term = static_cast<int>(terms_.size());
    row.num_terms = r.num_terms;
    row.target = r.target;
    row.unilateral = row_unilateral[i] != 0;
    for (int t = r.first_term; t < r.first_term + r.num_terms; ++t) {
      const ConstraintTerm& term = set.term(t);
      const ConstraintPoint& point = set.point(term.point);
      Term captured;
      captured.direction = term.direction;
      if (point.body < 0) {
        captured.p_kinematic = point.p_end;
        captured.moving = moves_with_needle[term.point] != 0;
        captured.p_N = X_NW * point.p_end;
        if (captured.moving && !row.unilateral) row.turns = true;
      } else {
        if (point.body != body) {
          throw InputError(Str("constraint snapshot: row ", i, " uses body ", point.body,
                               ", only body ", body, " is captured"));
        }
        if (body_point_of[term.point] < 0) {
          body_point_of[term.point] = static_cast<int>(set_point_of.size());
          set_point_of.push_back(term.point);
        }
        captured.body_point = body_point_of[term.point];
      }
      terms_.push_back(captured);
    }
    rows_.push_back(row);
  }

  // free positions and compliance blocks of the body points
  const int B = static_cast<int>(set_point_of.size());
  num_body_points_ = B;
  free_.resize(B);
  G_.resize(3 * B, 3 * B);
  const std::vector<int>& nodes = set.point_nodes();
  const std::vector<double>& weights = set.point_weights();
  for (int b = 0; b < B; ++b) {
    const int p = set_point_of[b];
    free_[b] = set.CalcFreePosition(p);
    const auto& Y = solver.compliance().point_columns(p);
    for (int a = 0; a < B; ++a) {
      const ConstraintPoint& pa = set.point(set_point_of[a]);
      G_.block<3, 3>(3 * a, 3 * b) =
          GatherRows(&nodes[pa.first_node], &weights[pa.first_node], pa.num_nodes, Y);
    }
  }
  const int Q = static_cast<int>(probes.size());
  P_.resize(3 * Q, 3 * B);
  probe_free_.resize(Q);
  const Eigen::Matrix3Xd& x_free = set.body(body).free_positions();
  for (int q = 0; q < Q; ++q) {
    const SnapshotProbe& probe = probes[q];
    NSIM_CHECK(probe.nodes.size() == probe.weights.size() && !probe.nodes.empty(),
               "probe needs nodes and weights");
    const int count = static_cast<int>(probe.nodes.size());
    probe_free_[q].setZero();
    for (int k = 0; k < count; ++k) probe_free_[q] += probe.weights[k] * x_free.col(probe.nodes[k]);
    for (int b = 0; b < B; ++b) {
      P_.block<3, 3>(3 * q, 3 * b) = GatherRows(probe.nodes.data(), probe.weights.data(), count,
                                                solver.compliance().point_columns(set_point_of[b]));
    }
  }
}

SnapshotSolveReport ConstraintSnapshot::Solve(const Eigen::Isometry3d& X_WN_new,
                                              SnapshotWorkspace& ws,
                                              std::vector<Eigen::Vector3d>* probe_positions) const {
  const int m = num_rows();
  const int B = num_body_points_;
  SnapshotSolveReport report;
  report.num_rows = m;
  const Eigen::Matrix3d R_rel = X_WN_new.linear() * X_WN_.linear().transpose();

  // rows at the perturbed pose: compliance rows H (rows x 3B) and free values delta
  ws.H.setZero(m, 3 * B);
  ws.delta.resize(m);
  for (int i = 0; i < m; ++i) {
    const Row& row = rows_[i];
    double g = -row.target;
    for (int t = row.first_term; t < row.first_term + row.num_terms; ++t) {
      const Term& term = terms_[t];
      const Eigen::Vector3d d = row.turns ? Eigen::Vector3d(R_rel * term.direction) : term.direction;
      if (term.body_point >= 0) {
        ws.H.block<1, 3>(i, 3 * term.body_point) += d.transpose();
        g += d.dot(free_[term.body_point]);
      } else {
        g += d.dot(term.moving ? Eigen::Vector3d(X_WN_new * term.p_N) : term.p_kinematic);
      }
    }
    ws.delta[i] = g;
  }
  ws.HG.noalias() = ws.H * G_;
  ws.W.noalias() = ws.HG * ws.H.transpose();

  // active set: bilateral rows always, unilateral rows while they push (lambda >= 0)
  ws.in_active.assign(m, 1);
  if (any_unilateral_) {
    for (int i = 0; i < m; ++i)
      if (rows_[i].unilateral && ws.delta[i] >= 0.0) ws.in_active[i] = 0;
  }
  ws.lambda.setZero(m);
  const int max_iterations = any_unilateral_ ? 2 * m + 2 : 1;
  for (int it = 0; it < max_iterations; ++it) {
    ws.active.clear();
    for (int i = 0; i < m; ++i)
      if (ws.in_active[i]) ws.active.push_back(i);
    const int k = static_cast<int>(ws.active.size());
    ws.lambda.setZero(m);
    if (k > 0) {
      ws.W_active.resize(k, k);
      ws.rhs.resize(k);
      for (int a = 0; a < k; ++a) {
        ws.rhs[a] = -ws.delta[ws.active[a]];
        for (int b = 0; b < k; ++b) ws.W_active(a, b) = ws.W(ws.active[a], ws.active[b]);
      }
      ws.ldlt.compute(ws.W_active);
      const double max_diag = ws.W_active.diagonal().cwiseAbs().maxCoeff();
      const double min_pivot = ws.ldlt.vectorD().cwiseAbs().minCoeff();
      if (!(min_pivot > kSingularPivotRatio * max_diag)) {
        ws.W_active.diagonal().array() += kRegularization * max_diag;
        ws.ldlt.compute(ws.W_active);
        report.regularized = true;
      }
      const Eigen::VectorXd solution = ws.ldlt.solve(ws.rhs);
      for (int a = 0; a < k; ++a) ws.lambda[ws.active[a]] = solution[a];
    }
    if (!any_unilateral_) break;
    report.active_set_iterations = it + 1;
    // switch rows whose law is violated: pulling contacts leave, penetrating ones enter
    bool changed = false;
    const Eigen::VectorXd r = ws.delta + ws.W * ws.lambda;
    for (int i = 0; i < m; ++i) {
      if (!rows_[i].unilateral) continue;
      if (ws.in_active[i] && ws.lambda[i] < 0.0) {
        ws.in_active[i] = 0;
        changed = true;
      } else if (!ws.in_active[i] && r[i] < -1e-12) {
        ws.in_active[i] = 1;
        changed = true;
      }
    }
    if (!changed) break;
    if (it + 1 == max_iterations) report.converged = false;
  }
  const Eigen::VectorXd r = ws.delta + ws.W * ws.lambda;
  for (int i = 0; i < m; ++i) {
    const double violation = rows_[i].unilateral ? std::max(0.0, -r[i]) : std::abs(r[i]);
    report.max_violation = std::max(report.max_violation, violation);
  }

  // probes: x(q) = x_free(q) + P H^T lambda
  const Eigen::VectorXd force = ws.H.transpose() * ws.lambda;  // 3B (N)
  probe_positions->resize(probe_free_.size());
  for (int q = 0; q < num_probes(); ++q) {
    (*probe_positions)[q] = probe_free_[q] + P_.middleRows<3>(3 * q) * force;
  }
  return report;
}

}  // namespace nsim
