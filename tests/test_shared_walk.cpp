// States that lie close together (an edge's, a planner's batch of neighbours) share one walk of
// the world in the batched checks: their answers against brute force, with every option, link
// kind and world rule, when all of the body's links move little and when some move far.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include "core/kernels/pose_boxes.h"
#include "cube_collision/batch.h"
#include "support/batch_world.h"

namespace {

using namespace batchworld;

// Bundles of `per` states: a random body pose (centre within `spread` of the origin, links
// within 1.5 of it) drifting by up to `drift` along a random line over the bundle, each link
// also moved and turned by up to `near` from its place, or by up to `far` for the links from
// `far_from` on (those links walk state by state).
std::vector<fcl::Transform3d> bundles(std::size_t count, std::size_t per, std::size_t links,
                                      std::uint32_t seed, double spread, double drift, double near,
                                      double far = 0, std::size_t far_from = ~std::size_t(0)) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<fcl::Transform3d> poses;
  for (std::size_t b = 0; b < count; ++b) {
    const fcl::Vector3d centre = spread * fcl::Vector3d(u(rng), u(rng), u(rng));
    const fcl::Vector3d line = drift * fcl::Vector3d(u(rng), u(rng), u(rng)).normalized();
    std::vector<fcl::Transform3d> base;
    for (std::size_t l = 0; l < links; ++l) {
      fcl::Transform3d tf = randomPose(rng, 1.5);
      tf.translation() += centre;
      base.push_back(tf);
    }
    for (std::size_t k = 0; k < per; ++k)
      for (std::size_t l = 0; l < links; ++l) {
        const double t = double(k) / double(per);
        const double step = (l >= far_from ? far : near) * t;
        fcl::Transform3d tf = base[l];
        tf.translation() += t * line + step * fcl::Vector3d(u(rng), u(rng), u(rng));
        tf.linear() =
            tf.linear() *
            fcl::AngleAxisd(step * u(rng), fcl::Vector3d(u(rng), u(rng), u(rng) + 2).normalized())
                .toRotationMatrix();
        poses.push_back(tf);
      }
  }
  return poses;
}

class SharedWalkWorlds : public ::testing::TestWithParam<std::tuple<std::size_t, bool>> {};

