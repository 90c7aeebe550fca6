#pragma once
// The immutable FEM model of one soft body (MuJoCo mjModel / Drake FemModel style): rest mesh,
// material, lumped mass, Dirichlet nodes and the fixed sparsity pattern of the step's system
// matrix with precomputed scatter indices. Built once; FemState holds everything that changes.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <vector>

#include "common/fem/corotational.h"
#include "common/fem/fem_config.h"
#include "common/fem/tet_lanes.h"
#include "common/mesh/tet_mesh.h"

namespace nsim {

/// Which nodes have kinematically prescribed motion. Both kinds are Dirichlet nodes, eliminated
/// from the linear system exactly (no penalty springs).
struct FemBoundary {
  /// Nodes that never move (their velocity is zero).
  std::vector<int> fixed_nodes;
  /// Nodes that follow a trajectory given step by step in FemState::prescribed_positions
  /// (e.g. the liver nodes inside the diaphragm box).
  std::vector<int> prescribed_nodes;
};

class FemModel {
 public:
  /// Validates `config` and the boundary (InputError: node index out of range, a node listed
  /// twice), precomputes the rest shapes (InputError for a non-positive rest volume), the lumped
  /// mass and the system pattern. Costs O(#tets log) time; allocation happens here, not in steps.
  FemModel(const TetMesh& mesh, const FemConfig& config, const FemBoundary& boundary = {});

  const FemConfig& get_config() const { return config_; }
  const LameParameters& get_lame() const { return lame_; }
  const TetMesh& get_mesh() const { return mesh_; }
  int num_nodes() const { return mesh_.num_nodes(); }
  int num_tets() const { return mesh_.num_tets(); }
  /// Rest positions (m), 3 x #nodes.
  const Eigen::Matrix3Xd& get_rest_positions() const { return mesh_.X; }
  /// Rest shape of every tet (gradients, volume), index = tet index.
  const std::vector<TetRestShape>& get_rest_shapes() const { return rest_; }
  /// The same tets and rest shapes in blocks of kTetLanes, for the solver's element kernels.
  const TetBlocks& get_tet_blocks() const { return blocks_; }
  /// Lumped nodal mass (kg), #nodes: each tet gives rho V / 4 to each of its nodes.
  const Eigen::VectorXd& get_lumped_mass() const { return mass_; }
  double get_total_mass() const { return total_mass_; }

  const std::vector<int>& get_fixed_nodes() const { return fixed_nodes_; }
  const std::vector<int>& get_prescribed_nodes() const { return prescribed_nodes_; }
  /// Fixed nodes followed by prescribed nodes: the order of FemState::reaction_forces.
  const std::vector<int>& get_dirichlet_nodes() const { return dirichlet_nodes_; }
  /// Free (unknown) nodes in increasing node order; free node k owns reduced DOFs 3k..3k+2.
  const std::vector<int>& get_free_nodes() const { return free_nodes_; }
  int num_free_nodes() const { return static_cast<int>(free_nodes_.size()); }
  /// Reduced index of `node` among the free nodes, -1 for a Dirichlet node.
  int get_free_index(int node) const { return free_index_[node]; }

  /// Pattern of the reduced system matrix A_ff (3 #free x 3 #free, both triangles stored,
  /// column-major, sorted rows, values zero). Every 3x3 node block is stored densely.
  const Eigen::SparseMatrix<double>& get_system_pattern() const { return pattern_; }
  /// Per tet, per local node pair (a, b) at index a + 4 b: offset of the 3x3 block (a, b) inside
  /// the columns of node b (value index = outerIndex[3 fb + c] + offset + r for row r, column c),
  /// or -1 when a or b is a Dirichlet node.
  const std::vector<std::array<int, 16>>& get_block_offsets() const { return block_offsets_; }
  /// Value index of the diagonal entry of each reduced DOF (3 #free).
  const std::vector<int>& get_diagonal_index() const { return diagonal_index_; }
  /// Tets with at least one Dirichlet node (they couple prescribed motion into the free rows).
  const std::vector<int>& get_dirichlet_tets() const { return dirichlet_tets_; }
  /// Tets adjacent to each free node (CSR: tets in [offset[k], offset[k+1])), for nodal rotations.
  const std::vector<int>& get_node_tet_offsets() const { return node_tet_offsets_; }
  const std::vector<int>& get_node_tets() const { return node_tets_; }

 private:
  FemConfig config_;
  LameParameters lame_;
  TetMesh mesh_;
  std::vector<TetRestShape> rest_;
  TetBlocks blocks_;
  Eigen::VectorXd mass_;
  double total_mass_ = 0.0;
  std::vector<int> fixed_nodes_, prescribed_nodes_, dirichlet_nodes_, free_nodes_, free_index_;
  Eigen::SparseMatrix<double> pattern_;
  std::vector<std::array<int, 16>> block_offsets_;
  std::vector<int> diagonal_index_;
  std::vector<int> dirichlet_tets_;
  std::vector<int> node_tet_offsets_, node_tets_;
};

}  // namespace nsim
