// Dynamic updates. After every kind of motion and every update variant, along long interleaved
// sequences of registrations, removals, moves and queries, and as objects move between the cubes
// and the unbounded list, the cube manager answers as brute force over the AABBs and
// fcl::NaiveCollisionManager do; validate() holds throughout.

#include <gtest/gtest.h>

#include "support/dynamic_world.h"

namespace cube {
namespace testing {
namespace {

using namespace dynamic_world;

template <typename S>
S cubeCentreMin(const CubeCollisionManager<S>& m) {
  S best = std::numeric_limits<S>::max();
  m.distance([&](Obj<S>* a, Obj<S>* b, S& dist) {
    best = std::min(best, centreDistance(a, b));
    dist = best;
  });
  return best;
}
template <typename S>
S cubeCentreMin(const CubeCollisionManager<S>& m, Obj<S>* q) {
  S best = std::numeric_limits<S>::max();
  m.distance(q, [&](Obj<S>* a, Obj<S>* b, S& dist) {
    best = std::min(best, centreDistance(a, b));
    dist = best;
  });
  return best;
}
template <typename S>
S bruteCentreMin(const std::vector<Obj<S>*>& objs) {
  S best = std::numeric_limits<S>::max();
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j)
      best = std::min(best, centreDistance(objs[i], objs[j]));
  return best;
}
template <typename S>
S bruteCentreMin(const std::vector<Obj<S>*>& objs, Obj<S>* q) {
  S best = std::numeric_limits<S>::max();
  for (auto* o : objs)
    if (o != q) best = std::min(best, centreDistance(o, q));
  return best;
}

/// Naive's minimum distance (default callback) compared with the cube manager's: equal within
/// the tolerance when positive; when Naive finds contact (<= 0) the value depends on which
/// touching pair comes first, so only the sign is compared.
template <typename S>
::testing::AssertionResult sameMinDistance(S got, S expected) {
  if (expected > 0) return closeDistance<S>(got, expected);
  if (got <= 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "Naive finds contact, the cube manager " << got;
}

struct Motion {
  const char* name;
  double fraction;  // of the objects moved per round
  double step;      // per axis, world units
  bool rotate;
};
// Small: 1% of the world; teleport: anywhere in (and beyond) the world; rotation in place.
const Motion kMotions[] = {{"small", 0.2, 0.01 * 2 * kHalf, false},
                           {"teleport", 0.1, 2 * kHalf, false},
                           {"rotation", 0.3, 0.0, true},
                           {"everything small", 1.0, 0.01 * 2 * kHalf, true},
                           // Under 1/32 of the objects: update() refits their paths only.
                           {"few", 0.02, 0.05 * 2 * kHalf, false}};

// After each kind of motion and each update variant: self-collide, per-object queries and
// distance equal brute force and Naive.
TYPED_TEST(Dynamic, RandomMotionThenEachUpdateVariantEqualsNaive) {
  using S = TypeParam;
  for (const Motion& motion : kMotions) {
    for (Variant variant : {Variant::all, Variant::single, Variant::vector}) {
      SCOPED_TRACE(std::string(motion.name) + " motion, " + name(variant));
      auto sc = scene<S>(500, 101);
      auto far = scene<S>(300, 102, 0.02);  // nothing touches: comparable minimum distances
      const auto objs = sc.pointers();
      const auto far_objs = far.pointers();
      CubeCollisionManager<S> cube, cube_far;
      cube.registerObjects(objs);
      cube.setup();
      cube_far.registerObjects(far_objs);
      cube_far.setup();
      fcl::NaiveCollisionManager<S> naive, naive_far;
      for (auto* o : objs) naive.registerObject(o);
      for (auto* o : far_objs) naive_far.registerObject(o);
      for (std::uint32_t round = 0; round < 4; ++round) {
        SCOPED_TRACE("round " + std::to_string(round));
        const auto moved = scenes::jitter(sc, motion.fraction, motion.step, motion.rotate, round);
        const auto far_moved =
            scenes::jitter(far, motion.fraction, motion.step, motion.rotate, round + 50);
        ASSERT_FALSE(moved.empty());
        applyUpdate(cube, variant, moved);
        applyUpdate(cube_far, variant, far_moved);
        ASSERT_TRUE(valid(cube));
        ASSERT_TRUE(valid(cube_far));

        const auto brute = oracle::bruteSelfPairs(objs);
        ASSERT_FALSE(brute.empty());
        ASSERT_EQ(oracle::selfPairs<S>(cube), brute);
        Colliding<S> mine, theirs;
        cube.collide(&mine, &Colliding<S>::record);
        naive.collide(&theirs, &Colliding<S>::record);
        ASSERT_EQ(mine.result(), theirs.result());
        // Per-object: the moved objects and some that stayed.
        std::vector<Obj<S>*> qs(moved.begin(),
                                moved.begin() + std::min<std::size_t>(40, moved.size()));
        for (std::size_t i = 0; i < objs.size(); i += 25) qs.push_back(objs[i]);
        for (std::size_t i = 0; i < qs.size(); ++i) {
          Obj<S>* q = qs[i];
          ASSERT_EQ(cubeObjectCalls<S>(cube, q), bruteCrossPairs<S>(objs, {q}));
          ASSERT_EQ(cubeCentreMin<S>(cube, q), bruteCentreMin<S>(objs, q));
          if (i % 4 != 0) continue;  // Naive runs the narrow phase on every object: sample
          Colliding<S> m1, m2;
          cube.collide(q, &m1, &Colliding<S>::record);
          naive.collide(q, &m2, &Colliding<S>::record);
          ASSERT_EQ(m1.result(), m2.result());
        }
        ASSERT_EQ(cubeCentreMin<S>(cube), bruteCentreMin<S>(objs));
        // Distance with FCL's narrow phase on the scene where nothing touches.
        const S expected = fclMinDistance<S>(
            [&](void* d, fcl::DistanceCallBack<S> f) { naive_far.distance(d, f); });
        ASSERT_TRUE(sameMinDistance<S>(cubeMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) {
                                         cube_far.distance(d, f);
                                       }),
                                       expected));
        std::vector<Obj<S>*> far_qs(
            far_moved.begin(), far_moved.begin() + std::min<std::size_t>(20, far_moved.size()));
        for (std::size_t i = 0; i < far_objs.size(); i += 30) far_qs.push_back(far_objs[i]);
        for (auto* q : far_qs) {
          const S e = fclMinDistance<S>(
              [&](void* d, fcl::DistanceCallBack<S> f) { naive_far.distance(q, d, f); });
          ASSERT_TRUE(
              sameMinDistance<S>(cubeMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) {
                                   cube_far.distance(q, d, f);
                                 }),
                                 e));
        }
      }
    }
  }
}

