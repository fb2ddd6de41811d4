// The narrow-phase pipeline's answers (narrow_phase.h, queries.h) are FCL's on every thread count:
// collideAll gives the contacts, in the order, that FCL's own accumulation gives (fcl::collide on
// each pair of the manager's walk with one result); minimumDistance the brute-force minimum of
// fcl::distance; collidePairs each pair's own fcl::collide; the colliding pairs those that added a
// contact.

#include <gtest/gtest.h>

#include "support/narrow_phase_world.h"

namespace {

using namespace narrowphase;

// collideAll on 0 (the default), 1, 2, 3 and 8 threads (more than the cores: oversubscribed),
// with and without a cache,
// equals FCL's accumulation bit for bit, for self, object and manager-against-manager queries,
// on primitives and meshes, for budgets that stop early and budgets that take everything.
TYPED_TEST(NarrowPhase, CollideAllEqualsFclOnEveryThreadCount) {
  using S = TypeParam;
  for (bool meshes : {false, true}) {
    auto world = scene<S>(Layout::clustered, meshes, meshes ? 150 : 400, 7);
    auto robot = scene<S>(Layout::clustered, meshes, 40, 8);
    cube::CubeCollisionManager<S> m, r;
    m.registerObjects(world.pointers());
    r.registerObjects(robot.pointers());
    for (const auto& request : requests<S>()) {
      Accumulate<S> self, one, two;
      self.request = one.request = two.request = request;
      m.collide(&self, &Accumulate<S>::fn);
      m.collide(robot.objects[0].get(), &one, &Accumulate<S>::fn);
      m.collide(&r, &two, &Accumulate<S>::fn);
      if (request.num_max_contacts > 100) {
        ASSERT_GT(self.result.numContacts(), 50u) << "the scene must collide a lot";
        ASSERT_GT(self.colliding.size(), 20u);
        ASSERT_GT(two.result.numContacts(), 5u);
      }
      for (int threads : {0, 1, 2, 3, 8}) {
        cube::NarrowPhaseCache<S> cache;
        for (int round = 0; round < 2; ++round) {  // round 1: answered from the cache
          cube::NarrowPhaseOptions<S> o;
          o.threads = threads;
          o.cache = round == 0 && threads == 2 ? nullptr : &cache;
          const auto what = ::testing::Message()
                            << "meshes " << meshes << " max " << request.num_max_contacts
                            << " contact " << request.enable_contact << " threads " << threads
                            << " round " << round;
          const bool geometry = request.enable_contact;
          // The colliding pairs come with the contacts: a stale list must be replaced.
          std::vector<cube::ObjectPair<S>> pairs(3, {nullptr, nullptr});
          o.colliding = &pairs;
          EXPECT_TRUE(sameContacts(cube::collideAll<S>(m, request, o), self.result, geometry))
              << what;
          EXPECT_EQ(pairs, self.colliding) << what;
          EXPECT_TRUE(sameContacts(cube::collideAll<S>(m, robot.objects[0].get(), request, o),
                                   one.result, geometry))
              << what;
          EXPECT_EQ(pairs, one.colliding) << what;
          EXPECT_TRUE(sameContacts(cube::collideAll<S>(m, r, request, o), two.result, geometry))
              << what;
          EXPECT_EQ(pairs, two.colliding) << what;
        }
      }
    }
  }
}

// minimumDistance on 0, 1, 2, 3 and 8 threads, with and without a cache, equals the
// brute-force minimum of fcl::distance, self and for an object; more than one thread gives the
// same bits on every count, and the nearest points belong to a pair at that distance.
TYPED_TEST(NarrowPhase, MinimumDistanceEqualsBruteForceOnEveryThreadCount) {
  using S = TypeParam;
  for (bool meshes : {false, true}) {
    cube::scenes::SceneOptions so;
    so.n = meshes ? 60 : 200;
    so.meshes = meshes;
    so.seed = 5;
    so.size_scale = 0.02;  // nothing touches: the search runs its course
    auto world = cube::scenes::makeScene<S>(so);
    auto objs = world.pointers();
    fcl::CollisionObject<S>* probe = objs.back();
    objs.pop_back();
    fcl::DistanceRequest<S> req;
    req.enable_nearest_points = true;
    S self_min = std::numeric_limits<S>::max(), probe_min = self_min;
    for (std::size_t i = 0; i < objs.size(); ++i) {
      fcl::DistanceResult<S> r;
      probe_min = std::min(probe_min, fcl::distance(objs[i], probe, req, r));
      for (std::size_t j = i + 1; j < objs.size(); ++j) {
        fcl::DistanceResult<S> q;
        self_min = std::min(self_min, fcl::distance(objs[i], objs[j], req, q));
      }
    }
    ASSERT_GT(self_min, 0);
    cube::CubeCollisionManager<S> m;
    m.registerObjects(objs);
    // FCL's tolerance, and the rounding of coordinates up to half_extent (float: 1e-4 apart).
    const S tol = S(req.distance_tolerance) * (S(1) + self_min) +
                  S(64) * std::numeric_limits<S>::epsilon() * S(so.half_extent);
    std::vector<S> self_got, probe_got;
    for (int threads : {0, 1, 2, 3, 8}) {
      cube::NarrowPhaseCache<S> cache;
      for (int round = 0; round < 2; ++round) {
        cube::NarrowPhaseOptions<S> o;
        o.threads = threads;
        o.cache = round == 0 ? nullptr : &cache;
        const auto what = ::testing::Message()
                          << "meshes " << meshes << " threads " << threads << " round " << round;
        const auto a = cube::minimumDistance<S>(m, req, o);
        EXPECT_NEAR(a.min_distance, self_min, tol) << what;
        EXPECT_NEAR((a.nearest_points[0] - a.nearest_points[1]).norm(), a.min_distance,
                    S(100) * tol)
            << what;
        const auto b = cube::minimumDistance<S>(m, probe, req, o);
        EXPECT_NEAR(b.min_distance, probe_min, tol) << what;
        if (threads > 1 || (threads == 0 && cube::hardwareThreads() > 1)) {
          self_got.push_back(a.min_distance);
          probe_got.push_back(b.min_distance);
        }
      }
    }
    for (std::size_t k = 1; k < self_got.size(); ++k) {
      EXPECT_EQ(self_got[k], self_got[0]) << "meshes " << meshes;
      EXPECT_EQ(probe_got[k], probe_got[0]) << "meshes " << meshes;
    }
  }
}

// collidePairs gives each pair the result of its own fcl::collide, culled pairs none, on any
// thread count and from the cache.
TYPED_TEST(NarrowPhase, CollidePairsEqualsFclPerPair) {
  using S = TypeParam;
  auto world = scene<S>(Layout::uniform, false, 400, 21);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(world.pointers());
  const auto pairs = cube::overlappingPairs<S>(m);
  fcl::CollisionRequest<S> req;
  req.num_max_contacts = 4;
  req.enable_contact = true;
  std::size_t colliding = 0;
  cube::NarrowPhaseCache<S> cache;
  for (int threads : {0, 1, 2, 3, 8})
    for (bool cached : {false, true, true}) {
      cube::NarrowPhaseOptions<S> o;
      o.threads = threads;
      o.cache = cached ? &cache : nullptr;
      const auto got = cube::collidePairs<S>(pairs, req, o);
      ASSERT_EQ(got.size(), pairs.size());
      colliding = 0;
      for (std::size_t i = 0; i < pairs.size(); ++i) {
        fcl::CollisionResult<S> r;
        fcl::collide(pairs[i].first, pairs[i].second, req, r);
        EXPECT_TRUE(sameContacts(got[i], r)) << "pair " << i << " threads " << threads;
        colliding += r.isCollision();
      }
    }
  EXPECT_GT(colliding, 20u);
}

// NarrowPhaseOptions::colliding on the paths the stream does not take: a request with costs
// (FCL's default callback, in turn) and collideMerged over a pair list, with and without costs,
// on every thread count: the pairs that added a contact to FCL's accumulating result, in turn.
TYPED_TEST(NarrowPhase, CollidingPairsOnEveryPath) {
  using S = TypeParam;
  auto world = scene<S>(Layout::clustered, false, 400, 23);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(world.pointers());
  const auto pairs = cube::overlappingPairs<S>(m);
  for (bool cost : {false, true})
    for (std::size_t max : {std::size_t(5), std::size_t(1) << 30}) {
      fcl::CollisionRequest<S> req;
      req.num_max_contacts = max;
      req.enable_cost = cost;
      Accumulate<S> walk, list;
      walk.request = list.request = req;
      m.collide(&walk, &Accumulate<S>::fn);
      for (const auto& [a, b] : pairs)
        if (Accumulate<S>::fn(a, b, &list)) break;
      if (max > 100) {
        ASSERT_GT(walk.colliding.size(), 20u) << "the scene must collide";
      }
      for (int threads : {1, 2, 3}) {
        const auto what = ::testing::Message()
                          << "cost " << cost << " max " << max << " threads " << threads;
        std::vector<cube::ObjectPair<S>> got(1, {nullptr, nullptr});
        cube::NarrowPhaseOptions<S> o;
        o.threads = threads;
        o.colliding = &got;
        cube::collideAll<S>(m, req, o);
        EXPECT_EQ(got, walk.colliding) << what;
        cube::collideMerged<S>(pairs, req, o);
        EXPECT_EQ(got, list.colliding) << what;
      }
    }
}

}  // namespace
