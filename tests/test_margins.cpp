// Margins (setMargin) against brute force on grown boxes and FCL's narrow phase on every pair,
// and contracts the headers state, each against what the calls do: margins between managers,
// the predicate in distance queries, bits and margins forgotten on unregistration, planes in
// contactsWithinMargin, and the ray's box test.

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "cube_collision/continuous.h"
#include "cube_collision/margins.h"
#include "cube_collision/spatial_queries.h"
#include "support/oracle.h"
#include "support/pair_rules_world.h"

namespace {

using namespace pair_rules;

// Margins: brute force on boxes grown by each object's margin, computed as the core defines it.
template <typename S>
fcl::AABB<S> grownBox(const Obj<S>* o, S m) {
  fcl::AABB<S> b = o->getAABB();
  for (int k = 0; k < 3; ++k) {
    b.min_[k] = b.min_[k] - m;
    b.max_[k] = b.max_[k] + m;
  }
  return b;
}

template <typename S>
void checkMargins() {
  auto sc = scene<S>(600, 61, 1.0);
  auto qs = scene<S>(40, 62, 1.0);
  const auto objs = sc.pointers();
  const S size = S(cube::scenes::typicalSize({}));
  CubeCollisionManager<S> m;
  m.registerObjects(objs);
  std::map<Obj<S>*, S> own;
  std::mt19937 rng(5);
  for (std::size_t i = 0; i < objs.size(); i += 3) {
    own[objs[i]] = S(rng() % 100) / S(100) * size;
    m.setMargin(objs[i], own[objs[i]]);
  }
  const S all = size / S(4);
  m.setMargin(all);
  const auto marginOf = [&](Obj<S>* o) { return own.count(o) ? own[o] : all; };
  for (Obj<S>* o : objs) EXPECT_EQ(m.margin(o), marginOf(o));
  for (int step = 0; step < 2; ++step) {
    std::vector<Pair<S>> want;
    for (std::size_t i = 0; i < objs.size(); ++i)
      for (std::size_t j = i + 1; j < objs.size(); ++j)
        if (grownBox(objs[i], marginOf(objs[i])).overlap(grownBox(objs[j], marginOf(objs[j]))))
          want.push_back(unordered(objs[i], objs[j]));
    std::sort(want.begin(), want.end());
    EXPECT_GT(want.size(), cube::oracle::bruteSelfPairs(objs).size()) << "margins grow nothing";
    EXPECT_EQ(cube::oracle::selfPairs(m), want);
    // Query objects: a registered one grows by its margin, another by the manager-wide one.
    for (Obj<S>* q : {objs[0], objs[1], qs.objects[0].get(), qs.objects[1].get()}) {
      const S mq = std::find(objs.begin(), objs.end(), q) != objs.end() ? marginOf(q) : all;
      std::vector<Obj<S>*> got, expect;
      m.collide(q, [&](Obj<S>* a, Obj<S>*) { got.push_back(a); });
      for (Obj<S>* o : objs)
        if (o != q && grownBox(o, marginOf(o)).overlap(grownBox(q, mq))) expect.push_back(o);
      std::sort(got.begin(), got.end());
      std::sort(expect.begin(), expect.end());
      EXPECT_EQ(got, expect);
    }
    std::string why;
    EXPECT_TRUE(m.validate(&why)) << why;
    cube::scenes::jitter(sc, 0.1, double(size), true, 71);
    m.update();
  }
}

TEST(Margins, EqualBruteForceOnGrownBoxes) {
  checkMargins<double>();
  checkMargins<float>();
}

// Swept pairs follow the same rules: swept boxes grown by the margins, bits and predicate.
TEST(Margins, SweptPairsFollowMarginsBitsAndPredicate) {
  auto sc = scene<double>(400, 131, 1.0);
  const auto objs = sc.pointers();
  const double size = cube::scenes::typicalSize({});
  CubeCollisionManager<double> m;
  m.registerObjects(objs);
  const auto bits = randomBits(m, objs, 29);
  m.setMargin(0.2 * size);
  for (std::size_t i = 0; i < objs.size(); i += 7) m.setMargin(objs[i], 0.5 * size);
  m.setPairFilter([&](Obj<double>* a, Obj<double>* b) { return a != objs[1] && b != objs[1]; });
  std::vector<cube::Motion<double>> motions;
  std::map<Obj<double>*, fcl::AABB<double>> box;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> step(-2 * size, 2 * size);
  for (Obj<double>* o : objs) box[o] = grownBox(o, m.margin(o));
  for (std::size_t i = 0; i < objs.size(); i += 4) {
    fcl::Transform3d end = objs[i]->getTransform();
    end.translation() += fcl::Vector3d(step(rng), step(rng), step(rng));
    motions.push_back({objs[i], end});
    const fcl::AABB<double> sw = cube::sweptBox(*objs[i], end, fcl::CCDM_TRANS);
    fcl::AABB<double> g = sw;
    const double mg = m.margin(objs[i]);
    for (int k = 0; k < 3; ++k) {
      g.min_[k] = sw.min_[k] - mg;
      g.max_[k] = sw.max_[k] + mg;
    }
    box[objs[i]] = g;
  }
  std::vector<Pair<double>> want;
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j)
      if ((i % 4 == 0 || j % 4 == 0) && box[objs[i]].overlap(box[objs[j]]) &&
          pass(bitsOf(bits, objs[i]), bitsOf(bits, objs[j])) && i != 1 && j != 1)
        want.push_back(unordered(objs[i], objs[j]));
  std::sort(want.begin(), want.end());
  std::vector<Pair<double>> got;
  for (const auto& p : cube::sweptPairs(m, motions)) got.push_back(unordered(p.first, p.second));
  std::sort(got.begin(), got.end());
  EXPECT_FALSE(want.empty());
  EXPECT_EQ(got, want);
}