TEST_P(SharedWalkWorlds, StatesCloseTogetherEqualBruteForce) {
  const auto [n, meshes] = GetParam();
  World w;
  fillWorld(w, n, 40 + std::uint32_t(n), meshes, n < 100);
  const cube::BodySet<S> body = randomBody(9, 6, meshes);
  // All links close together, then the links of the body's later leaves far apart.
  for (const double far : {0.0, 4.0}) {
    const auto poses = bundles(8, 16, body.size(), meshes ? 4 : 3, n < 100 ? 2 : 10, 1.5, 0.1, far,
                               far > 0 ? 4 : ~std::size_t(0));
    // (self-collision, first pair; clearance without it), on one thread and on three.
    for (const auto& [self, first, threads] :
         {std::tuple{false, false, 1}, std::tuple{true, true, 3}, std::tuple{true, false, 3}}) {
      cube::BatchOptions o;
      o.self_collision = self;
      o.first_pair = first;
      o.clearance = !first;
      o.threads = threads;
      std::size_t hits = 0;
      expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits);
      // The scene must exercise both answers.
      EXPECT_GT(hits, 2u);
      EXPECT_LT(hits, poses.size() / body.size() - 2);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(SharedWalk, SharedWalkWorlds,
                         ::testing::Combine(::testing::Values(std::size_t(60), std::size_t(400)),
                                            ::testing::Bool()));

TEST(SharedWalk, MarginsFilterBitsAndThePredicate) {
  World w;
  fillWorld(w, 300, 23, false, true);
  w.manager.setMargin(0.05);
  for (std::size_t i = 0; i < w.objects.size(); i += 3)
    w.manager.setMargin(w.objects[i].get(), 0.2);
  for (std::size_t i = 0; i < w.objects.size(); i += 4)
    w.manager.setFilter(w.objects[i].get(), 2, ~0ull);
  std::mt19937 rng(8);
  cube::BodySet<S> body;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> bits;
  for (std::size_t l = 0; l < 7; ++l) {
    const std::uint64_t mask = l % 2 ? ~std::uint64_t(2) : ~std::uint64_t(0);
    body.addLink(randomShape(rng, 1.0, false), l % 3 == 0 ? 0.3 : 0.0, 1, mask);
    bits.emplace_back(1, mask);
  }
  body.excludePair(0, 1);
  body.excludePair(2, 5);
  const auto poses = bundles(6, 30, body.size(), 9, 8, 1.5, 0.1);
  cube::BatchOptions o;
  o.self_collision = true;
  o.threads = 1;
  for (const bool first : {false, true}) {
    o.first_pair = first;
    o.clearance = !first;
    std::size_t hits = 0;
    expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, &hits, nullptr,
               bits);
    EXPECT_GT(hits, 10u);
  }
  // With a pair predicate every state walks on its own: the same answers.
  const std::function<bool(Object*, Object*)> keep = [](Object* a, Object*) {
    return a->getTranslation()[0] >= 0;
  };
  w.manager.setPairFilter(keep);
  o.first_pair = true;
  o.clearance = false;
  expectSame(cube::checkStates(w.manager, body, poses, o), w, body, poses, o, nullptr, keep, bits);
}

// Edges of small steps (a planner's resolution) in both orders: the serial scan's answer of
// brute force, for every thread count, from the array and from poses written on demand.
TEST(SharedWalk, EdgesOfSmallStepsGiveTheSerialScansAnswer) {
  World w;
  fillWorld(w, 150, 17, true, true);
  const cube::BodySet<S> body = randomBody(8, 12, true);
  const std::size_t per = 45;
  const auto poses = bundles(12, per, body.size(), 21, 12, 3, 0.3);
  std::vector<std::size_t> starts;
  for (std::size_t e = 0; e < 12; ++e) starts.push_back(e * per);
  cube::BatchOptions o;  // without self-collision: links placed at random overlap
  std::vector<bool> colliding;
  for (std::size_t k = 0; k < poses.size() / body.size(); ++k)
    colliding.push_back(brute(w, body, poses.data() + k * body.size(), false).colliding);
  std::size_t free_edges = 0;
  for (const auto order : {cube::MotionOrder::path, cube::MotionOrder::bisection})
    for (const int t : {1, 2, 8}) {
      o.threads = t;
      const auto first = cube::checkMotions(w.manager, body, poses, starts, order, o);
      free_edges = 0;
      for (std::size_t e = 0; e < starts.size(); ++e) {
        std::size_t want = cube::kNoIndex;
        for (const std::size_t i : visitOrder(per, order))
          if (colliding[starts[e] + i]) {
            want = i;
            break;
          }
        EXPECT_EQ(first[e], want) << "edge " << e;
        free_edges += want == cube::kNoIndex;
        const cube::PoseFunction<S> pose_of = [&](std::size_t k, fcl::Transform3d* out) {
          std::copy_n(poses.begin() + long((starts[e] + k) * body.size()), body.size(), out);
        };
        EXPECT_EQ(cube::checkMotion(w.manager, body, per, pose_of, order, o), want);
      }
    }
  EXPECT_GT(free_edges, 1u);
  EXPECT_LT(free_edges, 11u);
}

TEST(SharedWalk, WalkBoxesKernelsAgreeBitForBit) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-50, 50), pos(0, 3), m(0, 0.5);
  for (const std::size_t n : {1, 3, 4, 5, 30, 33}) {
    std::vector<double> c[3], h[3], margin, grow[2], lo[2][3], hi[2][3];
    for (std::size_t k = 0; k < n; ++k) {
      for (int d = 0; d < 3; ++d) {
        c[d].push_back(u(rng));
        h[d].push_back(pos(rng));
      }
      margin.push_back(k % 2 ? m(rng) : 0.0);
    }
    for (int v = 0; v < 2; ++v) {
      grow[v].assign(n, 0);
      for (int d = 0; d < 3; ++d) {
        lo[v][d].assign(n, 0);
        hi[v][d].assign(n, 0);
      }
    }
    const auto io = [&](int v) {
      return cube::detail::WalkBoxes<double>{{c[0].data(), c[1].data(), c[2].data()},
                                             {h[0].data(), h[1].data(), h[2].data()},
                                             margin.data(),
                                             1e-6,
                                             grow[v].data(),
                                             {lo[v][0].data(), lo[v][1].data(), lo[v][2].data()},
                                             {hi[v][0].data(), hi[v][1].data(), hi[v][2].data()}};
    };
    EXPECT_TRUE(cube::detail::walkBoxes(n, io(0)));
    EXPECT_TRUE(cube::detail::walkBoxesPortable(n, io(1)));
    for (std::size_t k = 0; k < n; ++k) {
      const double reach = std::max({std::abs(c[0][k]), std::abs(c[1][k]), std::abs(c[2][k])}) +
                           std::max({h[0][k], h[1][k], h[2][k]});
      EXPECT_EQ(grow[0][k], grow[1][k]);
      EXPECT_EQ(grow[0][k], 1e-6 * (1 + reach));
      for (int d = 0; d < 3; ++d) {
        EXPECT_EQ(lo[0][d][k], lo[1][d][k]);
        EXPECT_EQ(hi[0][d][k], hi[1][d][k]);
        EXPECT_EQ(lo[0][d][k], c[d][k] - h[d][k] - (grow[0][k] + margin[k]));
        EXPECT_EQ(hi[0][d][k], c[d][k] + h[d][k] + (grow[0][k] + margin[k]));
      }
    }
    // A NaN or infinite entry anywhere is reported by every version.
    for (const double bad : {std::nan(""), HUGE_VAL}) {
      c[1][n / 2] = bad;
      EXPECT_FALSE(cube::detail::walkBoxes(n, io(0)));
      EXPECT_FALSE(cube::detail::walkBoxesPortable(n, io(1)));
      c[1][n / 2] = 0;
      h[2][n - 1] = bad;
      EXPECT_FALSE(cube::detail::walkBoxes(n, io(0)));
      EXPECT_FALSE(cube::detail::walkBoxesPortable(n, io(1)));
      h[2][n - 1] = 1;
    }
  }
}

}  // namespace
