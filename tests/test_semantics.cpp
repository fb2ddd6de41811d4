// The numbered semantics of docs/guarantees.md, each in its own test, plus bad input, config and
// invariants of the tree, in double and float. Every expected answer comes from brute force over
// the AABBs or from fcl::NaiveCollisionManager on the same objects.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <stdexcept>
#include <thread>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/cube_collision_manager.h"
#include "scenes.h"
#include "support/correctness.h"

namespace cube {
namespace testing {
namespace {

template <typename S>
class Semantics : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(Semantics, Scalars);

template <typename S>
using V3 = fcl::Vector3<S>;

template <typename S>
scenes::Scene<S> scene(std::size_t n, std::uint32_t seed = 5,
                       scenes::Layout layout = scenes::Layout::uniform, double overlaps = 2.0) {
  scenes::SceneOptions o;
  o.n = n;
  o.seed = seed;
  o.layout = layout;
  o.overlaps_per_object = overlaps;
  return scenes::makeScene<S>(o);
}

/// A callback that counts calls and stops at the first.
template <typename S>
struct StopAtFirst {
  int calls = 0;
  static bool collide(Obj<S>*, Obj<S>*, void* d) {
    ++static_cast<StopAtFirst*>(d)->calls;
    return true;
  }
  static bool distance(Obj<S>*, Obj<S>*, void* d, S&) {
    ++static_cast<StopAtFirst*>(d)->calls;
    return true;
  }
};

// 3. Overlap is closed: AABBs that only touch (a face, an edge, a corner) are candidates; a gap
// of one ulp is not.
TYPED_TEST(Semantics, TouchingBoxesAreCandidates) {
  using S = TypeParam;
  const S gap = std::nextafter(S(1), S(2));  // just above 1
  auto objs = boxes<S>({
      {V3<S>(0, 0, 0), V3<S>(1, 1, 1)},
      {V3<S>(1, 0, 0), V3<S>(2, 1, 1)},      // shares the face x = 1 with #0
      {V3<S>(1, 1, 0), V3<S>(2, 2, 1)},      // shares an edge with #0, a face with #1
      {V3<S>(-1, -1, -1), V3<S>(0, 0, 0)},   // shares the corner (0, 0, 0) with #0
      {V3<S>(gap, 5, 5), V3<S>(2, 6, 6)},    // apart from everything
      {V3<S>(-3, 5, 5), V3<S>(S(1), 6, 6)},  // just left of #4: a gap of one ulp
  });
  // Objects #4 and #5 must be apart in the precondition, the touching pairs touching.
  ASSERT_EQ(objs[5]->getAABB().max_[0], S(1));
  ASSERT_GT(objs[4]->getAABB().min_[0], objs[5]->getAABB().max_[0]);
  const auto ptrs = raw(objs);
  const auto brute = oracle::bruteSelfPairs(ptrs);
  const std::vector<Pair<S>> touching{
      oracle::unordered<S>(ptrs[0], ptrs[1]), oracle::unordered<S>(ptrs[0], ptrs[2]),
      oracle::unordered<S>(ptrs[0], ptrs[3]), oracle::unordered<S>(ptrs[1], ptrs[2])};
  ASSERT_EQ(brute, sorted(touching)) << "FCL's overlap() is closed: the oracle is brute force";

  CubeCollisionManager<S> cube;
  cube.registerObjects(ptrs);
  cube.setup();
  EXPECT_EQ(oracle::selfPairs<S>(cube), brute);
  // The same touching pairs through an object query and through manager-vs-manager.
  EXPECT_EQ(cubeObjectCalls<S>(cube, ptrs[0]), bruteCrossPairs<S>(ptrs, {ptrs[0]}));
  CubeCollisionManager<S> one;
  one.registerObject(ptrs[1]);
  EXPECT_EQ(managerCalls<S>(one, &cube), bruteCrossPairs<S>({ptrs[1]}, ptrs));
  // And in a larger tree, where the touching pair sits in different cubes.
  auto more = scene<S>(200, 3);
  auto all = more.pointers();
  all.insert(all.end(), ptrs.begin(), ptrs.end());
  CubeCollisionManager<S> big(Config{0, 1});
  big.registerObjects(all);
  EXPECT_EQ(oracle::selfPairs<S>(big), oracle::bruteSelfPairs(all));
}

// 5. A registered query object is not paired with itself, and every other overlapping object is
// reported exactly once, for collide and for distance.
TYPED_TEST(Semantics, RegisteredQueryObjectNotPairedWithItself) {
  using S = TypeParam;
  // Thirty boxes all overlapping each other: every other object is a candidate.
  std::vector<std::pair<V3<S>, V3<S>>> corners;
  for (int i = 0; i < 30; ++i) corners.emplace_back(V3<S>(S(i), 0, 0), V3<S>(S(i + 40), 10, 10));
  auto objs = boxes<S>(corners);
  const auto ptrs = raw(objs);
  CubeCollisionManager<S> cube;
  cube.registerObjects(ptrs);
  cube.setup();
  for (auto* q : ptrs) {
    const auto calls = cubeObjectCalls<S>(cube, q);
    EXPECT_EQ(calls.size(), ptrs.size() - 1);
    EXPECT_EQ(calls, bruteCrossPairs<S>(ptrs, {q}));

    DistCalls<S> d;
    cube.distance(q, &d, &DistCalls<S>::record);
    EXPECT_EQ(sorted(d.calls), bruteCrossPairs<S>(ptrs, {q})) << "distance(obj)";
  }
  // Also on a scene, through Naive with the query object excluded.
  auto sc = scene<S>(300, 9);
  const auto sp = sc.pointers();
  CubeCollisionManager<S> m;
  m.registerObjects(sp);
  for (std::size_t i = 0; i < sp.size(); i += 7) {
    Colliding<S> mine, theirs;
    m.collide(sp[i], &mine, &Colliding<S>::record);
    fcl::NaiveCollisionManager<S> naive;
    for (auto* o : sp)
      if (o != sp[i]) naive.registerObject(o);
    naive.collide(sp[i], &theirs, &Colliding<S>::record);
    EXPECT_EQ(mine.result(), theirs.result());
    EXPECT_EQ(cubeObjectCalls<S>(m, sp[i]), bruteCrossPairs<S>(sp, {sp[i]}));
  }
}

// 1. A callback returning true stops the whole query at once: exactly one call, in every query.
TYPED_TEST(Semantics, EarlyStopAfterExactlyOneCallback) {
  using S = TypeParam;
  auto sc = scene<S>(300, 11, scenes::Layout::clustered, 4.0);
  auto other = scene<S>(150, 12, scenes::Layout::clustered, 4.0);
  const auto a = sc.pointers();
  const auto b = other.pointers();
  ASSERT_GT(oracle::bruteSelfPairs(a).size(), 10u);
  ASSERT_GT(bruteCrossPairs<S>(a, b).size(), 10u);
  CubeCollisionManager<S> cube, cube_b;
  cube.registerObjects(a);
  cube.setup();
  cube_b.registerObjects(b);
  fcl::NaiveCollisionManager<S> naive_b;
  for (auto* o : b) naive_b.registerObject(o);
  fcl::DynamicAABBTreeCollisionManager<S> tree_b;
  tree_b.registerObjects(b);
  tree_b.setup();

  auto once = [](auto&& query) {
    StopAtFirst<S> s;
    query(&s);
    return s.calls;
  };
  EXPECT_EQ(once([&](StopAtFirst<S>* s) { cube.collide(s, &StopAtFirst<S>::collide); }), 1);
  EXPECT_EQ(once([&](StopAtFirst<S>* s) { cube.distance(s, &StopAtFirst<S>::distance); }), 1);
  EXPECT_EQ(once([&](StopAtFirst<S>* s) { cube.collide(&cube, s, &StopAtFirst<S>::collide); }), 1);
  // A query object overlapping many: pick the one with most candidates.
  Obj<S>* busy = a[0];
  for (auto* o : a)
    if (bruteCrossPairs<S>(a, {o}).size() > bruteCrossPairs<S>(a, {busy}).size()) busy = o;
  ASSERT_GT(bruteCrossPairs<S>(a, {busy}).size(), 2u);
  EXPECT_EQ(once([&](StopAtFirst<S>* s) { cube.collide(busy, s, &StopAtFirst<S>::collide); }), 1);
  EXPECT_EQ(once([&](StopAtFirst<S>* s) { cube.distance(busy, s, &StopAtFirst<S>::distance); }), 1);
  for (Manager<S>* o : std::vector<Manager<S>*>{&cube_b, &naive_b, &tree_b}) {
    EXPECT_EQ(once([&](StopAtFirst<S>* s) { cube.collide(o, s, &StopAtFirst<S>::collide); }), 1);
    EXPECT_EQ(once([&](StopAtFirst<S>* s) { cube.distance(o, s, &StopAtFirst<S>::distance); }), 1);
  }
  // Stopping later: a callback that stops at its k-th call is called exactly k times.
  for (int k : {2, 5, 10}) {
    int calls = 0;
    cube.collide([&](Obj<S>*, Obj<S>*) { return ++calls == k; });
    EXPECT_EQ(calls, k);
  }
  // And FCL's default callback in binary mode stops at the first colliding pair.
  int after_done = 0;
  struct Data {
    fcl::DefaultCollisionData<S> fcl;
    int* after_done;
  } data{{}, &after_done};
  cube.collide(&data, [](Obj<S>* x, Obj<S>* y, void* d) {
    auto* dd = static_cast<Data*>(d);
    if (dd->fcl.done) ++*dd->after_done;
    return fcl::DefaultCollisionFunction<S>(x, y, &dd->fcl);
  });
  ASSERT_TRUE(data.fcl.result.isCollision()) << "the clustered scene should collide";
  EXPECT_EQ(after_done, 0) << "a callback was called after one returned true";
}

// 8. Empty and one-object managers call no callback, in any query.
TYPED_TEST(Semantics, EmptyAndSingleObjectManagersCallNoCallback) {
  using S = TypeParam;
  auto objs = boxes<S>({{V3<S>(0, 0, 0), V3<S>(1, 1, 1)}, {V3<S>(0, 0, 0), V3<S>(1, 1, 1)}});
  CubeCollisionManager<S> empty, single, filled_then_emptied;
  single.registerObject(objs[0].get());
  filled_then_emptied.registerObjects(raw(objs));
  filled_then_emptied.setup();
  filled_then_emptied.unregisterObject(objs[0].get());
  filled_then_emptied.unregisterObject(objs[1].get());
  ASSERT_TRUE(filled_then_emptied.empty());
  CubeCollisionManager<S> cleared;
  cleared.registerObjects(raw(objs));
  cleared.clear();
  EXPECT_TRUE(cleared.empty());
  EXPECT_EQ(cleared.size(), 0u);
  for (CubeCollisionManager<S>* m : {&empty, &filled_then_emptied, &cleared}) {
    int calls = 0;
    auto c = [&](Obj<S>*, Obj<S>*) { ++calls; };
    auto d = [&](Obj<S>*, Obj<S>*, S&) { ++calls; };
    m->collide(c);
    m->distance(d);
    m->collide(objs[0].get(), c);
    m->distance(objs[0].get(), d);
    m->collide(&single, c);
    m->distance(&single, d);
    single.collide(m, c);
    single.distance(m, d);
    m->setup();
    m->collide(c);
    EXPECT_EQ(calls, 0);
    EXPECT_TRUE(valid(*m));
  }
  int calls = 0;
  auto c = [&](Obj<S>*, Obj<S>*) { ++calls; };
  auto d = [&](Obj<S>*, Obj<S>*, S&) { ++calls; };
  for (int setup = 0; setup < 2; ++setup) {
    single.collide(c);
    single.distance(d);
    single.collide(&single, c);
    single.distance(&single, d);
    single.collide(objs[0].get(), c);  // the registered object itself
    single.distance(objs[0].get(), d);
    single.setup();
  }
  EXPECT_EQ(calls, 0);
  // Sanity: the second object (same box) is found, so the zero above is not vacuous.
  single.collide(objs[1].get(), c);
  EXPECT_EQ(calls, 1);
}

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

// 9. Several threads may query one manager at once and get Naive's answers.
TYPED_TEST(Semantics, TwoThreadsQueryingAtOnceGetNaiveAnswers) {
  using S = TypeParam;
  auto sc = scene<S>(600, 41);
  auto qs = scene<S>(200, 42);
  const auto objs = sc.pointers();
  const auto queries = qs.pointers();
  CubeCollisionManager<S> cube;
  cube.registerObjects(objs);
  cube.setup();
  fcl::NaiveCollisionManager<S> naive;
  for (auto* o : objs) naive.registerObject(o);
  // Expected answers first, single-threaded.
  const auto self_expected = oracle::bruteSelfPairs(objs);
  Colliding<S> naive_hits;
  naive.collide(&naive_hits, &Colliding<S>::record);
  std::vector<std::vector<Pair<S>>> obj_expected;
  std::vector<S> dist_expected;
  for (auto* q : queries) {
    obj_expected.push_back(bruteCrossPairs<S>(objs, {q}));
    dist_expected.push_back(
        fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) { naive.distance(q, d, f); }));
  }
  const CubeCollisionManager<S>& shared = cube;
  auto work = [&](int which, std::vector<std::string>* errors) {
    for (int round = 0; round < 4; ++round) {
      if (oracle::selfPairs<S>(shared) != self_expected) errors->push_back("self pairs");
      Colliding<S> hits;
      shared.collide(&hits, &Colliding<S>::record);
      if (hits.result() != naive_hits.result()) errors->push_back("colliding pairs");
      // The two threads walk the queries in opposite orders.
      for (std::size_t k = 0; k < queries.size(); ++k) {
        const std::size_t i = which == 0 ? k : queries.size() - 1 - k;
        if (cubeObjectCalls<S>(shared, queries[i]) != obj_expected[i])
          errors->push_back("object query " + std::to_string(i));
        const S d = cubeMinDistance<S>(
            [&](void* dd, fcl::DistanceCallBack<S> f) { shared.distance(queries[i], dd, f); });
        // Touching pairs stop the default callback at whichever comes first, with an
        // order-dependent value <= 0; only positive minima are comparable.
        const bool same =
            dist_expected[i] > 0 ? bool(closeDistance<S>(d, dist_expected[i])) : d <= 0;
        if (!same)
          errors->push_back("distance " + std::to_string(i) + ": " + std::to_string(d) + " vs " +
                            std::to_string(dist_expected[i]));
      }
    }
  };
  std::vector<std::string> e0, e1;
  std::thread t0(work, 0, &e0), t1(work, 1, &e1);
  t0.join();
  t1.join();
  EXPECT_TRUE(e0.empty()) << e0.size() << " mismatches, first: " << e0.front();
  EXPECT_TRUE(e1.empty()) << e1.size() << " mismatches, first: " << e1.front();
}

// 6. collide(this) / distance(this) is the self query: same calls, same order.
TYPED_TEST(Semantics, ManagerVsItselfEqualsSelfQuery) {
  using S = TypeParam;
  auto sc = scene<S>(300, 51);
  CubeCollisionManager<S> cube;
  cube.registerObjects(sc.pointers());
  cube.setup();
  Calls<S> self, via;
  cube.collide(&self, &Calls<S>::record);
  cube.collide(&cube, &via, &Calls<S>::record);
  ASSERT_FALSE(self.calls.empty());
  EXPECT_EQ(via.calls, self.calls);
  DistCalls<S> dself, dvia;
  cube.distance(&dself, &DistCalls<S>::record);
  cube.distance(&cube, &dvia, &DistCalls<S>::record);
  EXPECT_EQ(dvia.calls, dself.calls);
  // Every unordered pair once (the recorder never lowers dist), never (a, a).
  const std::size_t n = sc.objects.size();
  EXPECT_EQ(dself.calls.size(), n * (n - 1) / 2);
  std::set<Pair<S>> distinct;
  for (const auto& p : dself.calls) {
    EXPECT_NE(p.first, p.second);
    distinct.insert(oracle::unordered(p.first, p.second));
  }
  EXPECT_EQ(distinct.size(), dself.calls.size());
  const S expected = fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) {
    fcl::NaiveCollisionManager<S> naive;
    for (auto* o : sc.pointers()) naive.registerObject(o);
    naive.distance(d, f);
  });
  EXPECT_TRUE(closeDistance<S>(
      fclMinDistance<S>([&](void* d, fcl::DistanceCallBack<S> f) { cube.distance(&cube, d, f); }),
      expected));
}