TEST(Margins, BadInputChangesNothing) {
  auto sc = scene<double>(10, 81);
  const auto objs = sc.pointers();
  CubeCollisionManager<double> m;
  m.registerObjects({objs[0], objs[1]});
  m.setMargin(objs[0], 0.5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {-1.0, nan, inf}) {
    EXPECT_THROW(m.setMargin(objs[0], bad), std::invalid_argument);
    EXPECT_THROW(m.setMargin(bad), std::invalid_argument);
  }
  EXPECT_THROW(m.setMargin(nullptr, 1.0), std::invalid_argument);
  EXPECT_THROW(m.setMargin(objs[2], 1.0), std::invalid_argument);
  EXPECT_EQ(m.margin(objs[0]), 0.5);
  EXPECT_EQ(m.margin(objs[1]), 0.0);
  EXPECT_EQ(m.margin(objs[2]), 0.0);
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
}

// contactsWithinMargin against FCL's narrow phase on every pair: colliding, or fcl::distance at
// most the two margins. Canonical order hands pairs over as brute force calls them (i < j).
TEST(Margins, ContactsWithinMarginEqualNarrowPhaseOnEveryPair) {
  for (const bool meshes : {false, true}) {
    cube::scenes::SceneOptions o;
    o.n = meshes ? 150 : 300;
    o.seed = 111;
    o.meshes = meshes;
    o.overlaps_per_object = 1.0;
    auto sc = cube::scenes::makeScene<double>(o);
    const auto objs = sc.pointers();
    cube::Config cfg;
    cfg.canonical_pairs = true;
    CubeCollisionManager<double> m(cfg);
    m.registerObjects(objs);
    const double size = cube::scenes::typicalSize(o);
    m.setMargin(size * 0.2);
    for (std::size_t i = 0; i < objs.size(); i += 5) m.setMargin(objs[i], size * 0.6);
    std::vector<std::tuple<Obj<double>*, Obj<double>*, bool, double>> want;
    for (std::size_t i = 0; i < objs.size(); ++i)
      for (std::size_t j = i + 1; j < objs.size(); ++j) {
        fcl::CollisionRequest<double> creq;
        fcl::CollisionResult<double> cres;
        if (fcl::collide(objs[i], objs[j], creq, cres) > 0) {
          want.emplace_back(objs[i], objs[j], true, 0.0);
          continue;
        }
        fcl::DistanceRequest<double> dreq(true);
        fcl::DistanceResult<double> dres;
        const double d = fcl::distance(objs[i], objs[j], dreq, dres);
        if (d <= m.margin(objs[i]) + m.margin(objs[j]))
          want.emplace_back(objs[i], objs[j], false, d);
      }
    for (const int threads : {1, 2}) {
      cube::NarrowPhaseStats stats;
      const auto got =
          cube::contactsWithinMargin(m, fcl::DistanceRequest<double>(true), threads, &stats);
      std::vector<std::tuple<Obj<double>*, Obj<double>*, bool, double>> g;
      for (const auto& c : got) g.emplace_back(c.a, c.b, c.colliding, c.distance);
      std::sort(g.begin(), g.end());
      auto w = want;
      std::sort(w.begin(), w.end());
      EXPECT_EQ(g, w) << "meshes " << meshes << " threads " << threads;
      EXPECT_GT(w.size(), 0u);
      EXPECT_GT(stats.culled, 0u) << "the widened tight volumes proved no pair apart";
    }
    // One object against the manager: (managed, obj).
    std::vector<Obj<double>*> got_q, want_q;
    for (const auto& c : cube::contactsWithinMargin(m, objs[0])) {
      EXPECT_EQ(c.b, objs[0]);
      got_q.push_back(c.a);
    }
    for (const auto& t : want)
      if (std::get<0>(t) == objs[0] || std::get<1>(t) == objs[0])
        want_q.push_back(std::get<0>(t) == objs[0] ? std::get<1>(t) : std::get<0>(t));
    std::sort(got_q.begin(), got_q.end());
    std::sort(want_q.begin(), want_q.end());
    EXPECT_EQ(got_q, want_q);
  }
}
// Contracts stated in the headers, each against what the calls do.
namespace contracts {

std::unique_ptr<Obj<double>> box(double x, double size = 1) {
  auto o = std::make_unique<Obj<double>>(std::make_shared<fcl::Boxd>(size, size, size),
                                         fcl::Transform3d(Eigen::Translation3d(x, 0, 0)));
  o->computeAABB();
  return o;
}

std::size_t pairsBetween(const CubeCollisionManager<double>& m,
                         fcl::BroadPhaseCollisionManagerd& o) {
  std::size_t n = 0;
  m.collide(&o, &n, [](Obj<double>*, Obj<double>*, void* d) {
    ++*static_cast<std::size_t*>(d);
    return false;
  });
  return n;
}

}  // namespace contracts

