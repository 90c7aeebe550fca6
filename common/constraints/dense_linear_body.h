#pragma once
// A small linear elastic body with a dense system matrix, for tests, examples and lumped
// objects: n particles with masses m_i, an optional stiffness K (3n x 3n, symmetric positive
// semi-definite) about rest positions X, Rayleigh damping C = alpha M + beta K, gravity and
// external nodal forces. With K = 0 it is a set of free particles. Implicit Euler, exact for a
// linear body (DESIGN.md "Physics"):
//     A dv = h (f + h K v),  A = M + h C + h^2 K,  f = -K (x - X) - C v + M g + f_ext,
// A factorized once by Cholesky (LLT), so its compliance C = h^2 A^-1 is constant.

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "common/constraints/constraint_body.h"

namespace nsim {

/// Parameters of a DenseLinearBody.
struct DenseLinearBodyConfig {
  Eigen::VectorXd masses;                             ///< per node (kg), > 0, size n
  Eigen::Matrix3Xd rest_positions;                    ///< X (m), 3 x n; also the initial positions
  Eigen::MatrixXd stiffness;                          ///< K (N/m), 3n x 3n symmetric; empty means 0
  double time_step = 0.01;                            ///< h (s), > 0
  double rayleigh_mass = 0.0;                         ///< alpha (1/s), >= 0
  double rayleigh_stiffness = 0.0;                    ///< beta (s), >= 0
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  ///< g (m/s^2)
};

/// See the file comment. Step protocol: SolveFreeMotion(), then the constraint solver's
/// ApplyCorrection (or none: the free motion is already the committed end-of-step state).
class DenseLinearBody : public ConstraintBody {
 public:
  /// Throws InputError on sizes or values out of range.
  explicit DenseLinearBody(const DenseLinearBodyConfig& config);

  /// Starts a step: start positions = current positions, then the free motion (no constraint
  /// force) is computed and committed as the current state.
  void SolveFreeMotion();

  int num_nodes() const override { return static_cast<int>(x_.cols()); }
  const Eigen::Matrix3Xd& start_positions() const override { return x_start_; }
  const Eigen::Matrix3Xd& free_positions() const override { return x_free_; }
  void ApplyCompliance(const Eigen::SparseMatrix<double>& forces,
                       Eigen::MatrixXd& displacements) const override;
  std::uint64_t compliance_version() const override { return version_; }
  void ApplyCorrection(const Eigen::Matrix3Xd& dx) override;

  /// Current positions (m) and velocities (m/s), 3 x n.
  const Eigen::Matrix3Xd& positions() const { return x_; }
  const Eigen::Matrix3Xd& velocities() const { return v_; }
  void set_positions(const Eigen::Matrix3Xd& x);
  void set_velocities(const Eigen::Matrix3Xd& v);
  /// External nodal forces (N), 3 x n, held until changed.
  Eigen::Matrix3Xd& external_forces() { return f_ext_; }
  /// Changes the time step (refactorizes A and changes compliance_version()).
  void set_time_step(double h);

  const Eigen::VectorXd& masses() const { return m_; }
  double time_step() const { return h_; }
  /// The system matrix A (kg), 3n x 3n.
  const Eigen::MatrixXd& system_matrix() const { return A_; }
  /// Sum of m_i v_i (kg m/s).
  Eigen::Vector3d CalcMomentum() const;

 private:
  void Factorize();

  Eigen::VectorXd m_;
  Eigen::Matrix3Xd X_;
  Eigen::MatrixXd K_;
  double h_;
  double alpha_, beta_;
  Eigen::Vector3d g_;
  Eigen::Matrix3Xd x_, v_, x_start_, x_free_, f_ext_;
  Eigen::MatrixXd A_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  std::uint64_t version_ = 0;
};

}  // namespace nsim
