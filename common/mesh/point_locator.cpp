#include "common/mesh/point_locator.h"

#include <Eigen/LU>
#include <cmath>
#include <limits>

#include "common/core/error.h"
#include "common/mesh/triangle_geometry.h"

namespace nsim {
namespace {

// faces opposite each local vertex, and the local vertices of each face
constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

}  // namespace

TetLocator::TetLocator(const TetMesh& mesh, const Eigen::Matrix3Xd& x, double tolerance)
    : tets_(mesh.tets), x_(x), tolerance_(tolerance) {
  NSIM_CHECK(x.cols() == mesh.num_nodes(), "positions have ", x.cols(), " columns for ",
             mesh.num_nodes(), " nodes");
  NSIM_CHECK(tolerance >= 0, "tolerance must be >= 0, got ", tolerance);
  inverse_.resize(tets_.size());
  valid_.assign(tets_.size(), 0);
  std::vector<Eigen::AlignedBox3d> boxes(tets_.size());
  for (size_t i = 0; i < tets_.size(); ++i) {
    const Eigen::Vector4i& t = tets_[i];
    Eigen::Matrix3d m;
    m << x_.col(t[1]) - x_.col(t[0]), x_.col(t[2]) - x_.col(t[0]), x_.col(t[3]) - x_.col(t[0]);
    // degenerate when |det| is negligible against the edge lengths cubed
    const double scale = m.colwise().norm().prod();
    const double det = m.determinant();
    if (std::abs(det) > 1e-12 * scale) {
      inverse_[i] = m.inverse();
      valid_[i] = 1;
    }
    Eigen::AlignedBox3d box;
    for (int k = 0; k < 4; ++k) box.extend(Eigen::Vector3d(x_.col(t[k])));
    // pad so points within the barycentric tolerance (plus rounding) pass the box test
    const double pad = (tolerance_ + 1e-12) * box.sizes().maxCoeff();
    boxes[i] = Eigen::AlignedBox3d(box.min().array() - pad, box.max().array() + pad);
  }
  tree_ = AabbTree(boxes);
}

std::optional<TetPoint> TetLocator::Locate(const Eigen::Vector3d& p) const {
  TetPoint best;
  double best_min = -std::numeric_limits<double>::infinity();
  tree_.VisitContaining(p, [&](int i) {
    if (!valid_[i]) return false;
    const Eigen::Vector3d w = inverse_[i] * (p - x_.col(tets_[i][0]));
    const Eigen::Vector4d bary(1.0 - w.sum(), w[0], w[1], w[2]);
    const double min = bary.minCoeff();
    if (min > best_min) {
      best_min = min;
      best.tet = i;
      best.bary = bary;
    }
    return min >= 0;  // inside: done
  });
  if (best.tet < 0 || best_min < -tolerance_) return std::nullopt;
  return best;
}

TetPoint TetLocator::LocateClosest(const Eigen::Vector3d& p, double* distance) const {
  NSIM_CHECK(!tets_.empty(), "LocateClosest on a mesh without tetrahedra");
  if (const auto inside = Locate(p)) {
    if (distance) *distance = 0.0;
    return *inside;
  }
  // nearest tetrahedron: distance to its closest face point
  Eigen::Vector4d best_bary = Eigen::Vector4d::Zero();
  double best_sq = 0;
  const int best = tree_.FindNearest(
      p,
      [&](int i, double bound) {
        const Eigen::Vector4i& t = tets_[i];
        double tet_best = std::numeric_limits<double>::infinity();
        Eigen::Vector4d tet_bary;
        for (const auto& f : kFace) {
          const Eigen::Vector3d w =
              ClosestPointOnTriangle(p, x_.col(t[f[0]]), x_.col(t[f[1]]), x_.col(t[f[2]]));
          const Eigen::Vector3d q =
              w[0] * x_.col(t[f[0]]) + w[1] * x_.col(t[f[1]]) + w[2] * x_.col(t[f[2]]);
          const double d = (q - p).squaredNorm();
          if (d < tet_best) {
            tet_best = d;
            tet_bary.setZero();
            for (int k = 0; k < 3; ++k) tet_bary[f[k]] = w[k];
          }
        }
        if (tet_best < bound) best_bary = tet_bary;
        return tet_best;
      },
      &best_sq);
  if (distance) *distance = std::sqrt(best_sq);
  return TetPoint{best, best_bary};
}

}  // namespace nsim