// setMargin: against another cube manager each side's objects are grown by their own manager's
// margins; against any other manager, its objects by this manager's manager-wide margin.
TEST(Contracts, MarginsBetweenManagers) {
  using contracts::box;
  // Unit boxes whose faces are 1.8 apart: within 1.0 + 1.0, not within 1.0 + 0.5 or 0.5 + 0.5.
  auto a = box(0), b = box(2.8);
  CubeCollisionManager<double> ma, mb;
  ma.registerObject(a.get());
  mb.registerObject(b.get());
  ma.setMargin(1.0);
  mb.setMargin(0.5);
  fcl::DynamicAABBTreeCollisionManagerd fa, fb;
  fa.registerObject(a.get());
  fb.registerObject(b.get());
  fa.setup();
  fb.setup();
  EXPECT_EQ(contracts::pairsBetween(ma, mb), 0u) << "cube-cube: 1.0 + 0.5 < 1.8";
  EXPECT_EQ(contracts::pairsBetween(mb, ma), 0u);
  EXPECT_EQ(contracts::pairsBetween(ma, fb), 1u) << "b grown by ma's margin: 1.0 + 1.0 > 1.8";
  EXPECT_EQ(contracts::pairsBetween(mb, fa), 0u) << "a grown by mb's margin: 0.5 + 0.5 < 1.8";
  mb.setMargin(b.get(), 0.9);  // b's own margin: cube-cube now 1.0 + 0.9 > 1.8
  EXPECT_EQ(contracts::pairsBetween(ma, mb), 1u);
  EXPECT_EQ(contracts::pairsBetween(mb, ma), 1u);
}