// Thousands of interleaved registrations, removals, moves with each update variant, setup(),
// clear() and queries from a fixed seed; after every step validate() holds and self pairs and an
// object query equal brute force; every 100 steps the narrow phase agrees with Naive.
template <typename S>
void interleaved(const Config& cfg, int steps, std::uint32_t seed) {
  auto pool_scene = scene<S>(420, seed);
  const auto pool = pool_scene.pointers();
  std::mt19937 rng(seed);
  auto pick = [&](std::size_t n) {
    return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng);
  };
  CubeCollisionManager<S> cube(cfg);
  Registry<S> reg;
  for (std::size_t i = 0; i < 300; ++i) reg.add(pool[i]);
  cube.registerObjects(reg.live);
  std::size_t counts[10] = {};
  for (int step = 0; step < steps; ++step) {
    const int op = int(pick(10));
    ++counts[op];
    std::string what;
    switch (op) {
      case 0:
      case 1: {  // register one (or try to register a registered one: no effect)
        Obj<S>* o = pool[pick(pool.size())];
        cube.registerObject(o);
        reg.add(o);
        what = "registerObject";
        break;
      }
      case 2: {  // a small batch
        std::vector<Obj<S>*> batch;
        for (std::size_t k = 1 + pick(6); k > 0; --k) batch.push_back(pool[pick(pool.size())]);
        cube.registerObjects(batch);
        for (auto* o : batch) reg.add(o);
        what = "registerObjects";
        break;
      }
      case 3:
      case 4: {  // unregister one, registered or not; keep about 300 registered
        for (int k = reg.live.size() > 320 ? 3 : 1; k > 0; --k) {
          Obj<S>* o = pool[pick(pool.size())];
          cube.unregisterObject(o);
          reg.remove(o);
        }
        what = "unregisterObject";
        break;
      }
      case 5:
      case 6: {  // move one (maybe unregistered) + update(obj)
        Obj<S>* o = pool[pick(pool.size())];
        moveObject(o, rng, pick(8) == 0 ? 2 * kHalf : 40.0, pick(3) == 0);
        cube.update(o);
        what = "update(obj)";
        break;
      }
      case 7: {  // move several + update(vector)
        std::vector<Obj<S>*> moved;
        for (std::size_t k = 1 + pick(12); k > 0; --k) {
          moved.push_back(pool[pick(pool.size())]);
          moveObject(moved.back(), rng, pick(8) == 0 ? 2 * kHalf : 40.0, pick(3) == 0);
        }
        cube.update(moved);
        what = "update(vector)";
        break;
      }
      case 8: {  // move registered ones + update()
        for (std::size_t k = 1 + pick(12); k > 0 && !reg.live.empty(); --k)
          moveObject(reg.live[pick(reg.live.size())], rng, pick(8) == 0 ? 2 * kHalf : 40.0,
                     pick(3) == 0);
        cube.update();
        what = "update()";
        break;
      }
      default: {  // setup(), rarely clear() and a fresh batch
        if (pick(40) == 0) {
          cube.clear();
          reg = Registry<S>();
          ASSERT_TRUE(cube.empty());
          std::vector<Obj<S>*> batch(pool.begin() + pick(100), pool.begin() + 300 + pick(100));
          cube.registerObjects(batch);
          for (auto* o : batch) reg.add(o);
          what = "clear + registerObjects";
        } else {
          cube.setup();
          what = "setup()";
        }
        break;
      }
    }
    SCOPED_TRACE("step " + std::to_string(step) + ": " + what);
    // Objects that moved while unregistered are re-read when registered; registered ones that
    // moved were updated above, so live AABBs are what the manager must hold.
    ASSERT_TRUE(valid(cube));
    ASSERT_EQ(cube.size(), reg.live.size());
    ASSERT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(reg.live));
    Obj<S>* q = pool[pick(pool.size())];
    ASSERT_EQ(cubeObjectCalls<S>(cube, q), bruteCrossPairs<S>(reg.live, {q}));
    if (step % 100 == 0) {
      std::vector<Obj<S>*> got;
      cube.getObjects(got);
      ASSERT_EQ(std::set<Obj<S>*>(got.begin(), got.end()), reg.in);
      ASSERT_EQ(got.size(), reg.live.size());
      fcl::NaiveCollisionManager<S> naive;
      for (auto* o : reg.live) naive.registerObject(o);
      Colliding<S> mine, theirs;
      cube.collide(&mine, &Colliding<S>::record);
      naive.collide(&theirs, &Colliding<S>::record);
      ASSERT_EQ(mine.result(), theirs.result());
      ASSERT_EQ(cubeCentreMin<S>(cube), bruteCentreMin<S>(reg.live));
      ASSERT_EQ(cubeCentreMin<S>(cube, q), bruteCentreMin<S>(reg.live, q));
    }
  }
  // The sequence really exercised every operation.
  for (int op = 0; op < 10; ++op) EXPECT_GT(counts[op], std::size_t(steps / 20)) << "op " << op;
}

