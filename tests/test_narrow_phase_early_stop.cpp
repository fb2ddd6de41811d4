// Queries that stop early keep FCL's answer: a contact budget that ends inside a pair keeps FCL's
// contacts of that pair, a one-contact request calls FCL no more often on threads than on one, and
// testing the last colliding pair first (last_hit_first) keeps the answer.

#include <gtest/gtest.h>

#include "support/narrow_phase_world.h"

namespace {

using namespace narrowphase;

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

}  // namespace
