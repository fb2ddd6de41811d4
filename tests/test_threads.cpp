// Several threads query one manager at once: every const query is safe to run
// concurrently and each thread gets Naive's answer. Meant to run under ThreadSanitizer too
// (-DCUBE_COLLISION_SANITIZE=thread), where any data race fails the test.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <limits>
#include <memory>
#include <random>
#include <thread>
#include <vector>

#include "cube_collision/callbacks.h"
#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "scenes.h"
#include "support/oracle.h"

namespace {

using S = double;
using Object = fcl::CollisionObject<S>;
using Pair = cube::oracle::Pair<S>;

bool record(Object* a, Object* b, void* d) {
  static_cast<std::vector<Pair>*>(d)->emplace_back(a, b);
  return false;
}

// Narrow-phase distance of boxes, spheres and cylinders (the scene has no planes here).
bool minDistance(Object* a, Object* b, void* d, S& dist) {
  const Pair p = cube::oracle::unordered(a, b);
  fcl::DistanceRequest<S> req;
  fcl::DistanceResult<S> res;
  const S v = std::max<S>(0, fcl::distance(p.first, p.second, req, res));
  S& best = *static_cast<S*>(d);
  best = std::min(best, v);
  dist = std::min(dist, v);
  return false;
}

cube::scenes::Scene<S> sceneOf(std::size_t n, std::uint32_t seed) {
  cube::scenes::SceneOptions opt;
  opt.n = n;
  opt.seed = seed;
  opt.overlaps_per_object = 2;
  return cube::scenes::makeScene<S>(opt);
}

// Runs worker(0) .. worker(threads - 1) on as many threads, released together, and joins them.
template <class Worker>
void runTogether(int threads, Worker&& worker) {
  std::atomic<int> go{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&, t] {
      go.fetch_add(1);
      while (go.load() < threads) std::this_thread::yield();
      worker(t);
    });
  for (auto& t : pool) t.join();
}

std::vector<Pair> sorted(std::vector<Pair> v) {
  std::sort(v.begin(), v.end());
  return v;
}

// What every thread must see, computed once by Naive and brute force.
struct Expected {
  std::vector<Pair> self;                  // unordered
  std::vector<std::vector<Pair>> objects;  // per query object, (managed, query)
  std::vector<Pair> vs_other;              // (ours, theirs)
  std::vector<Pair> narrow;                // narrow-phase colliding pairs, unordered
  S distance = 0;
};

TEST(Threads, ConcurrentQueriesAllGetNaivesAnswer) {
  auto scene = sceneOf(1500, 7);
  auto other_scene = sceneOf(300, 8);
  // A plane and a halfspace, so the unbounded list is read concurrently too.
  Object plane(std::make_shared<fcl::Plane<S>>(fcl::Vector3<S>(0, 0, 1), 0));
  Object half(std::make_shared<fcl::Halfspace<S>>(fcl::Vector3<S>(1, 0, 0), 1500));
  plane.computeAABB();
  half.computeAABB();

  std::vector<Object*> objs = scene.pointers();
  cube::CubeCollisionManager<S> m;
  m.registerObjects(objs);
  m.registerObject(&plane);
  m.registerObject(&half);
  objs.push_back(&plane);
  objs.push_back(&half);
  cube::CubeCollisionManager<S> other;
  other.registerObjects(other_scene.pointers());
  // Distances only among the bounded objects (FCL's GJK distance does not take planes).
  cube::CubeCollisionManager<S> bounded;
  bounded.registerObjects(scene.pointers());

  Expected want;
  want.self = cube::oracle::bruteSelfPairs(objs);
  const auto queries = other_scene.pointers();
  for (std::size_t q = 0; q < 40; ++q) {
    std::vector<Pair> p;
    for (auto* o : objs)
      if (o->getAABB().overlap(queries[q]->getAABB())) p.emplace_back(o, queries[q]);
    want.objects.push_back(sorted(p));
  }
  for (auto* a : objs)
    for (auto* b : other_scene.pointers())
      if (a->getAABB().overlap(b->getAABB())) want.vs_other.emplace_back(a, b);
  want.vs_other = sorted(want.vs_other);
  auto naive = cube::oracle::naiveOf(objs);
  want.narrow = cube::oracle::collidingPairs(naive);
  auto naive_bounded = cube::oracle::naiveOf(scene.pointers());
  want.distance = std::numeric_limits<S>::max();
  naive_bounded.distance(&want.distance, minDistance);
  ASSERT_GT(want.self.size(), 1000u);  // a scene with real work in it
  ASSERT_GT(want.vs_other.size(), 100u);

  constexpr int kThreads = 4, kRounds = 3;
  std::atomic<int> mismatches{0};
  auto worker = [&](int id) {
    for (int round = 0; round < kRounds; ++round) {
      // Each thread runs the queries in its own order, so different kinds overlap in time.
      for (int k = 0; k < 5; ++k) {
        switch ((k + id + round) % 5) {
          case 0: {
            if (cube::oracle::selfPairs(m) != want.self) ++mismatches;
            break;
          }
          case 1: {
            for (std::size_t q = 0; q < want.objects.size(); ++q) {
              std::vector<Pair> got;
              m.collide(queries[q], &got, record);
              if (sorted(got) != want.objects[q]) ++mismatches;
            }
            break;
          }
          case 2: {
            std::vector<Pair> got;
            m.collide(&other, &got, record);
            if (sorted(got) != want.vs_other) ++mismatches;
            break;
          }
          case 3: {
            S best = std::numeric_limits<S>::max();
            bounded.distance(&best, minDistance);
            if (best != want.distance) ++mismatches;
            break;
          }
          default: {
            if (cube::oracle::collidingPairs(m) != want.narrow) ++mismatches;
            // The library's own default callbacks, with their per-call data.
            cube::CollisionData<S> data;
            data.request.num_max_contacts = 1000000;
            m.collide(&data, cube::defaultCollisionCallback<S>);
            if (data.result.numContacts() < want.narrow.size()) ++mismatches;
            break;
          }
        }
      }
    }
  };
  runTogether(kThreads, worker);
  EXPECT_EQ(mismatches.load(), 0);
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
}

