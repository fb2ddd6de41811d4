// The tree the manager builds: degenerate scenes, every cube split at its median, leaves and depth
// as Config asks, and Config's checks of its knobs; answers stay brute force's.

#include <gtest/gtest.h>

#include "support/semantics_world.h"

namespace cube {
namespace testing {
namespace {

using namespace semantics_world;

// Degenerate inputs where median splits tie: identical boxes, zero-size boxes at one point, and
// points on a line. Every pair is still reported once and the leaves still respect leaf_size.
TYPED_TEST(Semantics, DegenerateScenesIdenticalAndZeroSizeBoxes) {
  using S = TypeParam;
  std::vector<std::pair<V3<S>, V3<S>>> same, points, line;
  for (int i = 0; i < 120; ++i) {
    same.emplace_back(V3<S>(1, 2, 3), V3<S>(4, 5, 6));
    points.emplace_back(V3<S>(7, 7, 7), V3<S>(7, 7, 7));
    line.emplace_back(V3<S>(S(i), 0, 0), V3<S>(S(i), 0, 0));  // touching nothing
  }
  for (const auto* corners : {&same, &points, &line}) {
    auto objs = boxes<S>(*corners);
    const auto ptrs = raw(objs);
    const auto brute = oracle::bruteSelfPairs(ptrs);
    for (int leaf_size : {1, 4}) {
      CubeCollisionManager<S> cube(Config{0, leaf_size});
      cube.registerObjects(ptrs);
      cube.setup();
      ASSERT_TRUE(valid(cube));
      for (const auto& [c, depth] : liveCubes(::cube::detail::coreOf(cube).tree())) {
        const auto& n = ::cube::detail::coreOf(cube).tree().nodes()[c];
        if (n.isLeaf()) {
          EXPECT_LE(n.count, std::uint32_t(leaf_size)) << "depth " << depth;
        }
      }
      EXPECT_EQ(oracle::selfPairs<S>(cube), brute);
      EXPECT_EQ(cubeObjectCalls<S>(cube, ptrs[17]), bruteCrossPairs<S>(ptrs, {ptrs[17]}));
      // Removing half and adding them back one by one keeps everything.
      for (std::size_t i = 0; i < ptrs.size(); i += 2) cube.unregisterObject(ptrs[i]);
      for (std::size_t i = 0; i < ptrs.size(); i += 2) cube.registerObject(ptrs[i]);
      ASSERT_TRUE(valid(cube));
      EXPECT_EQ(oracle::selfPairs<S>(cube), brute);
    }
    if (corners != &line) {
      EXPECT_EQ(brute.size(), ptrs.size() * (ptrs.size() - 1) / 2);
    } else {
      EXPECT_TRUE(brute.empty());
    }
  }
}

// The first build splits every cube at its median object along its longest side, by centre
// (the sum of the float bounds, ties by registration order), and each cube's bounds are exactly
// the union of its objects' rounded boxes. Large enough that the selection samples its pivots,
// on inputs that defeat poor pivots: sorted either way, all equal, few distinct centres.
TYPED_TEST(Semantics, BuildSplitsEveryCubeAtItsMedian) {
  using S = TypeParam;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  std::vector<std::vector<std::pair<V3<S>, V3<S>>>> inputs(5);
  for (int i = 0; i < 3000; ++i) {
    const S x = S(i) * S(0.5);
    inputs[0].emplace_back(V3<S>(x, 0, 0), V3<S>(x + 1, 1, 1));                // ascending
    inputs[1].emplace_back(V3<S>(-x, 0, 0), V3<S>(-x + 1, 1, 1));              // descending
    inputs[2].emplace_back(V3<S>(1, 2, 3), V3<S>(4, 5, 6));                    // all equal
    inputs[3].emplace_back(V3<S>(S(i % 3), 0, 0), V3<S>(S(i % 3) + 1, 1, 1));  // 3 centres
    inputs[4].emplace_back(V3<S>(0, S(i % 7), -x), V3<S>(1, S(i % 7) + 1, -x + 2));
  }
  auto uniform = scene<S>(4000);
  std::vector<std::vector<Obj<S>*>> sets;
  std::vector<std::vector<std::unique_ptr<TestObject<S>>>> owned;
  for (const auto& corners : inputs) {
    owned.push_back(boxes<S>(corners));
    sets.push_back(raw(owned.back()));
  }
  sets.push_back(uniform.pointers());
  for (int leaf_size : {1, 4, 7}) {
    for (const auto& ptrs : sets) {
      CubeCollisionManager<S> cube(Config{0, leaf_size});
      cube.registerObjects(ptrs);
      cube.setup();
      ASSERT_TRUE(valid(cube));
      const auto& t = ::cube::detail::coreOf(cube).tree();
      const auto& nodes = t.nodes();
      const auto& items = t.items();
      // Each cube's object range, children before parents (children have larger indices).
      std::vector<std::pair<std::uint32_t, std::uint32_t>> range(nodes.size());
      std::size_t internal = 0;
      for (std::size_t i = nodes.size(); i-- > 0;) {
        const auto& n = nodes[i];
        if (n.isLeaf()) {
          range[i] = {n.first, n.first + n.count};
          continue;
        }
        ++internal;
        const auto l = range[n.first], r = range[n.first + 1];
        ASSERT_EQ(l.second, r.first) << "children of " << i << " not adjacent";
        range[i] = {l.first, r.second};
      }
      ASSERT_EQ(range[t.root()], std::make_pair(0u, std::uint32_t(ptrs.size())));
      ASSERT_GT(internal, 0u);
      for (std::size_t i = 0; i < nodes.size(); ++i) {
        const auto& n = nodes[i];
        // Bounds: exactly the union of the objects' rounded boxes.
        float lo[3] = {kInf, kInf, kInf}, hi[3] = {-kInf, -kInf, -kInf};
        for (std::uint32_t p = range[i].first; p < range[i].second; ++p) {
          float a[3], b[3];
          detail::roundOut(items[p].box, a, b);
          for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], a[k]);
            hi[k] = std::max(hi[k], b[k]);
          }
        }
        for (int k = 0; k < 3; ++k) {
          ASSERT_EQ(n.lo[k], lo[k]) << "cube " << i;
          ASSERT_EQ(n.hi[k], hi[k]) << "cube " << i;
        }
        if (n.isLeaf()) continue;
        int axis = 0;
        for (int k = 1; k < 3; ++k)
          if (double(hi[k]) - lo[k] > double(hi[axis]) - lo[axis]) axis = k;
        auto key = [&](std::uint32_t p) {
          float a[3], b[3];
          detail::roundOut(items[p].box, a, b);
          const float c = a[axis] + b[axis];
          return std::make_pair(c == c ? c : 0.0f,
                                ::cube::detail::coreOf(cube).table().seq(items[p].id));
        };
        const std::uint32_t count = range[i].second - range[i].first;
        const std::uint32_t split = range[n.first].second - range[i].first;
        const std::uint32_t full = (count / 2 + leaf_size - 1) / leaf_size * leaf_size;
        ASSERT_EQ(split, full < count ? full : count / 2) << "cube " << i;
        auto left_max = key(range[i].first), right_min = key(range[i].first + split);
        for (std::uint32_t p = range[i].first; p < range[i].first + split; ++p)
          left_max = std::max(left_max, key(p));
        for (std::uint32_t p = range[i].first + split; p < range[i].second; ++p)
          right_min = std::min(right_min, key(p));
        ASSERT_LT(left_max, right_min) << "cube " << i << " is not split at its median";
      }
    }
  }
}

