// The posed boxes of a batch's links: the vector kernels equal the portable version bit for bit,
// and the exact box.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/kernels/pose_boxes.h"
#include "cube_collision/batch.h"
#include "support/batch_world.h"

namespace {

using namespace batchworld;

// The posed boxes of the links (AVX2 where the CPU has it) equal the portable version bit for
// bit, and the exact box: c = R mid + t, h = |R| half.
TEST(Batch, PoseBoxesKernelsAgree) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-5, 5), pos(0, 2);
  for (const std::size_t n :
       {std::size_t(1), std::size_t(3), std::size_t(4), std::size_t(30), std::size_t(33)}) {
    std::vector<fcl::Transform3d> poses;
    std::vector<double> mid[3], half[3], c[2][3], h[2][3];
    for (std::size_t k = 0; k < n; ++k) {
      poses.push_back(randomPose(rng, 50));
      for (int d = 0; d < 3; ++d) {
        mid[d].push_back(u(rng));
        half[d].push_back(pos(rng));
      }
    }
    for (int v = 0; v < 2; ++v)
      for (int d = 0; d < 3; ++d) {
        c[v][d].assign(n, 0);
        h[v][d].assign(n, 0);
      }
    const auto io = [&](int v) {
      return cube::detail::PoseBoxes<double>{{mid[0].data(), mid[1].data(), mid[2].data()},
                                             {half[0].data(), half[1].data(), half[2].data()},
                                             {c[v][0].data(), c[v][1].data(), c[v][2].data()},
                                             {h[v][0].data(), h[v][1].data(), h[v][2].data()}};
    };
    cube::detail::poseBoxes(poses.data()->data(), n, io(0));
    cube::detail::poseBoxesPortable(poses.data()->data(), n, io(1));
    for (std::size_t k = 0; k < n; ++k) {
      const fcl::Vector3d m(mid[0][k], mid[1][k], mid[2][k]),
          hf(half[0][k], half[1][k], half[2][k]);
      const fcl::Vector3d want_c = poses[k].linear() * m + poses[k].translation();
      const fcl::Vector3d want_h = poses[k].linear().cwiseAbs() * hf;
      for (int d = 0; d < 3; ++d) {
        EXPECT_EQ(c[0][d][k], c[1][d][k]);
        EXPECT_EQ(h[0][d][k], h[1][d][k]);
        EXPECT_NEAR(c[0][d][k], want_c[d], 1e-9);
        EXPECT_NEAR(h[0][d][k], want_h[d], 1e-9);
      }
    }
  }
}

}  // namespace
