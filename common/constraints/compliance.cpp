#include "common/constraints/compliance.h"

#include <algorithm>

#include "common/core/error.h"

namespace nsim {

int ComplianceAssembler::Prefetch(ConstraintBody& body, const std::vector<int>& nodes,
                                  int max_new_nodes) {
  BodyCache& cache = caches_[body.uid()];
  if (cache.version != body.compliance_version()) {
    cache.nodes.clear();
    cache.version = body.compliance_version();
  }
  pending_nodes_.clear();
  for (int node : nodes) {
    NSIM_CHECK(node >= 0 && node < body.num_nodes(), "prefetch of node ", node, " of a body of ",
               body.num_nodes(), " nodes");
    const auto it = cache.nodes.find(node);
    if (it != cache.nodes.end()) {
      it->second.idle = 0;
      continue;
    }
    if (static_cast<int>(pending_nodes_.size()) < max_new_nodes &&
        std::find(pending_nodes_.begin(), pending_nodes_.end(), node) == pending_nodes_.end())
      pending_nodes_.push_back(node);
  }
  return SolvePending(body, cache, nullptr);
}

int ComplianceAssembler::SolvePending(const ConstraintBody& body, BodyCache& cache,
                                      const ConstraintSet* set) {
  const int num_nodes = static_cast<int>(pending_nodes_.size());
  const int k = num_nodes + (set != nullptr ? static_cast<int>(pending_points_.size()) : 0);
  if (k == 0) return 0;
  const int n = body.num_nodes();
  std::vector<Eigen::Triplet<double>> triplets;
  for (int j = 0; j < num_nodes; ++j)
    for (int c = 0; c < 3; ++c) triplets.emplace_back(3 * pending_nodes_[j] + c, 3 * j + c, 1.0);
  for (int j = num_nodes; j < k; ++j) {
    const ConstraintPoint& pt = set->point(pending_points_[j - num_nodes]);
    for (int m = 0; m < pt.num_nodes; ++m) {
      const int node = set->point_nodes()[pt.first_node + m];
      const double w = set->point_weights()[pt.first_node + m];
      for (int c = 0; c < 3; ++c) triplets.emplace_back(3 * node + c, 3 * j + c, w);
    }
  }
  Eigen::SparseMatrix<double> rhs(3 * n, 3 * k);
  rhs.setFromTriplets(triplets.begin(), triplets.end());
  body.ApplyCompliance(rhs, solved_);
  NSIM_CHECK(solved_.rows() == 3 * n && solved_.cols() == 3 * k, "ApplyCompliance returned ",
             solved_.rows(), " x ", solved_.cols(), ", expected ", 3 * n, " x ", 3 * k);
  for (int j = 0; j < num_nodes; ++j)
    cache.nodes[pending_nodes_[j]].Y = solved_.middleCols(3 * j, 3);
  return 3 * k;
}

void ComplianceAssembler::Assemble(const ConstraintSet& set, Eigen::MatrixXd& W) {
  const int num_points = set.num_points();
  stats_ = ComplianceStats{};
  point_columns_.assign(num_points, nullptr);
  if (static_cast<int>(point_storage_.size()) < num_points) point_storage_.resize(num_points);

  // which body points are used by a row
  std::vector<char> used(num_points, 0);
  for (int i = 0; i < set.num_rows(); ++i) {
    const ConstraintRow& r = set.row(i);
    for (int t = r.first_term; t < r.first_term + r.num_terms; ++t) used[set.term(t).point] = 1;
  }
  for (int p = 0; p < num_points; ++p) {
    if (set.point(p).body < 0) used[p] = 0;
    stats_.num_body_points += used[p];
  }

  for (int b = 0; b < set.num_bodies(); ++b) {
    const ConstraintBody& body = set.body(b);
    const int n = body.num_nodes();
    BodyCache& cache = caches_[body.uid()];
    if (cache.version != body.compliance_version()) {
      cache.nodes.clear();
      cache.version = body.compliance_version();
      ++cache.changes_in_a_row;
    } else {
      cache.changes_in_a_row = 0;
    }
    // a compliance that changes at every assemble (a body refactorized every step) keeps
    // nothing: its keyed points are solved like unkeyed ones (3 columns, not 3 per node)
    const bool node_columns = cache.changes_in_a_row < 2;
    for (auto& [node, entry] : cache.nodes) ++entry.idle;

    // the nodes of keyed points not cached yet, and the unkeyed points
    pending_nodes_.clear();
    pending_points_.clear();
    for (int p = 0; p < num_points; ++p) {
      const ConstraintPoint& pt = set.point(p);
      if (!used[p] || pt.body != b) continue;
      if (pt.key == 0 || !node_columns) {
        pending_points_.push_back(p);
        continue;
      }
      bool all_cached = true;
      for (int m = 0; m < pt.num_nodes; ++m) {
        const int node = set.point_nodes()[pt.first_node + m];
        if (cache.nodes.count(node) > 0) continue;
        all_cached = false;
        if (std::find(pending_nodes_.begin(), pending_nodes_.end(), node) == pending_nodes_.end())
          pending_nodes_.push_back(node);
      }
      stats_.num_reused_points += all_cached ? 1 : 0;
    }

    // one multi-column solve: 3 unit columns per pending node, then 3 per unkeyed point
    stats_.num_solved_columns += SolvePending(body, cache, &set);
    for (size_t j = 0; j < pending_points_.size(); ++j) {
      const int p = pending_points_[j];
      point_storage_[p] = solved_.middleCols(3 * (pending_nodes_.size() + j), 3);
      point_columns_[p] = &point_storage_[p];
    }

    // keyed points: Y_p = sum_k w_k C e_{n_k} from the node columns
    for (int p = 0; p < num_points; ++p) {
      const ConstraintPoint& pt = set.point(p);
      if (!used[p] || pt.body != b || pt.key == 0 || !node_columns) continue;
      const int* nodes = set.point_nodes().data() + pt.first_node;
      const double* weights = set.point_weights().data() + pt.first_node;
      for (int m = 0; m < pt.num_nodes; ++m) cache.nodes.at(nodes[m]).idle = 0;
      if (pt.num_nodes == 1 && weights[0] == 1.0) {
        point_columns_[p] = &cache.nodes.at(nodes[0]).Y;
        continue;
      }
      Columns& Y = point_storage_[p];
      Y.setZero(3 * n, 3);
      for (int m = 0; m < pt.num_nodes; ++m) Y.noalias() += weights[m] * cache.nodes.at(nodes[m]).Y;
      point_columns_[p] = &Y;
    }

    // evict long-unused node columns
    for (auto it = cache.nodes.begin(); it != cache.nodes.end();) {
      if (it->second.idle > kMaxIdleAssembles)
        it = cache.nodes.erase(it);
      else
        ++it;
    }
  }

  // point-point blocks N_p Y_q for points on the same body
  point_block_.setZero(3 * num_points, 3 * num_points);
  for (int q = 0; q < num_points; ++q) {
    if (!used[q]) continue;
    const Columns& Yq = *point_columns_[q];
    for (int p = 0; p < num_points; ++p) {
      const ConstraintPoint& pt = set.point(p);
      if (!used[p] || pt.body != set.point(q).body) continue;
      Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
      for (int m = 0; m < pt.num_nodes; ++m) {
        const int node = set.point_nodes()[pt.first_node + m];
        block += set.point_weights()[pt.first_node + m] * Yq.middleRows<3>(3 * node);
      }
      point_block_.block<3, 3>(3 * p, 3 * q) = block;
    }
  }

  // rows: W_ij = sum over term pairs of d_t^T B(p_t, p_s) d_s
  const int m = set.num_rows();
  W.setZero(m, m);
  for (int i = 0; i < m; ++i) {
    const ConstraintRow& ri = set.row(i);
    for (int j = 0; j <= i; ++j) {
      const ConstraintRow& rj = set.row(j);
      double w = 0.0;
      for (int t = ri.first_term; t < ri.first_term + ri.num_terms; ++t) {
        const ConstraintTerm& tt = set.term(t);
        if (!used[tt.point]) continue;
        for (int s = rj.first_term; s < rj.first_term + rj.num_terms; ++s) {
          const ConstraintTerm& ts = set.term(s);
          if (!used[ts.point] || set.point(ts.point).body != set.point(tt.point).body) continue;
          w +=
              tt.direction.dot(point_block_.block<3, 3>(3 * tt.point, 3 * ts.point) * ts.direction);
        }
      }
      W(i, j) = w;
      W(j, i) = w;
    }
  }
}

void ComplianceAssembler::CalcCorrections(const ConstraintSet& set, const Eigen::VectorXd& lambda,
                                          std::vector<Eigen::Matrix3Xd>& dx) const {
  NSIM_CHECK(lambda.size() == set.num_rows(), "lambda has ", lambda.size(), " entries for ",
             set.num_rows(), " rows");
  NSIM_CHECK(static_cast<int>(point_columns_.size()) == set.num_points(),
             "CalcCorrections needs the Assemble of the same set");
  // force on every point: f_p = sum over its terms of d_t lambda_row
  Eigen::Matrix3Xd force = Eigen::Matrix3Xd::Zero(3, set.num_points());
  for (int i = 0; i < set.num_rows(); ++i) {
    const ConstraintRow& r = set.row(i);
    for (int t = r.first_term; t < r.first_term + r.num_terms; ++t)
      force.col(set.term(t).point) += set.term(t).direction * lambda[i];
  }
  dx.resize(set.num_bodies());
  for (int b = 0; b < set.num_bodies(); ++b) dx[b].setZero(3, set.body(b).num_nodes());
  for (int p = 0; p < set.num_points(); ++p) {
    const int b = set.point(p).body;
    if (b < 0 || point_columns_[p] == nullptr) continue;
    Eigen::Map<Eigen::VectorXd> dx_flat(dx[b].data(), dx[b].size());
    dx_flat.noalias() += *point_columns_[p] * force.col(p);
  }
}

}  // namespace nsim