// 2. collide(obj) / distance(obj) call callback(managed, obj); manager-vs-manager calls
// callback(object of this, object of other), whatever the other manager's type.
TYPED_TEST(Semantics, CallbackArgumentOrder) {
  using S = TypeParam;
  auto sa = scene<S>(200, 61, scenes::Layout::uniform, 3.0);
  auto sb = scene<S>(100, 62, scenes::Layout::uniform, 3.0);
  const auto a = sa.pointers();
  const auto b = sb.pointers();
  const std::set<Obj<S>*> in_a(a.begin(), a.end()), in_b(b.begin(), b.end());
  CubeCollisionManager<S> cube_a, cube_b;
  cube_a.registerObjects(a);
  cube_b.registerObjects(b);
  fcl::NaiveCollisionManager<S> naive_b;
  for (auto* o : b) naive_b.registerObject(o);
  fcl::DynamicAABBTreeCollisionManager<S> tree_b;
  tree_b.registerObjects(b);
  tree_b.setup();
  std::size_t calls = 0;
  for (auto* q : b) {
    cube_a.collide(q, [&](Obj<S>* x, Obj<S>* y) {
      ++calls;
      EXPECT_TRUE(in_a.count(x));
      EXPECT_EQ(y, q);
    });
    cube_a.distance(q, [&](Obj<S>* x, Obj<S>* y, S&) {
      ++calls;
      EXPECT_TRUE(in_a.count(x));
      EXPECT_EQ(y, q);
    });
  }
  for (Manager<S>* other : std::vector<Manager<S>*>{&cube_b, &naive_b, &tree_b}) {
    cube_a.collide(other, [&](Obj<S>* x, Obj<S>* y) {
      ++calls;
      EXPECT_TRUE(in_a.count(x) && in_b.count(y));
    });
    cube_a.distance(other, [&](Obj<S>* x, Obj<S>* y, S&) {
      ++calls;
      EXPECT_TRUE(in_a.count(x) && in_b.count(y));
    });
  }
  EXPECT_GT(calls, 1000u);
}

