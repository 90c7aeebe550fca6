#include "common/mesh/triangle_geometry.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace nsim {
namespace {

// closest point of segment [a, b] to p as the parameter s in [0, 1]
double ClosestOnSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                        const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len_sq = ab.squaredNorm();
  if (!(len_sq > 0)) return 0.0;
  return std::clamp((p - a).dot(ab) / len_sq, 0.0, 1.0);
}

}  // namespace

Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  // degenerate triangle: the closest of the three edges
  if (!(ab.cross(ac).squaredNorm() >
        1e-28 * std::pow(std::max(ab.squaredNorm(), ac.squaredNorm()), 2))) {
    const double s_ab = ClosestOnSegment(p, a, b), s_ac = ClosestOnSegment(p, a, c),
                 s_bc = ClosestOnSegment(p, b, c);
    const Eigen::Vector3d w_ab(1 - s_ab, s_ab, 0), w_ac(1 - s_ac, 0, s_ac), w_bc(0, 1 - s_bc, s_bc);
    auto dist = [&](const Eigen::Vector3d& w) {
      return (w[0] * a + w[1] * b + w[2] * c - p).squaredNorm();
    };
    const double d_ab = dist(w_ab), d_ac = dist(w_ac), d_bc = dist(w_bc);
    if (d_ab <= d_ac && d_ab <= d_bc) return w_ab;
    return d_ac <= d_bc ? w_ac : w_bc;
  }
  // Voronoi regions of the vertices, then edges, then the face
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {1 - v - w, v, w};
}

bool IntersectRayTriangle(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                          const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector3d& c, double* t, Eigen::Vector3d* bary,
                          double edge_tolerance) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a;
  const Eigen::Vector3d pvec = dir.cross(e2);
  const double det = e1.dot(pvec);
  // parallel (relative to the sizes involved)
  if (!(std::abs(det) > 1e-14 * dir.norm() * e1.norm() * e2.norm())) return false;
  const double inv_det = 1.0 / det;
  const Eigen::Vector3d tvec = origin - a;
  const double u = tvec.dot(pvec) * inv_det;
  if (u < -edge_tolerance || u > 1 + edge_tolerance) return false;
  const Eigen::Vector3d qvec = tvec.cross(e1);
  const double v = dir.dot(qvec) * inv_det;
  if (v < -edge_tolerance || u + v > 1 + edge_tolerance) return false;
  *t = e2.dot(qvec) * inv_det;
  *bary = Eigen::Vector3d(1 - u - v, u, v);
  return true;
}

}  // namespace nsim
