// Registration and setup() (docs/guarantees.md): objects registered after setup() are found without
// another, setup() is idempotent, and the same input gives the same callback order.
// Every expected answer comes from brute force over the AABBs or from fcl::NaiveCollisionManager
// on the same objects, in double and float.

#include <gtest/gtest.h>

#include "support/semantics_world.h"

namespace cube {
namespace testing {
namespace {

using namespace semantics_world;

// 8. Objects registered after setup() are found by the next query without another setup(), and
// unregistered ones are gone.
TYPED_TEST(Semantics, RegistrationAfterSetupFoundWithoutSetup) {
  using S = TypeParam;
  auto sc = scene<S>(400, 21);
  const auto all = sc.pointers();
  CubeCollisionManager<S> cube;
  std::vector<Obj<S>*> live(all.begin(), all.begin() + 200);
  cube.registerObjects(live);
  cube.setup();
  fcl::NaiveCollisionManager<S> naive;
  for (auto* o : live) naive.registerObject(o);
  for (std::size_t i = 200; i < all.size(); ++i) {
    cube.registerObject(all[i]);
    naive.registerObject(all[i]);
    live.push_back(all[i]);
    ASSERT_TRUE(valid(cube));
    if (i % 25 == 0 || i + 1 == all.size()) {
      ASSERT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(live)) << "after " << i;
      // The newest object finds its neighbours and they find it.
      ASSERT_EQ(cubeObjectCalls<S>(cube, all[i]), bruteCrossPairs<S>(live, {all[i]}));
      Colliding<S> mine, theirs;
      cube.collide(&mine, &Colliding<S>::record);
      naive.collide(&theirs, &Colliding<S>::record);
      ASSERT_EQ(mine.result(), theirs.result());
    }
  }
  // An object registered after setup far from everything, then one overlapping it exactly.
  auto far = boxes<S>({{V3<S>(5000, 5000, 5000), V3<S>(5001, 5001, 5001)},
                       {V3<S>(5000, 5000, 5000), V3<S>(5001, 5001, 5001)}});
  cube.registerObject(far[0].get());
  cube.registerObject(far[1].get());
  live.push_back(far[0].get());
  live.push_back(far[1].get());
  EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(live));
  std::vector<Obj<S>*> visited;
  S nearest = std::numeric_limits<S>::max();
  cube.distance(far[0].get(), [&](Obj<S>* a, Obj<S>* b, S& dist) {
    visited.push_back(a);
    nearest = std::min(nearest, S(a->getAABB().distance(b->getAABB())));
    dist = nearest;
    return false;
  });
  EXPECT_NE(std::find(visited.begin(), visited.end(), far[1].get()), visited.end());
  EXPECT_EQ(nearest, 0);
  // Unregistered after setup: gone from the next query.
  for (std::size_t i = 0; i < live.size(); i += 3) cube.unregisterObject(live[i]);
  std::vector<Obj<S>*> kept;
  for (std::size_t i = 0; i < live.size(); ++i)
    if (i % 3 != 0) kept.push_back(live[i]);
  ASSERT_TRUE(valid(cube));
  EXPECT_EQ(cube.size(), kept.size());
  EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(kept));
}

// 8. setup() is idempotent: a second setup() builds nothing and the next query makes the same
// callbacks in the same order.
TYPED_TEST(Semantics, SetupIsIdempotent) {
  using S = TypeParam;
  auto sc = scene<S>(500, 31, scenes::Layout::clustered);
  CubeCollisionManager<S> cube;
  for (auto* o : sc.pointers()) cube.registerObject(o);
  cube.setup();
  const auto builds = ::cube::detail::coreOf(cube).tree().buildCount();
  Calls<S> before;
  cube.collide(&before, &Calls<S>::record);
  DistCalls<S> dbefore;
  cube.distance(sc.objects[7].get(), &dbefore, &DistCalls<S>::record);
  ASSERT_FALSE(before.calls.empty());
  for (int i = 0; i < 3; ++i) cube.setup();
  EXPECT_EQ(::cube::detail::coreOf(cube).tree().buildCount(), builds);
  Calls<S> after;
  cube.collide(&after, &Calls<S>::record);
  DistCalls<S> dafter;
  cube.distance(sc.objects[7].get(), &dafter, &DistCalls<S>::record);
  EXPECT_EQ(after.calls, before.calls);
  EXPECT_EQ(dafter.calls, dbefore.calls);
  EXPECT_TRUE(valid(cube));
}

// setup() of a manager that never held an object builds nothing (registering an empty batch
// changes nothing either); the objects registered afterwards are found before and after the next
// setup(), which builds the same tree and makes the same callbacks as a manager that skipped the
// empty steps.
TYPED_TEST(Semantics, EmptySetupBuildsNothingAndLaterRegistrationsAnswerExactly) {
  using S = TypeParam;
  auto sc = scene<S>(300, 37);
  const auto all = sc.pointers();
  CubeCollisionManager<S> cube, fresh;
  cube.registerObjects({});
  cube.setup();
  cube.setup();
  EXPECT_EQ(::cube::detail::coreOf(cube).tree().buildCount(), 0u);
  EXPECT_EQ(cube.size(), 0u);
  ASSERT_TRUE(valid(cube));
  EXPECT_TRUE(oracle::selfPairs<S>(cube).empty());
  cube.registerObjects(all);
  ASSERT_TRUE(valid(cube));
  EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(all));
  cube.setup();
  ASSERT_TRUE(valid(cube));
  fresh.registerObjects(all);
  fresh.setup();
  EXPECT_EQ(::cube::detail::coreOf(cube).tree().buildCount(),
            ::cube::detail::coreOf(fresh).tree().buildCount());
  Calls<S> mine, theirs;
  cube.collide(&mine, &Calls<S>::record);
  fresh.collide(&theirs, &Calls<S>::record);
  ASSERT_FALSE(theirs.calls.empty());
  EXPECT_EQ(mine.calls, theirs.calls);
  EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(all));
}

// Same input, same tree and same callback order: two managers built from the same objects make
// identical calls, whatever the registration path (batch or one by one before setup()).
TYPED_TEST(Semantics, SameInputSameCallbackOrder) {
  using S = TypeParam;
  auto sc = scene<S>(500, 33);
  CubeCollisionManager<S> a, b;
  a.registerObjects(sc.pointers());
  a.setup();
  for (auto* o : sc.pointers()) b.registerObject(o);
  b.setup();
  Calls<S> ca, cb;
  a.collide(&ca, &Calls<S>::record);
  b.collide(&cb, &Calls<S>::record);
  EXPECT_EQ(ca.calls, cb.calls);
  ASSERT_FALSE(ca.calls.empty());
}

}  // namespace
}  // namespace testing
}  // namespace cube