// 7. Distance keeps visiting pairs whose AABBs overlap once the best distance is <= 0: a
// signed-distance callback reporting penetration depth must see the deepest pair.
TYPED_TEST(Semantics, DistanceVisitsOverlappingPairsWhenDistNonPositive) {
  using S = TypeParam;
  // Pairs of boxes overlapping by increasing depths along x; pairs far apart from each other.
  std::vector<std::pair<V3<S>, V3<S>>> corners;
  for (int k = 0; k < 40; ++k) {
    const S x = S(100 * k), depth = S(1 + (k * 37) % 40) / 8;  // depths in a shuffled order
    corners.emplace_back(V3<S>(x, 0, 0), V3<S>(x + 10, 10, 10));
    corners.emplace_back(V3<S>(x + 10 - depth, 0, 0), V3<S>(x + 20, 10, 10));
  }
  auto objs = boxes<S>(corners);
  const auto ptrs = raw(objs);
  const auto overlapping = oracle::bruteSelfPairs(ptrs);
  ASSERT_EQ(overlapping.size(), 40u);
  // Signed distance from the AABBs: minus the overlap along x.
  auto signedDistance = [](Obj<S>* x, Obj<S>* y) {
    const auto& p = x->getAABB();
    const auto& q = y->getAABB();
    return std::max(p.min_[0], q.min_[0]) - std::min(p.max_[0], q.max_[0]);
  };
  S deepest = 0;
  for (const auto& p : overlapping) deepest = std::min(deepest, signedDistance(p.first, p.second));
  for (int leaf_size : {1, 4, 16}) {
    SCOPED_TRACE("leaf_size " + std::to_string(leaf_size));
    CubeCollisionManager<S> cube(Config{0, leaf_size});
    cube.registerObjects(ptrs);
    cube.setup();
    std::vector<Pair<S>> seen;
    S best = std::numeric_limits<S>::max();
    cube.distance([&](Obj<S>* x, Obj<S>* y, S& dist) {
      seen.push_back(oracle::unordered(x, y));
      best = std::min(best, signedDistance(x, y));
      dist = best;
      return false;
    });
    EXPECT_EQ(best, deepest);
    // Every overlapping pair was visited, each once.
    std::vector<Pair<S>> seen_overlapping;
    for (const auto& p : sorted(seen))
      if (p.first->getAABB().overlap(p.second->getAABB())) seen_overlapping.push_back(p);
    EXPECT_EQ(seen_overlapping, overlapping);
    // Per-object: the second box of the deepest pair against everything.
    for (std::size_t i = 0; i < ptrs.size(); i += 2) {
      std::size_t visits = 0;
      S obj_best = std::numeric_limits<S>::max();
      cube.distance(ptrs[i], [&](Obj<S>* x, Obj<S>* y, S& dist) {
        if (x->getAABB().overlap(y->getAABB())) ++visits;
        obj_best = std::min(obj_best, signedDistance(x, y));
        dist = obj_best;
        return false;
      });
      EXPECT_EQ(visits, 1u) << "object " << i << " overlaps exactly one box";
      EXPECT_EQ(obj_best, signedDistance(ptrs[i], ptrs[i + 1]));
    }
  }
}

