#pragma once
// Constraint-space compliance W = sum_b H_b C_b H_b^T (m/N), C_b = h^2 A_b^-1 (thesis eq. 3.2;
// Duriez 2009), built from the sparse structure of H: for every body point p the body solves
// only the 3 columns Y_p = C_b N_p^T (3 n_b x 3, N_p the 3 x 3 n_b barycentric selection), and
//     W_ij = sum_{t in i, s in j, same body} d_t^T (N_{p_t} Y_{p_s}) d_s.
// Y_p does not depend on the row directions, so rows that rotate (a needle that turns, the
// perturbations of the inverse simulation) reuse it.
// Caching across steps (DESIGN.md "Speed"): a keyed point's columns are combined from per-node
// columns, Y_p = sum_k w_k C_b e_{n_k} (exact: C_b is linear), and the node columns are kept
// while the body's compliance_version() is unchanged. A keyed point that moves (a needle tip
// crossing a tet, a seeded point whose tet changes) costs a solve only for the nodes not seen
// before; a point on one node with weight 1 (a contact node) uses the node's columns directly.
// Unkeyed points, and keyed points of a body whose compliance changed at this and the previous
// assemble (refactorized every step), are solved for their own 3 columns (cheaper than 3 per
// node when nothing can be kept).

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include "common/constraints/constraint_set.h"

namespace nsim {

/// Counters of the last Assemble.
struct ComplianceStats {
  int num_body_points = 0;     ///< distinct body points referenced by rows
  int num_reused_points = 0;   ///< keyed points served from cached node columns alone
  int num_solved_columns = 0;  ///< right-hand sides handed to ApplyCompliance (3 per new node
                               ///< of a keyed point, 3 per unkeyed point)
};

/// Builds W and the corrections, and caches the compliance columns of keyed points. Holds all
/// scratch space; reuse one object across steps.
class ComplianceAssembler {
 public:
  /// Computes the columns Y_p of every body point used by a row of `set` (keyed points from
  /// cached node columns) and W (num_rows x num_rows, m/N). Node columns not used for
  /// `kMaxIdleAssembles` consecutive calls are evicted.
  void Assemble(const ConstraintSet& set, Eigen::MatrixXd& W);

  /// Position corrections dx_b = C_b H_b^T lambda (m), 3 x n_b per body of `set`, for the
  /// multipliers lambda (N) of the rows, using the columns of the last Assemble (same set).
  void CalcCorrections(const ConstraintSet& set, const Eigen::VectorXd& lambda,
                       std::vector<Eigen::Matrix3Xd>& dx) const;

  /// The 3 n_b x 3 compliance columns Y_p of body point p from the last Assemble.
  const Eigen::Matrix<double, Eigen::Dynamic, 3>& point_columns(int p) const {
    return *point_columns_[p];
  }

  const ComplianceStats& stats() const { return stats_; }

  /// Solves and caches the node columns of `nodes` of `body` not cached yet, ahead of the
  /// Assemble that will use them (speculative work between steps: the nodes a needle is about
  /// to reach, contacts about to form). Only for a body whose compliance stays valid between
  /// steps (its compliance_version unchanged until then, ConstraintBody::ApplyCompliance
  /// callable outside a step); columns of an older version are dropped first. The requested
  /// nodes count as used (not evicted for kMaxIdleAssembles assembles). At most
  /// `max_new_nodes` are solved, the first of `nodes` not cached (the rest in a later call). A
  /// node column's value does not depend on what it is solved with (CholmodFactor::Solve), so
  /// prefetching changes no result. Returns the number of columns solved (3 per new node).
  int Prefetch(ConstraintBody& body, const std::vector<int>& nodes,
               int max_new_nodes = std::numeric_limits<int>::max());

  /// Forgets every cached column.
  void ClearCache() { caches_.clear(); }

  static constexpr int kMaxIdleAssembles = 8;

 private:
  using Columns = Eigen::Matrix<double, Eigen::Dynamic, 3>;
  struct NodeEntry {
    Columns Y;     // C_b e_node: 3 n_b x 3
    int idle = 0;  // assembles since last use
  };
  struct BodyCache {
    std::uint64_t version = 0;
    std::unordered_map<int, NodeEntry> nodes;  // by node index
    int changes_in_a_row = 0;                  // assembles that found a new compliance_version
  };

  // solves 3 unit columns per node of pending_nodes_, then (with a set) 3 weighted columns per
  // point of pending_points_, into solved_ in that order; caches the node columns; returns
  // the number of columns solved
  int SolvePending(const ConstraintBody& body, BodyCache& cache, const ConstraintSet* set);

  std::unordered_map<std::uint64_t, BodyCache> caches_;  // by body uid
  std::vector<const Columns*> point_columns_;            // per point of the set
  std::vector<Columns> point_storage_;                   // Y_p of points not aliasing a node
  Eigen::MatrixXd point_block_;                          // 3P x 3P: N_p Y_q
  std::vector<int> pending_nodes_, pending_points_;      // to solve for one body
  Eigen::MatrixXd solved_;                               // 3n x 3k output of ApplyCompliance
  ComplianceStats stats_;
};

}  // namespace nsim
