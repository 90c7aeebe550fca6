#include "common/fem/fem_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "common/core/error.h"
#include "common/fem/fem_state.h"

namespace nsim {
namespace {

constexpr double kRoundOff = 1e-12;  // relative, sums over a few hundred elements

TetMesh Box() { return MakeBoxTetMesh({5, 4, 6}, {0.04, 0.03, 0.05}, {0.1, -0.2, 0.0}); }

std::string ErrorOf(const TetMesh& mesh, const FemConfig& config, const FemBoundary& boundary) {
  try {
    FemModel model(mesh, config, boundary);
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

TEST(FemModelTest, LumpedMassSumsToDensityTimesVolume) {
  FemConfig config;
  const FemModel model(Box(), config);
  const double volume = 0.04 * 0.03 * 0.05;
  EXPECT_NEAR(model.get_total_mass(), 1060.0 * volume, kRoundOff * 1060.0 * volume);
  EXPECT_NEAR(model.get_lumped_mass().sum(), model.get_total_mass(), kRoundOff * model.get_total_mass());
  EXPECT_TRUE((model.get_lumped_mass().array() > 0).all());
}

TEST(FemModelTest, RejectsBadBoundaryAndConfig) {
  FemConfig config;
  EXPECT_EQ(ErrorOf(Box(), config, {{0, 120}, {}}), "fixed node index must be in [0, 120), got 120");
  EXPECT_EQ(ErrorOf(Box(), config, {{3}, {3}}), "prescribed node 3 is listed twice");
  EXPECT_EQ(ErrorOf(Box(), config, {{-1}, {}}), "fixed node index must be in [0, 120), got -1");
  config.young_modulus = -3;
  EXPECT_EQ(ErrorOf(Box(), config, {}), "fem.young_modulus must be > 0 (Pa), got -3");
  TetMesh flat = Box();
  flat.X.col(flat.tets[7][1]) = flat.X.col(flat.tets[7][0]);
  EXPECT_NE(ErrorOf(flat, FemConfig{}, {}).find("rest volume must be > 0"), std::string::npos);
}

TEST(FemModelTest, DirichletBookkeeping) {
  const TetMesh mesh = Box();
  const FemModel model(mesh, FemConfig{}, {{0, 1, 2}, {10, 11}});
  EXPECT_EQ(model.num_free_nodes(), mesh.num_nodes() - 5);
  EXPECT_EQ(model.get_dirichlet_nodes(), (std::vector<int>{0, 1, 2, 10, 11}));
  EXPECT_EQ(model.get_free_index(0), -1);
  EXPECT_EQ(model.get_free_index(3), 0);
  EXPECT_EQ(model.get_free_nodes()[model.get_free_index(57)], 57);
  const auto& pattern = model.get_system_pattern();
  EXPECT_EQ(pattern.rows(), 3 * model.num_free_nodes());
  // pattern symmetric: every stored (i, j) has a stored (j, i)
  Eigen::MatrixXd dense = Eigen::MatrixXd(pattern);
  Eigen::SparseMatrix<double> ones = pattern;
  for (int k = 0; k < ones.nonZeros(); ++k) ones.valuePtr()[k] = 1.0;
  const Eigen::MatrixXd structure = Eigen::MatrixXd(ones);
  EXPECT_EQ(structure, structure.transpose());
  EXPECT_EQ(dense.norm(), 0.0);
  // every tet touching a Dirichlet node is listed, and no other
  int touching = 0;
  for (const auto& t : mesh.tets) {
    bool any = false;
    for (int a = 0; a < 4; ++a) any |= model.get_free_index(t[a]) < 0;
    touching += any;
  }
  EXPECT_EQ(static_cast<int>(model.get_dirichlet_tets().size()), touching);
}

// patch test: a linear displacement field u = c + G X gives the same strain in every element and
// zero elastic force at interior nodes (the resultant on boundary nodes is the boundary traction)
TEST(FemModelTest, PatchTestLinearFieldGivesConstantStrainAndNoInteriorForce) {
  TetMesh mesh = MakeBoxTetMesh({5, 5, 5}, {0.04, 0.04, 0.04});
  // perturb interior nodes so elements are irregular
  std::vector<bool> boundary(mesh.num_nodes(), false);
  for (const auto& f : mesh.surface)
    for (int a = 0; a < 3; ++a) boundary[f[a]] = true;
  srand(1);
  for (int i = 0; i < mesh.num_nodes(); ++i)
    if (!boundary[i]) mesh.X.col(i) += 0.001 * Eigen::Vector3d::Random();
  const FemModel model(mesh, FemConfig{});
  Eigen::Matrix3d G;
  G << 0.010, 0.004, -0.002,  //
      0.001, -0.006, 0.003,   //
      0.005, 0.002, 0.008;
  FemState state(model);
  state.x = (mesh.X + G * mesh.X).colwise() + Eigen::Vector3d(0.01, 0.02, -0.03);
  const Eigen::Matrix3d F_expected = Eigen::Matrix3d::Identity() + G;
  for (int e = 0; e < model.num_tets(); ++e) {
    Matrix34d xe;
    for (int a = 0; a < 4; ++a) xe.col(a) = state.x.col(mesh.tets[e][a]);
    EXPECT_LT((CalcDeformationGradient(model.get_rest_shapes()[e], xe) - F_expected).norm(), 1e-13);
  }
  const Eigen::Matrix3Xd f = CalcElasticForces(model, state);
  // force scale: E * strain * face area of an element
  const double scale = 5500.0 * G.norm() * 0.01 * 0.01;
  int interior = 0;
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    if (boundary[i]) continue;
    ++interior;
    EXPECT_LT(f.col(i).norm(), 1e-10 * scale) << "node " << i;
  }
  EXPECT_EQ(interior, 27);
  EXPECT_GT(f.norm(), 0.1 * scale);  // the boundary does carry the traction
  EXPECT_LT(f.rowwise().sum().norm(), 1e-10 * scale);  // self-equilibrated
}

}  // namespace
}  // namespace nsim