// Objects with unbounded AABBs (planes, halfspaces) live in a separate list but are still
// tested by every query.
TYPED_TEST(Semantics, UnboundedObjectsAreTestedByEveryQuery) {
  using S = TypeParam;
  auto sc = scene<S>(300, 71);
  auto plane = std::make_unique<Obj<S>>(std::make_shared<fcl::Plane<S>>(V3<S>(0, 0, 1), S(0)));
  auto half =
      std::make_unique<Obj<S>>(std::make_shared<fcl::Halfspace<S>>(V3<S>(1, 0, 0), S(-1500)));
  plane->computeAABB();
  half->computeAABB();
  auto objs = sc.pointers();
  objs.push_back(plane.get());
  objs.push_back(half.get());
  CubeCollisionManager<S> cube;
  cube.registerObjects(objs);
  cube.setup();
  ASSERT_TRUE(valid(cube));
  EXPECT_EQ(::cube::detail::coreOf(cube).unboundedItems().size(), 2u);
  const auto brute = oracle::bruteSelfPairs(objs);
  EXPECT_EQ(oracle::selfPairs<S>(cube), brute);
  fcl::NaiveCollisionManager<S> naive;
  for (auto* o : objs) naive.registerObject(o);
  Colliding<S> mine, theirs;
  cube.collide(&mine, &Colliding<S>::record);
  naive.collide(&theirs, &Colliding<S>::record);
  EXPECT_EQ(mine.result(), theirs.result());
  bool plane_hit = false;
  for (const auto& p : mine.hits) plane_hit |= p.first == plane.get() || p.second == plane.get();
  EXPECT_TRUE(plane_hit) << "300 objects straddle z = 0 somewhere";
  for (auto* q : {plane.get(), half.get(), objs[3]})
    EXPECT_EQ(cubeObjectCalls<S>(cube, q), bruteCrossPairs<S>(objs, {q}));
  CubeCollisionManager<S> just_plane;
  just_plane.registerObject(plane.get());
  EXPECT_EQ(managerCalls<S>(cube, &just_plane), bruteCrossPairs<S>(objs, {plane.get()}));
  EXPECT_EQ(managerCalls<S>(just_plane, &cube), bruteCrossPairs<S>({plane.get()}, objs));
  // Distance: with a callback that never lowers dist every pair is visited once, the plane's
  // and the halfspace's included.
  DistCalls<S> visits;
  cube.distance(&visits, &DistCalls<S>::record);
  EXPECT_EQ(sorted(visits.calls).size(), objs.size() * (objs.size() - 1) / 2);
  std::size_t with_plane = 0;
  for (const auto& p : visits.calls)
    with_plane += p.first == plane.get() || p.second == plane.get();
  EXPECT_EQ(with_plane, objs.size() - 1);
  // Unregistering an unbounded object works like any other.
  cube.unregisterObject(plane.get());
  objs.erase(std::find(objs.begin(), objs.end(), plane.get()));
  EXPECT_TRUE(valid(cube));
  EXPECT_EQ(oracle::selfPairs<S>(cube), oracle::bruteSelfPairs(objs));
}

