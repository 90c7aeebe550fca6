#pragma once
// Closest-point and first-intersection queries against a mesh's boundary surface, on given node
// positions (rest or deformed): where a needle touches the skin or the liver.

#include <Eigen/Core>
#include <limits>
#include <optional>
#include <vector>

#include "common/mesh/aabb_tree.h"
#include "common/mesh/tet_mesh.h"
#include "common/mesh/tet_point.h"

namespace nsim {

/// A point on the boundary surface.
struct SurfacePoint {
  int triangle = -1;                                 ///< index into TetMesh::surface
  Eigen::Vector3d bary = Eigen::Vector3d::Zero();    ///< barycentric weights in the triangle
  Eigen::Vector3d p = Eigen::Vector3d::Zero();       ///< position (m)
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< outward unit normal of the triangle
  double distance = 0;  ///< closest-point queries: |query - p| (m); ray queries: hit parameter t
  TetPoint tet_point;   ///< the same point as a material point of the tet owning the triangle
};

/// Boundary-surface queries over an AABB tree of the triangles of TetMesh::surface, built on a
/// snapshot of the node positions; rebuild when the positions change. Queries are const and
/// thread-safe. Copies what it needs.
class SurfaceLocator {
 public:
  /// Builds over mesh.surface at positions `x` (3 x #nodes, m). Each triangle must be a face of
  /// some tetrahedron of `mesh` (true for TetMesh surfaces built by this library; checked:
  /// aborts otherwise); the owners come from CalcSurfaceTets.
  SurfaceLocator(const TetMesh& mesh, const Eigen::Matrix3Xd& x);
  /// The same with the tet owning each surface triangle given (MeshAdjacency::surface_tets,
  /// #surface triangles): what the first constructor computes (CalcSurfaceTets), most of a
  /// build's cost (one core, 2660-node liver: 2.6 ms to build, 0.28 ms with the owners given;
  /// mesh_bench BuildSurfaceLocator*), precomputed once for a locator rebuilt on every step's
  /// positions. A wrong owner is a programming error (checked: aborts).
  SurfaceLocator(const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                 const std::vector<int>& surface_tets);
  /// Builds over the rest positions mesh.X.
  explicit SurfaceLocator(const TetMesh& mesh) : SurfaceLocator(mesh, mesh.X) {}

  /// The closest point of the surface to q (m). Precondition: the surface is not empty.
  SurfacePoint Closest(const Eigen::Vector3d& q) const;

  /// First crossing of the segment from a to b (m) with the surface, from either side; nullopt
  /// when it crosses nothing. `distance` of the result is the parameter t in [0, 1] along the
  /// segment: p = a + t (b - a).
  std::optional<SurfacePoint> FirstHit(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;

  /// First crossing of the ray origin + t dir, t in [0, t_max] (t in units of |dir|).
  std::optional<SurfacePoint> RayCast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                      double t_max = std::numeric_limits<double>::infinity()) const;

  /// Signed distance from q to the surface (m), negative inside: the distance to the closest
  /// point, with the sign from whether q is enclosed (a ray parity count along a fixed
  /// direction). Precondition: the surface is closed.
  double SignedDistance(const Eigen::Vector3d& q) const;

  int num_triangles() const { return static_cast<int>(triangles_.size()); }

 private:
  SurfacePoint MakePoint(int triangle, const Eigen::Vector3d& bary, double distance) const;

  std::vector<Eigen::Vector3i> triangles_;
  Eigen::Matrix3Xd x_;
  std::vector<TetPoint> owner_;               // per triangle: owning tet; bary unused
  std::vector<Eigen::Vector3i> owner_local_;  // per triangle: local index in the tet of each vertex
  AabbTree tree_;
};

}  // namespace nsim
