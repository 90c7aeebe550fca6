#include "common/fem/tet_lanes.h"

#include "common/core/error.h"
#include "common/fem/corotational.h"

namespace nsim {

TetBlocks MakeTetBlocks(const std::vector<Eigen::Vector4i>& tets,
                        const std::vector<TetRestShape>& rest) {
  NSIM_CHECK(tets.size() == rest.size(), "MakeTetBlocks: ", tets.size(), " tets but ",
             rest.size(), " rest shapes");
  TetBlocks blocks;
  blocks.num_tets = static_cast<int>(tets.size());
  const int count = (blocks.num_tets + kTetLanes - 1) / kTetLanes;
  blocks.nodes.resize(count);
  blocks.volume.assign(count, TetLanes::Zero());
  TetLanes34 zero;
  zero.fill(TetLanes::Zero());
  blocks.grad.assign(count, zero);
  for (int b = 0; b < count; ++b)
    for (int l = 0; l < kTetLanes; ++l) {
      const int e = kTetLanes * b + l;
      if (e >= blocks.num_tets) {
        blocks.nodes[b][l] = blocks.nodes[b][0];  // padding: zero volume and gradients
        continue;
      }
      blocks.nodes[b][l] = tets[e];
      blocks.volume[b][l] = rest[e].volume;
      for (int i = 0; i < 12; ++i) blocks.grad[b][i][l] = rest[e].grad_n(i);
    }
  return blocks;
}

}  // namespace nsim