// Bad input throws std::invalid_argument and changes nothing; benign misuse has no effect.
TYPED_TEST(Semantics, BadInputThrowsAndChangesNothing) {
  using S = TypeParam;
  auto sc = scene<S>(100, 81);
  auto objs = sc.pointers();
  CubeCollisionManager<S> cube;
  cube.registerObjects(objs);
  cube.setup();
  const auto pairs = oracle::selfPairs<S>(cube);
  auto nan = boxes<S>({{V3<S>(0, 0, 0), V3<S>(1, 1, 1)}, {V3<S>(0, 0, 0), V3<S>(1, 1, 1)}});
  nan[0]->setNaN();
  auto ok = boxes<S>({{V3<S>(0, 0, 0), V3<S>(1, 1, 1)}});
  auto unchanged = [&]() {
    EXPECT_EQ(cube.size(), objs.size());
    EXPECT_TRUE(valid(cube));
    EXPECT_EQ(oracle::selfPairs<S>(cube), pairs);
  };
  EXPECT_THROW(cube.registerObject(nullptr), std::invalid_argument);
  unchanged();
  EXPECT_THROW(cube.registerObject(nan[0].get()), std::invalid_argument);
  unchanged();
  EXPECT_THROW(cube.registerObjects({ok[0].get(), nullptr}), std::invalid_argument);
  unchanged();
  EXPECT_THROW(cube.registerObjects({ok[0].get(), nan[0].get()}), std::invalid_argument);
  unchanged();
  std::vector<Obj<S>*> big_batch(objs.begin(), objs.end());  // large batch: rebuild path
  big_batch.push_back(ok[0].get());
  big_batch.push_back(nullptr);
  CubeCollisionManager<S> fresh;
  EXPECT_THROW(fresh.registerObjects(big_batch), std::invalid_argument);
  EXPECT_TRUE(fresh.empty());
  EXPECT_THROW(cube.collide(nan[0].get(), [](Obj<S>*, Obj<S>*) {}), std::invalid_argument);
  EXPECT_THROW(cube.distance(nan[0].get(), [](Obj<S>*, Obj<S>*, S&) {}), std::invalid_argument);
  EXPECT_THROW(cube.collide(static_cast<Obj<S>*>(nullptr), [](Obj<S>*, Obj<S>*) {}),
               std::invalid_argument);
  // Registering twice, unregistering or updating an unknown object: no effect.
  cube.registerObject(objs[5]);
  cube.registerObjects({objs[6], objs[6]});
  unchanged();
  cube.unregisterObject(nan[1].get());
  cube.unregisterObject(nullptr);
  cube.update(nan[1].get());
  unchanged();
  // A registered object whose AABB became NaN: update(obj) throws and keeps the old box.
  auto victim = boxes<S>({{V3<S>(0, 0, 0), V3<S>(10, 10, 10)}});
  cube.registerObject(victim[0].get());
  objs.push_back(victim[0].get());
  const auto with_victim = oracle::bruteSelfPairs(objs);
  victim[0]->setNaN();
  EXPECT_THROW(cube.update(victim[0].get()), std::invalid_argument);
  EXPECT_TRUE(valid(cube));
  EXPECT_THROW(cube.update(), std::invalid_argument);
  EXPECT_THROW(cube.update(std::vector<Obj<S>*>{objs[0], victim[0].get()}), std::invalid_argument);
  EXPECT_TRUE(valid(cube));
  EXPECT_EQ(oracle::selfPairs<S>(cube), with_victim) << "the NaN object keeps its old box";
}

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

