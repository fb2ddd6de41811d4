// Ray and region queries (spatial_queries.h) equal loops over every registered object, in mixed
// and large scenes, after updates and unregistration, and with margins.

#include <gtest/gtest.h>

#include "support/spatial_brute.h"

namespace {

using namespace spatialbrute;

TYPED_TEST(SpatialQueries, RaysEqualBruteForceInMixedScenes) {
  using S = TypeParam;
  World<S> w(300, 5);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  ASSERT_TRUE(m.validate());
  std::size_t narrow_hits = 0;
  checkRays(m, w.objs, 140, 17, &narrow_hits);
  EXPECT_GT(narrow_hits, 20u) << "the narrow phase should decide many hits";
}

TYPED_TEST(SpatialQueries, RaysEqualBruteForceInLargeBoxScene) {
  using S = TypeParam;
  World<S> w(4000, 9, false);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  cube::RayOptions<S> box_only;
  box_only.narrow_phase = false;
  for (const auto& [from, to] : segments(w.objs, 300, 3))
    expectSameHits(cube::raycastAll(m, from, to, box_only), bruteRay(m, from, to, box_only),
                   "large scene");
  checkRays(m, w.objs, 30, 4);
}

TYPED_TEST(SpatialQueries, RegionsEqualBruteForce) {
  using S = TypeParam;
  World<S> w(600, 21);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  checkRegions(m, w.objs, 8);
}

TYPED_TEST(SpatialQueries, ResultsFollowUpdatesAndUnregistration) {
  using S = TypeParam;
  World<S> w(400, 33);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> step(-8, 8);
  for (int round = 0; round < 3; ++round) {
    for (std::size_t i = round; i < w.objs.size(); i += 3) {
      Obj<S>* o = w.objs[i];
      o->setTranslation(o->getTranslation() + V3<S>(S(step(rng)), S(step(rng)), S(step(rng))));
      o->computeAABB();
    }
    m.update();
    ASSERT_TRUE(m.validate());
    checkRays(m, w.objs, 40, 100 + round);
    checkRegions(m, w.objs, 200 + round);
    for (std::size_t i = round; i < w.objs.size(); i += 17) m.unregisterObject(w.objs[i]);
    ASSERT_TRUE(m.validate());
    std::vector<Obj<S>*> left;
    m.getObjects(left);
    checkRays(m, left, 40, 300 + round);
    checkRegions(m, left, 400 + round);
  }
}

// With margins (margins.h) the manager's boxes are grown: the queries test those, as the loop
// over every object does with the grown boxes; the narrow phase still sees the geometry.
TYPED_TEST(SpatialQueries, MarginsGrowTheTestedBoxes) {
  using S = TypeParam;
  World<S> w(300, 61);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  m.setMargin(S(0.75));
  for (std::size_t i = 0; i < w.objs.size(); i += 5) m.setMargin(w.objs[i], S(3));
  ASSERT_TRUE(m.validate());
  checkRays(m, w.objs, 60, 62);
  checkRegions(m, w.objs, 63);
}

}  // namespace
