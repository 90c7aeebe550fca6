#include "common/steering/constraint_snapshot.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "common/core/error.h"
#include "common/robot/pose_math.h"

namespace nsim {
namespace {

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
  SnapshotBody captured;
  captured.body = body;
  captured.probes = probes;
  Capture(set, solver, {captured}, moves_with_needle, X_WN);
}

void ConstraintSnapshot::Capture(const ConstraintSet& set, const ConstraintSolver& solver,
                                 const std::vector<SnapshotBody>& bodies,
                                 const std::vector<char>& moves_with_needle,
                                 const Eigen::Isometry3d& X_WN) {
  NSIM_CHECK(static_cast<int>(moves_with_needle.size()) == set.num_points(),
             "moves_with_needle must have one entry per point");
  NSIM_CHECK(solver.W().rows() == set.num_rows(), "Capture needs the Assemble of the same set");
  X_WN_ = X_WN;
  const Eigen::Isometry3d X_NW = X_WN.inverse();
  // which captured body each set body is
  std::vector<int> captured_of(set.num_bodies(), -1);
  for (size_t c = 0; c < bodies.size(); ++c) {
    NSIM_CHECK(bodies[c].body >= 0 && bodies[c].body < set.num_bodies(),
               "captured body index out of range");
    NSIM_CHECK(bodies[c].free_sensitivity.size() == 0 ||
                   (bodies[c].free_sensitivity.rows() ==
                        3 * set.body(bodies[c].body).free_positions().cols() &&
                    bodies[c].free_sensitivity.cols() == 6),
               "free_sensitivity must be 3 #nodes x 6");
    captured_of[bodies[c].body] = static_cast<int>(c);
  }

  // body points used by the rows, numbered in order of first use
  std::vector<int> body_point_of(set.num_points(), -1);
  std::vector<int> set_point_of;
  terms_.clear();
  rows_.clear();
  groups_ = set.groups();
  config_ = solver.config();
  config_.method = set.all_bilateral() ? ConstraintMethod::kDirect : ConstraintMethod::kActiveSet;
  std::vector<char> row_unilateral(set.num_rows(), 0);
  for (const ConstraintGroup& group : groups_) {
    if (group.law == ConstraintLaw::kFriction) {
      throw InputError("constraint snapshot: Coulomb friction groups are not supported");
    }
    if (group.law == ConstraintLaw::kUnilateral) row_unilateral[group.first_row] = 1;
  }
  for (int i = 0; i < set.num_rows(); ++i) {
    const ConstraintRow& r = set.row(i);
    Row row;
    row.first_term = static_cast<int>(terms_.size());
    row.num_terms = r.num_terms;
    row.target = r.target;
    row.softness = r.softness;
    row.compliance = r.compliance;
    for (int t = r.first_term; t < r.first_term + r.num_terms; ++t) {
      const ConstraintTerm& term = set.term(t);
      const ConstraintPoint& point = set.point(term.point);
      Term captured;
      captured.direction = term.direction;
      if (point.body < 0) {
        captured.p_kinematic = point.p_end;
        captured.moving = moves_with_needle[term.point] != 0;
        captured.p_N = X_NW * point.p_end;
        if (captured.moving && !row_unilateral[i]) row.turns = true;
      } else {
        if (captured_of[point.body] < 0) {
          throw InputError(Str("constraint snapshot: row ", i, " uses body ", point.body,
                               ", which is not captured"));
        }
        if (body_point_of[term.point] < 0) {
          body_point_of[term.point] = static_cast<int>(set_point_of.size());
          set_point_of.push_back(term.point);
        }
        captured.body_point = body_point_of[term.point];
        if (bodies[captured_of[point.body]].rows_turn && !row_unilateral[i]) row.turns = true;
      }
      terms_.push_back(captured);
    }
    rows_.push_back(row);
  }

  // free positions and compliance blocks of the body points (zero across bodies)
  const int B = static_cast<int>(set_point_of.size());
  num_body_points_ = B;
  free_.resize(B);
  G_.setZero(3 * B, 3 * B);
  const std::vector<int>& nodes = set.point_nodes();
  const std::vector<double>& weights = set.point_weights();
  bool any_sensitivity = false;
  for (const SnapshotBody& body : bodies) any_sensitivity |= body.free_sensitivity.size() > 0;
  point_sensitivity_.resize(any_sensitivity ? 3 * B : 0, 6);
  for (int b = 0; b < B; ++b) {
    const int p = set_point_of[b];
    const ConstraintPoint& pb = set.point(p);
    free_[b] = set.CalcFreePosition(p);
    const auto& Y = solver.compliance().point_columns(p);
    for (int a = 0; a < B; ++a) {
      const ConstraintPoint& pa = set.point(set_point_of[a]);
      if (pa.body != pb.body) continue;
      G_.block<3, 3>(3 * a, 3 * b) =
          GatherRows(&nodes[pa.first_node], &weights[pa.first_node], pa.num_nodes, Y);
    }
    if (any_sensitivity) {
      const Eigen::MatrixXd& S = bodies[captured_of[pb.body]].free_sensitivity;
      point_sensitivity_.middleRows<3>(3 * b).setZero();
      if (S.size() > 0)
        for (int k = 0; k < pb.num_nodes; ++k)
          point_sensitivity_.middleRows<3>(3 * b) +=
              weights[pb.first_node + k] * S.middleRows<3>(3 * nodes[pb.first_node + k]);
    }
  }
  int Q = 0;
  for (const SnapshotBody& body : bodies) Q += static_cast<int>(body.probes.size());
  P_.setZero(3 * Q, 3 * B);
  probe_free_.resize(Q);
  probe_sensitivity_.setZero(any_sensitivity ? 3 * Q : 0, 6);
  int q = 0;
  for (const SnapshotBody& body : bodies) {
    const Eigen::Matrix3Xd& x_free = set.body(body.body).free_positions();
    for (const SnapshotProbe& probe : body.probes) {
      NSIM_CHECK(probe.nodes.size() == probe.weights.size() && !probe.nodes.empty(),
                 "probe needs nodes and weights");
      const int count = static_cast<int>(probe.nodes.size());
      probe_free_[q].setZero();
      for (int k = 0; k < count; ++k) {
        probe_free_[q] += probe.weights[k] * x_free.col(probe.nodes[k]);
        if (body.free_sensitivity.size() > 0)
          probe_sensitivity_.middleRows<3>(3 * q) +=
              probe.weights[k] * body.free_sensitivity.middleRows<3>(3 * probe.nodes[k]);
      }
      for (int b = 0; b < B; ++b) {
        if (set.point(set_point_of[b]).body != body.body) continue;
        P_.block<3, 3>(3 * q, 3 * b) =
            GatherRows(probe.nodes.data(), probe.weights.data(), count,
                       solver.compliance().point_columns(set_point_of[b]));
      }
      ++q;
    }
  }
  if (hold_friction_) HoldFrictionForces(solver.lambda());
}

void ConstraintSnapshot::HoldFrictionForces(const Eigen::VectorXd& lambda) {
  NSIM_CHECK(lambda.size() == num_rows(), "HoldFrictionForces needs the step's multipliers");
  const int B = num_body_points_;
  // the held rows' forces on the body points (their directions at the captured pose)
  Eigen::VectorXd held = Eigen::VectorXd::Zero(3 * B);
  std::vector<char> held_row(rows_.size(), 0);
  bool any = false;
  for (const ConstraintGroup& group : groups_) {
    if (group.law != ConstraintLaw::kAxialFriction) continue;
    for (int i = group.first_row; i < group.first_row + group.num_rows; ++i) {
      held_row[i] = 1;
      any = true;
      const Row& row = rows_[i];
      for (int t = row.first_term; t < row.first_term + row.num_terms; ++t)
        if (terms_[t].body_point >= 0)
          held.segment<3>(3 * terms_[t].body_point) += lambda[i] * terms_[t].direction;
    }
  }
  if (!any) return;
  // their corrections become part of the free motion
  const Eigen::VectorXd shift = G_ * held;
  for (int b = 0; b < B; ++b) free_[b] += shift.segment<3>(3 * b);
  const Eigen::VectorXd probe_shift = P_ * held;
  for (int q = 0; q < num_probes(); ++q) probe_free_[q] += probe_shift.segment<3>(3 * q);
  // and the rows leave the problem (the groups renumbered; only axial groups name another)
  std::vector<int> new_index(rows_.size(), -1);
  std::vector<Row> rows;
  for (size_t i = 0; i < rows_.size(); ++i) {
    if (held_row[i]) continue;
    new_index[i] = static_cast<int>(rows.size());
    rows.push_back(rows_[i]);
  }
  std::vector<ConstraintGroup> groups;
  bool all_bilateral = true;
  for (const ConstraintGroup& group : groups_) {
    if (group.law == ConstraintLaw::kAxialFriction) continue;
    ConstraintGroup g = group;
    g.first_row = new_index[group.first_row];
    all_bilateral = all_bilateral && g.law == ConstraintLaw::kBilateral;
    groups.push_back(g);
  }
  rows_ = std::move(rows);
  groups_ = std::move(groups);
  if (all_bilateral) config_.method = ConstraintMethod::kDirect;
}

ConstraintSolveReport ConstraintSnapshot::Solve(
    const Eigen::Isometry3d& X_WN_new, SnapshotWorkspace& ws,
    std::vector<Eigen::Vector3d>* probe_positions) const {
  const int m = num_rows();
  const int B = num_body_points_;
  const Eigen::Matrix3d R_rel = X_WN_new.linear() * X_WN_.linear().transpose();
  // free positions that follow the base pose: shifted by S [dp; log(R' R^T)]
  const bool shifted = point_sensitivity_.rows() > 0;
  Vector6d pose_delta = Vector6d::Zero();
  if (shifted) {
    pose_delta.head<3>() = X_WN_new.translation() - X_WN_.translation();
    pose_delta.tail<3>() = LogSO3(R_rel);
    ws.shift.noalias() = point_sensitivity_ * pose_delta;
  }

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
        if (shifted) g += d.dot(ws.shift.segment<3>(3 * term.body_point));
      } else {
        g += d.dot(term.moving ? Eigen::Vector3d(X_WN_new * term.p_N) : term.p_kinematic);
      }
    }
    ws.delta[i] = g;
  }
  ws.HG.noalias() = ws.H * G_;
  ws.W.noalias() = ws.HG * ws.H.transpose();
  ApplyRowSoftness(rows_, ws.W);
  const ConstraintSolveReport report =
      SolveConstraintLaws(ws.W, ws.delta, groups_, config_, ws.solver, ws.lambda);

  // the forces on the needle's moving points: lambda_i times each moving term's direction
  ws.needle_force.setZero();
  for (int i = 0; i < m; ++i) {
    const Row& row = rows_[i];
    for (int t = row.first_term; t < row.first_term + row.num_terms; ++t) {
      const Term& term = terms_[t];
      if (term.body_point >= 0 || !term.moving) continue;
      const Eigen::Vector3d d = row.turns ? Eigen::Vector3d(R_rel * term.direction) : term.direction;
      ws.needle_force += ws.lambda[i] * d;
    }
  }

  // probes: x(q) = x_free(q) + P H^T lambda
  ws.force.noalias() = ws.H.transpose() * ws.lambda;  // 3B (N)
  probe_positions->resize(probe_free_.size());
  for (int q = 0; q < num_probes(); ++q) {
    (*probe_positions)[q] = probe_free_[q] + P_.middleRows<3>(3 * q) * ws.force;
    if (shifted) (*probe_positions)[q] += probe_sensitivity_.middleRows<3>(3 * q) * pose_delta;
  }
  return report;
}

