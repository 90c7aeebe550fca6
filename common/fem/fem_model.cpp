#include "common/fem/fem_model.h"

#include <algorithm>

#include "common/core/error.h"

namespace nsim {

FemModel::FemModel(const TetMesh& mesh, const FemConfig& config, const FemBoundary& boundary)
    : config_(config), mesh_(mesh) {
  config_.Validate();
  lame_ = CalcLameParameters(config_.young_modulus, config_.poisson_ratio);
  const int n = mesh_.num_nodes();
  if (n < 4 || mesh_.tets.empty())
    throw InputError(Str("FEM mesh must have >= 4 nodes and >= 1 tet, got ", n, " nodes and ",
                         mesh_.num_tets(), " tets"));
  if (!mesh_.X.allFinite()) throw InputError("FEM mesh node positions must be finite");

  // rest shapes and lumped mass
  rest_.resize(mesh_.tets.size());
  mass_ = Eigen::VectorXd::Zero(n);
  for (int e = 0; e < mesh_.num_tets(); ++e) {
    const Eigen::Vector4i& t = mesh_.tets[e];
    Matrix34d X;
    for (int a = 0; a < 4; ++a) {
      if (t[a] < 0 || t[a] >= n)
        throw InputError(Str("tet ", e, " node index must be in [0, ", n, "), got ", t[a]));
      X.col(a) = mesh_.X.col(t[a]);
    }
    try {
      rest_[e] = CalcTetRestShape(X);
    } catch (const InputError& error) {
      throw InputError(Str("tet ", e, ": ", error.what()));
    }
    for (int a = 0; a < 4; ++a) mass_[t[a]] += config_.density * rest_[e].volume / 4.0;
  }
  blocks_ = MakeTetBlocks(mesh_.tets, rest_);
  total_mass_ = mass_.sum();
  for (int i = 0; i < n; ++i)
    if (!(mass_[i] > 0.0))
      throw InputError(Str("FEM mesh node ", i, " belongs to no tet (every node needs mass)"));

  // Dirichlet nodes
  std::vector<int> kind(n, 0);  // 0 free, 1 fixed, 2 prescribed
  auto mark = [&](const std::vector<int>& nodes, int k, const char* what) {
    for (int i : nodes) {
      if (i < 0 || i >= n)
        throw InputError(Str(what, " node index must be in [0, ", n, "), got ", i));
      if (kind[i] != 0) throw InputError(Str(what, " node ", i, " is listed twice"));
      kind[i] = k;
    }
  };
  mark(boundary.fixed_nodes, 1, "fixed");
  mark(boundary.prescribed_nodes, 2, "prescribed");
  fixed_nodes_ = boundary.fixed_nodes;
  prescribed_nodes_ = boundary.prescribed_nodes;
  dirichlet_nodes_ = fixed_nodes_;
  dirichlet_nodes_.insert(dirichlet_nodes_.end(), prescribed_nodes_.begin(),
                          prescribed_nodes_.end());
  free_index_.assign(n, -1);
  for (int i = 0; i < n; ++i) {
    if (kind[i] == 0) {
      free_index_[i] = static_cast<int>(free_nodes_.size());
      free_nodes_.push_back(i);
    }
  }
  if (free_nodes_.empty()) throw InputError("FEM model must have at least one free node");

  // node adjacency among free nodes (each list sorted, includes the node itself)
  const int nf = num_free_nodes();
  std::vector<std::vector<int>> neighbors(nf);
  for (int k = 0; k < nf; ++k) neighbors[k].push_back(k);
  for (int e = 0; e < mesh_.num_tets(); ++e) {
    const Eigen::Vector4i& t = mesh_.tets[e];
    bool touches_dirichlet = false;
    for (int a = 0; a < 4; ++a) {
      const int fa = free_index_[t[a]];
      if (fa < 0) {
        touches_dirichlet = true;
        continue;
      }
      for (int b = 0; b < 4; ++b) {
        const int fb = free_index_[t[b]];
        if (fb >= 0) neighbors[fb].push_back(fa);
      }
    }
    if (touches_dirichlet) dirichlet_tets_.push_back(e);
  }
  for (auto& list : neighbors) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }

  // compressed column storage of the reduced matrix, 3x3 blocks dense
  const int ndof = 3 * nf;
  std::vector<int> outer(ndof + 1, 0);
  for (int k = 0; k < nf; ++k)
    for (int c = 0; c < 3; ++c)
      outer[3 * k + c + 1] = outer[3 * k + c] + 3 * static_cast<int>(neighbors[k].size());
  const int nnz = outer[ndof];
  std::vector<int> inner(nnz);
  for (int k = 0; k < nf; ++k)
    for (int c = 0; c < 3; ++c) {
      int pos = outer[3 * k + c];
      for (int j : neighbors[k])
        for (int r = 0; r < 3; ++r) inner[pos++] = 3 * j + r;
    }
  std::vector<double> zeros(nnz, 0.0);
  pattern_ = Eigen::Map<const Eigen::SparseMatrix<double>>(ndof, ndof, nnz, outer.data(),
                                                           inner.data(), zeros.data());
  pattern_.makeCompressed();

  diagonal_index_.resize(ndof);
  for (int k = 0; k < nf; ++k) {
    const int rank = static_cast<int>(
        std::lower_bound(neighbors[k].begin(), neighbors[k].end(), k) - neighbors[k].begin());
    for (int c = 0; c < 3; ++c) diagonal_index_[3 * k + c] = outer[3 * k + c] + 3 * rank + c;
  }

  block_offsets_.resize(mesh_.tets.size());
  for (int e = 0; e < mesh_.num_tets(); ++e) {
    const Eigen::Vector4i& t = mesh_.tets[e];
    for (int b = 0; b < 4; ++b)
      for (int a = 0; a < 4; ++a) {
        const int fa = free_index_[t[a]], fb = free_index_[t[b]];
        int offset = -1;
        if (fa >= 0 && fb >= 0) {
          const auto& list = neighbors[fb];
          offset = 3 * static_cast<int>(std::lower_bound(list.begin(), list.end(), fa) -
                                        list.begin());
        }
        block_offsets_[e][a + 4 * b] = offset;
      }
  }

  // tets around each free node
  node_tet_offsets_.assign(nf + 1, 0);
  for (const auto& t : mesh_.tets)
    for (int a = 0; a < 4; ++a)
      if (free_index_[t[a]] >= 0) ++node_tet_offsets_[free_index_[t[a]] + 1];
  for (int k = 0; k < nf; ++k) node_tet_offsets_[k + 1] += node_tet_offsets_[k];
  node_tets_.resize(node_tet_offsets_[nf]);
  std::vector<int> fill(node_tet_offsets_.begin(), node_tet_offsets_.end() - 1);
  for (int e = 0; e < mesh_.num_tets(); ++e)
    for (int a = 0; a < 4; ++a) {
      const int f = free_index_[mesh_.tets[e][a]];
      if (f >= 0) node_tets_[fill[f]++] = e;
    }
}

}  // namespace nsim
