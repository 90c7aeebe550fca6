#include "common/scene/patient_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/core/error.h"
#include "common/mesh/mesh_adjacency.h"
#include "common/mesh/point_locator.h"
#include "common/mesh/surface_locator.h"

namespace nsim {
namespace {

FemConfig WithSceneStep(FemConfig fem, const PatientSceneConfig& config) {
  fem.time_step = config.time_step;
  fem.gravity = config.gravity;
  return fem;
}

TetMesh PlaceMesh(const TetMesh& mesh_S, const Eigen::Isometry3d& X_WS) {
  TetMesh mesh_W = mesh_S;
  for (int i = 0; i < mesh_W.num_nodes(); ++i) mesh_W.X.col(i) = X_WS * mesh_S.X.col(i);
  return mesh_W;
}

std::vector<int> SurfaceNodes(const TetMesh& mesh) {
  std::vector<int> nodes;
  for (const Eigen::Vector3i& tri : mesh.surface)
    for (int k = 0; k < 3; ++k) nodes.push_back(tri[k]);
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  return nodes;
}

FemBoundary MakeLiverBoundary(const PatientSceneConfig& config, const TetMesh& liver) {
  FemBoundary boundary;
  for (int i = 0; i < liver.num_nodes(); ++i) {
    const Eigen::Vector3d p = liver.X.col(i);
    if (config.diaphragm.Contains(p)) {
      boundary.prescribed_nodes.push_back(i);
      continue;
    }
    for (const OrientedBox& anchor : config.anchors)
      if (anchor.Contains(p)) {
        boundary.fixed_nodes.push_back(i);
        break;
      }
  }
  if (boundary.prescribed_nodes.empty())
    throw InputError("patient.diaphragm encloses no liver node: breathing would not act");
  for (size_t a = 0; a < config.anchors.size(); ++a) {
    bool any = false;
    for (int i = 0; i < liver.num_nodes() && !any; ++i)
      any =
          config.anchors[a].Contains(liver.X.col(i)) && !config.diaphragm.Contains(liver.X.col(i));
    if (!any) throw InputError(Str("patient.anchors[", a, "] encloses no free liver node"));
  }
  return boundary;
}

FemBoundary MakeSkinBoundary(const PatientSceneConfig& config, const TetMesh& skin_W) {
  FemBoundary boundary;
  for (int i = 0; i < skin_W.num_nodes(); ++i)
    for (const OrientedBox& rib : config.ribs)
      if (CalcBoxProximity(rib, skin_W.X.col(i)).signed_distance <= config.skin.attach_distance) {
        boundary.fixed_nodes.push_back(i);
        break;
      }
  if (boundary.fixed_nodes.empty())
    throw InputError(Str("patient.skin: no skin node lies within attach_distance = ",
                         config.skin.attach_distance, " m of a rib: the skin would float"));
  return boundary;
}

TetPoint LocateInLiver(const TetLocator& locator, const Eigen::Vector3d& p,
                       const std::string& key) {
  const std::optional<TetPoint> found = locator.Locate(p);
  if (!found) throw InputError(Str(key, " = [", p.transpose(), "] m is outside the liver mesh"));
  return *found;
}

// keys of the rib-contact node points (the needle coupling numbers its points from 1 upwards)
constexpr std::uint64_t kRibContactKey = std::uint64_t{1} << 62;

}  // namespace

PatientSceneModel::PatientSceneModel(const PatientSceneConfig& config, const TetMesh& liver_mesh,
                                     const TetMesh& skin_mesh_in_skin_frame)
    : config_(config), breathing_([&] {
        config.Validate();
        return config.breathing;
      }()) {
  // liver: diaphragm nodes prescribed, anchor nodes fixed; ribs must not overlap it at rest
  for (size_t r = 0; r < config_.ribs.size(); ++r) {
    int inside = 0;
    for (int i = 0; i < liver_mesh.num_nodes(); ++i)
      inside += config_.ribs[r].Contains(liver_mesh.X.col(i)) ? 1 : 0;
    if (inside > 0)
      throw InputError(Str("patient.ribs[", r, "] overlaps the liver at rest (", inside,
                           " liver nodes inside the box)"));
  }
  liver_ = std::make_unique<FemModel>(liver_mesh, WithSceneStep(config_.liver, config_),
                                      MakeLiverBoundary(config_, liver_mesh));
  const TetMesh skin_W = PlaceMesh(skin_mesh_in_skin_frame, config_.skin.X_WS);
  skin_ = std::make_unique<FemModel>(skin_W, WithSceneStep(config_.skin.fem, config_),
                                     MakeSkinBoundary(config_, skin_W));

  surface_nodes_ = SurfaceNodes(liver_mesh);
  for (int node : surface_nodes_)
    if (liver_->get_free_index(node) >= 0) contact_nodes_.push_back(node);

  const TetLocator locator(liver_mesh);
  for (size_t m = 0; m < config_.markers_W.size(); ++m)
    markers_.push_back(
        LocateInLiver(locator, config_.markers_W[m], Str("patient.markers[", m, "]")));
  target_ = LocateInLiver(locator, config_.target_W, "patient.target");

  coupling_ = std::make_unique<NeedleTissueCoupling>(
      config_.needle.coupling,
      std::vector<const TetMesh*>{&skin_->get_mesh(), &liver_->get_mesh()});
  rigid_needle_ = std::make_unique<RigidNeedleModel>(config_.needle.geometry());
  if (config_.needle.kind == NeedleKind::kFlexible) {
    BeamNeedleConfig beam = config_.needle.flexible;
    beam.time_step = config_.time_step;
    beam_needle_ = std::make_unique<BeamNeedleModel>(beam);
  }
}

PatientSceneState::PatientSceneState(const PatientSceneModel& model, const Eigen::Isometry3d& X_WF)
    : liver(model.liver()), skin(model.skin()), coupling(model.coupling().MakeState()) {
  ResetRigidNeedle(model.rigid_needle(), X_WF, rigid_needle);
  if (model.beam_needle() != nullptr) {
    beam_needle.emplace(*model.beam_needle());
    ResetBeamNeedle(*model.beam_needle(), X_WF, *beam_needle);
  }
}

PatientScene::PatientScene(const PatientSceneConfig& config, const TetMesh& liver_mesh,
                           const TetMesh& skin_mesh_in_skin_frame, const Eigen::Isometry3d& X_WF)
    : model_(
          std::make_unique<const PatientSceneModel>(config, liver_mesh, skin_mesh_in_skin_frame)),
      state_(*model_, X_WF) {
  if (!X_WF.matrix().allFinite()) throw InputError("initial flange pose must be finite");
  liver_solver_ = std::make_unique<FemSolver>(model_->liver());
  skin_solver_ = std::make_unique<FemSolver>(model_->skin());
  // the liver's compliance: the rest factor (constant, its cached columns survive every
  // refresh) or the last factor (exact at the last factorization, columns recomputed when it
  // changes)
  liver_body_ = std::make_unique<FemConstraintBody>(
      *liver_solver_, state_.liver,
      SelectConstraintCompliance(config.liver_rest_compliance));
  skin_body_ = std::make_unique<FemConstraintBody>(*skin_solver_, state_.skin);
  if (state_.beam_needle)
    needle_body_ = std::make_unique<BeamNeedleBody>(*model_->beam_needle(), *state_.beam_needle);
  // the columns the first steps need (the rib contacts at rest) before the first, timed step,
  // all of them
  PrefetchUpTo(std::numeric_limits<int>::max());
}

PatientScene::~PatientScene() = default;

int PatientScene::Prefetch() { return PrefetchUpTo(kMaxPrefetchNodes); }

int PatientScene::PrefetchUpTo(int max_new_nodes) {
  const PatientSceneConfig& config = model_->config();
  if (!config.liver_rest_compliance) return 0;
  std::vector<int> nodes;
  if (config.prefetch_ahead > 0.0) {
    const NeedleView view = needle_body_ ? MakeNeedleView(*needle_body_, -1)
                                         : MakeNeedleView(model_->rigid_needle(), state_.rigid_needle);
    nodes = model_->coupling().CalcNodesAhead(kLiverTissue, view, state_.liver.x, state_.coupling,
                                              config.prefetch_ahead);
  }
  if (config.prefetch_rib_margin > 0.0)
    for (int node : model_->contact_nodes())
      for (const OrientedBox& rib : config.ribs)
        if (CalcBoxProximity(rib, state_.liver.x.col(node)).signed_distance <
            config.prefetch_rib_margin) {
          nodes.push_back(node);
          break;
        }
  return nodes.empty() ? 0 : solver_.compliance().Prefetch(*liver_body_, nodes, max_new_nodes);
}

int PatientScene::AddRibContacts(ConstraintSet& set, int liver_body) {
  const double margin = model_->config().rib_contact_margin;
  int rows = 0;
  rib_rows_.clear();
  for (int node : model_->contact_nodes()) {
    const Eigen::Vector3d x_start = state_.liver.x.col(node);
    const Eigen::Vector3d x_free = state_.liver.x_free.col(node);
    for (const OrientedBox& rib : model_->config().ribs) {
      const BoxProximity at_start = CalcBoxProximity(rib, x_start);
      const BoxProximity at_free = CalcBoxProximity(rib, x_free);
      if (!(std::min(at_start.signed_distance, at_free.signed_distance) < margin)) continue;
      // a supporting plane of the box: through the closest point to the (outside) start
      // position, normal towards it; its outer side is outside the box
      const BoxProximity& plane = at_start.signed_distance > 0 ? at_start : at_free;
      const int box_point = set.AddKinematicPoint(plane.p_W, plane.p_W);
      // keyed: with the rest compliance its columns are reused across steps
      const int node_point = set.AddNodePoint(liver_body, node, kRibContactKey | node);
      set.AddContact(node_point, box_point, plane.normal_W, 0.0);
      rib_rows_.push_back(set.num_rows() - 1);
      ++rows;
    }
  }
  return rows;
}

SceneStepReport PatientScene::Step(const Eigen::Isometry3d& X_WF_end, double bevel_angle) {
  if (!X_WF_end.matrix().allFinite() || !std::isfinite(bevel_angle))
    throw InputError("scene step: the flange pose and bevel angle must be finite");
  const PatientSceneModel& model = *model_;
  const double t_end = time() + model.config().time_step;
  const BreathingModel& breathing = model.breathing();
  if (t_end > breathing.t_end())
    throw InputError(Str("the run outlasts the breathing table: t = ", t_end,
                         " s > breathing.horizon = ", breathing.t_end(), " s"));
  SceneStepReport report;
  // on one CPU, the liver's background refresh waits for the end of this step
  // (patient.liver.refactor_hold_steps, common/fem/worker_gate.h)
  const FemSolver::RefreshHold hold = liver_body_->solver().HoldRefresh();
  report.refresh_held = hold.holds();

  // diaphragm: the enclosed liver nodes reach X + d(t + h) at the step end
  const Eigen::Vector3d d = breathing.CalcDisplacement(t_end);
  const std::vector<int>& prescribed = model.liver().get_prescribed_nodes();
  const Eigen::Matrix3Xd& X = model.liver().get_rest_positions();
  for (size_t k = 0; k < prescribed.size(); ++k)
    state_.liver.prescribed_positions.col(k) = X.col(prescribed[k]) + d;

  // bevel load of this step, from the state at the step start (as NeedleInsertionStepper)
  std::vector<FemState*> tissues = {&state_.skin, &state_.liver};
  for (const auto& [where, f] : tissue_loads_)
    tissues[where.first]->external_forces.col(where.second) -= f;
  tissue_loads_.clear();
  const NeedleTissueCoupling& coupling = model.coupling();
  if (needle_body_) {
    BeamNeedleState& ns = *state_.beam_needle;
    const int tip = ns.num_nodes() - 1;
    ns.external_forces.col(tip) -= tip_force_;
    ns.external_torques.col(tip) -= tip_torque_;
    ns.bevel_angle = bevel_angle;
    const BevelTipLoad load =
        coupling.CalcBevelTipLoad(MakeNeedleView(*needle_body_, -1), state_.coupling);
    tip_force_ = load.force_on_needle;
    tip_torque_ = load.torque_on_needle;
    ns.external_forces.col(tip) += tip_force_;
    ns.external_torques.col(tip) += tip_torque_;
    report.bevel_active = load.active;
    SetBeamNeedleTarget(*model.beam_needle(), X_WF_end, ns);
  } else {
    state_.rigid_needle.bevel_angle = bevel_angle;
    const BevelTipLoad load = coupling.CalcBevelTipLoad(
        MakeNeedleView(model.rigid_needle(), state_.rigid_needle), state_.coupling);
    if (load.active && load.tip_point.tet >= 0) {
      const TetMesh& mesh = coupling.get_mesh(load.tissue);
      for (int k = 0; k < 4; ++k) {
        const int node = mesh.tets[load.tip_point.tet][k];
        const Eigen::Vector3d f = -load.tip_point.bary[k] * load.force_for_rigid;
        tissues[load.tissue]->external_forces.col(node) += f;
        tissue_loads_.push_back({{load.tissue, node}, f});
      }
      report.bevel_active = true;
    }
    SetRigidNeedleTarget(model.rigid_needle(), X_WF_end, state_.rigid_needle);
  }

  // free motion of every body
  report.liver_stats = liver_body_->BeginStep();
  skin_body_->BeginStep();
  if (needle_body_) needle_body_->BeginStep();

  // constraints: needle-tissue rows, then liver-rib contacts
  set_.Clear();
  const int skin_index = set_.AddBody(*skin_body_);
  const int liver_index = set_.AddBody(*liver_body_);
  const int needle_index = needle_body_ ? set_.AddBody(*needle_body_) : -1;
  const NeedleView view = needle_body_ ? MakeNeedleView(*needle_body_, needle_index)
                                       : MakeNeedleView(model.rigid_needle(), state_.rigid_needle);
  coupling.AddConstraints(view, {skin_index, liver_index}, set_, state_.coupling);
  report.num_rib_contacts = AddRibContacts(set_, liver_index);
  report.num_rows = set_.num_rows();

  // resolution and correction, then the puncture / seeding update
  report.solve = solver_.Solve(set_);
  report.compliance = solver_.compliance().stats();
  skin_body_->EndStep();
  liver_body_->EndStep();
  if (needle_body_) needle_body_->EndStep();
  for (int row : rib_rows_)
    if (solver_.lambda()[row] > 0) ++report.num_active_rib_contacts;
  const std::vector<const Eigen::Matrix3Xd*> tissue_x = {&state_.skin.x, &state_.liver.x};
  if (needle_body_) {
    coupling.Update(MakeNeedleView(*needle_body_, needle_index), tissue_x, solver_.lambda(),
                    state_.liver.time, state_.coupling);
  } else {
    coupling.Update(view, tissue_x, solver_.lambda(), state_.liver.time, state_.coupling);
    AdvanceRigidNeedle(state_.rigid_needle);
  }
  ++state_.step;
  report.time = state_.liver.time;
  return report;
}

void PatientScene::CalcMarkerPositions(std::vector<Eigen::Vector3d>* p_WM) const {
  const auto& markers = model_->markers();
  p_WM->resize(markers.size());
  for (size_t m = 0; m < markers.size(); ++m)
    (*p_WM)[m] = EvalTetPoint(model_->liver().get_mesh(), state_.liver.x, markers[m]);
}

Eigen::Vector3d PatientScene::CalcTargetPosition() const {
  return EvalTetPoint(model_->liver().get_mesh(), state_.liver.x, model_->target());
}

Eigen::Matrix3Xd PatientScene::CalcNeedlePolyline() const {
  if (state_.beam_needle) return state_.beam_needle->x;
  const Eigen::Isometry3d& X_WN = state_.rigid_needle.X_WN_end;
  Eigen::Matrix3Xd points(3, 2);
  points.col(0) = X_WN.translation();
  points.col(1) = nsim::CalcTipPosition(X_WN, model_->rigid_needle().length());
  return points;
}

Eigen::Vector3d PatientScene::CalcTipPosition() const {
  const Eigen::Matrix3Xd points = CalcNeedlePolyline();
  return points.col(points.cols() - 1);
}

Eigen::Vector3d PatientScene::CalcTipDirection() const {
  if (state_.beam_needle) return state_.beam_needle->R.back().col(2);
  return state_.rigid_needle.X_WN_end.linear().col(2);
}

TissueStatus PatientScene::GetTissueStatus(int tissue) const {
  const TissueCouplingState& s = state_.coupling.tissues[tissue];
  TissueStatus status;
  status.phase = s.phase;
  status.punctured = s.phase == TissuePhase::kInside || s.phase == TissuePhase::kExited;
  status.puncture_time = status.punctured ? s.puncture_time : 0.0;
  status.depth = s.report.depth;
  status.past_seed = s.report.past_seed;
  status.tip_hold = s.report.tip_hold;
  return status;
}

bool PatientScene::CalcEntryPoint(Eigen::Vector3d* p_WP, Eigen::Vector3d* n_W) const {
  const TissueCouplingState& skin = state_.coupling.tissues[kSkinTissue];
  for (const NeedlePathPoint& point : skin.points) {
    if (point.kind != NeedlePathPoint::Kind::kEntry) continue;
    const TetMesh& mesh = model_->skin().get_mesh();
    *p_WP = EvalTetPoint(mesh, state_.skin.x, point.point);
    *n_W = SurfaceLocator(mesh, state_.skin.x).Closest(*p_WP).normal;
    return true;
  }
  return false;
}

double PatientScene::CalcMaxRibPenetration() const {
  double depth = 0.0;
  for (int node : model_->liver_surface_nodes())
    for (const OrientedBox& rib : model_->config().ribs)
      depth = std::max(depth, -CalcBoxProximity(rib, state_.liver.x.col(node)).signed_distance);
  return depth;
}

Eigen::Vector3d PatientScene::CalcBreathingDisplacement() const {
  return model_->breathing().CalcDisplacement(time());
}

}  // namespace nsim
