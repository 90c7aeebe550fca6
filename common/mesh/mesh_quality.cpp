#include "common/mesh/mesh_quality.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "common/core/error.h"

namespace nsim {
namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

TetQuality CalcTetQuality(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  TetQuality q;
  const Eigen::Vector3d p[4] = {a, b, c, d};
  q.volume = SignedTetVolume(a, b, c, d);
  // edges
  q.min_edge = std::numeric_limits<double>::infinity();
  q.max_edge = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) {
      const double l = (p[i] - p[j]).norm();
      q.min_edge = std::min(q.min_edge, l);
      q.max_edge = std::max(q.max_edge, l);
    }
  q.edge_ratio = q.min_edge > 0 ? q.max_edge / q.min_edge : std::numeric_limits<double>::infinity();
  // face normals (outward for positive volume), areas
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  Eigen::Vector3d n[4];
  double area = 0;
  for (int k = 0; k < 4; ++k) {
    n[k] = (p[kFace[k][1]] - p[kFace[k][0]]).cross(p[kFace[k][2]] - p[kFace[k][0]]);
    area += 0.5 * n[k].norm();
  }
  // circumradius: |l_a^2 (b x c) + l_b^2 (c x a) + l_c^2 (a x b)| / (12 V), edges from vertex 0
  const Eigen::Vector3d u = b - a, v = c - a, w = d - a;
  const double six_v = 6.0 * q.volume;
  const Eigen::Vector3d num =
      u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u) + w.squaredNorm() * u.cross(v);
  if (six_v != 0 && area > 0) {
    const double r_in = 3.0 * q.volume / area;  // signed
    const double r_circ = num.norm() / (2.0 * std::abs(six_v));
    q.radius_ratio = 3.0 * r_in / r_circ;
  }
  // dihedral angle at the edge shared by faces k and l: pi minus the angle between normals
  q.min_dihedral = kPi;
  q.max_dihedral = 0;
  for (int k = 0; k < 4; ++k)
    for (int l = k + 1; l < 4; ++l) {
      const double nk = n[k].norm(), nl = n[l].norm();
      if (!(nk > 0 && nl > 0)) {
        q.min_dihedral = 0;
        q.max_dihedral = kPi;
        continue;
      }
      const double cos_angle = std::clamp(-n[k].dot(n[l]) / (nk * nl), -1.0, 1.0);
      const double angle = std::acos(cos_angle);
      q.min_dihedral = std::min(q.min_dihedral, angle);
      q.max_dihedral = std::max(q.max_dihedral, angle);
    }
  return q;
}

std::vector<double> CalcTetVolumes(const TetMesh& mesh, const Eigen::Matrix3Xd& x) {
  NSIM_CHECK(x.cols() == mesh.num_nodes(), "positions have ", x.cols(), " columns for ",
             mesh.num_nodes(), " nodes");
  std::vector<double> volumes(mesh.tets.size());
  for (size_t e = 0; e < mesh.tets.size(); ++e) {
    const Eigen::Vector4i& t = mesh.tets[e];
    volumes[e] = SignedTetVolume(x.col(t[0]), x.col(t[1]), x.col(t[2]), x.col(t[3]));
  }
  return volumes;
}

