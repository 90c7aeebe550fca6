#pragma once
// Element quality of a tetrahedral mesh: volumes, inversion, shape measures and their
// statistics, on any node positions (rest or deformed).

#include <Eigen/Core>
#include <string>
#include <vector>

#include "common/mesh/tet_mesh.h"

namespace nsim {

/// Shape measures of one tetrahedron.
struct TetQuality {
  double volume = 0;        ///< signed volume (m^3)
  double radius_ratio = 0;  ///< 3 r_inscribed / r_circumscribed: 1 regular, 0 degenerate
                            ///< (negative when inverted)
  double edge_ratio = 0;    ///< longest / shortest edge, >= 1 (inf for a zero-length edge)
  double min_dihedral = 0;  ///< smallest dihedral angle (rad)
  double max_dihedral = 0;  ///< largest dihedral angle (rad)
  double min_edge = 0;      ///< shortest edge (m)
  double max_edge = 0;      ///< longest edge (m)
};

/// Shape measures of tetrahedron (a, b, c, d) (positions in m).
TetQuality CalcTetQuality(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector3d& c, const Eigen::Vector3d& d);

/// Summary of a mesh's element quality.
struct MeshQualityReport {
  int num_nodes = 0;
  int num_tets = 0;
  int num_surface_triangles = 0;
  double total_volume = 0;    ///< sum of signed tet volumes (m^3)
  double surface_volume = 0;  ///< volume enclosed by the surface by the divergence theorem (m^3);
                              ///< equals total_volume for a closed, outward surface
  double min_volume = 0;      ///< smallest signed tet volume (m^3)
  double max_volume = 0;      ///< largest signed tet volume (m^3)
  int num_inverted = 0;       ///< tets with volume <= 0
  double min_radius_ratio = 0, mean_radius_ratio = 0;
  int num_radius_ratio_below_0_1 = 0;  ///< slivers and needles: radius ratio < 0.1
  double max_edge_ratio = 0, mean_edge_ratio = 0;
  double min_dihedral = 0, max_dihedral = 0;           ///< over all tets (rad)
  double min_edge = 0, max_edge = 0, mean_edge = 0;    ///< edge lengths over all tets (m)
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero();  ///< of the node positions (m)
  Eigen::Vector3d bbox_max = Eigen::Vector3d::Zero();
  /// counts of tets with radius ratio in [0, 0.1), [0.1, 0.2), ..., [0.9, 1]; inverted ones
  /// are in bin 0
  std::vector<int> radius_ratio_histogram;
};

/// Signed volume of every tet at positions `x` (3 x #nodes, m); #tets values (m^3).
std::vector<double> CalcTetVolumes(const TetMesh& mesh, const Eigen::Matrix3Xd& x);

/// Quality report of `mesh` at positions `x` (3 x #nodes, m).
MeshQualityReport CalcMeshQuality(const TetMesh& mesh, const Eigen::Matrix3Xd& x);

/// Quality report at the rest positions mesh.X.
inline MeshQualityReport CalcMeshQuality(const TetMesh& mesh) {
  return CalcMeshQuality(mesh, mesh.X);
}

/// Multi-line human-readable text of a report (lengths in mm, volumes in cm^3, angles in deg).
std::string FormatMeshQuality(const MeshQualityReport& report);

}  // namespace nsim
