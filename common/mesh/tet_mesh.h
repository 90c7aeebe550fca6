#pragma once
// The tetrahedral mesh: rest node positions, element connectivity and boundary surface.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace nsim {

/// A linear tetrahedral mesh at rest. Immutable once built; positions of a deformed state live
/// in the state of whatever simulates it.
struct TetMesh {
  Eigen::Matrix3Xd X;                 ///< rest node positions (m), 3 x #nodes
  std::vector<Eigen::Vector4i> tets;  ///< node indices; positively oriented (volume > 0)
  std::vector<Eigen::Vector3i>
      surface;  ///< boundary triangles, counter-clockwise seen from outside

  int num_nodes() const { return static_cast<int>(X.cols()); }
  int num_tets() const { return static_cast<int>(tets.size()); }
};

/// Signed volume of tetrahedron (a, b, c, d) (m^3); positive when (b-a, c-a, d-a) is right-handed.
double SignedTetVolume(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& d);

/// Regular grid of nodes(0) x nodes(1) x nodes(2) nodes (each >= 2) spanning the box
/// [origin, origin + size], every cube cut into 6 tetrahedra along its main diagonal (conforming
/// across cubes). Surface triangles are computed.
TetMesh MakeBoxTetMesh(const Eigen::Vector3i& nodes, const Eigen::Vector3d& size,
                       const Eigen::Vector3d& origin = Eigen::Vector3d::Zero());

/// Boundary faces (those belonging to exactly one tet), oriented outward.
std::vector<Eigen::Vector3i> ComputeBoundarySurface(const std::vector<Eigen::Vector4i>& tets);

/// Reorders the nodes of every negatively oriented tet so that all volumes are positive.
void OrientTetsPositively(TetMesh& mesh);

}  // namespace nsim