MeshQualityReport CalcMeshQuality(const TetMesh& mesh, const Eigen::Matrix3Xd& x) {
  NSIM_CHECK(x.cols() == mesh.num_nodes(), "positions have ", x.cols(), " columns for ",
             mesh.num_nodes(), " nodes");
  MeshQualityReport r;
  r.num_nodes = mesh.num_nodes();
  r.num_tets = mesh.num_tets();
  r.num_surface_triangles = static_cast<int>(mesh.surface.size());
  r.radius_ratio_histogram.assign(10, 0);
  if (r.num_nodes > 0) {
    r.bbox_min = x.rowwise().minCoeff();
    r.bbox_max = x.rowwise().maxCoeff();
  }
  for (const auto& f : mesh.surface) {
    const Eigen::Vector3d a = x.col(f[0]), b = x.col(f[1]), c = x.col(f[2]);
    r.surface_volume += a.dot(b.cross(c)) / 6.0;
  }
  if (mesh.tets.empty()) return r;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  r.min_volume = r.min_radius_ratio = r.min_dihedral = r.min_edge = kInf;
  r.max_volume = -kInf;
  double edge_sum = 0;
  for (const auto& t : mesh.tets) {
    const TetQuality q = CalcTetQuality(x.col(t[0]), x.col(t[1]), x.col(t[2]), x.col(t[3]));
    r.total_volume += q.volume;
    r.min_volume = std::min(r.min_volume, q.volume);
    r.max_volume = std::max(r.max_volume, q.volume);
    if (!(q.volume > 0)) ++r.num_inverted;
    r.min_radius_ratio = std::min(r.min_radius_ratio, q.radius_ratio);
    r.mean_radius_ratio += q.radius_ratio;
    if (q.radius_ratio < 0.1) ++r.num_radius_ratio_below_0_1;
    r.radius_ratio_histogram[std::clamp(static_cast<int>(q.radius_ratio * 10), 0, 9)]++;
    r.max_edge_ratio = std::max(r.max_edge_ratio, q.edge_ratio);
    r.mean_edge_ratio += q.edge_ratio;
    r.min_dihedral = std::min(r.min_dihedral, q.min_dihedral);
    r.max_dihedral = std::max(r.max_dihedral, q.max_dihedral);
    r.min_edge = std::min(r.min_edge, q.min_edge);
    r.max_edge = std::max(r.max_edge, q.max_edge);
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) edge_sum += (x.col(t[i]) - x.col(t[j])).norm();
  }
  r.mean_radius_ratio /= r.num_tets;
  r.mean_edge_ratio /= r.num_tets;
  r.mean_edge = edge_sum / (6.0 * r.num_tets);  // each tet's 6 edges (shared edges counted per tet)
  return r;
}

std::string FormatMeshQuality(const MeshQualityReport& r) {
  constexpr double kDeg = 180.0 / kPi;
  std::ostringstream out;
  out << std::fixed << std::setprecision(3);
  out << "nodes " << r.num_nodes << ", tets " << r.num_tets << ", surface triangles "
      << r.num_surface_triangles << "\n";
  out << "bounding box (mm): " << 1e3 * r.bbox_min.transpose() << " .. "
      << 1e3 * r.bbox_max.transpose() << " (size " << 1e3 * (r.bbox_max - r.bbox_min).transpose()
      << ")\n";
  out << "volume (cm^3): tets " << 1e6 * r.total_volume << ", enclosed by surface "
      << 1e6 * r.surface_volume << "\n";
  out << std::setprecision(4);
  out << "tet volume (mm^3): min " << 1e9 * r.min_volume << ", max " << 1e9 * r.max_volume
      << ", inverted " << r.num_inverted << "\n";
  out << "radius ratio: min " << r.min_radius_ratio << ", mean " << r.mean_radius_ratio
      << ", below 0.1: " << r.num_radius_ratio_below_0_1 << "\n";
  out << "edge ratio: max " << r.max_edge_ratio << ", mean " << r.mean_edge_ratio << "\n";
  out << std::setprecision(2);
  out << "dihedral angle (deg): min " << kDeg * r.min_dihedral << ", max " << kDeg * r.max_dihedral
      << "\n";
  out << "edge length (mm): min " << 1e3 * r.min_edge << ", mean " << 1e3 * r.mean_edge << ", max "
      << 1e3 * r.max_edge << "\n";
  out << "radius ratio histogram [0,0.1) .. [0.9,1]:";
  for (int c : r.radius_ratio_histogram) out << " " << c;
  out << "\n";
  return out.str();
}

}  // namespace nsim
