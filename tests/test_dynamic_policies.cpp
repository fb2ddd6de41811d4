// The update policies rebuild when they should and only then; a no-motion update keeps the
// callback order; batch builds keep no slack. Answers stay brute force's throughout.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/rebuild_policy.h"
#include "support/dynamic_world.h"

namespace cube {
namespace testing {
namespace {

using namespace dynamic_world;

// The automatic policy rebuilds once objects are scattered far from where the tree was built,
// bringing the tree quality back within the threshold (near it when each object is updated by a
// call of its own), and does not rebuild on small jitter.
TYPED_TEST(Dynamic, AutomaticPolicyRebuildsOnScatterNotOnJitter) {
  using S = TypeParam;
  for (Variant variant : {Variant::all, Variant::single, Variant::vector}) {
    SCOPED_TRACE(name(variant));
    auto sc = scene<S>(1000, 111);
    const auto objs = sc.pointers();
    CubeCollisionManager<S> cube;
    cube.registerObjects(objs);
    cube.setup();
    const auto& t = ::cube::detail::coreOf(cube).tree();
    const double threshold = cube.config().rebuild_threshold;
    const auto built = t.buildCount();
    for (std::uint32_t round = 0; round < 5; ++round) {
      const auto moved = scenes::jitter(sc, 0.01, 0.01 * 2 * kHalf, true, 200 + round);
      ASSERT_FALSE(moved.empty());
      applyUpdate(cube, variant, moved);
      EXPECT_EQ(t.buildCount(), built) << "small jitter rebuilt the tree";
      EXPECT_LE(t.area(), threshold * t.builtArea());
    }
    ASSERT_TRUE(valid(cube));
    EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
    // Scatter: every object teleported.
    const auto moved = scenes::jitter(sc, 1.0, 2 * kHalf, true, 300);
    applyUpdate(cube, variant, moved);
    EXPECT_GT(t.buildCount(), built) << "scattering did not rebuild";
    if (variant == Variant::single) {
      // One call per object: the rebuild comes during the loop, the calls after it stretch the
      // new tree again, each adding its loss, so it cannot stay far past the threshold.
      EXPECT_LE(t.quality(), 2 * threshold) << "quality far from the threshold";
    } else {
      EXPECT_LE(t.area(), threshold * t.builtArea()) << "quality not back within the threshold";
    }
    ASSERT_TRUE(valid(cube));
    EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
  }
}

// With the automatic policy an update rebuilds exactly when the tree is past rebuild_threshold
// and the walks' predicted loss over the updates since the build (staleCost of each update's
// quality, with the room of the build's leaves recomputed here from the cubes and boxes) has
// passed rebuild_budget: checked update by update against a twin that only refits (same build,
// so the same quality until the first rebuild), for a steady drift and for one large motion
// followed by updates that move nothing, with budgets 0 (the threshold alone), 1 (the default),
// 2, and one no motion here spends.
TYPED_TEST(Dynamic, AutomaticPolicyRebuildsOnceStaleTreeCostAboutABuild) {
  using S = TypeParam;
  for (double budget : {0.0, 1.0, 2.0, 1e9}) {
    for (bool drift : {true, false}) {
      SCOPED_TRACE(::testing::Message() << "budget " << budget << (drift ? ", drift" : ", jump"));
      auto sc = scene<S>(800, 161);
      const auto objs = sc.pointers();
      std::mt19937 rng(162);
      std::normal_distribution<double> g(0, 1);
      std::vector<fcl::Vector3<S>> step;
      for (std::size_t i = 0; i < objs.size(); ++i)
        step.push_back(fcl::Vector3<S>(S(g(rng)), S(g(rng)), S(g(rng))).normalized() *
                       S(drift ? 20 : 700));
      Config c;
      c.rebuild_budget = budget;
      CubeCollisionManager<S> cube(c);
      c.update_policy = UpdatePolicy::refit;
      CubeCollisionManager<S> twin(c);
      for (auto* m : {&cube, &twin}) {
        m->registerObjects(objs);
        m->setup();
      }
      const auto& t = ::cube::detail::coreOf(cube).tree();
      const auto& twin_tree = ::cube::detail::coreOf(twin).tree();
      const auto built = t.buildCount();
      double leaf_area = 0, object_area = 0;
      for (const auto& node : twin_tree.nodes())
        if (node.isLeaf()) {
          leaf_area += ::cube::detail::surfaceArea(node);
          for (std::uint32_t p = node.first; p < node.first + node.count; ++p)
            object_area += ::cube::detail::surfaceArea(twin_tree.items()[p].box);
        }
      const double room = leaf_area / object_area;
      EXPECT_NEAR(twin_tree.builtRoom(), room, 1e-9 * room);
      double lost = 0;
      bool rebuilt = false;
      for (std::uint32_t round = 0; round < 40 && !rebuilt; ++round) {
        if (drift || round == 0) {
          for (std::size_t i = 0; i < objs.size(); ++i) {
            objs[i]->setTranslation(objs[i]->getTranslation() + step[i]);
            objs[i]->computeAABB();
          }
        }
        cube.update();
        twin.update();
        const double q = twin_tree.quality();
        lost += ::cube::detail::RebuildPolicy::staleCost(q, room);
        const bool due = q > c.rebuild_threshold && lost > budget;
        EXPECT_EQ(t.buildCount(), built + (due ? 1 : 0))
            << "round " << round << ", quality " << q << ", lost " << lost;
        if (!due) {
          EXPECT_DOUBLE_EQ(t.quality(), q);
        }
        if (round == 0 && !drift) {
          EXPECT_TRUE(q > c.rebuild_threshold && lost < 1.0)
              << "the jump should leave the tree where only the budget decides: quality " << q
              << ", lost " << lost;
        }
        rebuilt = due;
        ASSERT_TRUE(valid(cube));
        EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
      }
      // Every case here degrades past the threshold; only the unspendable budget never rebuilds.
      EXPECT_GT(twin_tree.quality(), c.rebuild_threshold);
      EXPECT_EQ(rebuilt, budget < 1e9);
    }
  }
}

// The default budget tells scenes apart by how crowded their leaves are: every object moved
// once by about its own size leaves both trees past the threshold, but a sparse scene's walks
// lose little on the stretched tree, so it is refitted, while a crowded scene's lose more than
// a build, so it is rebuilt at once. Answers equal brute force either way.
TYPED_TEST(Dynamic, DefaultBudgetRefitsSparseSceneAndRebuildsCrowdedOneAfterOneLargeMove) {
  using S = TypeParam;
  for (bool crowded : {false, true}) {
    SCOPED_TRACE(crowded ? "crowded" : "sparse");
    auto sc = crowded ? scene<S>(3000, 171, 2.0, scenes::Layout::clustered)
                      : scene<S>(3000, 171, 0.5, scenes::Layout::uniform);
    const auto objs = sc.pointers();
    CubeCollisionManager<S> cube;
    cube.registerObjects(objs);
    cube.setup();
    const auto& t = ::cube::detail::coreOf(cube).tree();
    const auto built = t.buildCount();
    const double room = t.builtRoom();
    double size = 0;  // the objects' mean AABB side
    for (const auto* o : objs) size += (o->getAABB().max_ - o->getAABB().min_).sum() / 3;
    size /= double(objs.size());
    scenes::jitter(sc, 1.0, 2 * size, false, 172);
    cube.update();
    EXPECT_EQ(t.buildCount(), built + (crowded ? 1 : 0)) << "room " << room;
    if (!crowded) {
      EXPECT_GT(t.quality(), cube.config().rebuild_threshold);
    }
    ASSERT_TRUE(valid(cube));
    EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
  }
}

// The predicted loss: none for a tree no worse than built, growing with the quality, falling
// with the room the leaves leave their objects, and finite for rooms of no area or NaN.
TEST(DynamicPolicy, StaleCostGrowsWithQualityAndFallsWithRoom) {
  using ::cube::detail::RebuildPolicy;
  EXPECT_EQ(RebuildPolicy::staleCost(1.0, 2.0), 0.0);
  EXPECT_EQ(RebuildPolicy::staleCost(0.8, 2.0), 0.0);
  EXPECT_EQ(RebuildPolicy::staleCost(std::numeric_limits<double>::quiet_NaN(), 2.0), 0.0);
  EXPECT_LT(RebuildPolicy::staleCost(1.5, 2.0), RebuildPolicy::staleCost(2.0, 2.0));
  EXPECT_GT(RebuildPolicy::staleCost(1.5, 0.5), RebuildPolicy::staleCost(1.5, 2.0));
  EXPECT_GT(RebuildPolicy::staleCost(1.5, 2.0), RebuildPolicy::staleCost(1.5, 20.0));
  for (double room : {0.0, 1e-300, std::numeric_limits<double>::quiet_NaN(),
                      std::numeric_limits<double>::infinity()}) {
    const double c = RebuildPolicy::staleCost(2.0, room);
    EXPECT_TRUE(std::isfinite(c) && c >= 0) << "room " << room << ": " << c;
  }
}

// A negative or NaN budget is refused.
TEST(DynamicConfig, RebuildBudgetMustBeNonNegative) {
  Config c;
  c.rebuild_budget = -0.5;
  EXPECT_THROW(c.check(), std::invalid_argument);
  EXPECT_THROW(CubeCollisionManagerd{c}, std::invalid_argument);
  c.rebuild_budget = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(c.check(), std::invalid_argument);
  c.rebuild_budget = 0;
  EXPECT_NO_THROW(c.check());
}

// UpdatePolicy::refit never rebuilds on update, however bad the tree gets, and stays correct.
TYPED_TEST(Dynamic, RefitPolicyNeverRebuildsOnUpdate) {
  using S = TypeParam;
  for (Variant variant : {Variant::all, Variant::single, Variant::vector}) {
    SCOPED_TRACE(name(variant));
    auto sc = scene<S>(600, 121);
    const auto objs = sc.pointers();
    Config c;
    c.update_policy = UpdatePolicy::refit;
    CubeCollisionManager<S> cube(c);
    cube.registerObjects(objs);
    cube.setup();
    const auto& t = ::cube::detail::coreOf(cube).tree();
    const auto built = t.buildCount();
    for (std::uint32_t round = 0; round < 3; ++round) {
      applyUpdate(cube, variant, scenes::jitter(sc, 1.0, 2 * kHalf, true, 400 + round));
      EXPECT_EQ(t.buildCount(), built);
      ASSERT_TRUE(valid(cube));
      EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
    }
    // The tree did degrade past the threshold: automatic would have rebuilt.
    EXPECT_GT(t.area(), c.rebuild_threshold * t.builtArea());
  }
}

// The first setup() builds from scratch; a later setup() after a few registrations and removals
// keeps the incremental tree under the automatic policy (as FCL's tree manager keeps its
// incremental insertions), and rebuilds under a forced policy. Answers are right either way.
TYPED_TEST(Dynamic, LaterSetupKeepsIncrementalWorkUnlessPolicyForces) {
  using S = TypeParam;
  for (UpdatePolicy policy : {UpdatePolicy::automatic, UpdatePolicy::refit}) {
    auto sc = scene<S>(500, 131);
    auto objs = sc.pointers();
    Config c;
    c.update_policy = policy;
    CubeCollisionManager<S> cube(c);
    cube.registerObjects(std::vector<Obj<S>*>(objs.begin(), objs.begin() + 450));
    cube.setup();
    const auto built = ::cube::detail::coreOf(cube).tree().buildCount();
    for (std::size_t i = 450; i < objs.size(); ++i) cube.registerObject(objs[i]);
    for (std::size_t i = 0; i < 20; ++i) cube.unregisterObject(objs[i]);
    EXPECT_EQ(::cube::detail::coreOf(cube).tree().buildCount(), built);
    cube.setup();
    if (policy == UpdatePolicy::automatic) {
      EXPECT_EQ(::cube::detail::coreOf(cube).tree().buildCount(), built)
          << "setup() threw the insertions away";
    } else {
      EXPECT_EQ(::cube::detail::coreOf(cube).tree().buildCount(), built + 1)
          << "forced policy did not rebuild";
    }
    ASSERT_TRUE(valid(cube));
    const std::vector<Obj<S>*> kept(objs.begin() + 20, objs.end());
    EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(kept));
  }
}

// UpdatePolicy::rebuild rebuilds on every update, even when nothing moved.
TYPED_TEST(Dynamic, RebuildPolicyAlwaysRebuilds) {
  using S = TypeParam;
  auto sc = scene<S>(300, 131);
  const auto objs = sc.pointers();
  Config c;
  c.update_policy = UpdatePolicy::rebuild;
  CubeCollisionManager<S> cube(c);
  cube.registerObjects(objs);
  cube.setup();
  const auto& t = ::cube::detail::coreOf(cube).tree();
  for (std::uint32_t round = 0; round < 3; ++round) {
    for (Variant variant : {Variant::all, Variant::single, Variant::vector}) {
      SCOPED_TRACE(name(variant));
      const auto before = t.buildCount();
      const auto moved = scenes::jitter(sc, round == 0 ? 0.0 : 0.05, 40, false, 500 + round);
      applyUpdate(
          cube, variant,
          variant == Variant::single && moved.empty() ? std::vector<Obj<S>*>{objs[0]} : moved);
      EXPECT_GT(t.buildCount(), before);
      ASSERT_TRUE(valid(cube));
      EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
    }
  }
}

// A no-motion update changes nothing: the next queries make the same callbacks in the same
// order, whether the tree was built in one batch, grown incrementally, or refitted after motion.
TYPED_TEST(Dynamic, NoMotionUpdateKeepsCallbackOrder) {
  using S = TypeParam;
  for (UpdatePolicy policy : {UpdatePolicy::automatic, UpdatePolicy::refit}) {
    for (int history = 0; history < 3; ++history) {
      SCOPED_TRACE("policy " + std::to_string(int(policy)) + ", history " +
                   std::to_string(history));
      auto sc = scene<S>(400, 141, 1.0, scenes::Layout::clustered);
      const auto objs = sc.pointers();
      Config c;
      c.update_policy = policy;
      CubeCollisionManager<S> cube(c);
      if (history == 1) {  // grown one object at a time after an initial build
        cube.registerObjects(std::vector<Obj<S>*>(objs.begin(), objs.begin() + 300));
        cube.setup();
        for (std::size_t i = 300; i < objs.size(); ++i) cube.registerObject(objs[i]);
        for (std::size_t i = 0; i < 40; ++i) cube.unregisterObject(objs[i * 7]);
      } else {
        cube.registerObjects(objs);
        cube.setup();
      }
      if (history == 2) {  // refitted after motion
        cube.update(scenes::jitter(sc, 0.05, 40, true, 600));
        cube.update();
      }
      const std::vector<Obj<S>*> queries{objs[1], objs[100], objs[399], objs[250]};
      const Sequence<S> before = record(cube, queries);
      ASSERT_GT(before.self.size(), 50u);
      ASSERT_FALSE(before.objects.empty());
      const auto builds = ::cube::detail::coreOf(cube).tree().buildCount();
      cube.update();
      EXPECT_TRUE(record(cube, queries) == before) << "after update()";
      cube.update(objs);
      EXPECT_TRUE(record(cube, queries) == before) << "after update(vector of all)";
      for (auto* o : objs) cube.update(o);
      EXPECT_TRUE(record(cube, queries) == before) << "after update(obj) of each";
      EXPECT_EQ(::cube::detail::coreOf(cube).tree().buildCount(), builds);
      EXPECT_TRUE(valid(cube));
    }
  }
  // With UpdatePolicy::rebuild the rebuilt tree of an unchanged scene is the same tree.
  auto sc = scene<S>(400, 142);
  const auto objs = sc.pointers();
  Config c;
  c.update_policy = UpdatePolicy::rebuild;
  CubeCollisionManager<S> cube(c);
  cube.registerObjects(objs);
  cube.setup();
  const std::vector<Obj<S>*> queries{objs[3], objs[200]};
  const Sequence<S> before = record(cube, queries);
  cube.update();
  EXPECT_TRUE(record(cube, queries) == before) << "rebuild policy, update()";
}

// A batch build holds each object once and no more room than its objects need: the slots are
// exactly the objects, the pointer map is sized to its load limit, and a batch into a manager
// that holds objects (live ones, dead slots) builds over both with the same answers.
TYPED_TEST(Dynamic, BatchBuildsKeepNoSlack) {
  using S = TypeParam;
  const std::size_t n = 3000;
  auto sc = scene<S>(2 * n, 171);
  const auto all = sc.pointers();
  const std::vector<Obj<S>*> first(all.begin(), all.begin() + n),
      second(all.begin() + n, all.end());
  CubeCollisionManager<S> cube;
  cube.registerObjects(first);
  cube.setup();
  ASSERT_TRUE(valid(cube));
  const auto& core = ::cube::detail::coreOf(cube);
  EXPECT_EQ(core.tree().items().capacity(), n);
  // 3/4 of the map's places at most are taken, and no more places than that asks for.
  EXPECT_LE(core.table().mapBytes(), sizeof(std::uint32_t) * ((4 * (n + 1) + 2) / 3));
  EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(first));
  // Dead slots, then a batch as large as what is left: one build over the live slots and it.
  std::vector<Obj<S>*> live;
  for (std::size_t i = 0; i < n; ++i) {
    if (i % 3 == 0)
      cube.unregisterObject(first[i]);
    else
      live.push_back(first[i]);
  }
  ASSERT_TRUE(valid(cube));
  const auto builds = core.tree().buildCount();
  cube.registerObjects(second);
  cube.setup();
  ASSERT_TRUE(valid(cube));
  EXPECT_GT(core.tree().buildCount(), builds);
  live.insert(live.end(), second.begin(), second.end());
  EXPECT_EQ(core.tree().items().capacity(), live.size());
  EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(live));
}

}  // namespace
}  // namespace testing
}  // namespace cube
