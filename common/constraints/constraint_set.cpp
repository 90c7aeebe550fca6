#include "common/constraints/constraint_set.h"

#include <cmath>

#include "common/core/error.h"

namespace nsim {

namespace {

bool IsFinite(const Eigen::Vector3d& v) { return v.allFinite(); }

}  // namespace

void CalcTangentBasis(const Eigen::Vector3d& n, Eigen::Vector3d& t1, Eigen::Vector3d& t2) {
  // pick the world axis least aligned with n, then Gram-Schmidt
  Eigen::Index axis = 0;
  n.cwiseAbs().minCoeff(&axis);
  Eigen::Vector3d e = Eigen::Vector3d::Unit(axis);
  t1 = (e - n.dot(e) * n).normalized();
  t2 = n.cross(t1);
}

void ConstraintSet::Clear() {
  bodies_.clear();
  points_.clear();
  point_nodes_.clear();
  point_weights_.clear();
  terms_.clear();
  rows_.clear();
  groups_.clear();
  first_ungrouped_row_ = 0;
}

int ConstraintSet::AddBody(ConstraintBody& body) {
  for (const ConstraintBody* b : bodies_) {
    if (b == &body) throw InputError("constraints: body added twice to the same ConstraintSet");
  }
  bodies_.push_back(&body);
  return num_bodies() - 1;
}

int ConstraintSet::AddPointImpl(int body, const int* nodes, const double* weights, int count,
                                std::uint64_t key) {
  if (body < 0 || body >= num_bodies())
    throw InputError(Str("constraints: body index must be in [0, ", num_bodies(), "), got ", body));
  if (count < 1) throw InputError("constraints: a body point needs at least one node, got 0");
  const int n = bodies_[body]->num_nodes();
  for (int k = 0; k < count; ++k) {
    if (nodes[k] < 0 || nodes[k] >= n)
      throw InputError(
          Str("constraints: point node index must be in [0, ", n, "), got ", nodes[k]));
    if (!std::isfinite(weights[k]))
      throw InputError(Str("constraints: point weight must be finite, got ", weights[k]));
  }
  ConstraintPoint p;
  p.body = body;
  p.first_node = static_cast<int>(point_nodes_.size());
  p.num_nodes = count;
  p.key = key;
  point_nodes_.insert(point_nodes_.end(), nodes, nodes + count);
  point_weights_.insert(point_weights_.end(), weights, weights + count);
  points_.push_back(p);
  return num_points() - 1;
}

int ConstraintSet::AddBodyPoint(int body, const std::vector<int>& nodes,
                                const std::vector<double>& weights, std::uint64_t key) {
  if (nodes.size() != weights.size())
    throw InputError(Str("constraints: expected as many weights as nodes (", nodes.size(),
                         "), got ", weights.size()));
  return AddPointImpl(body, nodes.data(), weights.data(), static_cast<int>(nodes.size()), key);
}

int ConstraintSet::AddBodyPoint(int body, const Eigen::Vector4i& tet, const Eigen::Vector4d& bary,
                                std::uint64_t key) {
  return AddPointImpl(body, tet.data(), bary.data(), 4, key);
}

int ConstraintSet::AddNodePoint(int body, int node, std::uint64_t key) {
  const double one = 1.0;
  return AddPointImpl(body, &node, &one, 1, key);
}

int ConstraintSet::AddKinematicPoint(const Eigen::Vector3d& p_start, const Eigen::Vector3d& p_end) {
  if (!IsFinite(p_start) || !IsFinite(p_end))
    throw InputError("constraints: kinematic point positions must be finite, got a NaN or inf");
  ConstraintPoint p;
  p.body = -1;
  p.first_node = static_cast<int>(point_nodes_.size());
  p.p_start = p_start;
  p.p_end = p_end;
  points_.push_back(p);
  return num_points() - 1;
}

void ConstraintSet::CheckPoint(int p, const char* what) const {
  if (p < 0 || p >= num_points())
    throw InputError(
        Str("constraints: ", what, " point index must be in [0, ", num_points(), "), got ", p));
}

void ConstraintSet::CheckRows(int first_row, int num_rows) const {
  if (!(first_row >= 0 && num_rows >= 0 && first_row + num_rows <= this->num_rows()))
    throw InputError(Str("constraints: rows [", first_row, ", ", first_row + num_rows,
                         ") are not rows of the set (", this->num_rows(), " rows)"));
}

void ConstraintSet::SetSoftness(int first_row, int num_rows, double softness) {
  CheckRows(first_row, num_rows);
  if (!(softness >= 0.0 && std::isfinite(softness)))
    throw InputError(Str("constraints: row softness must be finite and >= 0, got ", softness));
  for (int i = first_row; i < first_row + num_rows; ++i) rows_[i].softness = softness;
}

void ConstraintSet::SetCompliance(int first_row, int num_rows, double compliance) {
  CheckRows(first_row, num_rows);
  if (!(compliance >= 0.0 && std::isfinite(compliance)))
    throw InputError(Str("constraints: row compliance must be finite and >= 0 m/N, got ", compliance));
  for (int i = first_row; i < first_row + num_rows; ++i) rows_[i].compliance = compliance;
}

int ConstraintSet::AddRow(const std::vector<ConstraintTerm>& terms, double target) {
  if (terms.empty()) throw InputError("constraints: a row needs at least one term, got 0");
  if (!std::isfinite(target))
    throw InputError(Str("constraints: row target must be finite, got ", target));
  for (const ConstraintTerm& t : terms) {
    CheckPoint(t.point, "row term");
    if (!IsFinite(t.direction) || t.direction.squaredNorm() == 0.0)
      throw InputError("constraints: row direction must be finite and nonzero");
  }
  ConstraintRow row;
  row.first_term = static_cast<int>(terms_.size());
  row.num_terms = static_cast<int>(terms.size());
  row.target = target;
  terms_.insert(terms_.end(), terms.begin(), terms.end());
  rows_.push_back(row);
  return num_rows() - 1;
}

int ConstraintSet::AddGroup(ConstraintLaw law, int num_rows, double mu) {
  if (law == ConstraintLaw::kAxialFriction)
    throw InputError("constraints: axial friction groups are made by AddAxialFriction");
  ConstraintGroup g;
  g.law = law;
  g.num_rows = num_rows;
  g.mu = mu;
  return AddGroupImpl(g);
}

int ConstraintSet::AddGroupImpl(const ConstraintGroup& group) {
  const int ungrouped = this->num_rows() - first_ungrouped_row_;
  if (group.num_rows != ungrouped)
    throw InputError(Str("constraints: a group must take all ", ungrouped, " ungrouped rows, got ",
                         group.num_rows));
  const int expected_min = group.law == ConstraintLaw::kFriction ? 3 : 1;
  const int expected_max = group.law == ConstraintLaw::kBilateral ? 3 : expected_min;
  if (group.num_rows < expected_min || group.num_rows > expected_max)
    throw InputError(Str("constraints: this law expects ", expected_min, "-", expected_max,
                         " rows, got ", group.num_rows));
  if (!(group.mu >= 0.0) || !std::isfinite(group.mu))
    throw InputError(Str("constraints: friction coefficient mu must be >= 0, got ", group.mu));
  ConstraintGroup g = group;
  g.first_row = first_ungrouped_row_;
  groups_.push_back(g);
  first_ungrouped_row_ = this->num_rows();
  return num_groups() - 1;
}

int ConstraintSet::AddBilateral(int a, int b, const Eigen::Matrix3Xd& directions,
                                const Eigen::Vector3d& offset) {
  CheckPoint(a, "first");
  CheckPoint(b, "second");
  if (directions.cols() < 1 || directions.cols() > 3)
    throw InputError(
        Str("constraints: a bilateral group takes 1-3 directions, got ", directions.cols()));
  if (!IsFinite(offset)) throw InputError("constraints: bilateral offset must be finite");
  for (Eigen::Index k = 0; k < directions.cols(); ++k) {
    const Eigen::Vector3d d = directions.col(k);
    AddRow({{a, d}, {b, -d}}, d.dot(offset));
  }
  return AddGroup(ConstraintLaw::kBilateral, static_cast<int>(directions.cols()));
}

int ConstraintSet::AddContact(int a, int b, const Eigen::Vector3d& normal, double gap_min) {
  CheckPoint(a, "first");
  CheckPoint(b, "second");
  if (!IsFinite(normal) || normal.norm() == 0.0)
    throw InputError("constraints: contact normal must be finite and nonzero");
  const Eigen::Vector3d n = normal.normalized();
  AddRow({{a, n}, {b, -n}}, gap_min);
  return AddGroup(ConstraintLaw::kUnilateral, 1);
}

int ConstraintSet::AddFrictionContact(int a, int b, const Eigen::Vector3d& normal, double mu,
                                      double gap_min) {
  CheckPoint(a, "first");
  CheckPoint(b, "second");
  if (!IsFinite(normal) || normal.norm() == 0.0)
    throw InputError("constraints: contact normal must be finite and nonzero");
  if (!(mu >= 0.0) || !std::isfinite(mu))
    throw InputError(Str("constraints: friction coefficient mu must be >= 0, got ", mu));
  const Eigen::Vector3d n = normal.normalized();
  Eigen::Vector3d t1, t2;
  CalcTangentBasis(n, t1, t2);
  // tangent rows measure the slip over the step: target = value at the start of the step
  const Eigen::Vector3d rel_start = CalcStartPosition(a) - CalcStartPosition(b);
  AddRow({{a, n}, {b, -n}}, gap_min);
  AddRow({{a, t1}, {b, -t1}}, t1.dot(rel_start));
  AddRow({{a, t2}, {b, -t2}}, t2.dot(rel_start));
  return AddGroup(ConstraintLaw::kFriction, 3, mu);
}

int ConstraintSet::AddAxialFriction(int a, int b, const Eigen::Vector3d& axis, int normal_group,
                                    double mu, double stiction, const Eigen::Vector3d& offset) {
  CheckPoint(a, "first");
  CheckPoint(b, "second");
  if (!IsFinite(axis) || axis.squaredNorm() == 0.0)
    throw InputError("constraints: axial friction axis must be finite and nonzero");
  if (!IsFinite(offset)) throw InputError("constraints: axial friction offset must be finite");
  if (normal_group < 0 || normal_group >= num_groups() ||
      groups_[normal_group].law != ConstraintLaw::kBilateral)
    throw InputError(
        Str("constraints: the normal force of axial friction must be a bilateral "
            "group, got group ",
            normal_group));
  if (!(mu >= 0.0) || !std::isfinite(mu))
    throw InputError(Str("constraints: friction coefficient mu must be >= 0, got ", mu));
  if (!(stiction >= 0.0) || !std::isfinite(stiction))
    throw InputError(Str("constraints: axial friction stiction must be >= 0 (N), got ", stiction));
  AddRow({{a, axis}, {b, -axis}}, axis.dot(offset));
  ConstraintGroup g;
  g.law = ConstraintLaw::kAxialFriction;
  g.num_rows = 1;
  g.mu = mu;
  g.stiction = stiction;
  g.normal_group = normal_group;
  return AddGroupImpl(g);
}

Eigen::Vector3d ConstraintSet::CalcPointPosition(
    int point, const std::vector<const Eigen::Matrix3Xd*>& positions) const {
  const ConstraintPoint& p = points_[point];
  if (p.body < 0) return p.p_end;
  const Eigen::Matrix3Xd& x = *positions[p.body];
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int k = 0; k < p.num_nodes; ++k)
    sum += point_weights_[p.first_node + k] * x.col(point_nodes_[p.first_node + k]);
  return sum;
}

