#pragma once
// Exact point-triangle and ray-triangle geometry shared by the tetrahedron and surface locators.

#include <Eigen/Core>

namespace nsim {

/// Barycentric coordinates (w_a, w_b, w_c; all >= 0, summing to 1) of the point of triangle
/// (a, b, c) closest to p (Ericson, Real-Time Collision Detection, 5.1.5). Handles degenerate
/// triangles by falling back to the closest edge point.
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// Intersection of the ray origin + t dir with triangle (a, b, c) (Moller-Trumbore), either
/// side. Returns false when the ray is parallel to the triangle's plane or misses it; otherwise
/// sets *t (in units of |dir|, may be negative) and the barycentric coordinates *bary of the
/// hit. Points on an edge (within `edge_tolerance` in barycentric units) count as hits, so a
/// ray through a shared edge finds at least one of the two triangles.
bool IntersectRayTriangle(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                          const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector3d& c, double* t, Eigen::Vector3d* bary,
                          double edge_tolerance = 1e-12);

}  // namespace nsim
