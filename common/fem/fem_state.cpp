#include "common/fem/fem_state.h"

namespace nsim {

namespace {

Matrix34d Gather(const Eigen::Matrix3Xd& x, const Eigen::Vector4i& t) {
  Matrix34d xe;
  for (int a = 0; a < 4; ++a) xe.col(a) = x.col(t[a]);
  return xe;
}

}  // namespace

FemState::FemState(const FemModel& model) {
  const int n = model.num_nodes();
  x = model.get_rest_positions();
  v = Eigen::Matrix3Xd::Zero(3, n);
  external_forces = Eigen::Matrix3Xd::Zero(3, n);
  const auto& prescribed = model.get_prescribed_nodes();
  prescribed_positions.resize(3, static_cast<int>(prescribed.size()));
  for (size_t k = 0; k < prescribed.size(); ++k)
    prescribed_positions.col(k) = model.get_rest_positions().col(prescribed[k]);
  rotations.assign(model.num_tets(), Eigen::Matrix3d::Identity());
  dv_free = Eigen::Matrix3Xd::Zero(3, n);
  free_velocity = Eigen::Matrix3Xd::Zero(3, n);
  for (auto& change : free_velocity_changes) change = Eigen::Matrix3Xd::Zero(3, n);
  x_free = x;
  reaction_forces = Eigen::Matrix3Xd::Zero(3, static_cast<int>(model.get_dirichlet_nodes().size()));
}

double CalcKineticEnergy(const FemModel& model, const FemState& state) {
  return 0.5 * (state.v.colwise().squaredNorm().transpose().array() *
                model.get_lumped_mass().array())
                   .sum();
}

double CalcElasticEnergy(const FemModel& model, const FemState& state) {
  double energy = 0.0;
  const auto& tets = model.get_mesh().tets;
  for (int e = 0; e < model.num_tets(); ++e) {
    const TetRestShape& rest = model.get_rest_shapes()[e];
    const Eigen::Matrix3d F = CalcDeformationGradient(rest, Gather(state.x, tets[e]));
    energy += CalcCorotatedEnergy(rest, model.get_lame(), CalcPolarRotation(F), F);
  }
  return energy;
}

int CountInvertedTets(const FemModel& model, const FemState& state) {
  int inverted = 0;
  const auto& tets = model.get_mesh().tets;
  // det F = (current signed volume) / (rest volume), and every rest volume is > 0: the sign of
  // the signed volume decides
  for (const Eigen::Vector4i& t : tets) {
    const Eigen::Vector3d a = state.x.col(t[1]) - state.x.col(t[0]);
    const Eigen::Vector3d b = state.x.col(t[2]) - state.x.col(t[0]);
    const Eigen::Vector3d c = state.x.col(t[3]) - state.x.col(t[0]);
    if (!(a.dot(b.cross(c)) > 0)) ++inverted;  // a NaN counts too
  }
  return inverted;
}

double CalcGravitationalEnergy(const FemModel& model, const FemState& state) {
  return -(model.get_config().gravity.transpose() * state.x * model.get_lumped_mass()).value();
}

Eigen::Matrix3Xd CalcElasticForces(const FemModel& model, const FemState& state) {
  Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, model.num_nodes());
  const auto& tets = model.get_mesh().tets;
  for (int e = 0; e < model.num_tets(); ++e) {
    const TetRestShape& rest = model.get_rest_shapes()[e];
    const Eigen::Matrix3d F = CalcDeformationGradient(rest, Gather(state.x, tets[e]));
    const Matrix34d fe = CalcCorotatedForce(rest, model.get_lame(), CalcPolarRotation(F), F);
    for (int a = 0; a < 4; ++a) f.col(tets[e][a]) += fe.col(a);
  }
  return f;
}

}  // namespace nsim
