// What ray and region queries promise besides their answers: an empty manager finds nothing,
// concurrent queries agree with one thread's, and bad input throws and changes nothing.

#include <gtest/gtest.h>

#include "support/spatial_brute.h"

namespace {

using namespace spatialbrute;

TYPED_TEST(SpatialQueries, EmptyManagerFindsNothing) {
  using S = TypeParam;
  cube::CubeCollisionManager<S> m;
  EXPECT_FALSE(cube::raycastFirst(m, V3<S>(0, 0, 0), V3<S>(1, 1, 1)).has_value());
  EXPECT_TRUE(cube::raycastAll(m, V3<S>(0, 0, 0), V3<S>(1, 1, 1)).empty());
  EXPECT_TRUE(cube::objectsInBox(m, fcl::AABB<S>(V3<S>(-1, -1, -1), V3<S>(1, 1, 1))).empty());
  EXPECT_TRUE(cube::objectsNear(m, V3<S>(0, 0, 0), S(100)).empty());
}

// The queries share nothing: four threads at once get what one thread got.
TYPED_TEST(SpatialQueries, ConcurrentQueriesAgree) {
  using S = TypeParam;
  World<S> w(500, 41);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  const auto segs = segments(w.objs, 60, 43);
  std::vector<std::vector<cube::RayHit<S>>> want;
  std::vector<std::vector<Obj<S>*>> want_near;
  for (const auto& [from, to] : segs) {
    want.push_back(cube::raycastAll(m, from, to));
    want_near.push_back(cube::objectsNear(m, from, S(6)));
  }
  std::vector<int> mismatches(4, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int round = 0; round < 3; ++round)
        for (std::size_t i = 0; i < segs.size(); ++i) {
          const auto got = cube::raycastAll(m, segs[i].first, segs[i].second);
          const auto first = cube::raycastFirst(m, segs[i].first, segs[i].second);
          bool same = got.size() == want[i].size();
          for (std::size_t j = 0; same && j < got.size(); ++j)
            same = got[j].object == want[i][j].object && got[j].t == want[i][j].t;
          same = same && first.has_value() == !want[i].empty() &&
                 (!first || (first->object == want[i][0].object && first->t == want[i][0].t));
          same = same && cube::objectsNear(m, segs[i].first, S(6)) == want_near[i];
          mismatches[t] += !same;
        }
    });
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t) EXPECT_EQ(mismatches[t], 0) << "thread " << t;
}

TYPED_TEST(SpatialQueries, BadInputThrowsAndChangesNothing) {
  using S = TypeParam;
  World<S> w(100, 3);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  const S nan = std::numeric_limits<S>::quiet_NaN(), inf = std::numeric_limits<S>::infinity();
  const V3<S> ok(0, 0, 0), far(10, 10, 10);
  for (const V3<S>& bad : {V3<S>(nan, 0, 0), V3<S>(0, inf, 0), V3<S>(0, 0, -inf)}) {
    EXPECT_THROW(cube::raycastFirst(m, bad, far), std::invalid_argument);
    EXPECT_THROW(cube::raycastAll(m, ok, bad), std::invalid_argument);
    EXPECT_THROW(cube::raycastObject(*w.objs[0], w.objs[0]->getAABB(), bad, far),
                 std::invalid_argument);
    EXPECT_THROW(cube::objectsNear(m, bad, S(1)), std::invalid_argument);
  }
  const S big = std::numeric_limits<S>::max();
  EXPECT_THROW(cube::raycastAll(m, V3<S>(-big, 0, 0), V3<S>(big, 0, 0)), std::invalid_argument);
  for (const S tol : {S(-1), nan}) {
    cube::RayOptions<S> opt;
    opt.tolerance = tol;
    EXPECT_THROW(cube::raycastFirst(m, ok, far, opt), std::invalid_argument);
    EXPECT_THROW(cube::raycastAll(m, ok, far, opt), std::invalid_argument);
  }
  for (const S r : {S(-1), nan, -inf})
    EXPECT_THROW(cube::objectsNear(m, ok, r), std::invalid_argument);
  fcl::AABB<S> nan_box(ok, far);
  nan_box.max_[1] = nan;
  EXPECT_THROW(cube::objectsInBox(m, nan_box), std::invalid_argument);
  fcl::AABB<S> inverted(ok, far);
  std::swap(inverted.min_[2], inverted.max_[2]);
  EXPECT_THROW(cube::objectsInBox(m, inverted), std::invalid_argument);
  EXPECT_TRUE(m.validate());
  EXPECT_EQ(m.size(), w.objs.size());
}

}  // namespace
