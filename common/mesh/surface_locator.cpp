#include "common/mesh/surface_locator.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "common/core/error.h"
#include "common/mesh/mesh_adjacency.h"
#include "common/mesh/triangle_geometry.h"

namespace nsim {

SurfaceLocator::SurfaceLocator(const TetMesh& mesh, const Eigen::Matrix3Xd& x)
    : SurfaceLocator(mesh, x, CalcSurfaceTets(mesh)) {}

SurfaceLocator::SurfaceLocator(const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                               const std::vector<int>& surface_tets)
    : triangles_(mesh.surface), x_(x) {
  NSIM_CHECK(x.cols() == mesh.num_nodes(), "positions have ", x.cols(), " columns for ",
             mesh.num_nodes(), " nodes");
  NSIM_CHECK(surface_tets.size() == triangles_.size(), surface_tets.size(),
             " owning tets given for ", triangles_.size(), " surface triangles");
  owner_.assign(triangles_.size(), TetPoint());
  owner_local_.assign(triangles_.size(), Eigen::Vector3i::Constant(-1));
  for (size_t i = 0; i < triangles_.size(); ++i) {
    const int e = surface_tets[i];
    NSIM_CHECK(e >= 0 && e < mesh.num_tets(), "surface triangle ", i,
               " is no face of a tetrahedron");
    owner_[i].tet = e;
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 4; ++l)
        if (mesh.tets[e][l] == triangles_[i][k]) owner_local_[i][k] = l;
    NSIM_CHECK(owner_local_[i].minCoeff() >= 0, "surface triangle ", i, " is no face of tet ", e);
  }
  std::vector<Eigen::AlignedBox3d> boxes(triangles_.size());
  for (size_t i = 0; i < triangles_.size(); ++i) {
    Eigen::AlignedBox3d box;
    for (int k = 0; k < 3; ++k) box.extend(Eigen::Vector3d(x_.col(triangles_[i][k])));
    const double pad = 1e-12 * box.sizes().maxCoeff();
    boxes[i] = Eigen::AlignedBox3d(box.min().array() - pad, box.max().array() + pad);
  }
  tree_ = AabbTree(boxes);
}

SurfacePoint SurfaceLocator::MakePoint(int triangle, const Eigen::Vector3d& bary,
                                       double distance) const {
  const Eigen::Vector3i& f = triangles_[triangle];
  const Eigen::Vector3d a = x_.col(f[0]), b = x_.col(f[1]), c = x_.col(f[2]);
  SurfacePoint s;
  s.triangle = triangle;
  s.bary = bary;
  s.p = bary[0] * a + bary[1] * b + bary[2] * c;
  s.normal = (b - a).cross(c - a).normalized();
  s.distance = distance;
  s.tet_point.tet = owner_[triangle].tet;
  for (int k = 0; k < 3; ++k) s.tet_point.bary[owner_local_[triangle][k]] = bary[k];
  return s;
}

SurfacePoint SurfaceLocator::Closest(const Eigen::Vector3d& q) const {
  NSIM_CHECK(!triangles_.empty(), "closest point on an empty surface");
  Eigen::Vector3d best_bary = Eigen::Vector3d::Zero();
  double best_sq = 0;
  const int best = tree_.FindNearest(
      q,
      [&](int i, double bound) {
        const Eigen::Vector3i& f = triangles_[i];
        const Eigen::Vector3d a = x_.col(f[0]), b = x_.col(f[1]), c = x_.col(f[2]);
        const Eigen::Vector3d w = ClosestPointOnTriangle(q, a, b, c);
        const double d = (w[0] * a + w[1] * b + w[2] * c - q).squaredNorm();
        if (d < bound) best_bary = w;
        return d;
      },
      &best_sq);
  return MakePoint(best, best_bary, std::sqrt(best_sq));
}

std::optional<SurfacePoint> SurfaceLocator::RayCast(const Eigen::Vector3d& origin,
                                                    const Eigen::Vector3d& dir,
                                                    double t_max) const {
  NSIM_CHECK(dir.squaredNorm() > 0, "ray direction must be non-zero");
  int best = -1;
  Eigen::Vector3d best_bary;
  double t_best = t_max;
  tree_.VisitRay(origin, dir, &t_best, [&](int i, double* limit) {
    const Eigen::Vector3i& f = triangles_[i];
    double t;
    Eigen::Vector3d w;
    if (!IntersectRayTriangle(origin, dir, x_.col(f[0]), x_.col(f[1]), x_.col(f[2]), &t, &w))
      return;
    if (t < 0 || t > *limit || (best >= 0 && t == *limit)) return;
    *limit = t;
    best = i;
    best_bary = w;
  });
  if (best < 0) return std::nullopt;
  // clamp the edge slack so the weights stay a convex combination
  best_bary = best_bary.cwiseMax(0.0);
  best_bary /= best_bary.sum();
  return MakePoint(best, best_bary, t_best);
}

std::optional<SurfacePoint> SurfaceLocator::FirstHit(const Eigen::Vector3d& a,
                                                     const Eigen::Vector3d& b) const {
  if (!((b - a).squaredNorm() > 0)) return std::nullopt;
  return RayCast(a, b - a, 1.0);
}

double SurfaceLocator::SignedDistance(const Eigen::Vector3d& q) const {
  const SurfacePoint closest = Closest(q);
  // parity of crossings along a direction unlikely to graze edges; a hit on an edge or vertex
  // may be counted twice, so use three directions and take the majority
  static const Eigen::Vector3d kDirs[3] = {Eigen::Vector3d(0.5773, 0.5774, 0.5775).normalized(),
                                           Eigen::Vector3d(-0.3127, 0.8219, -0.4762).normalized(),
                                           Eigen::Vector3d(0.7071, -0.1234, -0.6963).normalized()};
  int inside_votes = 0;
  for (const Eigen::Vector3d& dir : kDirs) {
    int crossings = 0;
    double t_max = std::numeric_limits<double>::infinity();
    tree_.VisitRay(q, dir, &t_max, [&](int i, double*) {
      const Eigen::Vector3i& f = triangles_[i];
      double t;
      Eigen::Vector3d w;
      if (IntersectRayTriangle(q, dir, x_.col(f[0]), x_.col(f[1]), x_.col(f[2]), &t, &w, 0.0) &&
          t > 0)
        ++crossings;
    });
    inside_votes += crossings % 2;
  }
  return inside_votes >= 2 ? -closest.distance : closest.distance;
}

}  // namespace nsim
