#include "common/needle/needle_tissue.h"

#include <algorithm>
#include <cmath>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/mesh/point_locator.h"
#include "common/mesh/surface_locator.h"
#include "common/needle/beam_needle.h"
#include "common/needle/rigid_needle.h"

namespace nsim {

namespace {

// a point further ahead of the tip than this fraction of point_spacing is removed
constexpr double kRetractionSlack = 0.1;
// the tip constraint is skipped within this fraction of point_spacing after a seed (or, with
// tip_hold ramp, softened there: its hold grows in proportion to the tip's distance from the
// seed; with handover the seeded point's is)
constexpr double kTipSkipFraction = 0.25;
// with tip_hold ramp (handover), the tip constraint (the seeded point's) is left out below this
// fraction of kTipSkipFraction (where its hold would be at most this fraction of a rigid one)
constexpr double kTipRampStart = 0.02;
// barycentric slack of the point-location walk (-)
constexpr double kWalkTolerance = 1e-9;
// a point this far outside a tissue's surface (m) is in none of its tets, whatever the
// tolerance of the search (kWalkTolerance is barycentric: 1e-9 of a tet's size, picometres)
constexpr double kOutsideForSure = 1e-6;
// constraint-point key of the tip in each tissue (seeded points count up from 1; keys only
// need to be distinct within one body)
constexpr std::uint64_t kTipPointKey = std::uint64_t{1} << 61;

// the tip's distance past the last seeded point at the step's start, as seed_distance says
double PastSeed(const TissueCouplingConfig& cfg, const TissueCouplingState& ts) {
  return cfg.seed_distance == SeedDistance::kLastPoint ? ts.report.past_last_point
                                                       : ts.report.depth - ts.last_seed_depth;
}

// the tip's lateral rows at past_seed (the distance PastSeed gives), as tip_hold says: none
// (nullopt), or their softness (0: rigid; ramp: full / past - 1, which holds the fraction past /
// full of a rigid hold, from nothing at the seed to rigid a quarter spacing past it)
std::optional<double> TipHoldSoftness(const TissueCouplingConfig& cfg, double past_seed) {
  if (!cfg.tip_constraint) return std::nullopt;
  const double full_hold = kTipSkipFraction * cfg.point_spacing;
  switch (cfg.tip_hold) {
    case TipHold::kHandover:
      return 0.0;
    case TipHold::kRamp:
      if (past_seed < kTipRampStart * full_hold) return std::nullopt;
      return past_seed < full_hold ? full_hold / past_seed - 1.0 : 0.0;
    case TipHold::kQuarter:
      break;
  }
  return past_seed >= full_hold ? std::optional<double>(0.0) : std::nullopt;
}

Eigen::Vector3d PolylinePoint(const Eigen::Matrix3Xd& X, double u) {
  const int n = static_cast<int>(X.cols());
  const int k = std::clamp(static_cast<int>(std::floor(u)), 0, n - 2);
  const double w = std::clamp(u - k, 0.0, 1.0);
  return (1.0 - w) * X.col(k) + w * X.col(k + 1);
}

Eigen::Vector3d PolylineTangent(const Eigen::Matrix3Xd& X, double u) {
  const int n = static_cast<int>(X.cols());
  const int k = std::clamp(static_cast<int>(std::floor(u)), 0, n - 2);
  return (X.col(k + 1) - X.col(k)).normalized();
}

// parameter u of the polyline point closest to p
double ProjectOnPolyline(const Eigen::Matrix3Xd& X, const Eigen::Vector3d& p) {
  const int n = static_cast<int>(X.cols());
  double best = std::numeric_limits<double>::infinity(), best_u = 0.0;
  for (int k = 0; k + 1 < n; ++k) {
    const Eigen::Vector3d a = X.col(k), ab = X.col(k + 1) - a;
    const double len2 = ab.squaredNorm();
    const double w = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const double d2 = (a + w * ab - p).squaredNorm();
    if (d2 < best) {
      best = d2;
      best_u = k + w;
    }
  }
  return best_u;
}

Eigen::Vector3d TriangleNormal(const TetMesh& mesh, const Eigen::Matrix3Xd& x, int triangle) {
  const Eigen::Vector3i& f = mesh.surface[triangle];
  return (x.col(f[1]) - x.col(f[0])).cross(x.col(f[2]) - x.col(f[0])).normalized();
}

bool SegmentNearBox(const Eigen::Matrix3Xd& x, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                    double margin) {
  const Eigen::Vector3d lo = x.rowwise().minCoeff().array() - margin;
  const Eigen::Vector3d hi = x.rowwise().maxCoeff().array() + margin;
  const Eigen::Vector3d slo = a.cwiseMin(b), shi = a.cwiseMax(b);
  return (slo.array() <= hi.array()).all() && (shi.array() >= lo.array()).all();
}

}  // namespace

const char* ToString(TissuePhase phase) {
  switch (phase) {
    case TissuePhase::kOutside:
      return "outside";
    case TissuePhase::kContact:
      return "contact";
    case TissuePhase::kInside:
      return "inside";
    case TissuePhase::kExited:
      return "exited";
  }
  return "?";
}

const std::vector<std::string>& TipHoldNames() {
  static const std::vector<std::string> names = {"quarter", "ramp", "handover"};
  return names;
}

const std::vector<std::string>& SeedDistanceNames() {
  static const std::vector<std::string> names = {"depth", "last_point"};
  return names;
}

void TissueCouplingConfig::Validate(const std::string& prefix) const {
  auto check = [&](bool ok, const char* key, const char* rule, double value) {
    if (!ok) throw InputError(Str(prefix, ".", key, " must be ", rule, ", got ", value));
  };
  check(puncture_force > 0.0 && std::isfinite(puncture_force), "puncture_force", "> 0 (N)",
        puncture_force);
  check(friction_coefficient >= 0.0 && std::isfinite(friction_coefficient), "friction_coefficient",
        ">= 0", friction_coefficient);
  check(friction_force_per_length >= 0.0 && std::isfinite(friction_force_per_length),
        "friction_force_per_length", ">= 0 (N/m)", friction_force_per_length);
  check(point_spacing > 0.0 && std::isfinite(point_spacing), "point_spacing", "> 0 (m)",
        point_spacing);
  check(contact_margin >= 0.0 && std::isfinite(contact_margin), "contact_margin", ">= 0 (m)",
        contact_margin);
  check(lateral_compliance >= 0.0 && std::isfinite(lateral_compliance), "lateral_compliance",
        ">= 0 (m/N)", lateral_compliance);
  if (tip_hold == TipHold::kHandover && !tip_constraint)
    throw InputError(Str(prefix, ".tip_hold: handover needs ", prefix, ".tip_constraint: true"));
  check(tip_compliance >= 0.0 && std::isfinite(tip_compliance), "tip_compliance", ">= 0 (m/N)",
        tip_compliance);
  // Puncture forces of skin and organs are 0.1..10 N, friction coefficients below 1 and
  // friction along the shaft tens of N/m: 1000 N, 10 and 1e5 N/m bound anything physical;
  // path points are seeded mm apart in a needle at most 2 m long; a contact margin of 10 cm
  // puts the whole organ in contact.
  CheckAtMost(puncture_force, 1e3, prefix + ".puncture_force", "N");
  CheckAtMost(friction_coefficient, 10.0, prefix + ".friction_coefficient", "");
  CheckAtMost(friction_force_per_length, 1e5, prefix + ".friction_force_per_length", "N/m");
  CheckAtMost(point_spacing, 2.0, prefix + ".point_spacing", "m");
  CheckAtMost(contact_margin, 0.1, prefix + ".contact_margin", "m");
  // a point of the 2660-node liver holds its needle with ~330 N/m (h^2 A_0^-1 ~ 3e-3 m/N,
  // point_compliance): 1 m/N, a 1 N/m spring, no longer holds anything
  CheckAtMost(lateral_compliance, 1.0, prefix + ".lateral_compliance", "m/N");
  CheckAtMost(tip_compliance, 1.0, prefix + ".tip_compliance", "m/N");
}

void NeedleCouplingConfig::Validate() const {
  for (size_t i = 0; i < tissues.size(); ++i) tissues[i].Validate(Str("coupling.tissues[", i, "]"));
  bevel.Validate("coupling.bevel");
}

NeedleView MakeNeedleView(const RigidNeedleModel& model, const RigidNeedleState& state) {
  NeedleView v;
  const double L = model.length();
  v.start.resize(3, 2);
  v.end.resize(3, 2);
  v.start.col(0) = state.X_WN_start.translation();
  v.start.col(1) = CalcTipPosition(state.X_WN_start, L);
  v.end.col(0) = state.X_WN_end.translation();
  v.end.col(1) = CalcTipPosition(state.X_WN_end, L);
  v.segment_length = L;
  v.body = -1;
  v.R_WTip_end = state.X_WN_end.linear();
  v.bevel_angle = state.bevel_angle;
  return v;
}

NeedleView MakeNeedleView(const BeamNeedleBody& needle, int body_index) {
  NeedleView v;
  const BeamNeedleState& s = needle.state();
  v.start = s.x;
  v.end = needle.in_step() ? s.x_free : s.x;
  v.segment_length = needle.model().element_length();
  v.body = body_index;
  v.R_WTip_end = needle.in_step() ? needle.CalcFreeTipFrame() : s.R.back();
  v.bevel_angle = s.bevel_angle;
  return v;
}

NeedleTissueCoupling::NeedleTissueCoupling(const NeedleCouplingConfig& config,
                                           const std::vector<const TetMesh*>& meshes)
    : config_(config) {
  config_.Validate();
  if (meshes.size() != config_.tissues.size())
    throw InputError(Str("coupling: expected one mesh per tissue (", config_.tissues.size(),
                         "), got ", meshes.size()));
  bevel_loads_ = CalcBevelLoads(config_.bevel);
  for (const TetMesh* mesh : meshes) {
    NSIM_CHECK(mesh != nullptr && mesh->num_tets() > 0, "coupling: empty tissue mesh");
    Tissue t;
    t.mesh = *mesh;
    t.adjacency = CalcMeshAdjacency(t.mesh);
    tissues_.push_back(std::move(t));
  }
}

NeedleCouplingState NeedleTissueCoupling::MakeState() const {
  NeedleCouplingState s;
  s.tissues.resize(tissues_.size());
  return s;
}

TetPoint NeedleTissueCoupling::Walk(int t, const Eigen::Matrix3Xd& x, const Eigen::Vector3d& p,
                                    int hint) const {
  const TetMesh& mesh = tissues_[t].mesh;
  const auto& neighbors = tissues_[t].adjacency.tet_neighbors;
  int e = (hint >= 0 && hint < mesh.num_tets()) ? hint : 0;
  // walk towards p across the face of the most negative barycentric coordinate
  for (int it = 0; it < 4096; ++it) {
    const Eigen::Vector4i& tet = mesh.tets[e];
    const Eigen::Vector4d bary =
        CalcBarycentric(p, x.col(tet[0]), x.col(tet[1]), x.col(tet[2]), x.col(tet[3]));
    if (!bary.allFinite()) break;
    int k = 0;
    const double lowest = bary.minCoeff(&k);
    if (lowest >= -kWalkTolerance) return TetPoint{e, bary};
    const int next = neighbors[e][k];
    if (next < 0) break;  // left through the boundary (or a concavity)
    e = next;
  }
  return TetPoint{};
}

TetPoint NeedleTissueCoupling::Locate(int t, const Eigen::Matrix3Xd& x, const Eigen::Vector3d& p,
                                      int hint) const {
  const TetPoint walked = Walk(t, x, p, hint);
  if (walked.tet >= 0) return walked;
  // the walk left through the boundary: p is outside, or inside beyond a concavity. The
  // surface's signed distance tells (0.3 ms to build on the 2660-node liver, against 2.5 ms for
  // the tet locator); the tet locator searches only when p is inside or within a micrometre of
  // the surface (where its tolerance decides)
  const SurfaceLocator surface(tissues_[t].mesh, x, tissues_[t].adjacency.surface_tets);
  if (surface.SignedDistance(p) > kOutsideForSure) return TetPoint{};
  const TetLocator locator(tissues_[t].mesh, x, kWalkTolerance);
  const std::optional<TetPoint> found = locator.Locate(p);
  return found ? *found : TetPoint{};
}

std::vector<int> NeedleTissueCoupling::CalcNodesAhead(int t, const NeedleView& needle,
                                                      const Eigen::Matrix3Xd& x,
                                                      const NeedleCouplingState& state,
                                                      double distance) const {
  NSIM_CHECK(t >= 0 && t < num_tissues(), "tissue ", t, " of ", num_tissues());
  NSIM_CHECK(static_cast<int>(state.tissues.size()) == num_tissues(),
             "coupling state made for another coupling");
  const TetMesh& mesh = tissues_[t].mesh;
  NSIM_CHECK(x.cols() == mesh.num_nodes(), "positions have ", x.cols(), " columns for ",
             mesh.num_nodes(), " nodes");
  std::vector<int> nodes;
  const TissueCouplingState& ts = state.tissues[t];
  if (!(distance > 0.0) || ts.phase == TissuePhase::kExited) return nodes;
  const int n = needle.num_nodes();
  const Eigen::Vector3d tip = needle.end.col(n - 1);
  const Eigen::Vector3d z = needle.R_WTip_end.col(2);
  // where the walk along the axis starts: the tip's tet, or where the axis enters the surface
  double s = 0.0;
  int e = -1;
  if (ts.phase == TissuePhase::kInside) {
    const int hint = ts.points.empty() ? -1 : ts.points.back().point.tet;
    e = ts.tip.tet >= 0 ? ts.tip.tet : Walk(t, x, tip, hint).tet;
  } else if (SegmentNearBox(x, tip, tip + distance * z, 0.0)) {
    const SurfaceLocator surface(mesh, x, tissues_[t].adjacency.surface_tets);
    const std::optional<SurfacePoint> hit = surface.FirstHit(tip, tip + distance * z);
    if (hit && hit->normal.dot(z) < 0.0) {
      e = hit->tet_point.tet;
      s = hit->distance * distance;
    }
  }
  if (e < 0) return nodes;
  // the tets along the axis, sampled finer than any tet's size (a sample every 0.5 mm)
  constexpr double kSample = 5e-4;
  for (;;) {
    for (int k = 0; k < 4; ++k) nodes.push_back(mesh.tets[e][k]);
    s += kSample;
    if (s > distance) break;
    const TetPoint next = Walk(t, x, tip + s * z, e);
    if (next.tet < 0) break;  // out of the tissue
    e = next.tet;
  }
  // unique, in the order met (nearest the tip first)
  std::vector<int> unique;
  for (int node : nodes)
    if (std::find(unique.begin(), unique.end(), node) == unique.end()) unique.push_back(node);
  return unique;
}

void NeedleTissueCoupling::AddConstraints(const NeedleView& needle,
                                          const std::vector<int>& tissue_bodies, ConstraintSet& set,
                                          NeedleCouplingState& state) const {
  NSIM_CHECK(static_cast<int>(tissue_bodies.size()) == num_tissues(), "expected ", num_tissues(),
             " tissue bodies, got ", tissue_bodies.size());
  NSIM_CHECK(static_cast<int>(state.tissues.size()) == num_tissues(),
             "coupling state made for another coupling");
  const int n = needle.num_nodes();
  NSIM_CHECK(n >= 2 && needle.end.cols() == n, "needle view needs >= 2 nodes");
  state.tags.clear();

  const Eigen::Vector3d tip_start = needle.start.col(n - 1), tip_end = needle.end.col(n - 1);
  const Eigen::Vector3d z_tip_start = PolylineTangent(needle.start, n - 1);
  const Eigen::Vector3d z_tip_end = needle.R_WTip_end.col(2);
  const double u_tip = n - 1;

  std::vector<int> nodes(2);
  std::vector<double> weights(2);
  auto add_needle_point = [&](double u) {
    if (needle.body < 0)
      return set.AddKinematicPoint(PolylinePoint(needle.start, u), PolylinePoint(needle.end, u));
    const int k = std::clamp(static_cast<int>(std::floor(u)), 0, n - 2);
    const double w = std::clamp(u - k, 0.0, 1.0);
    nodes[0] = k;
    nodes[1] = k + 1;
    weights[0] = 1.0 - w;
    weights[1] = w;
    return set.AddBodyPoint(needle.body, nodes, weights);
  };
  // two bilateral rows orthogonal to the needle axis z between a tissue point and a needle
  // point, and the tag that names them
  auto add_lateral_rows = [&](int tissue_point, int needle_point, const Eigen::Vector3d& z,
                              CouplingRowTag::Kind kind, int tissue) {
    Eigen::Vector3d d0, d1;
    CalcTangentBasis(z, d0, d1);
    Eigen::Matrix<double, 3, 2> lateral;
    lateral << d0, d1;
    set.AddBilateral(tissue_point, needle_point, lateral);
    CouplingRowTag tag;
    tag.kind = kind;
    tag.tissue = tissue;
    tag.row = set.num_rows() - 2;
    tag.d0 = d0;
    tag.d1 = d1;
    return tag;
  };

  for (int t = 0; t < num_tissues(); ++t) {
    const TissueCouplingConfig& cfg = config_.tissues[t];
    TissueCouplingState& ts = state.tissues[t];
    const int b = tissue_bodies[t];
    const Eigen::Matrix3Xd& xs = set.body(b).start_positions();
    const TetMesh& mesh = tissues_[t].mesh;

    if (ts.phase == TissuePhase::kOutside) {
      // contact search along the tip's motion
      const Eigen::Vector3d a = tip_start - cfg.contact_margin * z_tip_start;
      if (SegmentNearBox(xs, a, tip_end, cfg.contact_margin)) {
        const SurfaceLocator surface(mesh, xs, tissues_[t].adjacency.surface_tets);
        const std::optional<SurfacePoint> hit = surface.FirstHit(a, tip_end);
        if (hit && hit->normal.dot(tip_end - a) < 0.0) {
          ts.phase = TissuePhase::kContact;
          ts.contact = hit->tet_point;
          ts.contact_triangle = hit->triangle;
          ts.contact_key = state.next_key++;
        }
      }
    }

    if (ts.phase == TissuePhase::kContact) {
      const Eigen::Vector3d normal = TriangleNormal(mesh, xs, ts.contact_triangle);
      const int pt =
          set.AddBodyPoint(b, mesh.tets[ts.contact.tet], ts.contact.bary, ts.contact_key);
      const int pn = add_needle_point(u_tip);
      set.AddContact(pn, pt, normal);
      CouplingRowTag tag;
      tag.kind = CouplingRowTag::Kind::kContact;
      tag.tissue = t;
      tag.row = set.num_rows() - 1;
      tag.d0 = normal;
      state.tags.push_back(tag);
      continue;
    }
    if (ts.phase != TissuePhase::kInside && ts.phase != TissuePhase::kExited) continue;

    const bool friction = cfg.friction_coefficient > 0.0 || cfg.friction_force_per_length > 0.0;
    // the tip's distance past the last seeded point sets how much of a hold the tip gets (or,
    // with tip_hold handover, that point): from nothing at the seed to rigid a quarter spacing past
    const double past_seed = PastSeed(cfg, ts);
    const double full_hold = kTipSkipFraction * cfg.point_spacing;
    const double first_hold = kTipRampStart * full_hold;
    const bool tip_held = ts.phase == TissuePhase::kInside && cfg.tip_constraint && ts.tip.tet >= 0;
    const bool handover = tip_held && cfg.tip_hold == TipHold::kHandover && past_seed < full_hold;
    const int num_points = static_cast<int>(ts.points.size());
    for (int i = 0; i < num_points; ++i) {
      const bool handed_over = handover && i == num_points - 1;
      if (handed_over && past_seed < first_hold) continue;  // the tip holds its tissue
      const NeedlePathPoint& p = ts.points[i];
      const Eigen::Vector3d xp = EvalTetPoint(mesh.tets, xs, p.point);
      const double u = ProjectOnPolyline(needle.start, xp);
      const Eigen::Vector3d z = PolylineTangent(needle.end, u);
      const int pt = set.AddBodyPoint(b, mesh.tets[p.point.tet], p.point.bary, p.key);
      const int pn = add_needle_point(u);
      CouplingRowTag tag = add_lateral_rows(pt, pn, z, CouplingRowTag::Kind::kLateral, t);
      if (cfg.lateral_compliance > 0.0) set.SetCompliance(tag.row, 2, cfg.lateral_compliance);
      if (handed_over) set.SetSoftness(tag.row, 2, full_hold / past_seed - 1.0);
      tag.point = i;
      state.tags.push_back(tag);
      if (!friction) continue;
      // axial row: relative axial slip over the step, its force bounded by the lateral one
      const Eigen::Vector3d offset = z * z.dot(xp - PolylinePoint(needle.start, u));
      set.AddAxialFriction(pt, pn, z, set.num_groups() - 1, cfg.friction_coefficient,
                           cfg.friction_force_per_length * cfg.point_spacing, offset);
      tag.kind = CouplingRowTag::Kind::kAxial;
      tag.row = set.num_rows() - 1;
      tag.d0 = z;
      tag.d1.setZero();
      state.tags.push_back(tag);
    }

    // tip: the tissue ahead is cut; laterally the tip follows the tissue it is in
    const std::optional<double> tip_softness =
        tip_held ? TipHoldSoftness(cfg, past_seed) : std::nullopt;
    if (tip_softness) {
      // keyed: the tip moves through the tissue, its columns come from cached node columns
      const int pt = set.AddBodyPoint(b, mesh.tets[ts.tip.tet], ts.tip.bary, kTipPointKey);
      const int pn = add_needle_point(u_tip);
      state.tags.push_back(add_lateral_rows(pt, pn, z_tip_end, CouplingRowTag::Kind::kTip, t));
      if (cfg.tip_compliance > 0.0) set.SetCompliance(set.num_rows() - 2, 2, cfg.tip_compliance);
      if (*tip_softness > 0.0) set.SetSoftness(set.num_rows() - 2, 2, *tip_softness);
    }
  }
}

std::optional<NeedleTissueCoupling::TipStretch> NeedleTissueCoupling::CalcTipStretch(
    int t, const NeedleCouplingState& state) const {
  NSIM_CHECK(t >= 0 && t < num_tissues(), "tissue ", t, " of ", num_tissues());
  const TissueCouplingConfig& cfg = config_.tissues[t];
  const TissueCouplingState& ts = state.tissues[t];
  if (ts.phase != TissuePhase::kInside) return std::nullopt;
  // as AddConstraints and Update measure it: past the last seed at the step's start
  const double past_seed = PastSeed(cfg, ts);
  TipStretch s;
  s.next_seed = std::max(0.0, cfg.point_spacing - past_seed);
  if (cfg.tip_constraint && cfg.tip_hold != TipHold::kHandover) {
    s.free_length = kTipSkipFraction * cfg.point_spacing;
    s.free_reach = std::max(0.0, s.free_length - past_seed);
  }
  return s;
}

void NeedleTissueCoupling::Update(const NeedleView& needle,
                                  const std::vector<const Eigen::Matrix3Xd*>& tissue_x,
                                  const Eigen::VectorXd& lambda, double time,
                                  NeedleCouplingState& state) const {
  NSIM_CHECK(static_cast<int>(tissue_x.size()) == num_tissues(), "expected ", num_tissues(),
             " tissue position sets, got ", tissue_x.size());
  const int n = needle.num_nodes();
  const Eigen::Vector3d tip = needle.end.col(n - 1);
  const Eigen::Vector3d z_tip = needle.R_WTip_end.col(2);
  state.tip_tissue = -1;

  // forces of the last solve
  std::vector<double> contact_lambda(num_tissues(), 0.0);
  std::vector<Eigen::Vector3d> contact_normal(num_tissues(), Eigen::Vector3d::Zero());
  for (int t = 0; t < num_tissues(); ++t) {
    TissueCouplingReport& r = state.tissues[t].report;
    r.contact_force = r.axial_contact_force = r.lateral_force = r.friction_force = r.tip_force = 0;
    r.total_force.setZero();
  }
  for (const CouplingRowTag& tag : state.tags) {
    NSIM_CHECK(tag.row >= 0 && tag.row < lambda.size(), "multipliers do not match the rows");
    TissueCouplingState& ts = state.tissues[tag.tissue];
    TissueCouplingReport& r = ts.report;
    switch (tag.kind) {
      case CouplingRowTag::Kind::kContact:
        contact_lambda[tag.tissue] = lambda[tag.row];
        contact_normal[tag.tissue] = tag.d0;
        r.total_force -= lambda[tag.row] * tag.d0;
        break;
      case CouplingRowTag::Kind::kLateral: {
        NeedlePathPoint& p = ts.points[tag.point];
        p.lateral_force = Eigen::Vector2d(lambda[tag.row], lambda[tag.row + 1]);
        p.axial_force = 0.0;
        p.slipping = false;
        r.lateral_force += p.lateral_force.norm();
        r.total_force += lambda[tag.row] * tag.d0 + lambda[tag.row + 1] * tag.d1;
        break;
      }
      case CouplingRowTag::Kind::kAxial: {
        NeedlePathPoint& p = ts.points[tag.point];
        const TissueCouplingConfig& cfg = config_.tissues[tag.tissue];
        p.axial_force = lambda[tag.row];
        const double bound = cfg.friction_coefficient * p.lateral_force.norm() +
                             cfg.friction_force_per_length * cfg.point_spacing;
        p.slipping = bound > 0.0 && std::abs(p.axial_force) >= bound * (1.0 - 1e-6);
        r.friction_force += p.axial_force;
        r.total_force += p.axial_force * tag.d0;
        break;
      }
      case CouplingRowTag::Kind::kTip: {
        const Eigen::Vector3d f = lambda[tag.row] * tag.d0 + lambda[tag.row + 1] * tag.d1;
        r.tip_force = f.norm();
        r.total_force += f;
        break;
      }
    }
  }

  for (int t = 0; t < num_tissues(); ++t) {
    const TissueCouplingConfig& cfg = config_.tissues[t];
    TissueCouplingState& ts = state.tissues[t];
    TissueCouplingReport& r = ts.report;
    const Eigen::Matrix3Xd& x = *tissue_x[t];
    const TetMesh& mesh = tissues_[t].mesh;

    if (ts.phase == TissuePhase::kContact) {
      const double lam = contact_lambda[t];
      r.contact_force = lam;
      r.axial_contact_force = lam * std::max(0.0, -contact_normal[t].dot(z_tip));
      if (r.axial_contact_force >= cfg.puncture_force) {
        // puncture: the contact point becomes the entry point
        ts.phase = TissuePhase::kInside;
        ts.puncture_time = time;
        NeedlePathPoint entry;
        entry.kind = NeedlePathPoint::Kind::kEntry;
        entry.point = ts.contact;
        entry.key = ts.contact_key;
        entry.seed_depth = 0.0;
        ts.points.assign(1, entry);
        ts.last_seed_depth = 0.0;
        ts.tip = ts.contact;
      } else if (!(lam > 0.0)) {
        const Eigen::Vector3d normal = TriangleNormal(mesh, x, ts.contact_triangle);
        if (normal.dot(tip - EvalTetPoint(mesh.tets, x, ts.contact)) > 0.0)
          ts.phase = TissuePhase::kOutside;
      }
    }

    if (ts.phase == TissuePhase::kInside || ts.phase == TissuePhase::kExited) {
      // retraction: remove the points the tip has moved back behind
      const double slack = kRetractionSlack * cfg.point_spacing;
      ts.points.erase(std::remove_if(ts.points.begin(), ts.points.end(),
                                     [&](const NeedlePathPoint& p) {
                                       const Eigen::Vector3d xp =
                                           EvalTetPoint(mesh.tets, x, p.point);
                                       return z_tip.dot(xp - tip) > slack;
                                     }),
                      ts.points.end());
      if (ts.points.empty() || ts.points.front().kind != NeedlePathPoint::Kind::kEntry) {
        ts = TissueCouplingState{};  // fully retracted: not punctured any more
        continue;
      }
      const bool has_exit = ts.points.back().kind == NeedlePathPoint::Kind::kExit;
      if (ts.phase == TissuePhase::kExited && !has_exit) {
        ts.phase = TissuePhase::kInside;
        ts.tip = TetPoint{};
      }
      double last = 0.0;
      for (const NeedlePathPoint& p : ts.points) last = std::max(last, p.seed_depth);
      ts.last_seed_depth = last;

      // a path point's position along the needle (in segments from its base)
      auto along = [&](const NeedlePathPoint& p) {
        return ProjectOnPolyline(needle.end, EvalTetPoint(mesh.tets, x, p.point));
      };
      const double u_entry = along(ts.points.front());
      if (ts.phase == TissuePhase::kExited) {
        r.depth = (along(ts.points.back()) - u_entry) * needle.segment_length;
      } else {
        r.depth = (n - 1 - u_entry) * needle.segment_length;
        const int hint = ts.tip.tet >= 0 ? ts.tip.tet : ts.points.back().point.tet;
        const TetPoint at_tip = Locate(t, x, tip, hint);
        if (at_tip.tet >= 0) {
          ts.tip = at_tip;
          if (state.tip_tissue < 0) state.tip_tissue = t;
          if (cfg.seed_distance == SeedDistance::kLastPoint) {
            // the entry point is the last one until the first seed: its projection is at hand
            const double u_last = ts.points.size() == 1 ? u_entry : along(ts.points.back());
            r.past_last_point = (n - 1 - u_last) * needle.segment_length;
          }
          if (PastSeed(cfg, ts) >= cfg.point_spacing) {
            NeedlePathPoint p;
            p.kind = NeedlePathPoint::Kind::kTrajectory;
            p.point = at_tip;
            p.key = state.next_key++;
            p.seed_depth = r.depth;
            ts.points.push_back(p);
            ts.last_seed_depth = r.depth;
            r.past_last_point = 0.0;  // the new point is at the tip
          }
        } else if (r.depth <= kRetractionSlack * cfg.point_spacing) {
          // the tip is still at the entry (just punctured, or backing out): not held
          ts.tip = TetPoint{};
        } else {
          // the tip left through the far surface: seed the exit point where the needle crosses
          ts.phase = TissuePhase::kExited;
          ts.tip = TetPoint{};
          const double back = std::max(r.depth - ts.last_seed_depth, 1e-6) + 1e-6;
          const SurfaceLocator surface(mesh, x, tissues_[t].adjacency.surface_tets);
          const std::optional<SurfacePoint> hit = surface.FirstHit(tip, tip - back * z_tip);
          if (hit) {
            NeedlePathPoint p;
            p.kind = NeedlePathPoint::Kind::kExit;
            p.point = hit->tet_point;
            p.key = state.next_key++;
            p.seed_depth = r.depth - hit->distance * back;
            ts.points.push_back(p);
            ts.last_seed_depth = p.seed_depth;
            r.depth = p.seed_depth;
          }
        }
      }
    }

    r.phase = ts.phase;
    r.punctured = ts.phase == TissuePhase::kInside || ts.phase == TissuePhase::kExited;
    r.puncture_time = ts.puncture_time;
    r.num_points = static_cast<int>(ts.points.size());
    if (!r.punctured) r.depth = 0.0;
    if (ts.phase != TissuePhase::kInside || ts.tip.tet < 0) {
      r.past_last_point = r.past_seed = r.tip_hold = 0.0;
    } else {
      // what the next step's AddConstraints holds the tip by
      r.past_seed = PastSeed(cfg, ts);
      const std::optional<double> softness = TipHoldSoftness(cfg, r.past_seed);
      r.tip_hold = softness ? 1.0 / (1.0 + *softness) : 0.0;
    }
  }
}

BevelTipLoad NeedleTissueCoupling::CalcBevelTipLoad(const NeedleView& needle,
                                                    const NeedleCouplingState& state) const {
  BevelTipLoad load;
  if (!config_.bevel.enabled || state.tip_tissue < 0) return load;
  const Eigen::Matrix3d R_WB = CalcBevelFrame(needle.R_WTip_end, needle.bevel_angle);
  load.active = true;
  ::nsim::CalcBevelTipLoad(config_.bevel, bevel_loads_, R_WB, load.force_on_needle,
                           load.torque_on_needle);
  load.force_for_rigid = bevel_loads_.q * R_WB.col(1);
  load.tissue = state.tip_tissue;
  load.tip_point = state.tissues[state.tip_tissue].tip;
  return load;
}

}  // namespace nsim
