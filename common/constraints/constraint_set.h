#pragma once
// The constraints of one time step: points on bodies (barycentric combinations of nodes) or
// kinematic (prescribed) points, rows over those points, and groups of rows sharing one law
// (bilateral, unilateral contact, Coulomb friction contact, the needle's axial friction). See
// constraint_body.h for units and constraint_solver.h for how the laws are solved.
//
// A row i has terms t = (point p_t, direction d_t) and a target; its value at end-of-step
// positions x is
//     g_i(x) = sum_t d_t . x(p_t) - target_i     (m),
// where x(p) = sum_k w_k x_{node k} for a body point and the prescribed end-of-step position for
// a kinematic point. The row's multiplier lambda_i (N) applies the force d_t lambda_i to every
// point p_t of the row, so row i of H_b is the sparse (node, weight * d_t) pattern of its terms
// on body b, and a positive lambda increases g (W is positive semi-definite).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "common/constraints/constraint_body.h"

namespace nsim {

/// The law a group of rows obeys.
enum class ConstraintLaw {
  kBilateral,      ///< 1-3 rows, g = 0, lambda free (fixed point, trajectory, coupling)
  kUnilateral,     ///< 1 row, g >= 0, lambda >= 0, g lambda = 0 (frictionless contact)
  kFriction,       ///< 3 rows (normal, tangent 1, tangent 2): normal as kUnilateral; tangent rows
                   ///< measure the slip over the step; |lambda_t| <= mu lambda_n, sticking
                   ///< (zero slip) inside the cone, slip opposed by lambda_t on its boundary
  kAxialFriction,  ///< 1 row measuring a slip over the step (the needle's axial row) whose force
                   ///< is bounded by mu |lambda_normal| + stiction, lambda_normal the multipliers
                   ///< of another, bilateral group (the needle's two lateral rows): zero slip
                   ///< inside the bound, slip opposed by lambda at the bound
};

/// Rows sharing one law, contiguous in the row list.
struct ConstraintGroup {
  ConstraintLaw law = ConstraintLaw::kBilateral;
  int first_row = 0;
  int num_rows = 0;
  double mu = 0.0;        ///< Coulomb coefficient (kFriction, kAxialFriction), >= 0
  double stiction = 0.0;  ///< kAxialFriction: constant part of the bound (N), >= 0
  int normal_group = -1;  ///< kAxialFriction: the bilateral group whose force is the normal force
};

/// A point on a body (barycentric combination of nodes) or a kinematic point (body == -1).
struct ConstraintPoint {
  int body = -1;       ///< index in the set's bodies, or -1 for a kinematic point
  int first_node = 0;  ///< range in ConstraintSet::point_nodes()/point_weights()
  int num_nodes = 0;
  std::uint64_t key = 0;  ///< caller's persistent identity (0: none, never cached)
  Eigen::Vector3d p_start = Eigen::Vector3d::Zero();  ///< kinematic: position at step start (m)
  Eigen::Vector3d p_end = Eigen::Vector3d::Zero();    ///< kinematic: position at step end (m)
};

/// One term of a row: a point and the direction the row measures it along (unit or not).
struct ConstraintTerm {
  int point = -1;
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
};

/// One row: terms [first_term, first_term + num_terms) and the target (m).
struct ConstraintRow {
  int first_term = 0;
  int num_terms = 0;
  double target = 0.0;
  /// The row's own compliance relative to its diagonal compliance W_ii (-), >= 0: the solve
  /// uses W_ii (1 + softness), so the row is a spring in series with the bodies rather than a
  /// rigid link. Alone, a bilateral row then removes the fraction 1 / (1 + softness) of its
  /// free violation (0: rigid, the default). For a hold that fades in or out continuously.
  double softness = 0.0;
  /// The row's own compliance in m/N, >= 0, added to its diagonal after the softness: the
  /// solve uses W_ii (1 + softness) + compliance, a spring of stiffness 1 / compliance in
  /// series with the bodies whatever their own compliance (0: rigid, the default). For the
  /// tissue around a needle that the mesh does not resolve (needle_tissue.h).
  double compliance = 0.0;
};

/// The constraint problem of one step. Refill it every step (Clear keeps the capacity); the
/// bodies must outlive the set. Builders validate their input and throw InputError.
class ConstraintSet {
 public:
  /// Removes bodies, points, rows and groups (keeps allocated capacity).
  void Clear();

  /// Registers a body (not owned) and returns its index.
  int AddBody(ConstraintBody& body);

  /// Adds a point sum_k weights[k] x_{nodes[k]} on body `body`. `key` (nonzero) marks a point
  /// that persists across steps (a tissue point seeded along a needle path, the needle tip, a
  /// contact node): its compliance columns are combined from per-node columns cached while the
  /// body's compliance_version() is unchanged, so it may move (other nodes, other weights) and
  /// costs a solve only for nodes not seen before (see compliance.h). Returns the point index.
  int AddBodyPoint(int body, const std::vector<int>& nodes, const std::vector<double>& weights,
                   std::uint64_t key = 0);
  /// Point at barycentric coordinates `bary` in the tetrahedron `tet` (node indices).
  int AddBodyPoint(int body, const Eigen::Vector4i& tet, const Eigen::Vector4d& bary,
                   std::uint64_t key = 0);
  /// The node itself.
  int AddNodePoint(int body, int node, std::uint64_t key = 0);
  /// A prescribed point (e.g. on a rigid needle) at p_start at the start of the step and p_end at
  /// its end (m).
  int AddKinematicPoint(const Eigen::Vector3d& p_start, const Eigen::Vector3d& p_end);

