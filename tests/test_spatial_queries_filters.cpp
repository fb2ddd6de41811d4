// Filter bits rule ray and region queries as they rule a loop over every object, including
// objects left with the default bits.

#include <gtest/gtest.h>

#include "support/spatial_brute.h"

namespace {

using namespace spatialbrute;

// Filter bits in each layout: none set (every object the default bits), few kinds (the cubes
// keep them apart after update(): whole cubes skipped or passed), the same bits set after the
// build (the cubes know no groups until the next update()), and hundreds of random values (more
// than the filter groups, tested object by object).
TYPED_TEST(SpatialQueries, FilterBitsRuleRaysAndRegionsAsLoopsOverEveryObject) {
  using S = TypeParam;
  World<S> w(500, 71);
  for (const int kinds : {-1, 4, 6, 0}) {
    for (const bool regroup : {true, false}) {
      if (kinds < 0 && !regroup) continue;
      cube::CubeCollisionManager<S> m;
      m.registerObjects(w.objs);
      if (kinds >= 0) spatial::setBits(m, w.objs, kinds, 72 + kinds);
      if (regroup) m.update();
      ASSERT_TRUE(m.validate());
      const std::string where =
          "kinds " + std::to_string(kinds) + (regroup ? " after update" : " before update");
      const std::size_t changed = checkFiltered(m, w.objs, 73 + kinds);
      EXPECT_GT(changed, 20u) << where << ": the filters should change many answers";
      // Objects unregistered, moved and updated: their bits go or stay with them.
      for (std::size_t i = 0; i < w.objs.size(); i += 13) m.unregisterObject(w.objs[i]);
      std::vector<Obj<S>*> left;
      m.getObjects(left);
      for (std::size_t i = 0; i < left.size(); i += 5)
        left[i]->setTranslation(left[i]->getTranslation() + V3<S>(3, -2, 1));
      for (Obj<S>* o : left) o->computeAABB();
      m.update();
      ASSERT_TRUE(m.validate());
      checkFiltered(m, left, 74 + kinds);
    }
  }
}

// The filter's bits against the default bits of objects that have none of their own: all of
// them pass, or none.
TYPED_TEST(SpatialQueries, FilterAgainstDefaultBitsPassesAllOrNone) {
  using S = TypeParam;
  World<S> w(200, 75);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  const fcl::AABB<S> all(V3<S>::Constant(-std::numeric_limits<S>::infinity()),
                         V3<S>::Constant(std::numeric_limits<S>::infinity()));
  std::vector<Obj<S>*> every;
  m.getObjects(every);
  EXPECT_EQ(cube::objectsInBox(m, all, cube::QueryFilter{}), every);
  EXPECT_EQ(cube::objectsInBox(m, all, cube::QueryFilter{3, 1}), every);
  EXPECT_TRUE(cube::objectsInBox(m, all, cube::QueryFilter{2, 2}).empty());
  EXPECT_TRUE(cube::objectsInBox(m, all, cube::QueryFilter{1, 2}).empty());
  EXPECT_TRUE(
      cube::raycastAll(m, V3<S>(-60, -60, -60), V3<S>(60, 60, 60), {}, cube::QueryFilter{1, 2})
          .empty());
  // An object that pairs with nothing is still found without a filter.
  m.setFilter(w.objs[0], 1, 0);
  const auto found = cube::objectsInBox(m, all);
  EXPECT_EQ(found, every);
  const auto filtered = cube::objectsInBox(m, all, cube::QueryFilter{});
  EXPECT_EQ(filtered.size(), every.size() - 1);
  EXPECT_EQ(std::count(filtered.begin(), filtered.end(), w.objs[0]), 0);
}

}  // namespace
