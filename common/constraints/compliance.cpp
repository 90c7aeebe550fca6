#include "common/constraints/compliance.h"

#include <algorithm>

#include "common/core/error.h"

namespace nsim {

namespace {

bool SameNodes(const ConstraintSet& set, const ConstraintPoint& p, const std::vector<int>& nodes,
               const std::vector<double>& weights) {
  if (static_cast<int>(nodes.size()) != p.num_nodes) return false;
  for (int k = 0; k < p.num_nodes; ++k) {
    if (set.point_nodes()[p.first_node + k] != nodes[k] ||
        set.point_weights()[p.first_node + k] != weights[k])
      return false;
  }
  return true;
}

}  // namespace

void ComplianceAssembler::Assemble(const ConstraintSet& set, Eigen::MatrixXd& W) {
  const int num_points = set.num_points();
  stats_ = ComplianceStats{};
  point_columns_.assign(num_points, nullptr);

  // which body points are used by a row
  std::vector<char> used(num_points, 0);
  for (int i = 0; i < set.num_rows(); ++i) {
    const ConstraintRow& r = set.row(i);
    for (int t = r.first_term; t < r.first_term + r.num_terms; ++t) used[set.term(t).point] = 1;
  }
  int num_unkeyed = 0;
  for (int p = 0; p < num_points; ++p) {
    if (!used[p] || set.point(p).body < 0) {
      used[p] = 0;
      continue;
    }
    ++stats_.num_body_points;
    if (set.point(p).key == 0) ++num_unkeyed;
  }
  if (static_cast<int>(unkeyed_.size()) < num_unkeyed) unkeyed_.resize(num_unkeyed);
  int next_unkeyed = 0;

  for (int b = 0; b < set.num_bodies(); ++b) {
    const ConstraintBody& body = set.body(b);
    const int n = body.num_nodes();
    BodyCache& cache = caches_[body.uid()];
    if (cache.version != body.compliance_version()) {
      cache.entries.clear();
      cache.version = body.compliance_version();
    }
    for (auto& [key, entry] : cache.entries) ++entry.idle;

    // serve cached points, collect the others
    pending_.clear();
    for (int p = 0; p < num_points; ++p) {
      const ConstraintPoint& pt = set.point(p);
      if (!used[p] || pt.body != b) continue;
      if (pt.key != 0) {
        auto it = cache.entries.find(pt.key);
        if (it != cache.entries.end()) {
          if (SameNodes(set, pt, it->second.nodes, it->second.weights)) {
            if (it->second.idle > 0) ++stats_.num_reused_points;
            it->second.idle = 0;
            point_columns_[p] = &it->second.Y;
            continue;
          }
          // the key was reused for another point: recompute
          cache.entries.erase(it);
        }
      }
      pending_.push_back(p);
    }

    // solve the 3 columns of every pending point at once
    if (!pending_.empty()) {
      const int k = static_cast<int>(pending_.size());
      std::vector<Eigen::Triplet<double>> triplets;
      for (int j = 0; j < k; ++j) {
        const ConstraintPoint& pt = set.point(pending_[j]);
        for (int m = 0; m < pt.num_nodes; ++m) {
          const int node = set.point_nodes()[pt.first_node + m];
          const double w = set.point_weights()[pt.first_node + m];
          for (int c = 0; c < 3; ++c) triplets.emplace_back(3 * node + c, 3 * j + c, w);
        }
      }
      Eigen::SparseMatrix<double> rhs(3 * n, 3 * k);
      rhs.setFromTriplets(triplets.begin(), triplets.end());
      body.ApplyCompliance(rhs, solved_);
      NSIM_CHECK(solved_.rows() == 3 * n && solved_.cols() == 3 * k, "ApplyCompliance returned ",
                 solved_.rows(), " x ", solved_.cols(), ", expected ", 3 * n, " x ", 3 * k);
      stats_.num_solved_columns += 3 * k;
      for (int j = 0; j < k; ++j) {
        const int p = pending_[j];
        const ConstraintPoint& pt = set.point(p);
        if (pt.key == 0) {
          unkeyed_[next_unkeyed] = solved_.middleCols(3 * j, 3);
          point_columns_[p] = &unkeyed_[next_unkeyed++];
          continue;
        }
        auto [it, inserted] = cache.entries.try_emplace(pt.key);
        Entry& e = it->second;
        if (inserted) {
          e.nodes.assign(set.point_nodes().begin() + pt.first_node,
                         set.point_nodes().begin() + pt.first_node + pt.num_nodes);
          e.weights.assign(set.point_weights().begin() + pt.first_node,
                           set.point_weights().begin() + pt.first_node + pt.num_nodes);
          e.Y = solved_.middleCols(3 * j, 3);
        }
        e.idle = 0;
        point_columns_[p] = &e.Y;
      }
    }

    // evict long-unused entries
    for (auto it = cache.entries.begin(); it != cache.entries.end();) {
      if (it->second.idle > kMaxIdleAssembles)
        it = cache.entries.erase(it);
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
