// The pair list (Config::keep_pairs) follows updates, keeps the walk's order and early stops, and
// stands through updates that move nothing.

#include <gtest/gtest.h>

#include "support/dynamic_world.h"

namespace cube {
namespace testing {
namespace {

using namespace dynamic_world;

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
      cube.setup();
      // setup() leaves the list as it was, whether it rebuilds the cubes (a stale tree) or not:
      // the list holds pairs of ids, which a rebuild does not change.
      expect_listed = listed_before;
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

}  // namespace
}  // namespace testing
}  // namespace cube