  /// Bilateral group: rows d_k . (x(a) - x(b)) = d_k . offset for each column d_k of
  /// `directions` (3 x 1..3, nonzero). With offset 0 the two points coincide along the d_k:
  /// directions = identity holds a point on another (or on a kinematic point); two directions
  /// orthogonal to a needle make a trajectory constraint. Returns the group index.
  int AddBilateral(int a, int b, const Eigen::Matrix3Xd& directions,
                   const Eigen::Vector3d& offset = Eigen::Vector3d::Zero());

  /// Unilateral contact: n . (x(a) - x(b)) >= gap_min, lambda >= 0 pushing a along +n and b
  /// along -n. n: contact normal (normalized here). Returns the group index.
  int AddContact(int a, int b, const Eigen::Vector3d& normal, double gap_min = 0.0);

  /// Coulomb friction contact: the normal row as AddContact, plus two tangent rows measuring the
  /// relative tangential displacement of a with respect to b over the step (targets from the
  /// start-of-step positions), with |lambda_t| <= mu lambda_n. Tangents: an orthonormal basis of
  /// the plane normal to n. Returns the group index.
  int AddFrictionContact(int a, int b, const Eigen::Vector3d& normal, double mu,
                         double gap_min = 0.0);

  /// Axial friction (the needle's): one row axis . (x(a) - x(b)) = axis . offset, the relative
  /// slip along `axis` (nonzero) over the step when offset is the start value, whose force is
  /// bounded by mu |lambda of normal_group| + stiction (N): the group's rows (bilateral, e.g.
  /// the two lateral rows of the same needle point) carry the normal force. Returns the group
  /// index.
  int AddAxialFriction(int a, int b, const Eigen::Vector3d& axis, int normal_group, double mu,
                       double stiction, const Eigen::Vector3d& offset = Eigen::Vector3d::Zero());

  /// Low-level: appends a row with the given terms and target and no group; close the rows with
  /// AddGroup. Returns the row index.
  int AddRow(const std::vector<ConstraintTerm>& terms, double target);
  /// Sets the softness (see ConstraintRow) of rows [first_row, first_row + num_rows); InputError
  /// unless it is finite and >= 0.
  void SetSoftness(int first_row, int num_rows, double softness);
  /// Sets the compliance (m/N, see ConstraintRow) of rows [first_row, first_row + num_rows);
  /// InputError for rows outside the set or a compliance that is negative or not finite.
  void SetCompliance(int first_row, int num_rows, double compliance);
  /// Low-level: makes the last `num_rows` rows (not yet grouped) one group of a law other than
  /// kAxialFriction (AddAxialFriction). Returns its index.
  int AddGroup(ConstraintLaw law, int num_rows, double mu = 0.0);

  /// Value g_i at the given per-body positions (m): positions[b] is 3 x n_b; kinematic points
  /// use p_end.
  double CalcRowValue(int row, const std::vector<const Eigen::Matrix3Xd*>& positions) const;
  /// Position x(p) of a point at per-body positions (m); kinematic points give p_end.
  Eigen::Vector3d CalcPointPosition(int point,
                                    const std::vector<const Eigen::Matrix3Xd*>& positions) const;
  /// Position of a point at the bodies' start-of-step positions (kinematic: p_start).
  Eigen::Vector3d CalcStartPosition(int point) const;
  /// Position of a point at the bodies' free positions (kinematic: p_end).
  Eigen::Vector3d CalcFreePosition(int point) const;

  int num_bodies() const { return static_cast<int>(bodies_.size()); }
  int num_points() const { return static_cast<int>(points_.size()); }
  int num_rows() const { return static_cast<int>(rows_.size()); }
  int num_groups() const { return static_cast<int>(groups_.size()); }
  /// True when every group is bilateral (the solver can then solve directly).
  bool all_bilateral() const;

  ConstraintBody& body(int b) const { return *bodies_[b]; }
  const ConstraintPoint& point(int p) const { return points_[p]; }
  const ConstraintRow& row(int i) const { return rows_[i]; }
  const ConstraintTerm& term(int t) const { return terms_[t]; }
  const ConstraintGroup& group(int g) const { return groups_[g]; }
  const std::vector<ConstraintGroup>& groups() const { return groups_; }
  const std::vector<ConstraintRow>& rows() const { return rows_; }
  const std::vector<int>& point_nodes() const { return point_nodes_; }
  const std::vector<double>& point_weights() const { return point_weights_; }

 private:
  int AddPointImpl(int body, const int* nodes, const double* weights, int count, std::uint64_t key);
  int AddGroupImpl(const ConstraintGroup& group);
  void CheckPoint(int p, const char* what) const;
  // InputError unless [first_row, first_row + num_rows) are rows of the set
  void CheckRows(int first_row, int num_rows) const;

  std::vector<ConstraintBody*> bodies_;
  std::vector<ConstraintPoint> points_;
  std::vector<int> point_nodes_;
  std::vector<double> point_weights_;
  std::vector<ConstraintTerm> terms_;
  std::vector<ConstraintRow> rows_;
  std::vector<ConstraintGroup> groups_;
  int first_ungrouped_row_ = 0;
};

/// Unit vectors t1, t2 with (n, t1, t2) right-handed orthonormal; n must be unit.
void CalcTangentBasis(const Eigen::Vector3d& n, Eigen::Vector3d& t1, Eigen::Vector3d& t2);

}  // namespace nsim