Eigen::Matrix3d ConstraintSnapshot::CalcNeedleTranslationStiffness(SnapshotWorkspace& ws) const {
  const int m = num_rows();
  const int B = num_body_points_;
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(m, 3);
  bool any = false;
  ws.H.setZero(m, 3 * B);
  for (int i = 0; i < m; ++i) {
    const Row& row = rows_[i];
    for (int t = row.first_term; t < row.first_term + row.num_terms; ++t) {
      const Term& term = terms_[t];
      if (term.body_point >= 0) {
        ws.H.block<1, 3>(i, 3 * term.body_point) += term.direction.transpose();
      } else if (term.moving) {
        D.row(i) += term.direction.transpose();
        any = true;
      }
    }
  }
  if (!any) return Eigen::Matrix3d::Zero();
  ws.HG.noalias() = ws.H * G_;
  ws.W.noalias() = ws.HG * ws.H.transpose();
  ApplyRowSoftness(rows_, ws.W);
  // W lambda = -delta and a translation dp adds D dp to delta: the force D^T lambda changes by
  // -D^T W^-1 D dp
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(ws.W);
  if (ldlt.info() != Eigen::Success) return Eigen::Matrix3d::Zero();
  const Eigen::Matrix3d K = D.transpose() * ldlt.solve(D);
  return K.allFinite() ? Eigen::Matrix3d(0.5 * (K + K.transpose())) : Eigen::Matrix3d::Zero();
}

}  // namespace nsim
