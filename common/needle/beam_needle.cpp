#include "common/needle/beam_needle.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "common/core/error.h"

namespace nsim {

namespace {

std::atomic<std::uint64_t> beam_version_counter{0};

Eigen::Vector3d LogRotation(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

Eigen::Matrix3d ExpRotation(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix();
}

// inverse left Jacobian of SO(3): log(exp(d) exp(phi)) = phi + JlInv(phi) d + O(d^2)
Eigen::Matrix3d CalcLeftJacobianInverse(const Eigen::Vector3d& phi) {
  const double t = phi.norm();
  Eigen::Matrix3d S;
  S << 0.0, -phi.z(), phi.y(), phi.z(), 0.0, -phi.x(), -phi.y(), phi.x(), 0.0;
  Eigen::Matrix3d J = Eigen::Matrix3d::Identity() - 0.5 * S;
  if (t > 1e-8) J += (1.0 / (t * t) - (1.0 + std::cos(t)) / (2.0 * t * std::sin(t))) * S * S;
  return J;
}

// co-rotated frame of element (i, j): z along the chord, x from the nodes' mean x director
Eigen::Matrix3d CalcElementFrame(const Eigen::Vector3d& xi, const Eigen::Vector3d& xj,
                                 const Eigen::Matrix3d& Ri, const Eigen::Matrix3d& Rj,
                                 double* length) {
  const Eigen::Vector3d chord = xj - xi;
  *length = chord.norm();
  const Eigen::Vector3d z = chord / *length;
  const Eigen::Vector3d xa = Ri.col(0) + Rj.col(0);
  const Eigen::Vector3d x = (xa - xa.dot(z) * z).normalized();
  Eigen::Matrix3d Re;
  Re.col(0) = x;
  Re.col(1) = z.cross(x);
  Re.col(2) = z;
  return Re;
}

// local deformation d (12) of an element in its co-rotated frame
void CalcLocalDeformation(const Eigen::Matrix3d& Re, const Eigen::Matrix3d& Ri,
                          const Eigen::Matrix3d& Rj, double length, double rest_length,
                          Eigen::Matrix<double, 12, 1>& d) {
  d.setZero();
  d.segment<3>(3) = LogRotation(Re.transpose() * Ri);
  d[8] = length - rest_length;
  d.segment<3>(9) = LogRotation(Re.transpose() * Rj);
}

}  // namespace

NeedleConfig MakeFlexibleNeedleConfig() {
  NeedleConfig c;
  c.length = 0.2;
  c.radius = 0.6e-3;
  c.young_modulus = 5e9;
  return c;
}

void BeamNeedleConfig::Validate() const {
  needle.Validate("needle");
  if (num_elements < 1)
    throw InputError(Str("needle.num_elements must be >= 1, got ", num_elements));
  if (!(time_step > 0.0) || !std::isfinite(time_step))
    throw InputError(Str("needle.time_step must be > 0 (s), got ", time_step));
  if (!(rayleigh_mass >= 0.0) || !std::isfinite(rayleigh_mass))
    throw InputError(Str("needle.rayleigh_mass must be >= 0 (1/s), got ", rayleigh_mass));
  if (!(rayleigh_stiffness >= 0.0) || !std::isfinite(rayleigh_stiffness))
    throw InputError(Str("needle.rayleigh_stiffness must be >= 0 (s), got ", rayleigh_stiffness));
  if (!gravity.allFinite())
    throw InputError(Str("needle.gravity must be finite (m/s^2), got ", gravity.transpose()));
}

BeamNeedleModel::BeamNeedleModel(const BeamNeedleConfig& config) : config_(config) {
  config_.Validate();
  const NeedleConfig& nc = config_.needle;
  const double L = nc.length / config_.num_elements;
  element_length_ = L;
  const double area = M_PI * nc.radius * nc.radius;
  const double I = CalcSecondMomentOfArea(nc.radius);
  const double J = 2.0 * I;
  const double G = nc.young_modulus / (2.0 * (1.0 + nc.poisson_ratio));
  ei_ = nc.young_modulus * I;
  ea_ = nc.young_modulus * area;
  X_FN_ = CalcToolOffset(nc);

  // Euler-Bernoulli element, axis z: bending planes (u_x, theta_y = slope) and
  // (u_y, theta_x = -slope), axial u_z, torsion theta_z
  k_local_.setZero();
  const double kb[4][4] = {{12.0, 6.0 * L, -12.0, 6.0 * L},
                           {6.0 * L, 4.0 * L * L, -6.0 * L, 2.0 * L * L},
                           {-12.0, -6.0 * L, 12.0, -6.0 * L},
                           {6.0 * L, 2.0 * L * L, -6.0 * L, 4.0 * L * L}};
  const double scale = ei_ / (L * L * L);
  const int plane_idx[2][4] = {{0, 4, 6, 10}, {1, 3, 7, 9}};
  const double plane_sign[2][4] = {{1, 1, 1, 1}, {1, -1, 1, -1}};
  for (int p = 0; p < 2; ++p)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        k_local_(plane_idx[p][a], plane_idx[p][b]) +=
            plane_sign[p][a] * plane_sign[p][b] * scale * kb[a][b];
  const double ka = ea_ / L, kt = G * J / L;
  k_local_(2, 2) += ka;
  k_local_(8, 8) += ka;
  k_local_(2, 8) -= ka;
  k_local_(8, 2) -= ka;
  k_local_(5, 5) += kt;
  k_local_(11, 11) += kt;
  k_local_(5, 11) -= kt;
  k_local_(11, 5) -= kt;

  const int n = num_nodes();
  mass_.assign(n, 0.0);
  inertia_.assign(n, 0.0);
  for (int e = 0; e < config_.num_elements; ++e) {
    for (int k : {e, e + 1}) {
      mass_[k] += 0.5 * nc.density * area * L;
      inertia_[k] += 0.5 * nc.density * J * L;
    }
  }
}

BeamNeedleState::BeamNeedleState(const BeamNeedleModel& model) {
  const int n = model.num_nodes();
  x.setZero(3, n);
  R.assign(n, Eigen::Matrix3d::Identity());
  v.setZero(3, n);
  w.setZero(3, n);
  external_forces.setZero(3, n);
  external_torques.setZero(3, n);
  x_free.setZero(3, n);
  phi_free.setZero(3, n);
  v_free.setZero(3, n);
  w_free.setZero(3, n);
  ResetBeamNeedle(model, Eigen::Isometry3d::Identity(), *this);
}

void ResetBeamNeedle(const BeamNeedleModel& model, const Eigen::Isometry3d& X_WF,
                     BeamNeedleState& state) {
  if (!X_WF.matrix().allFinite())
    throw InputError("needle: flange pose X_WF must be finite, got a NaN or inf");
  const Eigen::Isometry3d X_WN = X_WF * model.get_tool_offset();
  for (int k = 0; k < model.num_nodes(); ++k) {
    state.x.col(k) = X_WN * Eigen::Vector3d(0.0, 0.0, k * model.element_length());
    state.R[k] = X_WN.linear();
  }
  state.v.setZero();
  state.w.setZero();
  state.x_free = state.x;
  state.phi_free.setZero();
  state.v_free.setZero();
  state.w_free.setZero();
  state.X_WBase_target = X_WN;
}

void SetBeamNeedleTarget(const BeamNeedleModel& model, const Eigen::Isometry3d& X_WF,
                         BeamNeedleState& state) {
  if (!X_WF.matrix().allFinite())
    throw InputError("needle: flange pose X_WF must be finite, got a NaN or inf");
  state.X_WBase_target = X_WF * model.get_tool_offset();
}

void CalcBeamElasticForces(const BeamNeedleModel& model, const BeamNeedleState& state,
                           Eigen::Matrix3Xd& forces, Eigen::Matrix3Xd& torques) {
  const int n = model.num_nodes();
  forces.setZero(3, n);
  torques.setZero(3, n);
  Eigen::Matrix<double, 12, 1> d;
  for (int e = 0; e + 1 < n; ++e) {
    double length = 0.0;
    const Eigen::Matrix3d Re = CalcElementFrame(state.x.col(e), state.x.col(e + 1), state.R[e],
                                                state.R[e + 1], &length);
    CalcLocalDeformation(Re, state.R[e], state.R[e + 1], length, model.element_length(), d);
    const Eigen::Matrix<double, 12, 1> f = model.get_local_stiffness() * d;
    forces.col(e) -= Re * f.segment<3>(0);
    torques.col(e) -= Re * f.segment<3>(3);
    forces.col(e + 1) -= Re * f.segment<3>(6);
    torques.col(e + 1) -= Re * f.segment<3>(9);
  }
}

BeamNeedleBody::BeamNeedleBody(const BeamNeedleModel& model, BeamNeedleState& state)
    : model_(model), state_(state), n_(model.num_nodes()), h_(model.get_config().time_step) {
  NSIM_CHECK(state.num_nodes() == n_, "BeamNeedleState has ", state.num_nodes(),
             " nodes, the model ", n_);
  start_.setZero(3, 2 * n_);
  free_.setZero(3, 2 * n_);
  diag_.resize(n_);
  upper_.resize(n_);
  schur_.resize(n_);
  gain_.resize(n_);
  u_.setZero(6 * n_);
  f_.setZero(6 * n_);
  b_.setZero(6 * n_);
  dv_.setZero(6 * n_);
  rhs_.setZero(6 * (n_ - 1));
  version_ = ++beam_version_counter;
}

void BeamNeedleBody::BeginStep() {
  NSIM_CHECK(!in_step_, "BeginStep called twice without committing the step");
  BeamNeedleState& s = state_;
  if (!s.external_forces.allFinite() || !s.external_torques.allFinite())
    throw InputError("needle: external forces and torques must be finite, got a NaN or inf");
  const BeamNeedleConfig& cfg = model_.get_config();
  const double h = h_, alpha = cfg.rayleigh_mass, beta = cfg.rayleigh_stiffness;

  // forces at the step start and the co-rotated tangent K (block tridiagonal)
  for (int k = 0; k < n_; ++k) {
    diag_[k].setZero();
    upper_[k].setZero();
    u_.segment<3>(6 * k) = s.v.col(k);
    u_.segment<3>(6 * k + 3) = s.w.col(k);
    f_.segment<3>(6 * k) = s.external_forces.col(k) + model_.node_mass(k) * cfg.gravity;
    f_.segment<3>(6 * k + 3) = s.external_torques.col(k);
  }
  Eigen::Matrix<double, 12, 1> d;
  for (int e = 0; e + 1 < n_; ++e) {
    double length = 0.0;
    const Eigen::Matrix3d Re =
        CalcElementFrame(s.x.col(e), s.x.col(e + 1), s.R[e], s.R[e + 1], &length);
    CalcLocalDeformation(Re, s.R[e], s.R[e + 1], length, model_.element_length(), d);
    const Matrix12d& K = model_.get_local_stiffness();
    const Eigen::Matrix<double, 12, 1> fl = K * d;
    for (int a = 0; a < 4; ++a) f_.segment<3>(6 * e + 3 * a) -= Re * fl.segment<3>(3 * a);
    // T K T^T by 3 x 3 blocks
    Matrix12d Kg;
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        Kg.block<3, 3>(3 * a, 3 * b) = Re * K.block<3, 3>(3 * a, 3 * b) * Re.transpose();
    diag_[e] += Kg.block<6, 6>(0, 0);
    diag_[e + 1] += Kg.block<6, 6>(6, 6);
    upper_[e] += Kg.block<6, 6>(0, 6);
    // geometric stiffness of the axial tension N: its direction turns with the chord,
    // d(N z)/dx_j = N / l (I - z z^T). EA >> EI / L^2 makes it essential; compression is left
    // out (keeps A positive definite, at the price of no buckling in the tangent)
    const double tension = std::max(0.0, model_.axial_stiffness() *
                                             (length - model_.element_length()) /
                                             model_.element_length());
    const Eigen::Vector3d z = Re.col(2);
    const Eigen::Matrix3d G = tension / length * (Eigen::Matrix3d::Identity() - z * z.transpose());
    diag_[e].topLeftCorner<3, 3>() += G;
    diag_[e + 1].topLeftCorner<3, 3>() += G;
    upper_[e].topLeftCorner<3, 3>() -= G;
  }

  // b = h f - h alpha M u - (h beta + h^2) K u;  A = (1 + h alpha) M + (h beta + h^2) K
  const double ck = h * beta + h * h;
  for (int k = 0; k < n_; ++k) {
    Vector6d ku = diag_[k] * u_.segment<6>(6 * k);
    if (k + 1 < n_) ku += upper_[k] * u_.segment<6>(6 * (k + 1));
    if (k > 0) ku += upper_[k - 1].transpose() * u_.segment<6>(6 * (k - 1));
    Vector6d mu;
    mu << model_.node_mass(k) * u_.segment<3>(6 * k),
        model_.node_inertia(k) * u_.segment<3>(6 * k + 3);
    b_.segment<6>(6 * k) = h * f_.segment<6>(6 * k) - h * alpha * mu - ck * ku;
  }
  for (int k = 0; k < n_; ++k) {
    diag_[k] *= ck;
    upper_[k] *= ck;
    for (int c = 0; c < 3; ++c) {
      diag_[k](c, c) += (1.0 + h * alpha) * model_.node_mass(k);
      diag_[k](3 + c, 3 + c) += (1.0 + h * alpha) * model_.node_inertia(k);
    }
  }

  // base node prescribed: dv_0 from the target pose
  Vector6d dv0;
  dv0.head<3>() = (s.X_WBase_target.translation() - s.x.col(0)) / h - s.v.col(0);
  dv0.tail<3>() =
      LogRotation(s.X_WBase_target.linear() * s.R[0].transpose()) / h - s.w.col(0);

  // block Cholesky of A_ff (nodes 1..n-1)
  for (int k = 1; k < n_; ++k) {
    Matrix6d S = diag_[k];
    if (k > 1) S.noalias() -= upper_[k - 1].transpose() * gain_[k - 1];
    schur_[k].compute(S);
    NSIM_CHECK(schur_[k].info() == Eigen::Success, "needle system matrix not positive definite");
    if (k + 1 < n_) gain_[k] = schur_[k].solve(upper_[k]);
  }
  rhs_ = b_.tail(6 * (n_ - 1));
  rhs_.head<6>() -= upper_[0].transpose() * dv0;
  SolveReduced(rhs_);
  dv_.head<6>() = dv0;
  dv_.tail(6 * (n_ - 1)) = rhs_;

  for (int k = 0; k < n_; ++k) {
    s.v_free.col(k) = s.v.col(k) + dv_.segment<3>(6 * k);
    s.w_free.col(k) = s.w.col(k) + dv_.segment<3>(6 * k + 3);
    s.x_free.col(k) = s.x.col(k) + h * s.v_free.col(k);
    s.phi_free.col(k) = h * s.w_free.col(k);
  }
  start_.leftCols(n_) = s.x;
  start_.rightCols(n_).setZero();
  free_.leftCols(n_) = s.x_free;
  free_.rightCols(n_) = s.phi_free;
  version_ = ++beam_version_counter;
  in_step_ = true;
}

void BeamNeedleBody::SolveReduced(Eigen::VectorXd& r) const {
  // forward: y_k = r_k - G_{k-1}^T y_{k-1}; back: x_k = S_k^-1 y_k - G_k x_{k+1}
  const int m = n_ - 1;
  for (int k = 2; k <= m; ++k)
    r.segment<6>(6 * (k - 1)) -= gain_[k - 1].transpose() * r.segment<6>(6 * (k - 2));
  for (int k = m; k >= 1; --k) {
    Vector6d y = schur_[k].solve(Vector6d(r.segment<6>(6 * (k - 1))));
    if (k < m) y -= gain_[k] * r.segment<6>(6 * k);
    r.segment<6>(6 * (k - 1)) = y;
  }
}

void BeamNeedleBody::ApplyCompliance(const Eigen::SparseMatrix<double>& forces,
                                     Eigen::MatrixXd& displacements) const {
  NSIM_CHECK(in_step_, "ApplyCompliance outside a step (call BeginStep first)");
  NSIM_CHECK(forces.rows() == 6 * n_, "forces have ", forces.rows(), " rows, expected ", 6 * n_);
  displacements.setZero(6 * n_, forces.cols());
  // pseudo-node row r: node r / 3 < n is a position, otherwise a rotation
  auto dof_of_row = [this](int r) {
    const int node = r / 3, c = r % 3;
    return node < n_ ? 6 * node + c : 6 * (node - n_) + 3 + c;
  };
  for (int j = 0; j < forces.cols(); ++j) {
    rhs_.setZero();
    bool any = false;
    for (Eigen::SparseMatrix<double>::InnerIterator it(forces, j); it; ++it) {
      const int dof = dof_of_row(static_cast<int>(it.row()));
      if (dof < 6) continue;  // the clamped base takes it
      rhs_[dof - 6] += it.value();
      any = true;
    }
    if (!any) continue;
    SolveReduced(rhs_);
    for (int k = 1; k < n_; ++k) {
      displacements.block<3, 1>(3 * k, j) = h_ * h_ * rhs_.segment<3>(6 * (k - 1));
      displacements.block<3, 1>(3 * (n_ + k), j) = h_ * h_ * rhs_.segment<3>(6 * (k - 1) + 3);
    }
  }
}

void BeamNeedleBody::ApplyCorrection(const Eigen::Matrix3Xd& dx) {
  NSIM_CHECK(in_step_, "ApplyCorrection outside a step (call BeginStep first)");
  NSIM_CHECK(dx.cols() == 2 * n_, "correction has ", dx.cols(), " columns, expected ", 2 * n_);
  Commit(&dx);
}

void BeamNeedleBody::EndStep() {
  if (in_step_) Commit(nullptr);
}

void BeamNeedleBody::Commit(const Eigen::Matrix3Xd* dx) {
  BeamNeedleState& s = state_;
  for (int k = 0; k < n_; ++k) {
    Eigen::Vector3d dp = Eigen::Vector3d::Zero(), dphi = Eigen::Vector3d::Zero();
    if (dx != nullptr && k > 0) {
      dp = dx->col(k);
      dphi = dx->col(n_ + k);
    }
    s.x.col(k) = s.x_free.col(k) + dp;
    s.v.col(k) = s.v_free.col(k) + dp / h_;
    s.R[k] = ExpRotation(s.phi_free.col(k) + dphi) * s.R[k];
    s.w.col(k) = s.w_free.col(k) + dphi / h_;
  }
  // the base is prescribed exactly
  s.x.col(0) = s.X_WBase_target.translation();
  s.R[0] = s.X_WBase_target.linear();
  // keep the orientations orthonormal against round-off drift
  for (int k = 1; k < n_; ++k) s.R[k] = Eigen::Quaterniond(s.R[k]).normalized().toRotationMatrix();
  s.time += h_;
  in_step_ = false;
}

void BeamNeedleBody::CalcFreeMotionSensitivity(Eigen::MatrixXd& S) const {
  NSIM_CHECK(in_step_, "CalcFreeMotionSensitivity outside a step (call BeginStep first)");
  const BeamNeedleState& s = state_;
  S.setZero(6 * n_, 6);
  const Eigen::Matrix3d J =
      CalcLeftJacobianInverse(LogRotation(s.X_WBase_target.linear() * s.R[0].transpose()));
  for (int j = 0; j < 6; ++j) {
    // h d(dv_0) for a unit base perturbation e_j; the base node follows it exactly
    Vector6d h_dv0 = Vector6d::Zero();
    if (j < 3) {
      h_dv0[j] = 1.0;
    } else {
      h_dv0.tail<3>() = J.col(j - 3);
    }
    S.block<3, 1>(0, j) = h_dv0.head<3>();
    S.block<3, 1>(3 * n_, j) = h_dv0.tail<3>();
    // free nodes: h d(dv_f) = -A_ff^-1 A_f0 h d(dv_0), only node 1 couples to the base
    rhs_.setZero();
    rhs_.head<6>() = -upper_[0].transpose() * h_dv0;
    SolveReduced(rhs_);
    for (int k = 1; k < n_; ++k) {
      S.block<3, 1>(3 * k, j) = rhs_.segment<3>(6 * (k - 1));
      S.block<3, 1>(3 * (n_ + k), j) = rhs_.segment<3>(6 * (k - 1) + 3);
    }
  }
}

Eigen::Matrix3d BeamNeedleBody::CalcFreeTipFrame() const {
  return ExpRotation(state_.phi_free.col(n_ - 1)) * state_.R[n_ - 1];
}

}  // namespace nsim