// Leaves hold at most leaf_size objects when depth is not capped; with max_depth k no cube is
// deeper than k, cubes at depth k may hold more, and results do not change.
TYPED_TEST(Semantics, LeafSizeAndMaxDepthShapeTheTree) {
  using S = TypeParam;
  auto sc = scene<S>(1000, 91, scenes::Layout::clustered);
  const auto objs = sc.pointers();
  const auto brute = oracle::bruteSelfPairs(objs);
  for (int leaf_size : {1, 4, 16}) {
    for (int max_depth : {0, 1, 3, 6}) {
      SCOPED_TRACE("leaf_size " + std::to_string(leaf_size) + " max_depth " +
                   std::to_string(max_depth));
      Config cfg;
      cfg.leaf_size = leaf_size;
      cfg.max_depth = max_depth;
      for (bool incremental : {false, true}) {
        CubeCollisionManager<S> cube(cfg);
        if (incremental) {
          cube.registerObjects(std::vector<Obj<S>*>(objs.begin(), objs.begin() + 100));
          cube.setup();
          for (std::size_t i = 100; i < objs.size(); ++i) cube.registerObject(objs[i]);
        } else {
          cube.registerObjects(objs);
          cube.setup();
        }
        ASSERT_TRUE(valid(cube));
        const auto& t = ::cube::detail::coreOf(cube).tree();
        int deepest = 0;
        std::size_t crowded = 0, in_leaves = 0;
        for (const auto& [c, depth] : liveCubes(t)) {
          ASSERT_EQ(depthOf(t, c), depth) << "parent links disagree with the child links";
          deepest = std::max(deepest, depth);
          const auto& n = t.nodes()[c];
          if (!n.isLeaf()) continue;
          in_leaves += n.count;
          if (n.count > std::uint32_t(leaf_size)) {
            ++crowded;
            EXPECT_EQ(depth, max_depth) << "a crowded leaf above the depth cap";
          }
        }
        EXPECT_EQ(in_leaves, objs.size());
        if (max_depth > 0) {
          EXPECT_LE(deepest, max_depth);
          // 1000 objects do not fit in 2^k leaves of this size: the cap must bite.
          if ((std::size_t(1) << max_depth) * leaf_size < objs.size()) {
            EXPECT_EQ(deepest, max_depth);
            EXPECT_GT(crowded, 0u);
          }
        } else {
          EXPECT_EQ(crowded, 0u);
        }
        EXPECT_EQ(oracle::selfPairs<S>(cube), brute);
      }
    }
  }
}

// Config::check rejects out-of-range knobs, and so does the constructor.
TEST(Config, CheckRejectsOutOfRangeKnobs) {
  EXPECT_NO_THROW(Config().check());
  Config c;
  c.leaf_size = 0;
  EXPECT_THROW(c.check(), std::invalid_argument);
  EXPECT_THROW(CubeCollisionManagerd{c}, std::invalid_argument);
  c = Config();
  c.max_depth = -1;
  EXPECT_THROW(c.check(), std::invalid_argument);
  EXPECT_THROW(CubeCollisionManagerf{c}, std::invalid_argument);
  c = Config();
  c.rebuild_threshold = 1.0;
  EXPECT_THROW(c.check(), std::invalid_argument);
  c = Config();
  c.all_pairs_limit = Config::kMaxAllPairsLimit + 1;
  EXPECT_THROW(c.check(), std::invalid_argument);
  c.all_pairs_limit = Config::kMaxAllPairsLimit;
  EXPECT_NO_THROW(c.check());
  c = Config();
  c.leaf_size = 1;
  c.max_depth = 1;
  EXPECT_NO_THROW(c.check());
}

}  // namespace
}  // namespace testing
}  // namespace cube