// setPairFilter: in distance queries the predicate is asked for pairs whose boxes do not overlap
// (all the branch and bound hands over), and its false keeps a pair out of the minimum.
TEST(Contracts, PredicateInDistanceQueriesSeesPairsApart) {
  using contracts::box;
  auto a = box(0), b = box(3), c = box(10);
  CubeCollisionManager<double> m;
  m.registerObjects({a.get(), b.get(), c.get()});
  std::size_t apart = 0;
  m.setPairFilter([&](Obj<double>* x, Obj<double>* y) {
    apart += !x->getAABB().overlap(y->getAABB());
    return !((x == a.get() && y == b.get()) || (x == b.get() && y == a.get()));
  });
  double best = std::numeric_limits<double>::max();
  m.distance(&best, &cube::oracle::narrowDistance<double>);
  EXPECT_GT(apart, 0u);
  EXPECT_NEAR(best, 6.0, 1e-9) << "a-b (2 apart) dropped: b-c (6 apart) is the nearest";
}

// setFilter / setMargin: unregistering an object forgets its bits and its own margin.
TEST(Contracts, UnregisterForgetsBitsAndMargin) {
  using contracts::box;
  auto a = box(0), b = box(1.5);
  CubeCollisionManager<double> m;
  m.registerObjects({a.get(), b.get()});
  m.setFilter(a.get(), 2, 2);
  m.setMargin(a.get(), 3.0);
  EXPECT_EQ(m.filter(a.get()), std::make_pair(std::uint64_t(2), std::uint64_t(2)));
  EXPECT_EQ(m.margin(a.get()), 3.0);
  m.unregisterObject(a.get());
  m.registerObject(a.get());
  EXPECT_EQ(m.filter(a.get()), std::make_pair(std::uint64_t(1), ~std::uint64_t(0)));
  EXPECT_EQ(m.margin(a.get()), 0.0);
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
}

// contactsWithinMargin: a pair with a plane gets the distance of the objects' own AABBs, not
// of the boxes grown by the margins.
TEST(Contracts, PlaneContactsUseTheObjectsOwnAabbs) {
  using contracts::box;
  auto b = box(0);  // spans z in [-0.5, 0.5]
  Obj<double> plane(std::make_shared<fcl::Planed>(fcl::Vector3d(0, 0, 1), 2.0));
  plane.computeAABB();
  CubeCollisionManager<double> m;
  m.registerObjects({b.get(), &plane});
  m.setMargin(1.0);  // 1.5 apart, within 1.0 + 1.0
  const auto found = cube::contactsWithinMargin<double>(m);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_FALSE(found[0].colliding);
  EXPECT_EQ(found[0].distance, b->getAABB().distance(plane.getAABB()));
  EXPECT_NEAR(found[0].distance, 1.5, 1e-12);
}

// raycastObject's box test: the intersection of [0, 1] with every axis' interval. A segment that
// ends before the box or starts after it misses; one that ends on its face touches it at t = 1.
TEST(Contracts, RayBoxTestIsTheIntersectionOfTheIntervals) {
  auto o = contracts::box(0.5);  // the unit cube [0, 1]^3
  cube::RayOptions<double> box_only;
  box_only.narrow_phase = false;
  const auto hit = [&](double x0, double x1) {
    return cube::raycastObject<double>(*o, o->getAABB(), fcl::Vector3d(x0, 0.5, 0.5),
                                       fcl::Vector3d(x1, 0.5, 0.5), box_only);
  };
  EXPECT_FALSE(hit(-3, -1).has_value()) << "ends before the box";
  EXPECT_FALSE(hit(2, 3).has_value()) << "starts after it";
  EXPECT_FALSE(hit(-1, -3).has_value()) << "moves away from it";
  ASSERT_TRUE(hit(-1, 0).has_value());
  EXPECT_EQ(hit(-1, 0)->t, 1.0) << "ends on its face";
  ASSERT_TRUE(hit(-1, 3).has_value());
  EXPECT_EQ(hit(-1, 3)->t, 0.25);
  ASSERT_TRUE(hit(0.5, 3).has_value());
  EXPECT_EQ(hit(0.5, 3)->t, 0.0) << "starts inside";
}

}  // namespace
