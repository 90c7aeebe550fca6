#pragma once
// Barycentric location of points in a tetrahedral mesh, on given node positions (rest or
// deformed), accelerated by an AABB tree over the tetrahedra's bounding boxes.

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "common/mesh/aabb_tree.h"
#include "common/mesh/tet_mesh.h"
#include "common/mesh/tet_point.h"

namespace nsim {

/// Finds the tetrahedron containing a point, and its barycentric coordinates. Built once over a
/// snapshot of the node positions (O(#tets log #tets)); rebuild it when positions change.
/// Queries are const and thread-safe. Copies what it needs: the mesh may go away.
class TetLocator {
 public:
  /// Default slack on barycentric coordinates: a point counts as inside when every coordinate
  /// is >= -kDefaultTolerance (dimensionless).
  static constexpr double kDefaultTolerance = 1e-10;

  /// Builds over `mesh`'s tetrahedra at the node positions `x` (3 x #nodes, m).
  /// `tolerance` as kDefaultTolerance. Degenerate tets (zero volume at x) are never "inside".
  TetLocator(const TetMesh& mesh, const Eigen::Matrix3Xd& x, double tolerance = kDefaultTolerance);
  /// Builds over the rest positions mesh.X.
  explicit TetLocator(const TetMesh& mesh, double tolerance = kDefaultTolerance)
      : TetLocator(mesh, mesh.X, tolerance) {}

  /// The tetrahedron containing p (m) with its barycentric coordinates (each >= -tolerance,
  /// summing to 1), or nullopt when p is outside the mesh. On a shared face or edge any of the
  /// tetrahedra sharing it may be returned.
  std::optional<TetPoint> Locate(const Eigen::Vector3d& p) const;

  /// The point of the meshed volume closest to p: the containing tetrahedron when p is inside
  /// (*distance = 0), otherwise the tetrahedron holding the closest point of the mesh and that
  /// point's barycentric coordinates (all in [0, 1]); *distance (m) is |p - closest| when not null.
  /// Precondition: the mesh has at least one tetrahedron.
  TetPoint LocateClosest(const Eigen::Vector3d& p, double* distance = nullptr) const;

  int num_tets() const { return static_cast<int>(tets_.size()); }
  double tolerance() const { return tolerance_; }

 private:
  std::vector<Eigen::Vector4i> tets_;
  Eigen::Matrix3Xd x_;                    // positions the locator was built on
  std::vector<Eigen::Matrix3d> inverse_;  // per tet: inverse of [x1-x0, x2-x0, x3-x0]
  std::vector<unsigned char> valid_;      // per tet: not degenerate
  double tolerance_;
  AabbTree tree_;
};

}  // namespace nsim
