#pragma once
// VTK legacy ASCII writers (".vtk", readable by ParaView) for mesh states: the tetrahedral
// volume, its boundary surface, and polylines (a needle).

#include <Eigen/Core>
#include <iosfwd>
#include <string>
#include <vector>

#include "common/mesh/tet_mesh.h"

namespace nsim {

/// A named data array: 1 row (SCALARS) or 3 rows (VECTORS), one column per point or cell.
/// Names must be non-empty without whitespace. Units are the caller's (say them in the name,
/// e.g. "displacement_m").
struct VtkField {
  std::string name;
  Eigen::MatrixXd values;  ///< 1 x n or 3 x n
};

/// Point data (one column per node) and cell data (one column per cell) to attach.
struct VtkData {
  std::vector<VtkField> point_data;
  std::vector<VtkField> cell_data;
};

/// Writes the tetrahedral mesh at positions `x` (3 x #nodes, m; pass mesh.X for the rest
/// state) as an UNSTRUCTURED_GRID of VTK_TETRA cells. Fields must have #nodes / #tets columns.
/// Throws InputError when the file cannot be written.
void WriteVtkTetMesh(const std::string& path, const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                     const VtkData& data = {}, const std::string& title = "nsim tet mesh");
void WriteVtkTetMesh(std::ostream& out, const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                     const VtkData& data = {}, const std::string& title = "nsim tet mesh");

/// Writes the boundary surface mesh.surface at positions `x` as POLYDATA triangles. Only the
/// surface nodes are written (renumbered in ascending order of node index); point fields are
/// given per mesh node (#nodes columns) and subset, cell fields per surface triangle.
void WriteVtkSurface(const std::string& path, const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                     const VtkData& data = {}, const std::string& title = "nsim surface");
void WriteVtkSurface(std::ostream& out, const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                     const VtkData& data = {}, const std::string& title = "nsim surface");

/// Writes the points (3 x n, m) as one POLYDATA polyline through them in order (n >= 1), e.g. the
/// needle's nodes from base to tip. Point fields have n columns; one cell field column.
void WriteVtkPolyline(const std::string& path, const Eigen::Matrix3Xd& points,
                      const VtkData& data = {}, const std::string& title = "nsim polyline");
void WriteVtkPolyline(std::ostream& out, const Eigen::Matrix3Xd& points, const VtkData& data = {},
                      const std::string& title = "nsim polyline");

}  // namespace nsim
