#include "common/steering/steering_simulation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "common/core/error.h"
#include "common/mesh/point_locator.h"
#include "common/robot/pose_math.h"

namespace nsim {
namespace {

// keys of the marker points in the compliance cache: far above the coupling's keys (from 1)
constexpr std::uint64_t kMarkerKeyBase = std::uint64_t{1} << 62;

SnapshotProbe MakeProbe(const TetMesh& mesh, const TetPoint& point) {
  SnapshotProbe probe;
  for (int k = 0; k < 4; ++k) {
    probe.nodes.push_back(mesh.tets[point.tet][k]);
    probe.weights.push_back(point.bary[k]);
  }
  return probe;
}

// what CatchUp and Step are given: one finite position per marker, a rigid flange pose
void CheckMeasurements(const std::vector<Eigen::Vector3d>& p_WM, size_t num_markers,
                       const Eigen::Isometry3d& X_WF) {
  if (p_WM.size() != num_markers) {
    throw InputError(
        Str("inverse simulation: expected ", num_markers, " markers, got ", p_WM.size()));
  }
  for (const Eigen::Vector3d& p : p_WM) {
    if (!p.allFinite()) throw InputError("inverse simulation: a marker position is not finite");
  }
  if (!IsRigidTransform(X_WF, 1e-6)) {
    throw InputError("inverse simulation: the flange pose must be a finite rigid transform");
  }
}

// rotation whose z axis is `z` (unit); x is the world x axis made orthogonal (y if too close)
Eigen::Matrix3d FrameWithZ(const Eigen::Vector3d& z) {
  Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  if (std::abs(z.dot(x)) > 0.9) x = Eigen::Vector3d::UnitY();
  x = (x - z * z.dot(x)).normalized();
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return R;
}

// the model's anchors: every node inside a box is fixed
FemBoundary MakeModelBoundary(const InverseModelConfig& config, const TetMesh& mesh) {
  FemBoundary boundary;
  std::vector<int> per_box(config.anchors.size(), 0);
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    bool fixed = false;
    for (size_t a = 0; a < config.anchors.size(); ++a)
      if (config.anchors[a].Contains(mesh.X.col(i))) {
        ++per_box[a];
        fixed = true;
      }
    if (fixed) boundary.fixed_nodes.push_back(i);
  }
  for (size_t a = 0; a < config.anchors.size(); ++a) {
    if (per_box[a] == 0)
      throw InputError(Str("inverse.anchors[", a, "] encloses no node of the model liver"));
    for (size_t m = 0; m < config.markers_W.size(); ++m)
      if (config.anchors[a].Contains(config.markers_W[m]))
        throw InputError(Str("inverse.anchors[", a, "] contains marker ", m,
                             ": a fixed marker cannot follow its measurements"));
  }
  return boundary;
}

}  // namespace

std::unique_ptr<FemModel> MakeModelLiver(const InverseModelConfig& config, const TetMesh& mesh) {
  FemConfig fem = config.liver;
  fem.young_modulus = config.liver.young_modulus * config.young_modulus_factor;
  return std::make_unique<FemModel>(mesh, fem, MakeModelBoundary(config, mesh));
}

