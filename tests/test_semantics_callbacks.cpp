// The numbered semantics of docs/guarantees.md on which pairs a query hands to the callback, in
// which order of arguments, and when it stops: touching boxes are candidates, a query object is
// not paired with itself, a callback returning true stops at once, empty managers call nothing,
// collide(this) is the self query, distance visits overlapping pairs, unbounded objects are
// tested. Every expected answer comes from brute force over the AABBs or from
// fcl::NaiveCollisionManager on the same objects, in double and float.

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "support/semantics_world.h"

namespace cube {
namespace testing {
namespace {

using namespace semantics_world;

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

// Records the pairs of a self-collide in call order and stops after `limit` of them.
template <typename S>
struct StopAfter {
  std::size_t limit;
  std::vector<std::pair<Obj<S>*, Obj<S>*>> pairs;
  static bool collide(Obj<S>* a, Obj<S>* b, void* d) {
    auto& self = *static_cast<StopAfter*>(d);
    self.pairs.emplace_back(a, b);
    return self.pairs.size() >= self.limit;
  }
};

// A self-collide large enough for the float columns, stopped after k calls, makes exactly the
// first k calls of the whole walk: stopping early skips work, never a pair.
TYPED_TEST(Semantics, SelfCollideStoppedEarlyMakesTheWholeWalksFirstCalls) {
  using S = TypeParam;
  for (const auto layout : {scenes::Layout::uniform, scenes::Layout::clustered}) {
    auto sc = scene<S>(1200, 21, layout, 2.0);
    const auto objs = sc.pointers();
    CubeCollisionManager<S> cube;
    cube.registerObjects(objs);
    cube.setup();
    StopAfter<S> all{std::size_t(-1), {}};
    cube.collide(&all, &StopAfter<S>::collide);
    std::vector<Pair<S>> seen;
    for (const auto& p : all.pairs) seen.push_back(oracle::unordered(p.first, p.second));
    std::sort(seen.begin(), seen.end());
    ASSERT_EQ(seen, oracle::bruteSelfPairs(objs));
    ASSERT_GT(all.pairs.size(), 100u);
    for (const std::size_t k : {std::size_t(1), std::size_t(2), std::size_t(7), std::size_t(64),
                                all.pairs.size() / 2, all.pairs.size()}) {
      StopAfter<S> some{k, {}};
      cube.collide(&some, &StopAfter<S>::collide);
      ASSERT_EQ(some.pairs.size(), k);
      EXPECT_TRUE(std::equal(some.pairs.begin(), some.pairs.end(), all.pairs.begin()))
          << "k = " << k;
    }
  }
}

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

}  // namespace
}  // namespace testing
}  // namespace cube
