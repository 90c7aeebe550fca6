#include "common/mesh/aabb_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

namespace nsim {
namespace {

std::vector<Eigen::AlignedBox3d> RandomBoxes(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::AlignedBox3d> boxes;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d lo(u(rng), u(rng), u(rng));
    const Eigen::Vector3d size = 0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    boxes.emplace_back(lo, lo + size);
  }
  return boxes;
}

TEST(AabbTree, ContainmentMatchesBruteForce) {
  std::mt19937 rng(2);
  const auto boxes = RandomBoxes(500, rng);
  const AabbTree tree(boxes);
  EXPECT_EQ(tree.num_primitives(), 500);
  std::uniform_real_distribution<double> u(-0.1, 1.1);
  for (int q = 0; q < 300; ++q) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    std::set<int> expected, found;
    for (int i = 0; i < 500; ++i)
      if (boxes[i].contains(p)) expected.insert(i);
    EXPECT_FALSE(tree.VisitContaining(p, [&](int i) {
      EXPECT_TRUE(found.insert(i).second) << "visited twice";
      return false;
    }));
    EXPECT_EQ(found, expected);
  }
}

TEST(AabbTree, NearestMatchesBruteForce) {
  std::mt19937 rng(3);
  const auto boxes = RandomBoxes(300, rng);
  const AabbTree tree(boxes);
  std::uniform_real_distribution<double> u(-0.5, 1.5);
  for (int q = 0; q < 300; ++q) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    // primitive = the centre of each box
    auto dist = [&](int i, double) { return (boxes[i].center() - p).squaredNorm(); };
    double best_sq = 0;
    const int best = tree.FindNearest(p, dist, &best_sq);
    double expected = 1e300;
    for (int i = 0; i < 300; ++i) expected = std::min(expected, dist(i, 0));
    ASSERT_GE(best, 0);
    EXPECT_EQ(best_sq, expected);
    EXPECT_EQ(dist(best, 0), expected);
  }
}

TEST(AabbTree, RayVisitsEveryBoxItCrosses) {
  std::mt19937 rng(4);
  const auto boxes = RandomBoxes(400, rng);
  const AabbTree tree(boxes);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d origin =
        Eigen::Vector3d(0.5, 0.5, 0.5) + Eigen::Vector3d(u(rng), u(rng), u(rng));
    Eigen::Vector3d dir(u(rng), u(rng), u(rng));
    if (q % 10 == 0) dir = Eigen::Vector3d(0, 0, 1);  // axis-parallel rays too
    const double t_max = 1.5;
    std::set<int> visited;
    double limit = t_max;
    tree.VisitRay(origin, dir, &limit, [&](int i, double*) { visited.insert(i); });
    // brute force: sample densely along the ray
    for (int i = 0; i < 400; ++i) {
      bool crosses = false;
      for (int s = 0; s <= 3000 && !crosses; ++s)
        crosses = boxes[i].contains(origin + (t_max * s / 3000) * dir);
      if (crosses) {
        EXPECT_TRUE(visited.count(i)) << "box " << i << " missed by ray " << q;
      }
    }
  }
}

TEST(AabbTree, EmptyTree) {
  const AabbTree tree{std::vector<Eigen::AlignedBox3d>()};
  EXPECT_TRUE(tree.empty());
  double d = 0;
  EXPECT_EQ(tree.FindNearest(
                Eigen::Vector3d::Zero(), [](int, double) { return 0.0; }, &d),
            -1);
  EXPECT_FALSE(tree.VisitContaining(Eigen::Vector3d::Zero(), [](int) { return true; }));
}

}  // namespace
}  // namespace nsim
