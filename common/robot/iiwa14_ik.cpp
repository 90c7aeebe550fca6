#include "common/robot/iiwa14_ik.h"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <random>

#include "common/core/error.h"

namespace nsim {
namespace {

using Vector6dIk = Eigen::Matrix<double, 6, 1>;

constexpr double kMaxDamping = 1e6;      // mu above which a descent is stuck
constexpr double kMinDamping = 1e-12;    // floor of mu, keeps A A^T + mu I positive definite
constexpr double kBoundEpsilon = 1e-12;  // a joint this close to a bound counts as on it (rad)
constexpr double kNullRank = 1e-9;       // relative singular value below which V spans null(A)
// the mid-range pull acts while |e| > this (m and rad combined): near the solution it would keep
// moving along the self-motion manifold and turn quadratic convergence into linear
constexpr double kNullSpaceErrorThreshold = 1e-3;

// task error [p_target - p; Log(R_target R^T)]
Vector6dIk CalcError(const Eigen::Isometry3d& X_target, const Eigen::Isometry3d& X) {
  Vector6dIk e;
  e.segment<3>(kLinear) = X_target.translation() - X.translation();
  e.segment<3>(kAngular) = LogSO3(X_target.linear() * X.linear().transpose());
  return e;
}

}  // namespace

void Iiwa14IkConfig::Validate() const {
  if (!(position_tolerance > 0.0)) {
    throw InputError(Str("ik.position_tolerance must be > 0 (m), got ", position_tolerance));
  }
  if (!(orientation_tolerance > 0.0)) {
    throw InputError(
        Str("ik.orientation_tolerance must be > 0 (rad), got ", orientation_tolerance));
  }
  if (max_iterations < 1) {
    throw InputError(Str("ik.max_iterations must be >= 1, got ", max_iterations));
  }
  if (max_restarts < 0) {
    throw InputError(Str("ik.max_restarts must be >= 0, got ", max_restarts));
  }
  if (!(initial_damping > 0.0) || !std::isfinite(initial_damping)) {
    throw InputError(Str("ik.initial_damping must be > 0 (m^2), got ", initial_damping));
  }
  if (!(max_joint_step > 0.0) || !std::isfinite(max_joint_step)) {
    throw InputError(Str("ik.max_joint_step must be > 0 (rad), got ", max_joint_step));
  }
  if (!(null_space_gain >= 0.0 && null_space_gain <= 1.0)) {
    throw InputError(Str("ik.null_space_gain must be in [0, 1], got ", null_space_gain));
  }
}

Iiwa14InverseKinematics::Iiwa14InverseKinematics(const Iiwa14Model& model,
                                                 const Iiwa14IkConfig& config)
    : model_(model), config_(config) {
  config_.Validate();
}

bool Iiwa14InverseKinematics::Descend(const Eigen::Isometry3d& X_target, const Vector7d& q0,
                                      Iiwa14IkResult* out) const {
  const Iiwa14Config& c = model_.config();
  const Vector7d q_mid = model_.CalcMidRange();
  Iiwa14Kinematics kin;
  Jacobian67 J;
  Jacobian67 A;
  Jacobian67 A_free;
  Vector7d q = model_.ClampToLimits(q0);
  model_.CalcForwardKinematics(q, &kin);
  Vector6dIk e = CalcError(X_target, kin.X_WT);
  double cost = e.squaredNorm();
  double mu = config_.initial_damping;
  bool use_null = config_.null_space_gain > 0.0;
  int it = 0;
  bool converged = false;
  for (;;) {
    converged = e.segment<3>(kLinear).norm() <= config_.position_tolerance &&
                e.segment<3>(kAngular).norm() <= config_.orientation_tolerance;
    if (converged || it >= config_.max_iterations || mu > kMaxDamping) break;
    ++it;
    model_.CalcToolJacobian(kin, &J);
    A.topRows<3>() = J.topRows<3>();
    A.bottomRows<3>() = CalcSO3RightJacobianInverse(e.segment<3>(kAngular)) * J.bottomRows<3>();

    // active set on the bounds: fix joints whose step would leave the box, re-solve
    Eigen::Matrix<bool, 7, 1> free;
    free.setConstant(true);
    Vector7d dq;
    for (int pass = 0; pass <= kIiwaNumJoints; ++pass) {
      A_free = A;
      for (int j = 0; j < kIiwaNumJoints; ++j) {
        if (!free[j]) A_free.col(j).setZero();
      }
      Eigen::Matrix<double, 6, 6> M = A_free * A_free.transpose();
      M.diagonal().array() += mu;
      dq = A_free.transpose() * M.ldlt().solve(e);
      bool changed = false;
      for (int j = 0; j < kIiwaNumJoints; ++j) {
        if (!free[j]) continue;
        const bool at_lower = q[j] <= c.position_lower[j] + kBoundEpsilon && dq[j] < 0.0;
        const bool at_upper = q[j] >= c.position_upper[j] - kBoundEpsilon && dq[j] > 0.0;
        if (at_lower || at_upper) {
          free[j] = false;
          changed = true;
        }
      }
      if (!changed) break;
    }
    for (int j = 0; j < kIiwaNumJoints; ++j) {
      if (!free[j]) dq[j] = 0.0;
    }

    // null-space pull toward mid-range, projected exactly onto null(A_free)
    Vector7d dq_null = Vector7d::Zero();
    if (use_null && e.norm() > kNullSpaceErrorThreshold) {
      Eigen::JacobiSVD<Jacobian67> svd(A_free, Eigen::ComputeFullV);
      const auto& s = svd.singularValues();
      const double threshold = kNullRank * std::max(s[0], 1e-300);
      Vector7d z = config_.null_space_gain * (q_mid - q);
      for (int j = 0; j < kIiwaNumJoints; ++j) {
        if (!free[j]) z[j] = 0.0;
      }
      for (int k = 0; k < kIiwaNumJoints; ++k) {
        if (k >= 6 || s[k] <= threshold) {
          const Vector7d v = svd.matrixV().col(k);
          dq_null += v * v.dot(z);
        }
      }
      for (int j = 0; j < kIiwaNumJoints; ++j) {
        if (!free[j]) dq_null[j] = 0.0;
      }
    }

    Vector7d step = dq + dq_null;
    const double largest = step.cwiseAbs().maxCoeff();
    if (largest > config_.max_joint_step) step *= config_.max_joint_step / largest;
    const Vector7d q_trial = model_.ClampToLimits(q + step);
    Iiwa14Kinematics kin_trial;
    model_.CalcForwardKinematics(q_trial, &kin_trial);
    const Vector6dIk e_trial = CalcError(X_target, kin_trial.X_WT);
    const double cost_trial = e_trial.squaredNorm();
    if (cost_trial < cost) {
      q = q_trial;
      kin = kin_trial;
      e = e_trial;
      cost = cost_trial;
      mu = std::max(mu * 0.1, kMinDamping);
      use_null = config_.null_space_gain > 0.0;
    } else if (use_null) {
      use_null = false;  // retry the same damping without the null-space term
    } else {
      mu *= 10.0;
    }
  }
  out->q = q;
  out->position_error = e.segment<3>(kLinear).norm();
  out->orientation_error = e.segment<3>(kAngular).norm();
  out->iterations += it;
  out->success = converged;
  return converged;
}

Iiwa14IkResult Iiwa14InverseKinematics::Solve(const Eigen::Isometry3d& X_WT_target,
                                              const Vector7d& q_seed) const {
  Iiwa14IkResult best;
  best.q = model_.ClampToLimits(q_seed.allFinite() ? q_seed : model_.CalcMidRange());
  if (!IsRigidTransform(X_WT_target, 1e-6)) {
    best.position_error = std::numeric_limits<double>::infinity();
    best.orientation_error = std::numeric_limits<double>::infinity();
    return best;
  }
  const Iiwa14Config& c = model_.config();
  std::mt19937_64 rng(config_.random_seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double best_cost = std::numeric_limits<double>::infinity();
  int total_iterations = 0;
  for (int attempt = 0; attempt <= config_.max_restarts; ++attempt) {
    Vector7d q0;
    if (attempt == 0) {
      q0 = best.q;
    } else if (attempt == 1) {
      q0 = model_.CalcMidRange();
    } else {
      for (int j = 0; j < kIiwaNumJoints; ++j) {
        q0[j] = c.position_lower[j] + unit(rng) * (c.position_upper[j] - c.position_lower[j]);
      }
    }
    Iiwa14IkResult trial;
    const bool ok = Descend(X_WT_target, q0, &trial);
    total_iterations += trial.iterations;
    // compare attempts in the units of the tolerances
    const double cost = trial.position_error / config_.position_tolerance +
                        trial.orientation_error / config_.orientation_tolerance;
    if (ok || cost < best_cost) {
      best = trial;
      best_cost = cost;
      best.restarts = attempt;
    }
    if (ok) break;
  }
  best.iterations = total_iterations;
  return best;
}

}  // namespace nsim