TYPED_TEST(Dynamic, InterleavedSequenceAutomaticPolicy) {
  interleaved<TypeParam>(Config(), 3000, 7);
}
TYPED_TEST(Dynamic, InterleavedSequenceRefitPolicySmallLeaves) {
  Config c;
  c.update_policy = UpdatePolicy::refit;
  c.leaf_size = 1;
  interleaved<TypeParam>(c, 1500, 8);
}
TYPED_TEST(Dynamic, InterleavedSequenceRebuildPolicyDepthCap) {
  Config c;
  c.update_policy = UpdatePolicy::rebuild;
  c.max_depth = 4;
  interleaved<TypeParam>(c, 1500, 9);
}
TYPED_TEST(Dynamic, InterleavedSequenceLowThresholdLargeLeaves) {
  Config c;
  c.rebuild_threshold = 1.05;
  c.leaf_size = 9;
  interleaved<TypeParam>(c, 1500, 10);
}

// An object whose AABB becomes unbounded (say, replaced by a plane-sized box) moves to the
// unbounded list on update and back when it shrinks again; queries stay right throughout.
TYPED_TEST(Dynamic, ObjectsMoveBetweenCubesAndUnboundedList) {
  using S = TypeParam;
  using V = fcl::Vector3<S>;
  auto sc = scene<S>(200, 151);
  auto extra = boxes<S>({{V(0, 0, 0), V(10, 10, 10)}, {V(-100, 5, 5), V(-90, 6, 6)}});
  auto objs = sc.pointers();
  for (auto* e : raw(extra)) objs.push_back(e);
  CubeCollisionManager<S> cube;
  cube.registerObjects(objs);
  cube.setup();
  const S inf = std::numeric_limits<S>::infinity();
  for (Variant variant : {Variant::all, Variant::single, Variant::vector}) {
    SCOPED_TRACE(name(variant));
    extra[0]->setAABB(V(-inf, -inf, -1), V(inf, inf, 1));  // a slab through z = 0
    applyUpdate(cube, variant, {extra[0].get()});
    ASSERT_TRUE(valid(cube));
    EXPECT_EQ(::cube::detail::coreOf(cube).unboundedItems().size(), 1u);
    EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
    EXPECT_EQ(cubeObjectCalls<S>(cube, extra[1].get()), bruteCrossPairs<S>(objs, {extra[1].get()}));
    extra[0]->setAABB(V(0, 0, 0), V(10, 10, 10));
    applyUpdate(cube, variant, {extra[0].get()});
    ASSERT_TRUE(valid(cube));
    EXPECT_EQ(::cube::detail::coreOf(cube).unboundedItems().size(), 0u);
    EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
  }
}

}  // namespace
}  // namespace testing
}  // namespace cube
