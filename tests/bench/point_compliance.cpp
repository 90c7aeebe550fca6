// point_compliance: how stiffly a liver mesh holds a needle point, along the planned path.
// A diagnostic of the needle-tissue coupling (README "Where the registration error comes
// from"): the coupling holds the tissue at material points (one tet's barycentric point per
// trajectory point and at the tip), so the force a needle displacement costs is set by the
// point's compliance w = h^2 d^T H A_0^-1 H^T d (m/N, the constraint solve's diagonal,
// constraint_solver.h, with the rest compliance of both scenes), and that compliance belongs
// to the mesh: a point load in 3D has no converged discrete compliance (it grows like 1 / the
// element size).
//
//   point_compliance --config SCENARIO.yaml [--patient-meshes A.msh,B.msh] [--step 0.0025]
//
// For every depth s (m, from the planned entry towards the target and 5 mm past it) inside
// each liver, prints w along the two lateral directions and the axial one: the patient's liver
// (the scenario's mesh, its diaphragm box prescribed and its anchor boxes fixed) and every
// mesh of --patient-meshes with the same boxes; the controller's model (inverse.mesh, built
// as the controller builds it: MakeModelLiver, free but for inverse.anchors and the markers)
// as w and as the compliance left once the markers are held (the Schur complement of the
// marker rows, as in the model's step). Then the mean of each over the depths that all
// meshes share.
#include <Eigen/Dense>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "common/core/cli.h"
#include "common/core/error.h"
#include "common/fem/fem_model.h"
#include "common/fem/fem_solver.h"
#include "common/mesh/gmsh_reader.h"
#include "common/mesh/point_locator.h"
#include "common/scene/patient_scene.h"
#include "common/steering/steering_simulation.h"
#include "direct_sim/scenario_loader.h"
#include "inverse_sim/scenario_loader.h"