// Between rounds of concurrent queries the main thread moves objects and calls update() (never
// during a round: mutation is not concurrent with queries). The self-collides then come from the
// pair list of Config::keep_pairs, read by all threads at once (but after the step that moves a
// third of the objects, which drops the list); object queries walk the refitted (and sometimes
// rebuilt) tree. Every thread gets brute force's answer every round.
TEST(Threads, ConcurrentQueriesAfterEachUpdate) {
  auto scene = sceneOf(1200, 9);
  const std::vector<Object*> objs = scene.pointers();
  cube::Config listed;
  listed.keep_pairs = true;
  cube::CubeCollisionManager<S> m(listed);
  m.registerObjects(objs);
  m.setup();
  std::mt19937 rng(10);
  std::uniform_real_distribution<S> step(-60, 60);
  std::uniform_int_distribution<std::size_t> which(0, objs.size() - 1);
  constexpr int kThreads = 4, kSteps = 6;
  for (int s = 0; s < kSteps; ++s) {
    // Steps 0..2 move a few objects (the list is refreshed), 3 teleports many (rebuild).
    const std::size_t moves = s == 3 ? objs.size() / 3 : objs.size() / 50;
    for (std::size_t k = 0; k < moves; ++k) {
      Object* o = objs[which(rng)];
      fcl::Transform3<S> tf = o->getTransform();
      const S scale = s == 3 ? 20 : 1;
      tf.translation() += fcl::Vector3<S>(step(rng), step(rng), step(rng)) * scale;
      o->setTransform(tf);
      o->computeAABB();
    }
    m.update();
    // A third moved drops the list (that round walks); the next update lists afresh.
    EXPECT_EQ(m.pairsListed(), s != 3) << "step " << s;
    const std::vector<Pair> want_self = cube::oracle::bruteSelfPairs(objs);
    std::vector<std::vector<Pair>> want_objects;
    for (std::size_t q = 0; q < 30; ++q) {
      std::vector<Pair> p;
      for (auto* o : objs)
        if (o != objs[q * 37] && o->getAABB().overlap(objs[q * 37]->getAABB()))
          p.emplace_back(o, objs[q * 37]);
      want_objects.push_back(sorted(p));
    }
    ASSERT_GT(want_self.size(), 500u);
    std::atomic<int> mismatches{0};
    auto worker = [&](int id) {
      for (int round = 0; round < 3; ++round) {
        if ((id + round) % 2 == 0) {
          if (cube::oracle::selfPairs(m) != want_self) ++mismatches;
        } else {
          for (std::size_t q = 0; q < want_objects.size(); ++q) {
            std::vector<Pair> got;
            m.collide(objs[q * 37], &got, record);
            if (sorted(got) != want_objects[q]) ++mismatches;
          }
        }
      }
    };
    runTogether(kThreads, worker);
    EXPECT_EQ(mismatches.load(), 0) << "step " << s;
    std::string why;
    EXPECT_TRUE(m.validate(&why)) << why;
  }
}

}  // namespace

// The first pipeline queries of a manager build its per-object volumes: run from several threads
// at once on a fresh manager, each gets the answer of a manager that never keeps them.
TEST(Threads, ConcurrentFirstPipelineQueriesAgreeWithAManagerWithoutVolumes) {
  auto scene = sceneOf(2000, 17);
  cube::Config plain_config;
  plain_config.tight_volumes = false;
  cube::CubeCollisionManager<S> plain(plain_config);
  plain.registerObjects(scene.pointers());
  plain.setup();
  fcl::CollisionRequest<S> all;
  all.num_max_contacts = 1 << 20;
  const cube::NarrowPhaseOptions<S> one{1};
  const auto want = cube::collideAll<S>(plain, all, one);
  const S want_distance =
      cube::minimumDistance<S>(plain, fcl::DistanceRequest<S>(), one).min_distance;
  ASSERT_GT(want.numContacts(), 100u);
  for (int round = 0; round < 3; ++round) {
    cube::CubeCollisionManager<S> m;
    m.registerObjects(scene.pointers());
    m.setup();
    std::vector<std::size_t> contacts(4);
    std::vector<S> distances(4);
    runTogether(4, [&](int t) {
      if (t % 2 == 0)
        contacts[t] = cube::collideAll<S>(m, all, one).numContacts();
      else
        distances[t] = cube::minimumDistance<S>(m, fcl::DistanceRequest<S>(), one).min_distance;
    });
    for (int t = 0; t < 4; t += 2) EXPECT_EQ(contacts[t], want.numContacts());
    for (int t = 1; t < 4; t += 2) EXPECT_EQ(distances[t], want_distance);
    std::string why;
    EXPECT_TRUE(m.validate(&why)) << why;
  }
}