SteeringSimulation::SteeringSimulation(const InverseModelConfig& config,
                                       const SteeringPathConfig& path, const TetMesh& mesh,
                                       const Eigen::Isometry3d& X_WF)
    : config_(config), mesh_(mesh), needle_((config.Validate(), config.needle)) {
  path.Validate();
  if (!IsRigidTransform(X_WF, 1e-6)) {
    throw InputError("inverse simulation: the initial flange pose must be a finite rigid transform");
  }
  model_ = MakeModelLiver(config, mesh_);
  solver_ = std::make_unique<FemSolver>(*model_);
  state_ = std::make_unique<FemState>(*model_);
  body_ = std::make_unique<FemConstraintBody>(
      *solver_, *state_,
      SelectConstraintCompliance(config.rest_compliance));

  // the needle-liver coupling, with the model's axial friction (0: frictionless)
  NeedleCouplingConfig coupling;
  coupling.tissues = {config.coupling};
  coupling.bevel = config.bevel;
  coupling_ = std::make_unique<NeedleTissueCoupling>(coupling, std::vector<const TetMesh*>{&mesh_});
  snapshot_.set_hold_friction(config_.jacobian_friction_held);
  coupling_state_ = coupling_->MakeState();
  if (config.needle_kind == ModelNeedleKind::kFlexible) {
    beam_model_ = std::make_unique<BeamNeedleModel>(CalcModelBeamConfig(config));
    beam_state_ = std::make_unique<BeamNeedleState>(*beam_model_);
    beam_body_ = std::make_unique<BeamNeedleBody>(*beam_model_, *beam_state_);
  }
  ResetNeedle(X_WF);

  // markers and path targets as material points of the rest mesh
  const TetLocator locator(mesh_);
  for (size_t m = 0; m < config.markers_W.size(); ++m) {
    const std::optional<TetPoint> found = locator.Locate(config.markers_W[m]);
    if (!found) {
      throw InputError(Str("inverse.markers[", m, "] (", config.markers_W[m].transpose(),
                           ") is outside the inverse liver mesh"));
    }
    markers_.push_back(*found);
    marker_positions_.push_back(config.markers_W[m]);
  }
  if (!locator.Locate(path.target_W)) {
    throw InputError("controller.path.target is outside the inverse liver mesh");
  }
  direction_ = (path.target_W - path.entry_W).normalized();
  const Eigen::Vector3d start = path.entry_W - path.approach_distance * direction_;
  start_W_ = start;
  const double travel = (path.target_W - start).norm();
  const int n = std::max(1, static_cast<int>(std::ceil(travel / path.spacing - 1e-9)));
  std::vector<Eigen::Vector3d> points;
  std::vector<std::optional<TetPoint>> located;
  int first_inside = -1;
  for (int k = 1; k <= n; ++k) {
    points.push_back(start + (travel * k / n) * direction_);
    located.push_back(locator.Locate(points.back()));
    if (located.back() && first_inside < 0) first_inside = k - 1;
  }
  int last_reference = first_inside;
  for (int k = 0; k < n; ++k) {
    PathPoint p;
    if (located[k]) {
      p.reference = *located[k];
      path_probe_.push_back(static_cast<int>(probes_.size()));
      probes_.push_back(MakeProbe(mesh_, p.reference));
      last_reference = k;
    } else {
      const int r = k < first_inside ? first_inside : last_reference;
      p.reference = *located[r];
      p.offset = points[k] - points[r];
      path_probe_.push_back(-1 - r);  // resolved below
    }
    path_.push_back(p);
  }
  // outside points share the probe of their reference
  for (int k = 0; k < n; ++k) {
    if (path_probe_[k] < 0) {
      const int r = -1 - path_probe_[k];
      int probe = 0;
      for (int j = 0; j < r; ++j) probe += located[j] ? 1 : 0;
      path_probe_[k] = probe;
    }
  }
  if (beam_body_) {
    // the frozen step's bodies: the liver with the path probes; the beam with its tip node's
    // position (pseudo-node n - 1) and rotation increment (pseudo-node 2n - 1) as probes
    const int nodes = beam_model_->num_nodes();
    SnapshotBody liver_body;
    liver_body.probes = probes_;
    SnapshotBody beam_body;
    beam_body.probes = {SnapshotProbe{{nodes - 1}, {1.0}}, SnapshotProbe{{2 * nodes - 1}, {1.0}}};
    beam_body.rows_turn = true;
    snapshot_bodies_ = {liver_body, beam_body};
  }
}

void SteeringSimulation::ResetNeedle(const Eigen::Isometry3d& X_WF) {
  ResetRigidNeedle(needle_, X_WF, needle_state_);
  if (!beam_body_) return;
  ResetBeamNeedle(*beam_model_, X_WF, *beam_state_);
  beam_state_->external_forces.setZero();
  beam_state_->external_torques.setZero();
  beam_tip_force_.setZero();
  beam_tip_torque_.setZero();
}

Eigen::Vector3d SteeringSimulation::CalcTipPosition() const {
  if (beam_state_) return beam_state_->x.col(beam_state_->num_nodes() - 1);
  return nsim::CalcTipPosition(needle_state_.X_WN_end, needle_.length());
}

Eigen::Matrix3d SteeringSimulation::CalcTipFrame() const {
  if (beam_state_) return beam_state_->R.back();
  return needle_state_.X_WN_end.linear();
}

SteeringSimulation::~SteeringSimulation() = default;

Eigen::Isometry3d SteeringSimulation::CalcStartFlangePose(const NeedleConfig& needle,
                                                         const SteeringPathConfig& path) {
  const Eigen::Vector3d z = (path.target_W - path.entry_W).normalized();
  const Eigen::Vector3d tip = path.entry_W - path.approach_distance * z;
  Eigen::Isometry3d X_WN = Eigen::Isometry3d::Identity();
  X_WN.linear() = FrameWithZ(z);
  X_WN.translation() = tip - needle.length * z;
  return X_WN * CalcToolOffset(needle).inverse();
}