namespace nsim {
namespace {

struct Column {
  std::string name;
  std::vector<double> depth;            // m
  std::vector<Eigen::Vector3d> w;       // lateral 1, lateral 2, axial (m/N)
  std::vector<Eigen::Vector2d> w_held;  // lateral, markers held (model only)
};

// adds the rows of the material point `p` along `d` to column c of H (3n x k)
void AddPointRow(const TetMesh& mesh, const TetPoint& p, const Eigen::Vector3d& d, int c,
                 Eigen::MatrixXd& H) {
  for (int k = 0; k < 4; ++k) H.block<3, 1>(3 * mesh.tets[p.tet][k], c) += p.bary[k] * d;
}

Column Probe(const std::string& name, const FemModel& model, const SharedScenario& plan,
             double step, bool hold_markers) {
  const TetMesh& mesh = model.get_mesh();
  FemConfig config = model.get_config();
  const TetLocator locator(mesh);
  const Eigen::Vector3d z = (plan.target_W - plan.entry_W).normalized();
  const Eigen::Vector3d d1 = z.cross(Eigen::Vector3d::UnitX()).normalized(), d2 = z.cross(d1);
  Column column{name, {}, {}, {}};
  std::vector<TetPoint> points;
  const double length = (plan.target_W - plan.entry_W).norm() + 0.005;
  for (int i = 0; i * step <= length; ++i) {
    const std::optional<TetPoint> p = locator.Locate(plan.entry_W + i * step * z);
    if (!p) continue;
    points.push_back(*p);
    column.depth.push_back(i * step);
  }
  std::vector<TetPoint> markers;
  if (hold_markers)
    for (const Eigen::Vector3d& m : plan.markers_W) {
      const std::optional<TetPoint> p = locator.Locate(m);
      if (!p) throw InputError(Str(name, ": a marker is outside the mesh"));
      markers.push_back(*p);
    }
  const int nm = 3 * static_cast<int>(markers.size());
  const int cols = nm + 3 * static_cast<int>(points.size());
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(3 * mesh.num_nodes(), cols);
  for (size_t m = 0; m < markers.size(); ++m)
    for (int a = 0; a < 3; ++a) AddPointRow(mesh, markers[m], Eigen::Vector3d::Unit(a), 3 * m + a, H);
  for (size_t j = 0; j < points.size(); ++j) {
    const int c = nm + 3 * static_cast<int>(j);
    AddPointRow(mesh, points[j], d1, c, H);
    AddPointRow(mesh, points[j], d2, c + 1, H);
    AddPointRow(mesh, points[j], z, c + 2, H);
  }
  config.background_refactor = false;
  const FemModel copy(mesh, config, FemBoundary{model.get_fixed_nodes(), model.get_prescribed_nodes()});
  FemSolver solver(copy);
  Eigen::MatrixXd X;
  solver.ApplyInverse(H, X, FemInverse::kRestFactor);
  const double h = config.time_step;
  const Eigen::MatrixXd W = h * h * H.transpose() * X;
  Eigen::MatrixXd held = W.bottomRightCorner(cols - nm, cols - nm);
  if (nm > 0) {
    const Eigen::MatrixXd Wmn = W.topRightCorner(nm, cols - nm);
    held -= Wmn.transpose() * W.topLeftCorner(nm, nm).ldlt().solve(Wmn);
  }
  for (size_t j = 0; j < points.size(); ++j) {
    const int c = nm + 3 * static_cast<int>(j), o = 3 * static_cast<int>(j);
    column.w.emplace_back(W(c, c), W(c + 1, c + 1), W(c + 2, c + 2));
    column.w_held.emplace_back(held(o, o), held(o + 1, o + 1));
  }
  return column;
}

int Run(int argc, char** argv) {
  CommandLine cli("point_compliance --config SCENARIO.yaml [--patient-meshes A.msh,B.msh] [--step S]",
                  "Compliance of needle points along the planned path, patient and model livers");
  cli.Option("config", "SCENARIO", "scenario YAML", "", true)
      .Option("patient-meshes", "A.msh,B.msh", "more patient liver meshes (the scenario's boxes)")
      .Number("step", "S", "depth step (m)", "0.0025", 1e-4, 0.02);
  if (!cli.ParseOrPrintHelp(argc, argv, 1)) return 0;
  const std::string scenario = cli.GetString("config");
  std::vector<std::string> extra;
  if (cli.Has("patient-meshes")) {
    std::stringstream list(cli.GetString("patient-meshes"));
    for (std::string path; std::getline(list, path, ',');)
      if (!path.empty()) extra.push_back(path);
  }
  const double step = cli.GetDouble("step");

  const DirectScenario direct = LoadDirectScenario(scenario);
  const InverseScenario inverse = LoadInverseScenario(scenario);
  std::vector<Column> columns;
  auto patient = [&](const std::string& name, const TetMesh& mesh) {
    const PatientSceneModel scene(direct.scene, mesh, direct.skin_mesh);
    columns.push_back(Probe(name, scene.liver(), direct.shared, step, false));
  };
  patient("patient " + direct.liver_mesh_path, direct.liver_mesh);
  for (const std::string& path : extra) {
    TetMesh mesh;
    try {
      mesh = ReadGmshMesh(path);
    } catch (const InputError& e) {
      throw InputError(Str("--patient-meshes: ", e.what()));
    }
    patient("patient " + path, mesh);
  }
  const TetMesh model_mesh = ReadGmshMesh(inverse.mesh_path);
  const std::unique_ptr<FemModel> model = MakeModelLiver(inverse.loop.model, model_mesh);
  columns.push_back(Probe("model " + inverse.mesh_path, *model, inverse.shared, step, true));

  std::printf("# lateral compliance h^2 d^T H A_0^-1 H^T d of a needle point (1e-3 m/N): lateral 1 / 2 (/ "
              "markers held, model)\n");
  for (const Column& c : columns) std::printf("# %s\n", c.name.c_str());
  std::printf("depth_mm");
  for (size_t k = 0; k < columns.size(); ++k) std::printf("  liver%zu_w1  liver%zu_w2", k, k);
  std::printf("  model_held_w1  model_held_w2\n");
  std::vector<Eigen::Vector4d> sums(columns.size(), Eigen::Vector4d::Zero());
  int shared_rows = 0;
  for (size_t j = 0; j < columns[0].depth.size(); ++j) {
    const double s = columns[0].depth[j];
    std::vector<int> row;
    for (const Column& c : columns) {
      int found = -1;
      for (size_t q = 0; q < c.depth.size(); ++q)
        if (std::abs(c.depth[q] - s) < 1e-9) found = static_cast<int>(q);
      row.push_back(found);
    }
    bool all = true;
    for (int f : row) all = all && f >= 0;
    if (!all) continue;
    ++shared_rows;
    std::printf("%8.1f", 1e3 * s);
    for (size_t k = 0; k < columns.size(); ++k) {
      const Eigen::Vector3d& w = columns[k].w[row[k]];
      std::printf("  %9.3f  %9.3f", 1e3 * w[0], 1e3 * w[1]);
      sums[k].head<3>() += w;
      sums[k][3] += columns[k].w_held[row[k]].mean();
    }
    const Eigen::Vector2d& held = columns.back().w_held[row.back()];
    std::printf("  %13.3f  %13.3f\n", 1e3 * held[0], 1e3 * held[1]);
  }
  if (shared_rows == 0) throw InputError("no depth along the path lies inside every liver");
  std::printf("# mean over %d shared depths (1e-3 m/N): lateral, axial\n", shared_rows);
  for (size_t k = 0; k < columns.size(); ++k)
    std::printf("# %-50s lateral %.3f  axial %.3f%s\n", columns[k].name.c_str(),
                1e3 * (sums[k][0] + sums[k][1]) / (2 * shared_rows), 1e3 * sums[k][2] / shared_rows,
                k + 1 == columns.size()
                    ? Str("  markers held: lateral ", 1e3 * sums[k][3] / shared_rows).c_str()
                    : "");
  return 0;
}

}  // namespace
}  // namespace nsim

int main(int argc, char** argv) {
  try {
    return nsim::Run(argc, argv);
  } catch (const nsim::InputError& e) {
    std::cerr << "point_compliance: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "point_compliance: " << e.what() << "\n";
    return 1;
  }
}