// With unbounded_limit beyond float's range, boxes past float's range stay in the cubes, where
// their bounds round to float infinities: a box spanning both has no centre (inf - inf). The
// build must still order every object (its centre counts as 0) and answer like brute force.
TEST(Semantics, BoxesBeyondFloatRangeInsideTheCubes) {
  using S = double;
  std::vector<std::pair<V3<S>, V3<S>>> corners;
  for (int i = 0; i < 300; ++i) {
    const S x = S(i % 17), y = S(i % 5), z = S(i / 17);
    if (i % 10 == 0)
      corners.emplace_back(V3<S>(-1e39, y, z), V3<S>(1e39, y + 1, z + 1));  // both infinities
    else if (i % 10 == 5)
      corners.emplace_back(V3<S>(x, 1e39, z), V3<S>(x + 1, 2e39, z + 1));  // +inf only
    else
      corners.emplace_back(V3<S>(x, y, z), V3<S>(x + 1.5, y + 1.5, z + 1.5));
  }
  auto objs = boxes<S>(corners);
  const auto ptrs = raw(objs);
  const auto brute = oracle::bruteSelfPairs(ptrs);
  Config c;
  c.unbounded_limit = 1e300;
  for (int leaf_size : {1, 4, 16}) {
    c.leaf_size = leaf_size;
    CubeCollisionManager<S> cube(c);
    cube.registerObjects(ptrs);
    cube.setup();
    ASSERT_TRUE(valid(cube));
    EXPECT_TRUE(::cube::detail::coreOf(cube).unboundedItems().empty());  // all in the cubes
    EXPECT_EQ(oracle::selfPairs<S>(cube), brute);
    EXPECT_EQ(cubeObjectCalls<S>(cube, ptrs[30]), bruteCrossPairs<S>(ptrs, {ptrs[30]}));
  }
  EXPECT_GT(brute.size(), 500u);
}

