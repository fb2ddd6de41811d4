// Dynamic updates. After every kind of motion and every update variant, and along long
// interleaved sequences of registrations, removals, moves and queries, the cube manager answers
// as brute force over the AABBs and fcl::NaiveCollisionManager do; validate() holds throughout;
// the update policies rebuild when they should; a no-motion update keeps the callback order.

#include <gtest/gtest.h>

#include <random>
#include <set>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"
#include "support/correctness.h"

namespace cube {
namespace testing {
namespace {

template <typename S>
class Dynamic : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(Dynamic, Scalars);

constexpr double kHalf = 2000;  // scenes' default half extent

template <typename S>
scenes::Scene<S> scene(std::size_t n, std::uint32_t seed, double size_scale = 1.0,
                       scenes::Layout layout = scenes::Layout::uniform) {
  scenes::SceneOptions o;
  o.n = n;
  o.seed = seed;
  o.size_scale = size_scale;
  o.layout = layout;
  o.overlaps_per_object = 2.0;
  return scenes::makeScene<S>(o);
}

/// Distance between AABB centres: never below the AABB distance, so branch and bound may use
/// it, and its minimum does not depend on the visit order (unlike the default callback's, which
/// stops at the first touching pair).
template <typename S>
S centreDistance(Obj<S>* a, Obj<S>* b) {
  return (a->getAABB().center() - b->getAABB().center()).norm();
}

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

/// Moves one object by up to `step` per axis, optionally rotating it, and recomputes its AABB.
template <typename S>
void moveObject(Obj<S>* o, std::mt19937& rng, double step, bool rotate) {
  std::uniform_real_distribution<double> unit(-1, 1);
  fcl::Transform3<S> tf = o->getTransform();
  tf.translation() +=
      fcl::Vector3<S>(S(unit(rng) * step), S(unit(rng) * step), S(unit(rng) * step));
  if (rotate) {
    const fcl::Vector3<S> axis =
        fcl::Vector3<S>(S(unit(rng)), S(unit(rng)), S(unit(rng)) + S(2)).normalized();
    tf.linear() = fcl::AngleAxis<S>(S(unit(rng) * 3), axis).toRotationMatrix() * tf.linear();
  }
  o->setTransform(tf);
  o->computeAABB();
}

enum class Variant { all, single, vector };
const char* name(Variant v) {
  return v == Variant::all ? "update()" : v == Variant::single ? "update(obj)" : "update(vector)";
}

template <typename S>
void applyUpdate(CubeCollisionManager<S>& m, Variant v, const std::vector<Obj<S>*>& moved) {
  switch (v) {
    case Variant::all:
      m.update();
      break;
    case Variant::single:
      for (auto* o : moved) m.update(o);
      break;
    case Variant::vector:
      m.update(moved);
      break;
  }
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

/// The reference state of the sequence test: which pool objects are registered, in order.
template <typename S>
struct Registry {
  std::vector<Obj<S>*> live;  // registration order
  std::set<Obj<S>*> in;
  void add(Obj<S>* o) {
    if (in.insert(o).second) live.push_back(o);
  }
  void remove(Obj<S>* o) {
    if (in.erase(o)) live.erase(std::find(live.begin(), live.end(), o));
  }
};

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

// The automatic policy rebuilds once objects are scattered far from where the tree was built,
// bringing the tree quality back within the threshold, and does not rebuild on small jitter.
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
    EXPECT_LE(t.area(), threshold * t.builtArea()) << "quality not back within the threshold";
    ASSERT_TRUE(valid(cube));
    EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
  }
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

/// Every callback of the queries whose order a user can observe: self-collide, object queries,
/// and distance (a recorder that visits everything, and a pruning one).
template <typename S>
struct Sequence {
  std::vector<Pair<S>> self, objects, dist_all, dist_pruned;
  bool operator==(const Sequence& o) const {
    return self == o.self && objects == o.objects && dist_all == o.dist_all &&
           dist_pruned == o.dist_pruned;
  }
};
template <typename S>
Sequence<S> record(const CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& queries) {
  Sequence<S> s;
  Calls<S> c;
  m.collide(&c, &Calls<S>::record);
  s.self = c.calls;
  for (auto* q : queries) {
    Calls<S> cq;
    m.collide(q, &cq, &Calls<S>::record);
    s.objects.insert(s.objects.end(), cq.calls.begin(), cq.calls.end());
  }
  DistCalls<S> d;
  m.distance(&d, &DistCalls<S>::record);
  s.dist_all = d.calls;
  S best = std::numeric_limits<S>::max();
  m.distance([&](Obj<S>* a, Obj<S>* b, S& dist) {
    s.dist_pruned.emplace_back(a, b);
    best = std::min(best, centreDistance(a, b));
    dist = best;
  });
  for (auto* q : queries) {
    best = std::numeric_limits<S>::max();
    m.distance(q, [&](Obj<S>* a, Obj<S>* b, S& dist) {
      s.dist_pruned.emplace_back(a, b);
      best = std::min(best, centreDistance(a, b));
      dist = best;
    });
  }
  return s;
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

// Config::keep_pairs: update() and update(vector) keep the overlapping pairs, which the next
// self-collide reports without a walk. Along a long run of motions (small, teleports, rotations,
// objects crossing into and out of the unbounded list, a NaN AABB) mixed with single updates,
// registrations, removals, setup() and updates moving a third of the objects (which drop the
// list), the list is in use exactly when it should be, validate() (which compares the list with
// a fresh listing) holds, and the pairs equal brute force. Most updates take the incremental
// path (the list current before, a few objects moved).
template <typename S>
void pairListRun(std::size_t n, bool keep, std::uint32_t seed) {
  using V = fcl::Vector3<S>;
  auto sc = scene<S>(n, seed);
  auto extra = boxes<S>({{V(0, 0, 0), V(40, 40, 40)}, {V(-100, 5, 5), V(-60, 45, 45)}});
  auto pool = sc.pointers();
  for (auto* e : raw(extra)) pool.push_back(e);
  std::mt19937 rng(seed);
  auto pick = [&](std::size_t k) {
    return std::uniform_int_distribution<std::size_t>(0, k - 1)(rng);
  };
  Config c;
  c.keep_pairs = keep;
  CubeCollisionManager<S> cube(c);
  Registry<S> reg;
  for (auto* o : pool) reg.add(o);
  cube.registerObjects(reg.live);
  cube.setup();
  EXPECT_FALSE(cube.pairsListed()) << "setup() lists nothing";
  const S inf = std::numeric_limits<S>::infinity();
  std::size_t incremental = 0;
  for (int step = 0; step < 400; ++step) {
    const bool listed_before = cube.pairsListed();
    const int op = int(pick(20));
    bool expect_listed = false;
    std::string what;
    if (op < 12) {  // update() or update(vector) after a few objects moved
      std::vector<Obj<S>*> moved;
      for (std::size_t k = 1 + pick(std::max<std::size_t>(2, reg.live.size() / 40)); k > 0; --k) {
        Obj<S>* o = reg.live[pick(reg.live.size())];
        if (o == extra[0].get()) {
          // Into or out of the unbounded list: a slab, or back to a box.
          if (std::isinf(o->getAABB().min_[0]))
            extra[0]->setAABB(V(0, 0, 0), V(40, 40, 40));
          else
            extra[0]->setAABB(V(-inf, -inf, -1), V(inf, inf, 1));
        } else if (o != extra[1].get()) {
          moveObject(o, rng, pick(10) == 0 ? 2 * kHalf : 30.0, pick(4) == 0);
        }
        moved.push_back(o);
      }
      if (op < 8) {
        cube.update();
        what = "update()";
      } else {
        cube.update(moved);
        what = "update(vector)";
      }
      expect_listed = keep;
      incremental += listed_before && moved.size() * 4 <= reg.live.size();
    } else if (op < 14) {
      Obj<S>* o = reg.live[pick(reg.live.size())];
      if (o != extra[0].get() && o != extra[1].get()) moveObject(o, rng, 30.0, false);
      cube.update(o);
      what = "update(obj)";
    } else if (op < 16) {
      Obj<S>* o = pool[pick(pool.size())];
      if (reg.in.count(o) && reg.live.size() > n / 2) {
        cube.unregisterObject(o);
        reg.remove(o);
        what = "unregisterObject";
      } else {
        cube.registerObject(o);
        reg.add(o);
        what = "registerObject";
      }
    } else if (op < 17) {
      const std::size_t builds = ::cube::detail::coreOf(cube).tree().buildCount();
      cube.setup();
      // A setup() that does not rebuild leaves the list as it was.
      expect_listed = listed_before && ::cube::detail::coreOf(cube).tree().buildCount() == builds;
      what = "setup()";
    } else if (op < 18) {  // a third of the objects move: update() drops the list
      for (std::size_t k = 0; k < reg.live.size() / 3 + 1; ++k) {
        Obj<S>* o = reg.live[k * 3 % reg.live.size()];
        if (o != extra[0].get() && o != extra[1].get()) moveObject(o, rng, 30.0, false);
      }
      cube.update();
      what = "update() after a third moved";
    } else {  // a NaN AABB: update() throws, every other object is updated and listed
      extra[1]->setNaN();
      Obj<S>* o = reg.live[pick(reg.live.size())];
      if (o != extra[0].get() && o != extra[1].get()) moveObject(o, rng, 30.0, false);
      if (reg.in.count(extra[1].get()))
        EXPECT_THROW(cube.update(), std::invalid_argument);
      else
        cube.update();
      EXPECT_TRUE(valid(cube));
      extra[1]->setAABB(V(-100, 5, 5), V(-60, 45, 45));
      cube.update();  // the object gets its box back
      expect_listed = keep;
      what = "update() with a NaN AABB";
    }
    SCOPED_TRACE("step " + std::to_string(step) + ": " + what);
    ASSERT_TRUE(valid(cube));
    ASSERT_EQ(cube.pairsListed(), expect_listed);
    ASSERT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(reg.live));
  }
  if (keep) {
    EXPECT_GT(incremental, 100u) << "the incremental path was hardly taken";
  }
}

TYPED_TEST(Dynamic, PairListFollowsUpdatesLargeScene) {
  pairListRun<TypeParam>(700, true, 31);
}
TYPED_TEST(Dynamic, PairListFollowsUpdatesAllPairsScene) {
  pairListRun<TypeParam>(40, true, 32);
}
TYPED_TEST(Dynamic, PairListOffNeverListed) {
  pairListRun<TypeParam>(300, false, 33);
}

// Served from the list, a self-collide (also as collide(this)) makes the same callbacks in the
// same order and with the same argument order as the walk right after a listing, and stops
// where the callback says.
TYPED_TEST(Dynamic, PairListKeepsWalkOrderAndStops) {
  using S = TypeParam;
  for (std::size_t n : {40, 500}) {
    SCOPED_TRACE("n " + std::to_string(n));
    auto sc = scene<S>(n, 34);
    const auto objs = sc.pointers();
    Config on;
    on.keep_pairs = true;
    CubeCollisionManager<S> listed(on), walked;
    for (auto* m : {&listed, &walked}) {
      m->registerObjects(objs);
      m->setup();
      m->update();
    }
    ASSERT_TRUE(listed.pairsListed());
    ASSERT_FALSE(walked.pairsListed());
    Calls<S> a, b;
    listed.collide(&a, &Calls<S>::record);
    walked.collide(&b, &Calls<S>::record);
    ASSERT_GT(a.calls.size(), 10u);
    EXPECT_TRUE(a.calls == b.calls);
    Calls<S> self_as_other;  // collide(this) is the same self query, from the list too
    listed.collide(&listed, &self_as_other, &Calls<S>::record);
    EXPECT_TRUE(self_as_other.calls == a.calls);
    std::size_t calls = 0;
    listed.collide([&](Obj<S>*, Obj<S>*) { return ++calls == 3; });
    EXPECT_EQ(calls, 3u);
  }
}

// With keep_pairs, an update() that moves nothing keeps the list as it stands: still listed, the
// same callbacks in the same order (the moved objects' pairs of earlier refreshes still last),
// the pairs of the current boxes; a motion after it is followed as before.
TYPED_TEST(Dynamic, PairListStandsThroughUpdatesThatMoveNothing) {
  using S = TypeParam;
  auto sc = scene<S>(600, 35);
  const auto objs = sc.pointers();
  Config on;
  on.keep_pairs = true;
  CubeCollisionManager<S> cube(on);
  cube.registerObjects(objs);
  cube.setup();
  cube.update();  // listed
  for (std::uint32_t step = 0; step < 3; ++step) {
    scenes::jitter(sc, 0.02, 30, false, 700 + step);
    cube.update();  // refreshed: the moved objects' pairs last
  }
  ASSERT_TRUE(cube.pairsListed());
  Calls<S> before;
  cube.collide(&before, &Calls<S>::record);
  ASSERT_GT(before.calls.size(), 10u);
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE("update " + std::to_string(k));
    cube.update();
    ASSERT_TRUE(cube.pairsListed());
    Calls<S> after;
    cube.collide(&after, &Calls<S>::record);
    EXPECT_TRUE(after.calls == before.calls);
    EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
    EXPECT_TRUE(valid(cube));
  }
  scenes::jitter(sc, 0.02, 30, false, 710);
  cube.update();
  ASSERT_TRUE(cube.pairsListed());
  EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
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