Eigen::Vector3d ConstraintSet::CalcStartPosition(int point) const {
  const ConstraintPoint& p = points_[point];
  if (p.body < 0) return p.p_start;
  const Eigen::Matrix3Xd& x = bodies_[p.body]->start_positions();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int k = 0; k < p.num_nodes; ++k)
    sum += point_weights_[p.first_node + k] * x.col(point_nodes_[p.first_node + k]);
  return sum;
}

Eigen::Vector3d ConstraintSet::CalcFreePosition(int point) const {
  const ConstraintPoint& p = points_[point];
  if (p.body < 0) return p.p_end;
  const Eigen::Matrix3Xd& x = bodies_[p.body]->free_positions();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int k = 0; k < p.num_nodes; ++k)
    sum += point_weights_[p.first_node + k] * x.col(point_nodes_[p.first_node + k]);
  return sum;
}

double ConstraintSet::CalcRowValue(int row,
                                   const std::vector<const Eigen::Matrix3Xd*>& positions) const {
  const ConstraintRow& r = rows_[row];
  double g = -r.target;
  for (int t = r.first_term; t < r.first_term + r.num_terms; ++t)
    g += terms_[t].direction.dot(CalcPointPosition(terms_[t].point, positions));
  return g;
}

bool ConstraintSet::all_bilateral() const {
  for (const ConstraintGroup& g : groups_) {
    if (g.law != ConstraintLaw::kBilateral) return false;
  }
  return true;
}

}  // namespace nsim
