// Point location and surface queries on the committed liver meshes.
#include <benchmark/benchmark.h>

#include <random>
#include <string>
#include <vector>

#include "common/mesh/gmsh_reader.h"
#include "common/mesh/point_locator.h"
#include "common/mesh/mesh_adjacency.h"
#include "common/mesh/surface_locator.h"

namespace nsim {
namespace {

const TetMesh& Liver(int nodes) {
  static const TetMesh liver_700 =
      ReadGmshMesh(std::string(NSIM_SOURCE_DIR) + "/configs/meshes/liver_700.msh");
  static const TetMesh liver_2660 =
      ReadGmshMesh(std::string(NSIM_SOURCE_DIR) + "/configs/meshes/liver_2660.msh");
  static const TetMesh liver_10000 =
      ReadGmshMesh(std::string(NSIM_SOURCE_DIR) + "/configs/meshes/liver_10000.msh");
  return nodes == 700 ? liver_700 : nodes == 2660 ? liver_2660 : liver_10000;
}

// random query points in the mesh's bounding box (about half of them inside the organ)
std::vector<Eigen::Vector3d> Queries(const TetMesh& mesh, int n) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Vector3d lo = mesh.X.rowwise().minCoeff(), hi = mesh.X.rowwise().maxCoeff();
  std::vector<Eigen::Vector3d> points(n);
  for (auto& p : points) p = lo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo);
  return points;
}

void BM_BuildTetLocator(benchmark::State& state) {
  const TetMesh& mesh = Liver(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    TetLocator locator(mesh);
    benchmark::DoNotOptimize(locator);
  }
  state.counters["tets"] = mesh.num_tets();
}
BENCHMARK(BM_BuildTetLocator)
    ->Name("BuildTetLocator")
    ->Arg(700)
    ->Arg(2660)
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond);

void BM_LocatePoint(benchmark::State& state) {
  const TetMesh& mesh = Liver(static_cast<int>(state.range(0)));
  const TetLocator locator(mesh);
  const auto points = Queries(mesh, 4096);
  size_t i = 0;
  int inside = 0;
  for (auto _ : state) {
    const auto found = locator.Locate(points[i++ & 4095]);
    inside += found.has_value();
    benchmark::DoNotOptimize(found);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["inside_fraction"] = static_cast<double>(inside) / state.iterations();
}
BENCHMARK(BM_LocatePoint)->Name("LocatePoint")->Arg(700)->Arg(2660)->Arg(10000);

void BM_LocateClosest(benchmark::State& state) {
  const TetMesh& mesh = Liver(static_cast<int>(state.range(0)));
  const TetLocator locator(mesh);
  const auto points = Queries(mesh, 4096);
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(locator.LocateClosest(points[i++ & 4095]));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_LocateClosest)->Name("LocateClosest")->Arg(2660);

void BM_BuildSurfaceLocator(benchmark::State& state) {
  const TetMesh& mesh = Liver(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    SurfaceLocator surface(mesh);
    benchmark::DoNotOptimize(surface);
  }
}
BENCHMARK(BM_BuildSurfaceLocator)
    ->Name("BuildSurfaceLocator")
    ->Arg(2660)
    ->Unit(benchmark::kMillisecond);

// the same with the owning tets precomputed (MeshAdjacency::surface_tets): the rebuild on each
// step's positions that the needle's contact search does
void BM_BuildSurfaceLocatorWithOwners(benchmark::State& state) {
  const TetMesh& mesh = Liver(static_cast<int>(state.range(0)));
  const std::vector<int> owners = CalcMeshAdjacency(mesh).surface_tets;
  for (auto _ : state) {
    SurfaceLocator surface(mesh, mesh.X, owners);
    benchmark::DoNotOptimize(surface);
  }
}
BENCHMARK(BM_BuildSurfaceLocatorWithOwners)
    ->Name("BuildSurfaceLocatorWithOwners")
    ->Arg(2660)
    ->Unit(benchmark::kMillisecond);

void BM_SurfaceClosest(benchmark::State& state) {
  const TetMesh& mesh = Liver(static_cast<int>(state.range(0)));
  const SurfaceLocator surface(mesh);
  const auto points = Queries(mesh, 4096);
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(surface.Closest(points[i++ & 4095]));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SurfaceClosest)->Name("SurfaceClosest")->Arg(2660);

void BM_SegmentFirstHit(benchmark::State& state) {
  const TetMesh& mesh = Liver(static_cast<int>(state.range(0)));
  const SurfaceLocator surface(mesh);
  // needle-like segments: 10 cm long, from outside the organ towards its centre
  const auto points = Queries(mesh, 4096);
  size_t i = 0;
  for (auto _ : state) {
    const Eigen::Vector3d a = points[i++ & 4095] * 2.0;
    const Eigen::Vector3d b = a - 0.1 * a.normalized();
    benchmark::DoNotOptimize(surface.FirstHit(a, b));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SegmentFirstHit)->Name("SegmentFirstHit")->Arg(2660);

}  // namespace
}  // namespace nsim

BENCHMARK_MAIN();