// Gaps beyond 1.3e154 square to infinity in double: the walk must still find the nearest pair
// when the best distance so far is itself that large (self, object and manager queries), and
// not stop after the first pair it happens to visit.
TEST(Semantics, DistancesWhoseSquaresOverflow) {
  using S = double;
  std::vector<std::pair<V3<S>, V3<S>>> corners;
  // Boxes 1e200 apart along x, except one pair 3e199 apart (#11, #12), with sizes of 1e199.
  for (int i = 0; i < 40; ++i) {
    const S x = (i <= 11 ? S(i) : S(i) - 0.7) * 1e200;
    const S y = S(i % 3) * 1e199;
    corners.emplace_back(V3<S>(x, y, 0), V3<S>(x + 1e199, y + 1e199, 1e199));
  }
  auto objs = boxes<S>(corners);
  const auto ptrs = raw(objs);
  // The exact gap of two objects' boxes, without squaring (hypot).
  const auto gap = [](Obj<S>* a, Obj<S>* b) {
    S d[3];
    for (int k = 0; k < 3; ++k)
      d[k] = std::max({S(0), a->getAABB().min_[k] - b->getAABB().max_[k],
                       b->getAABB().min_[k] - a->getAABB().max_[k]});
    return std::hypot(d[0], std::hypot(d[1], d[2]));
  };
  S want = std::numeric_limits<S>::max();
  for (std::size_t i = 0; i < ptrs.size(); ++i)
    for (std::size_t j = i + 1; j < ptrs.size(); ++j) want = std::min(want, gap(ptrs[i], ptrs[j]));
  ASSERT_GT(want, 1e154);
  ASSERT_LT(want, 0.5e200);
  struct Search {
    S (*measure)(Obj<S>*, Obj<S>*);
    S best = std::numeric_limits<S>::max();
  };
  const auto fn = [](Obj<S>* a, Obj<S>* b, void* data, S& dist) {
    auto& s = *static_cast<Search*>(data);
    if (a != b) s.best = std::min(s.best, s.measure(a, b));
    dist = s.best;
    return false;
  };
  Config c;
  c.unbounded_limit = 1e300;  // keep them in the cubes
  for (int leaf_size : {1, 4}) {
    c.leaf_size = leaf_size;
    CubeCollisionManager<S> cube(c);
    cube.registerObjects(ptrs);
    cube.setup();
    ASSERT_TRUE(valid(cube));
    Search self{+gap};
    cube.distance(&self, fn);
    EXPECT_EQ(self.best, want) << "self, leaf size " << leaf_size;
    Search one{+gap};
    CubeCollisionManager<S> others(c);
    for (std::size_t i = 0; i < ptrs.size(); ++i)
      if (i != 12) others.registerObject(ptrs[i]);
    others.setup();
    others.distance(ptrs[12], &one, fn);
    EXPECT_EQ(one.best, want) << "object, leaf size " << leaf_size;
    Search cross{+gap};
    CubeCollisionManager<S> single(c);
    single.registerObject(ptrs[12]);
    single.setup();
    others.distance(&single, &cross, fn);
    EXPECT_EQ(cross.best, want) << "manager, leaf size " << leaf_size;
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

}  // namespace
}  // namespace testing
}  // namespace cube