void CatchUpConfig::Validate() const {
  if (!(advance_per_step > 0) || !std::isfinite(advance_per_step))
    throw InputError(Str("catch_up.advance_per_step must be > 0 (m), got ", advance_per_step));
  if (register_steps < 1)
    throw InputError(Str("catch_up.register_steps must be >= 1, got ", register_steps));
  if (settle_steps < 0)
    throw InputError(Str("catch_up.settle_steps must be >= 0, got ", settle_steps));
  if (!(rotation_per_step > 0) || !std::isfinite(rotation_per_step))
    throw InputError(Str("catch_up.rotation_per_step must be > 0 (rad), got ", rotation_per_step));
  if (!(min_depth >= 0) || !std::isfinite(min_depth))
    throw InputError(Str("catch_up.min_depth must be >= 0 (m), got ", min_depth));
}

CatchUpReport SteeringSimulation::CatchUp(const std::vector<Eigen::Vector3d>& p_WM,
                                          const Eigen::Isometry3d& X_WF,
                                          const CatchUpConfig& config, double bevel_angle) {
  const auto t0 = std::chrono::steady_clock::now();
  config.Validate();
  if (steps_ > 0) throw std::logic_error("SteeringSimulation::CatchUp after a Step");
  CheckMeasurements(p_WM, markers_.size(), X_WF);
  CatchUpReport report;
  const double length = needle_.length();
  const Eigen::Isometry3d X_WN = needle_.CalcNeedlePose(X_WF);
  const Eigen::Vector3d tip = nsim::CalcTipPosition(X_WN, length);
  if (!((tip - start_W_).dot(X_WN.linear().col(2)) > config.min_depth)) {
    ResetNeedle(X_WF);  // outside: the model starts as it is
    return report;
  }
  const Eigen::Isometry3d X_NF = needle_.get_tool_offset().inverse();
  // the flange pose of a needle whose tip is at p with orientation R
  auto flange = [&](const Eigen::Vector3d& p, const Eigen::Matrix3d& R) {
    Eigen::Isometry3d N = Eigen::Isometry3d::Identity();
    N.linear() = R;
    N.translation() = p - R.col(2) * length;
    return N * X_NF;
  };
  auto step = [&](const std::vector<Eigen::Vector3d>& markers, const Eigen::Isometry3d& X) {
    Step(markers, X, bevel_angle);
    ++report.steps;
  };

  // 1. the markers to their measured positions, the needle parked a needle length before the
  //    path's start (no coupling: it may be moved freely afterwards)
  ResetNeedle(flange(start_W_ - length * direction_, FrameWithZ(direction_)));
  std::vector<Eigen::Vector3d> markers(markers_.size());
  for (int i = 1; i <= config.register_steps; ++i) {
    const double s = static_cast<double>(i) / config.register_steps;
    for (size_t m = 0; m < markers_.size(); ++m)
      markers[m] = config_.markers_W[m] + s * (p_WM[m] - config_.markers_W[m]);
    step(markers, needle_state_.X_WN_end * X_NF);
  }

  // 2. the path as the registered liver carries it: its start and direction
  const std::vector<Eigen::Vector3d> path = CalcPathPositions();
  const double spacing_0 = (path_.size() > 1 ? (path[1] - path[0]).norm() : 0.0);
  const Eigen::Vector3d d =
      path.size() > 1 ? Eigen::Vector3d((path.back() - path.front()).normalized()) : direction_;
  Eigen::Vector3d start = path.front() - spacing_0 * d;
  const TetLocator deformed(mesh_, state_->x);
  for (int i = 0; i < 10 && deformed.Locate(start); ++i)
    start -= config_.coupling.point_spacing * d;
  const double depth = (tip - start).dot(d);
  // the needle's orientation along the path: its measured one turned from its axis onto d
  const Eigen::Matrix3d R_path =
      Eigen::Quaterniond::FromTwoVectors(X_WN.linear().col(2), d).toRotationMatrix() *
      X_WN.linear();

  // 3. driven in along the path to the measured tip's depth: the coupling punctures and seeds
  //    its points at the path's material points, as for an insertion that followed the plan
  ResetNeedle(flange(start, R_path));
  const int n = std::max(0, static_cast<int>(std::ceil(depth / config.advance_per_step - 1e-9)));
  for (int i = 1; i <= n; ++i) step(p_WM, flange(start + (depth * i / n) * d, R_path));
  const Eigen::Vector3d tip_path = start + std::max(0.0, depth) * d;

  // 4. from the path to the measured pose (the tip on a line, the orientation by slerp), the
  //    tissue on the needle following it; then held
  const Eigen::Quaterniond q0(R_path), q1(X_WN.linear());
  const double angle = q0.angularDistance(q1);
  const int m = std::max(
      1, static_cast<int>(std::ceil(std::max((tip - tip_path).norm() / config.advance_per_step,
                                             angle / config.rotation_per_step) -
                                    1e-9)));
  for (int i = 1; i <= m; ++i) {
    const double s = static_cast<double>(i) / m;
    step(p_WM, i == m
                   ? X_WF
                   : flange(tip_path + s * (tip - tip_path), q0.slerp(s, q1).toRotationMatrix()));
  }
  for (int i = 0; i < config.settle_steps; ++i) step(p_WM, X_WF);

  report.done = true;
  report.depth = depth;
  report.aligned = (tip - tip_path).norm();
  report.aligned_angle = angle;
  report.liver_phase = coupling_state_.tissues[0].phase;
  report.liver_points = static_cast<int>(coupling_state_.tissues[0].points.size());
  report.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

SteeringStepReport SteeringSimulation::Step(const std::vector<Eigen::Vector3d>& p_WM,
                                            const Eigen::Isometry3d& X_WF, double bevel_angle) {
  CheckMeasurements(p_WM, markers_.size(), X_WF);
  if (!std::isfinite(bevel_angle)) throw InputError("inverse simulation: bevel angle not finite");
  SteeringStepReport report;
  ApplyBevelLoad(bevel_angle);
  report.bevel_active = !bevel_loads_.empty() || beam_tip_torque_.any() || beam_tip_force_.any();
  SetRigidNeedleTarget(needle_, X_WF, needle_state_);
  if (beam_body_) SetBeamNeedleTarget(*beam_model_, X_WF, *beam_state_);
  report.fem = body_->BeginStep();
  if (beam_body_) beam_body_->BeginStep();

  // registration: each marker material point reaches its measured position (3 bilateral rows)
  set_.Clear();
  const int b = set_.AddBody(*body_);
  for (size_t m = 0; m < markers_.size(); ++m) {
    const int pt = set_.AddBodyPoint(b, mesh_.tets[markers_[m].tet], markers_[m].bary,
                                     kMarkerKeyBase + m);
    const int kp = set_.AddKinematicPoint(marker_positions_[m], p_WM[m]);
    set_.AddBilateral(pt, kp, Eigen::Matrix3d::Identity());
  }
  const int nb = beam_body_ ? set_.AddBody(*beam_body_) : -1;
  const int first_needle_point = set_.num_points();
  const NeedleView view = beam_body_ ? MakeNeedleView(*beam_body_, nb)
                                     : MakeNeedleView(needle_, needle_state_);
  coupling_->AddConstraints(view, {b}, set_, coupling_state_);

  constraint_solver_.Assemble(set_);
  report.solve = constraint_solver_.SolveMultipliers(set_);
  std::vector<char> moves(set_.num_points(), 0);
  for (int p = first_needle_point; p < set_.num_points(); ++p) moves[p] = set_.point(p).body < 0;
  if (beam_body_) {
    // both bodies; the beam's free motion follows its base pose (the needle frame N)
    snapshot_bodies_[0].body = b;
    snapshot_bodies_[1].body = nb;
    beam_body_->CalcFreeMotionSensitivity(snapshot_bodies_[1].free_sensitivity);
    snapshot_.Capture(set_, constraint_solver_, snapshot_bodies_, moves, needle_state_.X_WN_end);
    snapshot_R_WTip_start_ = beam_state_->R.back();
  } else {
    snapshot_.Capture(set_, constraint_solver_, b, moves, needle_state_.X_WN_end, probes_);
  }
  has_snapshot_ = true;
  constraint_solver_.ApplyCorrections(set_);
  body_->EndStep();
  if (beam_body_) beam_body_->EndStep();

  // the coupling sees the needle at the step end: the committed beam, or the rigid end pose
  coupling_->Update(beam_body_ ? MakeNeedleView(*beam_body_, nb) : view, {&state_->x},
                    constraint_solver_.lambda(), state_->time, coupling_state_);
  AdvanceRigidNeedle(needle_state_);
  marker_positions_ = p_WM;
  ++steps_;
  report.time = state_->time;
  report.num_rows = set_.num_rows();
  report.liver_phase = coupling_state_.tissues[0].phase;
  return report;
}

void SteeringSimulation::ApplyBevelLoad(double bevel_angle) {
  // the last step's load off, this step's from the state at the step start (the coupling after
  // the last Update, the needle at its end pose), as PatientScene::Step does for its rigid needle
  for (const auto& [node, f] : bevel_loads_) state_->external_forces.col(node) -= f;
  bevel_loads_.clear();
  needle_state_.bevel_angle = bevel_angle;
  if (beam_body_) {
    // the beam takes the tip load itself (the patient's flexible path): Misra's torque M x_B
    // (or force Q y_B) on the tip node, the tissue receiving it through the coupling's rows
    BeamNeedleState& ns = *beam_state_;
    const int tip = ns.num_nodes() - 1;
    ns.external_forces.col(tip) -= beam_tip_force_;
    ns.external_torques.col(tip) -= beam_tip_torque_;
    ns.bevel_angle = bevel_angle;
    const BevelTipLoad load =
        coupling_->CalcBevelTipLoad(MakeNeedleView(*beam_body_, -1), coupling_state_);
    beam_tip_force_ = load.force_on_needle;
    beam_tip_torque_ = load.torque_on_needle;
    ns.external_forces.col(tip) += beam_tip_force_;
    ns.external_torques.col(tip) += beam_tip_torque_;
    return;
  }
  const BevelTipLoad load =
      coupling_->CalcBevelTipLoad(MakeNeedleView(needle_, needle_state_), coupling_state_);
  if (!load.active || load.tip_point.tet < 0) return;
  // a rigid needle cannot take the tip torque: the tissue at the tip takes -Q y_B, spread over
  // the nodes of its tet by the tip's barycentric weights
  for (int k = 0; k < 4; ++k) {
    const int node = mesh_.tets[load.tip_point.tet][k];
    const Eigen::Vector3d f = -load.tip_point.bary[k] * load.force_for_rigid;
    state_->external_forces.col(node) += f;
    bevel_loads_.push_back({node, f});
  }
}

SteeringEvaluation SteeringSimulation::EvaluateAt(const Eigen::Isometry3d& X_WF,
                                                  SnapshotWorkspace& workspace) const {
  SteeringEvaluation out;
  out.X_WN = needle_.CalcNeedlePose(X_WF);
  out.p_WTip = nsim::CalcTipPosition(out.X_WN, needle_.length());
  out.R_WTip = out.X_WN.linear();
  std::vector<Eigen::Vector3d> probes;
  if (has_snapshot_) {
    out.solve = snapshot_.Solve(out.X_WN, workspace, &probes);
    if (!beam_body_) out.needle_force = workspace.needle_force;
    if (beam_body_) {
      // the bent needle's corrected tip node: position, and orientation exp(phi) R_start
      const size_t q = probes_.size();
      out.p_WTip = probes[q];
      out.R_WTip = ExpSO3(probes[q + 1]) * snapshot_R_WTip_start_;
    }
  } else {
    for (const SnapshotProbe& probe : probes_) {
      Eigen::Vector3d p = Eigen::Vector3d::Zero();
      for (size_t k = 0; k < probe.nodes.size(); ++k) p += probe.weights[k] * state_->x.col(probe.nodes[k]);
      probes.push_back(p);
    }
  }
  out.p_WPath.resize(path_.size());
  for (size_t i = 0; i < path_.size(); ++i) out.p_WPath[i] = probes[path_probe_[i]] + path_[i].offset;
  return out;
}

Eigen::Matrix3d SteeringSimulation::CalcNeedleTranslationStiffness(
    SnapshotWorkspace& workspace) const {
  if (!has_snapshot_ || beam_body_) return Eigen::Matrix3d::Zero();
  return snapshot_.CalcNeedleTranslationStiffness(workspace);
}

std::vector<Eigen::Vector3d> SteeringSimulation::CalcPathPositions() const {
  std::vector<Eigen::Vector3d> out;
  for (const PathPoint& p : path_) out.push_back(EvalTetPoint(mesh_, state_->x, p.reference) + p.offset);
  return out;
}

bool SteeringSimulation::liver_punctured() const {
  const TissuePhase phase = coupling_state_.tissues[0].phase;
  return phase == TissuePhase::kInside || phase == TissuePhase::kExited;
}

bool SteeringSimulation::CalcLiverEntryPoint(Eigen::Vector3d* p_W) const {
  const TissueCouplingState& ts = coupling_state_.tissues[0];
  if (!liver_punctured() || ts.points.empty()) return false;
  *p_W = EvalTetPoint(mesh_, state_->x, ts.points.front().point);
  return true;
}

}  // namespace nsim
