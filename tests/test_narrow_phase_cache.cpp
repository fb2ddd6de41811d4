// The narrow-phase pipeline's cache: it answers only pairs whose objects did not change since they
// were last answered, and every kind of change sends a pair back to FCL; cached or not, the
// contacts and their order are FCL's.

#include <gtest/gtest.h>

#include "support/narrow_phase_world.h"

namespace {

using namespace narrowphase;

// What the pipeline does per pair: culled pairs skip FCL, a second query on an unchanged world
// calls FCL for no pair (FCL's answers and those of the cull's costlier part come from the
// cache), and the counts add up.
TYPED_TEST(NarrowPhase, SecondQueryOnAStillWorldCallsFclForNoPair) {
  using S = TypeParam;
  auto world = scene<S>(Layout::uniform, false, 500, 3);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(world.pointers());
  fcl::CollisionRequest<S> all;
  all.num_max_contacts = 1 << 30;
  cube::NarrowPhaseCache<S> cache;
  cube::NarrowPhaseStats first, second;
  cube::NarrowPhaseOptions<S> o;
  o.cache = &cache;
  o.stats = &first;
  const auto a = cube::collideAll<S>(m, all, o);
  o.stats = &second;
  const auto b = cube::collideAll<S>(m, all, o);
  EXPECT_TRUE(sameContacts(a, b, false));
  const std::size_t candidates = cube::overlappingPairs<S>(m).size();
  EXPECT_EQ(first.candidate_pairs, candidates);
  EXPECT_EQ(first.culled + first.proved + first.narrow_calls, candidates);
  EXPECT_EQ(first.cached, 0u);
  EXPECT_GT(first.culled, 0u);
  EXPECT_GT(first.narrow_calls, 0u);
  EXPECT_EQ(second.candidate_pairs, candidates);
  // The pairs the cheaper part of the records' cull settles (spheres, boxes, inscribed balls) are
  // settled again, before the lookup, which costs more; those its costlier part settled after the
  // lookup missed (capsules, inner volumes) come from the cache with FCL's answers.
  EXPECT_EQ(second.narrow_calls, 0u);
  EXPECT_LE(second.culled, first.culled);
  EXPECT_LE(second.proved, first.proved);
  EXPECT_LT(second.culled + second.proved, first.culled + first.proved) << "some by the tight part";
  EXPECT_EQ(second.cached,
            first.narrow_calls + (first.culled - second.culled) + (first.proved - second.proved));
  EXPECT_EQ(second.culled + second.proved + second.cached, candidates);
  EXPECT_EQ(cache.size(), second.cached);
}

// A motion loop with one cache: objects move (translated, rotated, some back to where they
// were), and some leave the manager and come back. At every
// step collideAll with the cache equals collideAll without it, contacts and order, on 1 and 2
// threads; the pairs answered from the cache are those whose two objects did not change since
// they were last answered; and the cache never holds more than about twice one step's pairs.
TYPED_TEST(NarrowPhase, CacheFollowsAMotionLoop) {
  using S = TypeParam;
  for (const bool meshes : {false, true}) {
    auto world = scene<S>(Layout::clustered, meshes, meshes ? 100 : 300, 11);
    cube::Config config;
    config.keep_pairs = true;
    cube::CubeCollisionManager<S> m(config);
    m.registerObjects(world.pointers());
    fcl::CollisionRequest<S> all;
    all.num_max_contacts = 1 << 30;
    all.enable_contact = true;
    cube::NarrowPhaseCache<S> cache;
    std::map<const fcl::CollisionObject<S>*, fcl::Transform3<S>> start;
    for (auto* o : world.pointers()) start[o] = o->getTransform();
    std::vector<fcl::CollisionObject<S>*> out;  // unregistered for now
    std::set<const fcl::CollisionObject<S>*> changed;
    for (int step = 0; step < 9; ++step) {
      std::map<const fcl::CollisionObject<S>*, fcl::Transform3<S>> before;
      for (auto* o : world.pointers()) before[o] = o->getTransform();
      if (step > 0) {
        cube::scenes::jitter(world, 0.1, 0.05, step % 2 == 0, 100 + step);
        if (step % 3 == 0)  // a few back where they started: a pose seen before
          for (std::size_t i = 0; i < world.objects.size(); i += 37) {
            auto* o = world.objects[i].get();
            o->setTransform(start[o]);
            o->computeAABB();
          }
        if (step % 4 == 1) {  // some leave, those out come back
          for (auto* o : out) m.registerObject(o);
          out.clear();
          for (std::size_t i = step; i < world.objects.size(); i += 23)
            out.push_back(world.objects[i].get());
          for (auto* o : out) m.unregisterObject(o);
        }
        m.update();
      }
      changed.clear();
      for (auto* o : world.pointers())
        if (std::memcmp(before[o].matrix().data(), o->getTransform().matrix().data(),
                        sizeof(S) * 16) != 0)
          changed.insert(o);
      const auto candidates = cube::overlappingPairs<S>(m);
      std::size_t unchanged = 0;
      for (const auto& [a, b] : candidates) unchanged += !changed.count(a) && !changed.count(b);
      for (const int threads : {1, 2}) {
        cube::NarrowPhaseStats st;
        cube::NarrowPhaseOptions<S> o;
        o.threads = threads;
        o.cache = &cache;
        o.stats = &st;
        const auto got = cube::collideAll<S>(m, all, o);
        const auto want = cube::collideAll<S>(m, all, cube::NarrowPhaseOptions<S>{threads});
        EXPECT_TRUE(sameContacts(got, want)) << "step " << step << ", " << threads << " threads";
        EXPECT_EQ(st.candidate_pairs, candidates.size());
        EXPECT_EQ(st.culled + st.proved + st.cached + st.narrow_calls, st.candidate_pairs);
        if (threads == 1 && step > 0) {
          // Every unchanged pair that was a candidate last step too comes from the cache, and
          // no pair with a changed object does (its object was compared with its pose).
          EXPECT_LE(st.cached, unchanged) << "step " << step;
          EXPECT_GT(st.cached, 0u) << "step " << step;
        }
        if (threads == 2) {
          EXPECT_EQ(st.narrow_calls, 0u) << "the same world again";
          EXPECT_GT(st.cached, 0u) << "the same world again";
        }
        EXPECT_LE(cache.size(), 2 * candidates.size() + 64) << "step " << step;
      }
    }
    for (auto* o : out) m.registerObject(o);
    // forget drops the pairs of that object the cache holds (those FCL answered, this query or
    // an earlier one).
    const std::size_t held = cache.size();
    std::size_t of_first = 0;
    auto* first = world.objects[0].get();
    for (const auto& [a, b] : cube::overlappingPairs<S>(m)) of_first += a == first || b == first;
    ASSERT_GT(of_first, 0u) << "the first object of a clustered scene has neighbours";
    cache.forget(first);
    EXPECT_LT(cache.size(), held);
    cube::NarrowPhaseStats st;
    cube::NarrowPhaseOptions<S> o;
    o.threads = 1;
    o.cache = &cache;
    o.stats = &st;
    EXPECT_TRUE(sameContacts(cube::collideAll<S>(m, all, o),
                             cube::collideAll<S>(m, all, cube::NarrowPhaseOptions<S>{1})));
    EXPECT_GE(st.culled + st.narrow_calls, of_first) << "the forgotten pairs are answered anew";
    // Half the objects leave: the entries of their pairs go at the next query.
    for (std::size_t i = 0; i < world.objects.size(); i += 2)
      m.unregisterObject(world.objects[i].get());
    const auto got = cube::collideAll<S>(m, all, o);
    EXPECT_TRUE(sameContacts(got, cube::collideAll<S>(m, all, cube::NarrowPhaseOptions<S>{1})));
    EXPECT_LE(cache.size(), 2 * cube::overlappingPairs<S>(m).size() + 64);
  }
}

// Every kind of change sends the pairs of the changed object back to FCL: a translation by one
// ulp, a rotation, a geometry resized in place (new local AABB), another request. Setting the same
// transform again changes nothing. forget() and clear() drop answers. After each change the result
// equals an uncached query.
TYPED_TEST(NarrowPhase, EveryKindOfMotionInvalidatesTheCache) {
  using S = TypeParam;
  auto world = scene<S>(Layout::uniform, false, 300, 11);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(world.pointers());
  fcl::CollisionRequest<S> all;
  all.num_max_contacts = 1 << 30;
  all.enable_contact = true;
  cube::NarrowPhaseCache<S> cache;
  // An object of a colliding pair: its pairs are never culled, so its changes show.
  fcl::CollisionObject<S>* moved = nullptr;
  for (const auto& [a, b] : cube::overlappingPairs<S>(m)) {
    fcl::CollisionResult<S> r;
    if (fcl::collide(a, b, all, r) > 0) {
      moved = a;
      break;
    }
  }
  ASSERT_NE(moved, nullptr);

  const auto query = [&](cube::NarrowPhaseStats& st, const fcl::CollisionRequest<S>& req) {
    cube::NarrowPhaseOptions<S> o;
    o.cache = &cache;
    o.stats = &st;
    const auto got = cube::collideAll<S>(m, req, o);
    EXPECT_TRUE(sameContacts(got, cube::collideAll<S>(m, req, cube::NarrowPhaseOptions<S>{1}),
                             req.enable_contact));
    return got;
  };
  cube::NarrowPhaseStats warm;
  query(warm, all);
  const auto expectRecomputed = [&](const char* what, bool recomputed) {
    cube::NarrowPhaseStats st;
    query(st, all);
    if (recomputed)
      EXPECT_GT(st.narrow_calls, 0u) << what;
    else
      EXPECT_EQ(st.narrow_calls, 0u) << what;
    EXPECT_EQ(st.culled + st.proved + st.cached + st.narrow_calls, st.candidate_pairs) << what;
  };
  expectRecomputed("nothing moved", false);

  moved->setTransform(moved->getTransform());
  expectRecomputed("the same transform again", false);

  fcl::Vector3<S> t = moved->getTranslation();
  t[0] = std::nextafter(t[0], std::numeric_limits<S>::max());
  moved->setTranslation(t);
  moved->computeAABB();
  m.update(moved);
  expectRecomputed("one ulp along x", true);

  moved->setRotation(moved->getRotation() *
                     fcl::AngleAxis<S>(S(1e-3), fcl::Vector3<S>::UnitZ()).toRotationMatrix());
  moved->computeAABB();
  m.update(moved);
  expectRecomputed("a small rotation", true);

  // FCL 0.7 has no way to give an object another geometry; a geometry can change in place.
  auto* g = const_cast<fcl::CollisionGeometry<S>*>(moved->collisionGeometry().get());
  switch (g->getNodeType()) {
    case fcl::GEOM_BOX:
      static_cast<fcl::Box<S>*>(g)->side *= S(1.5);
      break;
    case fcl::GEOM_SPHERE:
      static_cast<fcl::Sphere<S>*>(g)->radius *= S(1.5);
      break;
    case fcl::GEOM_CYLINDER:
      static_cast<fcl::Cylinder<S>*>(g)->radius *= S(1.5);
      static_cast<fcl::Cylinder<S>*>(g)->lz *= S(1.5);
      break;
    default:
      FAIL() << "the scene has boxes, spheres and cylinders only";
  }
  g->computeLocalAABB();
  moved->computeAABB();
  m.update(moved);
  expectRecomputed("the geometry resized in place", true);

  fcl::CollisionRequest<S> other = all;
  other.enable_contact = false;
  cube::NarrowPhaseStats st;
  query(st, other);
  EXPECT_EQ(st.cached, 0u) << "another request";
  EXPECT_GT(st.narrow_calls, 0u);

  // Back to the request with contacts, which nothing proves: the moved object's colliding pair
  // is in the cache again.
  query(st, all);
  const std::size_t before = cache.size();
  cache.forget(moved);
  EXPECT_LT(cache.size(), before);
  cache.clear();
  EXPECT_EQ(cache.size(), 0u);
}

}  // namespace
