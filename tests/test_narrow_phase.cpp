// The narrow-phase pipeline (narrow_phase.h, queries.h): on every thread count it gives the
// contacts, in the order, that FCL's own accumulation gives (fcl::collide on each pair of the
// manager's walk with one result); the cache answers only pairs whose objects did not move, and
// every kind of change sends a pair back to FCL; distances equal the brute-force minimum.

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/geometric_shape_to_BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/queries.h"
#include "scenes.h"

namespace {

template <typename S>
class NarrowPhase : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(NarrowPhase, Scalars);

using cube::scenes::Layout;

template <typename S>
cube::scenes::Scene<S> scene(Layout layout, bool meshes, std::size_t n, std::uint32_t seed) {
  cube::scenes::SceneOptions o;
  o.n = n;
  o.layout = layout;
  o.meshes = meshes;
  o.seed = seed;
  o.overlaps_per_object = 3.0;  // many touching pairs: contacts to merge
  return cube::scenes::makeScene<S>(o);
}

// FCL's own way, the reference: fcl::collide on every pair the manager hands over, in its
// order, into one result, stopping once the result is full (FCL's DefaultCollisionFunction).
// `colliding`: the pairs that added a contact, in turn (NarrowPhaseOptions::colliding's oracle).
template <typename S>
struct Accumulate {
  fcl::CollisionRequest<S> request;
  fcl::CollisionResult<S> result;
  std::vector<cube::ObjectPair<S>> colliding;
  static bool fn(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* d) {
    auto& x = *static_cast<Accumulate*>(d);
    const std::size_t before = x.result.numContacts();
    fcl::collide(a, b, x.request, x.result);
    if (x.result.numContacts() > before) x.colliding.emplace_back(a, b);
    // With costs FCL's default callback never stops.
    return !x.request.enable_cost && x.result.isCollision() &&
           x.result.numContacts() >= x.request.num_max_contacts;
  }
};

template <typename S>
bool sameBits(const fcl::Vector3<S>& a, const fcl::Vector3<S>& b) {
  return std::memcmp(a.data(), b.data(), sizeof(S) * 3) == 0;
}

// Equal contact lists, order and every bit included. Without enable_contact FCL leaves a
// contact's position, normal and depth uninitialised: only the objects and primitives count.
template <typename S>
::testing::AssertionResult sameContacts(const fcl::CollisionResult<S>& a,
                                        const fcl::CollisionResult<S>& b,
                                        bool with_geometry = true) {
  if (a.numContacts() != b.numContacts())
    return ::testing::AssertionFailure()
           << a.numContacts() << " contacts against " << b.numContacts();
  for (std::size_t k = 0; k < a.numContacts(); ++k) {
    const fcl::Contact<S>&x = a.getContact(k), &y = b.getContact(k);
    if (x.o1 != y.o1 || x.o2 != y.o2 || x.b1 != y.b1 || x.b2 != y.b2)
      return ::testing::AssertionFailure() << "contact " << k << ": other objects";
    if (with_geometry && (!sameBits(x.pos, y.pos) || !sameBits(x.normal, y.normal) ||
                          std::memcmp(&x.penetration_depth, &y.penetration_depth, sizeof(S)) != 0))
      return ::testing::AssertionFailure() << "contact " << k << " differs";
  }
  return ::testing::AssertionSuccess();
}

template <typename S>
std::vector<fcl::CollisionRequest<S>> requests() {
  std::vector<fcl::CollisionRequest<S>> out;
  for (std::size_t max : {std::size_t(1), std::size_t(7), std::size_t(1) << 30})
    for (bool contact : {false, true}) {
      fcl::CollisionRequest<S> r;
      r.num_max_contacts = max;
      r.enable_contact = contact;
      out.push_back(r);
    }
  return out;
}

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

// NarrowPhaseOptions::last_hit_first: a robot of 24 objects stepping through a world, asking
// "does anything collide?" at each pose. The answer equals a plain collideAll at every pose; a
// reported contact belongs to a candidate pair that FCL says collides; and at poses where the
// last pair still collides the answer takes a single pair (one narrow-phase call or cached
// answer, nothing culled).
TYPED_TEST(NarrowPhase, LastHitFirstKeepsTheAnswerAndTestsThatPairFirst) {
  using S = TypeParam;
  // Meshes: their boxes and tight volumes overlap long before the triangles meet.
  auto world = scene<S>(Layout::uniform, true, 600, 21);
  auto robot = scene<S>(Layout::uniform, true, 24, 22);
  cube::CubeCollisionManager<S> w, r;
  w.registerObjects(world.pointers());
  r.registerObjects(robot.pointers());
  const fcl::CollisionRequest<S> any;  // one contact: stops at the first collision
  cube::NarrowPhaseCache<S> cache;
  cube::NarrowPhaseOptions<S> plain, fast;
  plain.threads = fast.threads = 1;
  fast.cache = &cache;
  fast.last_hit_first = true;
  std::size_t colliding = 0, one_pair = 0;
  for (int pose = 0; pose < 40; ++pose) {
    for (auto* o : robot.pointers()) {
      o->setTranslation(o->getTranslation() + fcl::Vector3<S>(S(0.05), S(0.02), 0));
      o->computeAABB();
    }
    r.update();
    cube::NarrowPhaseStats ps, fs;
    plain.stats = &ps;
    fast.stats = &fs;
    const auto want = cube::collideAll<S>(w, r, any, plain);
    const auto got = cube::collideAll<S>(w, r, any, fast);
    ASSERT_EQ(got.isCollision(), want.isCollision()) << "pose " << pose;
    if (!got.isCollision()) continue;
    ++colliding;
    ASSERT_EQ(got.numContacts(), 1u);
    const fcl::Contact<S>& c = got.getContact(0);
    bool found = false;
    for (const auto& [a, b] : cube::overlappingPairs<S>(w, r)) {
      if (a->collisionGeometry().get() != c.o1 || b->collisionGeometry().get() != c.o2) continue;
      fcl::CollisionResult<S> res;
      found = found || fcl::collide(a, b, any, res) > 0;
    }
    EXPECT_TRUE(found) << "pose " << pose << ": the contact is not from a colliding candidate";
    one_pair += fs.narrow_calls + fs.cached == 1 && fs.culled == 0;
  }
  ASSERT_GT(colliding, 10u) << "the path must collide often for the test to mean anything";
  EXPECT_GT(one_pair * 2, colliding) << one_pair << " of " << colliding;
  // After clear() nothing is remembered: the query runs as without the option.
  cache.clear();
  cube::NarrowPhaseStats a, b;
  plain.stats = &a;
  fast.stats = &b;
  plain.cache = nullptr;
  const auto x = cube::collideAll<S>(w, r, any, plain);
  const auto y = cube::collideAll<S>(w, r, any, fast);
  EXPECT_TRUE(sameContacts(x, y, false));
}

// The per-object volumes the pipeline culls with (Config::tight_volumes) follow every change
// update() sees, and some FCL's boxes do not show: a rod turned about its centre keeps the box of
// its bounding sphere but meets another object; a geometry changed in place with the same
// bounding sphere (then named to update(), as the Config says); a recycled id whose new object
// has the last one's transform and local AABB. Each time collideAll answers as fcl::collide
// does, through update(), update(obj) and update(objects), with the volumes and without.
TYPED_TEST(NarrowPhase, VolumesFollowWhatUpdateSees) {
  using S = TypeParam;
  const auto rz = [](double deg) {
    return fcl::AngleAxis<S>(S(deg * M_PI / 180), fcl::Vector3<S>::UnitZ()).toRotationMatrix();
  };
  const auto fclSays = [](fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) {
    fcl::CollisionRequest<S> req;
    fcl::CollisionResult<S> res;
    return fcl::collide(a, b, req, res) > 0;
  };
  for (const bool volumes : {true, false})
    for (int how = 0; how < 3; ++how) {
      cube::Config config;
      config.tight_volumes = volumes;
      cube::CubeCollisionManager<S> m(config);
      const auto update = [&](fcl::CollisionObject<S>* o) {
        if (how == 0) m.update();
        if (how == 1) m.update(o);
        if (how == 2) m.update(std::vector<fcl::CollisionObject<S>*>{o});
      };
      const auto collides = [&] {
        fcl::CollisionRequest<S> req;
        return cube::collideAll<S>(m, req, cube::NarrowPhaseOptions<S>{1}).isCollision();
      };
      const std::string what =
          std::string(volumes ? "volumes" : "no volumes") + ", update #" + std::to_string(how);
      auto rod_shape = std::make_shared<fcl::Box<S>>(S(4), S(0.2), S(0.2));
      fcl::CollisionObject<S> rod(rod_shape, rz(30), fcl::Vector3<S>::Zero());
      fcl::CollisionObject<S> probe(std::make_shared<fcl::Box<S>>(S(0.2), S(0.2), S(0.2)),
                                    fcl::Matrix3<S>::Identity(),
                                    rz(60) * fcl::Vector3<S>(1.9, 0, 0));
      rod.computeAABB();
      probe.computeAABB();
      m.registerObjects({&rod, &probe});
      // Far away, so that the manager holds enough objects to keep volumes per object
      // (kVolumeMinObjects); the ids of the test's objects then index its records.
      std::vector<std::unique_ptr<fcl::CollisionObject<S>>> fillers;
      for (int i = 0; i < 300; ++i) {
        fillers.push_back(std::make_unique<fcl::CollisionObject<S>>(
            std::make_shared<fcl::Sphere<S>>(S(0.1)), fcl::Matrix3<S>::Identity(),
            fcl::Vector3<S>(S(100 + i), S(100), S(100))));
        fillers.back()->computeAABB();
        m.registerObject(fillers.back().get());
      }
      m.setup();
      ASSERT_FALSE(fclSays(&rod, &probe));
      EXPECT_FALSE(collides()) << what;
      // Turned about its centre: FCL's box of the rod stays the same.
      const fcl::AABB<S> box = rod.getAABB();
      rod.setTransform(rz(60), fcl::Vector3<S>::Zero());
      rod.computeAABB();
      ASSERT_TRUE(box.equal(rod.getAABB()));
      ASSERT_TRUE(fclSays(&rod, &probe));
      update(&rod);
      EXPECT_TRUE(collides()) << what << ": the rod turned";
      // Back, then the geometry changed in place: the rod now lies along its y axis, which
      // points at the probe; its bounding sphere, so FCL's box, is the same.
      rod.setTransform(rz(-30), fcl::Vector3<S>::Zero());
      rod.computeAABB();
      update(&rod);
      EXPECT_FALSE(collides()) << what;
      rod_shape->side = fcl::Vector3<S>(S(0.2), S(4), S(0.2));
      rod_shape->computeLocalAABB();
      rod.computeAABB();
      ASSERT_TRUE(box.equal(rod.getAABB()));
      ASSERT_TRUE(fclSays(&rod, &probe));
      // Named, as Config::tight_volumes asks of a geometry changed in place.
      if (how == 2)
        m.update(std::vector<fcl::CollisionObject<S>*>{&rod});
      else
        m.update(&rod);
      EXPECT_TRUE(collides()) << what << ": the geometry changed";
      // A recycled id: a ball apart from the probe leaves, and a box with its transform and its
      // local AABB takes its id; the box's corner reaches the probe.
      m.unregisterObject(&rod);
      const fcl::Vector3<S> centre =
          probe.getTranslation() - fcl::Vector3<S>(0.8, 0.8, 0) / S(std::sqrt(2.0));
      fcl::CollisionObject<S> ball(std::make_shared<fcl::Sphere<S>>(S(0.6)),
                                   fcl::Matrix3<S>::Identity(), centre);
      fcl::CollisionObject<S> cube_(std::make_shared<fcl::Box<S>>(S(1.2), S(1.2), S(1.2)),
                                    fcl::Matrix3<S>::Identity(), centre);
      ball.computeAABB();
      cube_.computeAABB();
      ASSERT_FALSE(fclSays(&ball, &probe));
      ASSERT_TRUE(fclSays(&cube_, &probe));
      m.registerObject(&ball);
      EXPECT_FALSE(collides()) << what;
      m.unregisterObject(&ball);
      m.registerObject(&cube_);
      EXPECT_TRUE(collides()) << what << ": a recycled id";
    }
}

// A manager used through FCL's interface only keeps no per-object volumes: its memory and its
// answers are those of a manager without them. The first pipeline query builds them, updates keep
// them, dropVolumes() frees them, and the answers stay FCL's throughout.
TEST(NarrowPhaseVolumes, BuiltByThePipelinesFirstQueryAndDroppedOnRequest) {
  using S = double;
  auto world = scene<S>(Layout::uniform, false, 1000, 5);
  cube::Config plain_config;
  plain_config.tight_volumes = false;
  cube::CubeCollisionManager<S> plain(plain_config), m;
  plain.registerObjects(world.pointers());
  m.registerObjects(world.pointers());
  plain.setup();
  m.setup();
  std::string why;
  const auto valid = [&] { EXPECT_TRUE(m.validate(&why)) << why; };
  const std::size_t fcl_only = m.bytes();
  EXPECT_EQ(fcl_only, plain.bytes());
  // FCL's interface with the user's callbacks: self and object collides, distance, updates.
  std::size_t pairs = 0;
  m.collide(&pairs, [](fcl::CollisionObject<S>*, fcl::CollisionObject<S>*, void* d) {
    ++*static_cast<std::size_t*>(d);
    return false;
  });
  EXPECT_GT(pairs, 0u);
  for (auto* o : world.pointers()) {
    o->setTranslation(o->getTranslation() + fcl::Vector3<S>(0.01, 0, 0));
    o->computeAABB();
  }
  m.update();
  plain.update();
  valid();
  EXPECT_EQ(m.bytes(), plain.bytes());
  fcl::CollisionRequest<S> all;
  all.num_max_contacts = 1 << 20;
  const auto want = cube::collideAll<S>(plain, all);
  const auto got = cube::collideAll<S>(m, all);
  EXPECT_EQ(got.numContacts(), want.numContacts());
  EXPECT_GT(m.bytes(), plain.bytes());  // built by the pipeline's first query
  valid();
  // Kept fresh by the updates: objects moved onto one another still get FCL's answer.
  for (std::size_t i = 0; i + 1 < world.objects.size(); i += 7) {
    world.objects[i]->setTransform(world.objects[i + 1]->getTransform());
    world.objects[i]->computeAABB();
  }
  m.update();
  plain.update();
  valid();
  EXPECT_EQ(cube::collideAll<S>(m, all).numContacts(),
            cube::collideAll<S>(plain, all).numContacts());
  const std::size_t kept = m.bytes();
  m.dropVolumes();
  valid();
  EXPECT_LT(m.bytes(), kept);
  EXPECT_EQ(m.bytes(), plain.bytes());
  EXPECT_EQ(cube::collideAll<S>(m, all).numContacts(),
            cube::collideAll<S>(plain, all).numContacts());
  EXPECT_EQ(m.bytes(), kept);  // built again
  valid();
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

// Objects for the contact-budget test: sphere pairs that touch (one contact each), a box pair
// and a mesh pair that overlap face to face, tilted so that their contacts have different depths.
template <typename S>
struct BudgetScene {
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objects;
  std::vector<cube::ObjectPair<S>> pairs;  // in the order above, the two multi-contact pairs
                                           // after `before` sphere pairs
  fcl::CollisionObject<S>* add(std::shared_ptr<fcl::CollisionGeometry<S>> g,
                               const fcl::Vector3<S>& at, S tilt = 0) {
    fcl::Transform3<S> tf = fcl::Transform3<S>::Identity();
    tf.linear() = (fcl::AngleAxis<S>(tilt, fcl::Vector3<S>::UnitX()) *
                   fcl::AngleAxis<S>(tilt * S(0.6), fcl::Vector3<S>::UnitY()))
                      .toRotationMatrix();
    tf.translation() = at;
    objects.push_back(std::make_unique<fcl::CollisionObject<S>>(g, tf));
    objects.back()->computeAABB();
    return objects.back().get();
  }
  void spheres(std::size_t count, S x0) {
    auto ball = std::make_shared<fcl::Sphere<S>>(S(1));
    for (std::size_t i = 0; i < count; ++i) {
      const S x = x0 + S(10) * S(i);
      pairs.emplace_back(add(ball, {x, 0, 0}), add(ball, {x + S(1.5), 0, 0}));
    }
  }
  explicit BudgetScene(std::size_t before) {
    spheres(before, 0);
    auto box = std::make_shared<fcl::Box<S>>(S(2), S(2), S(2));
    pairs.emplace_back(add(box, {S(-50), 0, 0}), add(box, {S(-50), 0, S(1.8)}, S(0.05)));
    auto mesh = std::make_shared<fcl::BVHModel<fcl::OBBRSS<S>>>();
    fcl::generateBVHModel(*mesh, fcl::Box<S>(S(2), S(2), S(2)), fcl::Transform3<S>::Identity());
    pairs.emplace_back(add(mesh, {S(-80), 0, 0}), add(mesh, {S(-80), 0, S(1.8)}, S(0.05)));
    spheres(5, S(500));
  }
  std::vector<fcl::CollisionObject<S>*> pointers() const {
    std::vector<fcl::CollisionObject<S>*> out;
    for (const auto& o : objects) out.push_back(o.get());
    return out;
  }
};

// When the contact budget runs out inside a pair with several contacts, FCL keeps that pair's
// deepest contacts (shape pairs) or its first (meshes): the pipeline keeps the same ones, on
// every thread count, with and without a cache, for a pair list, a self-collide, an object
// query and a manager query. The budget leaves room for 1, 2 and 3 of the pair's contacts
// after 3 and after 1,100 sphere pairs (1,100: past the pairs answered at once, in chunks).
TYPED_TEST(NarrowPhase, ContactBudgetEndingInsideAPairKeepsFclsContacts) {
  using S = TypeParam;
  for (std::size_t before : {std::size_t(3), std::size_t(1100)}) {
    BudgetScene<S> scene(before);
    fcl::CollisionRequest<S> probe;
    probe.enable_contact = true;
    probe.num_max_contacts = 100;
    for (std::size_t which : {before, before + 1}) {  // the box pair, then the mesh pair
      fcl::CollisionResult<S> alone;
      fcl::collide(scene.pairs[which].first, scene.pairs[which].second, probe, alone);
      ASSERT_GE(alone.numContacts(), 4u) << "the pair must give several contacts";
      if (which == before) {
        bool differ = false;
        for (std::size_t k = 1; k < alone.numContacts(); ++k)
          differ |= alone.getContact(k).penetration_depth != alone.getContact(0).penetration_depth;
        ASSERT_TRUE(differ) << "the box pair's contacts must differ in depth";
      }
    }
    cube::CubeCollisionManager<S> m, other;
    m.registerObjects(scene.pointers());
    other.registerObject(scene.pairs[before].second);
    for (std::size_t extra : {1, 2, 3}) {
      fcl::CollisionRequest<S> request;
      request.enable_contact = true;
      // Every sphere pair gives one contact; the budget ends inside the first multi-contact
      // pair: the box pair in the list, whichever comes first in the self-collide's order.
      Accumulate<S> all;
      all.request = probe;
      all.request.num_max_contacts = 1000;
      m.collide(&all, &Accumulate<S>::fn);
      std::size_t at_box = 0;  // the first contact of the box pair or the mesh pair
      while (at_box < all.result.numContacts() &&
             all.result.getContact(at_box).o1->getNodeType() == fcl::GEOM_SPHERE)
        ++at_box;
      ASSERT_LT(at_box, all.result.numContacts());
      for (const bool self : {false, true}) {
        request.num_max_contacts = (self ? at_box : before) + extra;
        Accumulate<S> want;
        want.request = request;
        if (self) {
          m.collide(&want, &Accumulate<S>::fn);
        } else {
          for (const auto& [a, b] : scene.pairs)
            if (Accumulate<S>::fn(a, b, &want)) break;
        }
        ASSERT_EQ(want.result.numContacts(), request.num_max_contacts);
        for (int threads : {0, 1, 2, 3, 8}) {
          cube::NarrowPhaseCache<S> cache;
          for (int round = 0; round < 3; ++round) {  // no cache, filling it, answered from it
            cube::NarrowPhaseOptions<S> o;
            o.threads = threads;
            o.cache = round == 0 ? nullptr : &cache;
            const auto what = ::testing::Message()
                              << "before " << before << " extra " << extra << " self " << self
                              << " threads " << threads << " round " << round;
            const auto got = self ? cube::collideAll<S>(m, request, o)
                                  : cube::collideMerged<S>(scene.pairs, request, o);
            EXPECT_TRUE(sameContacts(got, want.result)) << what;
          }
        }
      }
      // The box pair's own contacts through an object query and a manager query.
      request.num_max_contacts = extra;
      Accumulate<S> one, two;
      one.request = two.request = request;
      m.collide(scene.pairs[before].second, &one, &Accumulate<S>::fn);
      m.collide(&other, &two, &Accumulate<S>::fn);
      for (int threads : {0, 1, 2, 3, 8}) {
        cube::NarrowPhaseCache<S> cache;
        for (int round = 0; round < 3; ++round) {
          cube::NarrowPhaseOptions<S> o;
          o.threads = threads;
          o.cache = round == 0 ? nullptr : &cache;
          EXPECT_TRUE(sameContacts(cube::collideAll<S>(m, scene.pairs[before].second, request, o),
                                   one.result))
              << "object query, extra " << extra << " threads " << threads << " round " << round;
          EXPECT_TRUE(sameContacts(cube::collideAll<S>(m, other, request, o), two.result))
              << "manager query, extra " << extra << " threads " << threads << " round " << round;
        }
      }
    }
  }
}

// A request for one contact calls FCL no more often on several threads than on one, with and
// without a cache, for a pair list, a self-collide and a manager query: pairs are answered one
// at a time and the walk stops at the first contact. The scene: 40 capsule pairs whose tight
// volumes overlap but whose capsules do not (each costs an FCL call), a touching box pair after
// the first 20 of them (corner to corner, so that their inscribed balls do not prove it).
TYPED_TEST(NarrowPhase, OneContactRequestCallsFclNoMoreOftenOnThreads) {
  using S = TypeParam;
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objects;
  std::vector<cube::ObjectPair<S>> pairs;
  cube::CubeCollisionManager<S> m, other;
  const auto add = [&](std::shared_ptr<fcl::CollisionGeometry<S>> g, const fcl::Vector3<S>& at) {
    fcl::Transform3<S> tf = fcl::Transform3<S>::Identity();
    tf.translation() = at;
    objects.push_back(std::make_unique<fcl::CollisionObject<S>>(g, tf));
    objects.back()->computeAABB();
    return objects.back().get();
  };
  auto capsule = std::make_shared<fcl::Capsule<S>>(S(1), S(2));
  auto box = std::make_shared<fcl::Box<S>>(S(2), S(2), S(2));
  for (int i = 0; i < 41; ++i) {
    const S x = S(20) * S(i);
    if (i == 20)
      pairs.emplace_back(add(box, {x, 0, 0}), add(box, {x + S(1.9), S(1.9), 0}));
    else  // corner to corner: boxes and bounding spheres overlap, the capsules are 1.3 apart
      pairs.emplace_back(add(capsule, {x, 0, 0}), add(capsule, {x + S(1.9), S(1.9), S(3.9)}));
    m.registerObject(pairs.back().first);
    other.registerObject(pairs.back().second);
  }
  fcl::CollisionRequest<S> any;
  cube::NarrowPhaseStats probe;
  cube::NarrowPhaseOptions<S> po;
  po.threads = 1;
  po.stats = &probe;
  ASSERT_TRUE(cube::collideMerged<S>(pairs, any, po).isCollision());
  ASSERT_EQ(probe.narrow_calls, 21u) << "20 capsule pairs survive the cull, then the boxes";
  const auto calls = [&](int threads, int query, cube::NarrowPhaseCache<S>* cache) {
    cube::NarrowPhaseStats st;
    cube::NarrowPhaseOptions<S> o;
    o.threads = threads;
    o.cache = cache;
    o.stats = &st;
    const auto res = query == 0   ? cube::collideMerged<S>(pairs, any, o)
                     : query == 1 ? cube::collideAll<S>(m, other, any, o)
                                  : cube::collideAll<S>(m, any, o);
    return std::make_pair(st.narrow_calls, res.isCollision());
  };
  for (int query = 0; query < 3; ++query)
    for (const bool cached : {false, true}) {
      cube::NarrowPhaseCache<S> c1;
      const auto one = calls(1, query, cached ? &c1 : nullptr);
      EXPECT_EQ(one.second, query != 2) << "the self-collide of m holds no touching pair";
      for (int threads : {0, 2, 3, 8}) {
        cube::NarrowPhaseCache<S> c;
        const auto many = calls(threads, query, cached ? &c : nullptr);
        EXPECT_EQ(many.second, one.second) << "query " << query << " threads " << threads;
        EXPECT_LE(many.first, one.first)
            << "query " << query << " threads " << threads << " cache " << cached;
      }
    }
}

// forEachPair calls fn once per index on any thread count and rethrows the first exception
// (by index) after the others ran.
TEST(NarrowPhaseApi, ForEachPairCallsEveryIndexOnceAndRethrows) {
  auto world = cube::scenes::makeScene<double>(cube::scenes::SceneOptions{});
  std::vector<cube::ObjectPair<double>> pairs;
  for (std::size_t i = 0; i + 1 < 300; ++i)
    pairs.emplace_back(world.objects[i].get(), world.objects[i + 1].get());
  for (int threads : {1, 2, 3}) {
    std::vector<std::atomic<int>> calls(pairs.size());
    cube::forEachPair<double>(
        pairs,
        [&](std::size_t i, fcl::CollisionObject<double>* a, fcl::CollisionObject<double>* b) {
          EXPECT_EQ(a, pairs[i].first);
          EXPECT_EQ(b, pairs[i].second);
          ++calls[i];
        },
        threads);
    for (const auto& c : calls) EXPECT_EQ(c.load(), 1);
    std::atomic<int> after{0};
    try {
      cube::forEachPair<double>(
          pairs,
          [&](std::size_t i, fcl::CollisionObject<double>*, fcl::CollisionObject<double>*) {
            if (i == 17 || i == 250) throw std::runtime_error("pair " + std::to_string(i));
            ++after;
          },
          threads);
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "pair 17");
    }
    EXPECT_EQ(after.load(), int(pairs.size()) - 2) << "the other calls ran";
  }
}

// collideConcurrently hands a thread-safe callback every candidate pair once, and stops early
// when it returns true.
TEST(NarrowPhaseApi, CollideConcurrentlySeesEveryPairOnceAndStops) {
  cube::scenes::SceneOptions so;
  so.n = 2000;
  so.overlaps_per_object = 3.0;
  auto world = cube::scenes::makeScene<double>(so);
  cube::CubeCollisionManager<double> m;
  m.registerObjects(world.pointers());
  const auto expected = cube::overlappingPairs<double>(m);
  ASSERT_GT(expected.size(), 1000u);
  struct Seen {
    std::mutex mutex;
    std::multiset<std::pair<const void*, const void*>> pairs;
    std::atomic<std::size_t> calls{0};
    std::size_t stop_after = 0;  // 0: never
  };
  const auto fn = [](fcl::CollisionObject<double>* a, fcl::CollisionObject<double>* b, void* d) {
    auto& s = *static_cast<Seen*>(d);
    const std::size_t k = ++s.calls;
    std::lock_guard<std::mutex> lock(s.mutex);
    s.pairs.emplace(a, b);
    return s.stop_after != 0 && k >= s.stop_after;
  };
  for (int threads : {1, 2, 3}) {
    Seen seen;
    cube::collideConcurrently<double>(m, &seen, fn, threads);
    std::multiset<std::pair<const void*, const void*>> want;
    for (const auto& [a, b] : expected) want.emplace(a, b);
    EXPECT_EQ(seen.pairs, want) << "threads " << threads;
    Seen stopping;
    stopping.stop_after = 10;
    cube::collideConcurrently<double>(m, &stopping, fn, threads);
    EXPECT_GE(stopping.calls.load(), 10u);
    EXPECT_LE(stopping.calls.load(), 256u + 10u) << "at most the running chunk finishes";
  }
}

// Bad input gets a clear error before any work: a null object in a pair list, an empty function,
// a null callback.
TEST(NarrowPhaseApi, BadInputThrowsBeforeAnyPairRuns) {
  auto world = cube::scenes::makeScene<double>(cube::scenes::SceneOptions{});
  cube::CubeCollisionManager<double> m;
  m.registerObjects(world.pointers());
  std::vector<cube::ObjectPair<double>> pairs = cube::overlappingPairs<double>(m);
  ASSERT_GT(pairs.size(), 10u);
  pairs[5].second = nullptr;
  fcl::CollisionRequest<double> req;
  cube::NarrowPhaseCache<double> cache;
  cube::NarrowPhaseOptions<double> o;
  o.cache = &cache;
  EXPECT_THROW(cube::collidePairs<double>(pairs, req, o), std::invalid_argument);
  EXPECT_THROW(cube::collideMerged<double>(pairs, req, o), std::invalid_argument);
  EXPECT_EQ(cache.size(), 0u) << "nothing ran";
  std::size_t calls = 0;
  EXPECT_THROW(cube::forEachPair<double>(pairs, [&](std::size_t, fcl::CollisionObjectd*,
                                                    fcl::CollisionObjectd*) { ++calls; }),
               std::invalid_argument);
  EXPECT_EQ(calls, 0u);
  pairs[5].second = pairs[5].first;
  EXPECT_THROW(cube::forEachPair<double>(pairs, {}), std::invalid_argument);
  EXPECT_THROW(cube::collideConcurrently<double>(m, nullptr, nullptr), std::invalid_argument);
}

}  // namespace
