#include "common/scene/patient_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "common/core/error.h"
#include "common/scene/robot_driver.h"
#include "tests/scene/scene_test_util.h"

namespace nsim {
namespace {

using testing::LoadCoarseScenario;

// the planned insertion of a scenario and a scene holding the needle at its start
struct SceneRig {
  DirectScenario s;
  InsertionPlan plan;
  std::unique_ptr<PatientScene> scene;

  explicit SceneRig(DirectScenario scenario) : s(std::move(scenario)) {
    const RigidNeedleModel needle(s.scene.needle.geometry());
    plan =
        MakeInsertionPlan(s.scene.entry_W, s.scene.target_W, needle, s.insertion.approach_distance);
    scene =
        std::make_unique<PatientScene>(s.scene, s.liver_mesh, s.skin_mesh, plan.CalcFlangePose(0));
  }
};

// a free-breathing run (needle parked outside), without cycle-to-cycle variation, recorded
struct BreathingRun {
  double h = 0, period = 0, amplitude = 0;
  std::vector<double> t, marker_si, diaphragm_si, d_si, penetration;
  double max_diaphragm_error = 0;  // |x - (X + d(t))| over the diaphragm nodes (m)
  int active_contact_steps = 0;
  int max_active_contacts = 0;
};

const BreathingRun& GetBreathingRun() {
  static const BreathingRun run = [] {
    DirectScenario s = LoadCoarseScenario();
    s.scene.breathing.period_cv = 0.0;
    s.scene.breathing.amplitude_cv = 0.0;
    SceneRig rig(s);
    BreathingRun r;
    r.h = s.scene.time_step;
    r.period = s.scene.breathing.period;
    r.amplitude = s.scene.breathing.si_amplitude;
    const FemModel& liver = rig.scene->model().liver();
    const std::vector<int>& prescribed = liver.get_prescribed_nodes();
    std::vector<Eigen::Vector3d> markers;
    const Eigen::Vector3d si = -s.scene.breathing.axis_si.normalized();  // superior
    const int steps = static_cast<int>(std::lround(2.25 * r.period / r.h));
    for (int k = 0; k < steps; ++k) {
      const SceneStepReport report = rig.scene->Step(rig.plan.CalcFlangePose(0));
      if (report.num_active_rib_contacts > 0) ++r.active_contact_steps;
      r.max_active_contacts = std::max(r.max_active_contacts, report.num_active_rib_contacts);
      rig.scene->CalcMarkerPositions(&markers);
      const Eigen::Vector3d d = rig.scene->CalcBreathingDisplacement();
      r.t.push_back(rig.scene->time());
      r.marker_si.push_back(markers[0].dot(si));
      r.d_si.push_back(d.dot(si));
      r.diaphragm_si.push_back(rig.scene->state().liver.x.col(prescribed[0]).dot(si));
      for (int node : prescribed)
        r.max_diaphragm_error = std::max(
            r.max_diaphragm_error,
            (rig.scene->state().liver.x.col(node) - liver.get_rest_positions().col(node) - d)
                .norm());
      r.penetration.push_back(rig.scene->CalcMaxRibPenetration());
    }
    return r;
  }();
  return run;
}

double PeakToPeak(const std::vector<double>& v, size_t from) {
  const auto [lo, hi] = std::minmax_element(v.begin() + from, v.end());
  return *hi - *lo;
}

// mean interval between upward crossings of the mean (s)
double MeasurePeriod(const std::vector<double>& t, const std::vector<double>& v) {
  double mean = 0;
  for (double x : v) mean += x;
  mean /= v.size();
  std::vector<double> crossings;
  for (size_t k = 1; k < v.size(); ++k)
    if (v[k - 1] < mean && v[k] >= mean)
      crossings.push_back(t[k - 1] + (mean - v[k - 1]) / (v[k] - v[k - 1]) * (t[k] - t[k - 1]));
  if (crossings.size() < 2) return 0.0;
  return (crossings.back() - crossings.front()) / (crossings.size() - 1);
}

TEST(PatientSceneTest, DiaphragmNodesFollowTheBreathingModelExactly) {
  const BreathingRun& r = GetBreathingRun();
  EXPECT_LT(r.max_diaphragm_error, 1e-12);
  // the configured peak-to-peak superior-inferior amplitude, exactly (no variation)
  EXPECT_NEAR(PeakToPeak(r.diaphragm_si, 0), r.amplitude, 1e-4 * r.amplitude);
}

TEST(PatientSceneTest, MarkersMoveWithTheConfiguredAmplitudeAndPeriod) {
  const BreathingRun& r = GetBreathingRun();
  // marker 0 (superior right lobe, 3 cm below the diaphragm box) follows the diaphragm with an
  // elastic attenuation and lag: most of the amplitude, the same period
  const size_t settle = static_cast<size_t>(0.25 * r.period / r.h);
  const double p2p = PeakToPeak(r.marker_si, settle);
  EXPECT_GT(p2p, 0.5 * r.amplitude);
  EXPECT_LT(p2p, 1.05 * r.amplitude);
  const double period = MeasurePeriod(r.t, r.marker_si);
  std::printf("marker 0: SI peak-to-peak %.2f mm (diaphragm %.2f mm), period %.3f s\n", 1e3 * p2p,
              1e3 * r.amplitude, period);
  EXPECT_NEAR(period, r.period, 2 * r.h) << "measured marker period " << period << " s";
  // the marker moves with the breathing signal (correlation of the SI coordinates)
  double mx = 0, md = 0;
  for (size_t k = 0; k < r.t.size(); ++k) mx += r.marker_si[k], md += r.d_si[k];
  mx /= r.t.size();
  md /= r.t.size();
  double sxd = 0, sxx = 0, sdd = 0;
  for (size_t k = 0; k < r.t.size(); ++k) {
    sxd += (r.marker_si[k] - mx) * (r.d_si[k] - md);
    sxx += (r.marker_si[k] - mx) * (r.marker_si[k] - mx);
    sdd += (r.d_si[k] - md) * (r.d_si[k] - md);
  }
  EXPECT_GT(sxd / std::sqrt(sxx * sdd), 0.95);
}

TEST(PatientSceneTest, LiverNeverPenetratesTheRibs) {
  const BreathingRun& r = GetBreathingRun();
  // the ribs do push the liver during the run ...
  EXPECT_GT(r.active_contact_steps, 10);
  EXPECT_GT(r.max_active_contacts, 0);
  // ... and no liver surface node ever enters a rib box (the constraint solver's tolerance)
  const double worst = *std::max_element(r.penetration.begin(), r.penetration.end());
  std::printf("rib contacts active in %d of %zu steps (up to %d rows), max penetration %.3g m\n",
              r.active_contact_steps, r.t.size(), r.max_active_contacts, worst);
  EXPECT_LT(worst, 1e-8) << "max penetration " << worst << " m";
}

TEST(PatientSceneTest, InsertionWithoutControllerPuncturesTheSkinThenTheLiver) {
  DirectScenario s = LoadCoarseScenario();
  SceneRig rig(s);
  const double speed = 0.02;  // m/s
  const double h = s.scene.time_step;
  const double start_distance =
      (rig.scene->CalcTargetPosition() - rig.scene->CalcTipPosition()).norm();
  double skin_time = -1, liver_time = -1;
  for (int k = 0; k < static_cast<int>(4.0 / h) && liver_time < 0; ++k) {
    rig.scene->Step(
        rig.plan.CalcFlangePose(std::min(speed * (k + 1) * h, rig.plan.total_travel())));
    const TissueStatus skin = rig.scene->GetTissueStatus(kSkinTissue);
    const TissueStatus liver = rig.scene->GetTissueStatus(kLiverTissue);
    if (skin.punctured && skin_time < 0) skin_time = skin.puncture_time;
    if (liver.punctured && liver_time < 0) {
      liver_time = liver.puncture_time;
      EXPECT_TRUE(skin.punctured) << "the liver was punctured before the skin";
    }
  }
  ASSERT_GT(skin_time, 0) << "the skin was not punctured";
  ASSERT_GT(liver_time, 0) << "the liver was not punctured";
  EXPECT_LT(skin_time, liver_time);
  // the skin is punctured once the tip travelled the approach distance (plus tenting)
  EXPECT_GT(skin_time, s.insertion.approach_distance / speed);
  Eigen::Vector3d p_entry, n_entry;
  ASSERT_TRUE(rig.scene->CalcEntryPoint(&p_entry, &n_entry));
  EXPECT_LT((p_entry - s.scene.entry_W).norm(), 0.006);
  EXPECT_GT(n_entry.dot(Eigen::Vector3d::UnitY()), 0.9);  // the skin faces anterior
  const double distance = (rig.scene->CalcTargetPosition() - rig.scene->CalcTipPosition()).norm();
  EXPECT_LT(distance, start_distance - 0.02);
  std::printf("skin punctured at %.2f s, liver at %.2f s, tip-target %.1f -> %.1f mm\n", skin_time,
              liver_time, 1e3 * start_distance, 1e3 * distance);
}

// With the rest compliance the rib contacts' compliance columns are solved when the scene is
// built, so the first step (the first one a realtime clock times) reuses them instead of
// solving them all at once; the last compliance option solves them in the step.
TEST(PatientSceneTest, TheRibContactsAtRestAreSolvedBeforeTheFirstStep) {
  for (const char* mesh : {"configs/meshes/liver_700.msh", "configs/meshes/liver_2660.msh"}) {
    for (const bool rest : {true, false}) {
      DirectScenario s = LoadCoarseScenario();
      s.liver_mesh = ReadGmshMesh(testing::SourcePath(mesh));
      s.scene.liver_rest_compliance = rest;
      SceneRig rig(s);
      const SceneStepReport first = rig.scene->Step(rig.plan.CalcFlangePose(0));
      ASSERT_GT(first.num_rib_contacts, 0) << mesh << ": no rib contact at the first step";
      std::printf("%s, %s compliance: %d rib contacts, %d points reused, %d columns solved\n",
                  mesh, rest ? "rest" : "last-factor", first.num_rib_contacts,
                  first.compliance.num_reused_points, first.compliance.num_solved_columns);
      if (rest) {
        EXPECT_GE(first.compliance.num_reused_points, first.num_rib_contacts) << mesh;
        EXPECT_EQ(first.compliance.num_solved_columns,
                  3 * (first.compliance.num_body_points - first.compliance.num_reused_points))
            << mesh;
      } else {
        EXPECT_EQ(first.compliance.num_reused_points, 0) << mesh;
      }
    }
  }
}

// PatientScene::Prefetch between steps solves ahead the liver compliance columns the needle
// and the ribs will need: an insertion through the skin and 2 cm into the liver gives the same
// state to the bit with it and without it (prefetch_ahead and prefetch_rib_margin 0), while
// the steps themselves solve far fewer liver columns
TEST(PatientSceneTest, PrefetchMovesTheColumnsOutOfTheStepsAndChangesNothing) {
  for (const char* mesh : {"configs/meshes/liver_700.msh", "configs/meshes/liver_2660.msh"}) {
    DirectScenario s = LoadCoarseScenario();
    s.liver_mesh = ReadGmshMesh(testing::SourcePath(mesh));
    ASSERT_TRUE(s.scene.liver_rest_compliance);
    // the factor refreshes adopted on schedule (when_ready depends on the worker's timing)
    s.scene.liver.refactor_adoption = FactorAdoption::kScheduled;
    ASSERT_GT(s.scene.prefetch_ahead, 0.0);
    ASSERT_GT(s.scene.prefetch_rib_margin, 0.0);
    SceneRig with(s);
    s.scene.prefetch_ahead = 0.0;
    s.scene.prefetch_rib_margin = 0.0;
    SceneRig without(s);
    const double h = s.scene.time_step, speed = 0.02;  // m/s
    int in_step_with = 0, in_step_without = 0, prefetched = 0, steps = 0;
    while (steps < 2000 && (!with.scene->GetTissueStatus(kLiverTissue).punctured ||
                            with.scene->GetTissueStatus(kLiverTissue).depth < 0.02)) {
      const Eigen::Isometry3d X = with.plan.CalcFlangePose(speed * h * ++steps);
      in_step_with += with.scene->Step(X).compliance.num_solved_columns;
      in_step_without += without.scene->Step(X).compliance.num_solved_columns;
      prefetched += with.scene->Prefetch();
      EXPECT_EQ(without.scene->Prefetch(), 0);
      const double diff =
          (with.scene->state().liver.x - without.scene->state().liver.x).cwiseAbs().maxCoeff();
      ASSERT_EQ(diff, 0.0) << mesh << ": differs at step " << steps;
    }
    ASSERT_GE(with.scene->GetTissueStatus(kLiverTissue).depth, 0.02) << mesh;
    EXPECT_EQ(with.scene->state().skin.x, without.scene->state().skin.x) << mesh;
    EXPECT_EQ(with.scene->CalcTipPosition(), without.scene->CalcTipPosition()) << mesh;
    // the skin's columns (its compliance changes every step) are solved in every step either
    // way: 3 per skin point; what differs is the liver's
    std::printf("%s: %d steps; columns solved in the steps %d with prefetch, %d without; %d "
                "prefetched\n", mesh, steps, in_step_with, in_step_without, prefetched);
    EXPECT_GT(prefetched, 0) << mesh;
    EXPECT_LT(in_step_with, in_step_without - prefetched / 2) << mesh;
  }
  // the last-factor compliance changes with every refresh: nothing to prefetch
  DirectScenario s = LoadCoarseScenario();
  s.scene.liver_rest_compliance = false;
  SceneRig rig(s);
  rig.scene->Step(rig.plan.CalcFlangePose(0.0));
  EXPECT_EQ(rig.scene->Prefetch(), 0);
}

TEST(PatientSceneTest, SameSeedSameRun) {
  DirectScenario s = LoadCoarseScenario();
  SceneRig a(s), b(s);
  for (int k = 0; k < 30; ++k) {
    const Eigen::Isometry3d X = a.plan.CalcFlangePose(0.0005 * k);
    a.scene->Step(X);
    b.scene->Step(X);
  }
  EXPECT_EQ(a.scene->state().liver.x, b.scene->state().liver.x);
}

// the InputError text of building a scene from `s`
std::string SceneError(const DirectScenario& s) {
  try {
    SceneRig rig(s);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(PatientSceneTest, BadScenesAreRejectedWithTheKey) {
  DirectScenario s = LoadCoarseScenario();
  s.scene.markers_W[2] = Eigen::Vector3d(0.3, 0, 0);  // 30 cm to the right: outside
  EXPECT_EQ(SceneError(s).rfind("patient.markers[2] = [", 0), 0u) << SceneError(s);

  s = LoadCoarseScenario();
  s.scene.ribs[1].center.y() = 0.0;  // inside the liver
  EXPECT_EQ(SceneError(s).rfind("patient.ribs[1] overlaps the liver at rest", 0), 0u);

  s = LoadCoarseScenario();
  s.scene.liver.young_modulus = -3;
  EXPECT_EQ(SceneError(s), "patient.liver.young_modulus must be > 0 (Pa), got -3");

  s = LoadCoarseScenario();
  s.scene.diaphragm.center.z() = 1.0;  // above the liver
  EXPECT_EQ(SceneError(s), "patient.diaphragm encloses no liver node: breathing would not act");
}

}  // namespace
}  // namespace nsim
