// Ray and region queries (spatial_queries.h) against loops over every registered object: the box
// tests written again here from the header's contract, the narrow phase through raycastObject
// (itself checked against the analytic intersections of a segment with a sphere and a box).

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/spatial_queries.h"
#include "scenes.h"
#include "support/spatial_world.h"

namespace {

using spatial::heldBox;
using spatial::Obj;
using spatial::segments;
using spatial::V3;
using spatial::World;

// The box test of the contract, written apart from the library's: entry and exit along the
// segment, or false.
template <typename S>
bool slab(const fcl::AABB<S>& box, const V3<S>& from, const V3<S>& to, double& entry) {
  double lo_t = 0, hi_t = 1;
  for (int k = 0; k < 3; ++k) {
    const double o = from[k], l = box.min_[k], h = box.max_[k];
    const double inv = 1.0 / (double(to[k]) - o);
    if (!std::isfinite(inv)) {
      if (o < l || o > h) return false;
      continue;
    }
    const double t1 = (l - o) * inv, t2 = (h - o) * inv;
    lo_t = std::max(lo_t, inv > 0 ? t1 : t2);
    hi_t = std::min(hi_t, inv > 0 ? t2 : t1);
  }
  entry = lo_t;
  return lo_t <= hi_t;
}

// Every registered object the filter lets through tested: the box test above, then
// raycastObject.
template <typename S>
std::vector<cube::RayHit<S>> bruteRay(const cube::CubeCollisionManager<S>& m, const V3<S>& from,
                                      const V3<S>& to, const cube::RayOptions<S>& opt,
                                      const std::optional<cube::QueryFilter>& filter = {}) {
  std::vector<Obj<S>*> objs;
  m.getObjects(objs);
  std::vector<cube::RayHit<S>> hits;
  for (Obj<S>* o : objs) {
    if (!spatial::lets(m, o, filter)) continue;
    double entry;
    const fcl::AABB<S> box = heldBox(m, o);
    const bool met = slab(box, from, to, entry);
    const auto h = cube::raycastObject(*o, box, from, to, opt);
    if (!met) {
      EXPECT_FALSE(h.has_value()) << "raycastObject hit an object whose box the segment misses";
      continue;
    }
    if (!opt.narrow_phase) {
      EXPECT_TRUE(h.has_value());
      if (h) {
        EXPECT_EQ(double(h->t), double(S(entry)));
      }
    }
    if (h) {
      EXPECT_GE(double(h->t), double(S(entry)));
      hits.push_back(*h);
    }
  }
  // Stable: equal t keeps registration order.
  std::stable_sort(hits.begin(), hits.end(),
                   [](const auto& a, const auto& b) { return a.t < b.t; });
  return hits;
}

template <typename S>
void expectSameHits(const std::vector<cube::RayHit<S>>& got,
                    const std::vector<cube::RayHit<S>>& want, const std::string& where) {
  ASSERT_EQ(got.size(), want.size()) << where;
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].object, want[i].object) << where << " hit " << i;
    EXPECT_EQ(got[i].t, want[i].t) << where << " hit " << i;
    EXPECT_EQ(got[i].kind, want[i].kind) << where << " hit " << i;
    EXPECT_EQ(got[i].distance, want[i].distance) << where << " hit " << i;
  }
}

template <typename S>
void checkRays(const cube::CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& objs, int n,
               std::uint32_t seed, std::size_t* narrow_hits = nullptr) {
  for (const bool narrow : {false, true}) {
    cube::RayOptions<S> opt;
    opt.narrow_phase = narrow;
    for (const auto& [from, to] : segments(objs, n, seed)) {
      const std::string where = std::string(narrow ? "narrow" : "box") + " segment " +
                                std::to_string(from[0]) + "," + std::to_string(from[1]) + "," +
                                std::to_string(from[2]) + " -> " + std::to_string(to[0]) + "," +
                                std::to_string(to[1]) + "," + std::to_string(to[2]);
      const auto want = bruteRay(m, from, to, opt);
      expectSameHits(cube::raycastAll(m, from, to, opt), want, where);
      const auto first = cube::raycastFirst(m, from, to, opt);
      ASSERT_EQ(first.has_value(), !want.empty()) << where;
      if (first) expectSameHits<S>({*first}, {want.front()}, where + " (first)");
      if (narrow_hits)
        for (const auto& h : want) *narrow_hits += h.kind == cube::HitKind::narrow_phase;
    }
  }
}

template <typename S>
std::vector<Obj<S>*> bruteInBox(const cube::CubeCollisionManager<S>& m, const fcl::AABB<S>& q,
                                const std::optional<cube::QueryFilter>& filter = {}) {
  std::vector<Obj<S>*> objs, out;
  m.getObjects(objs);
  for (Obj<S>* o : objs) {
    if (!spatial::lets(m, o, filter)) continue;
    const fcl::AABB<S> b = heldBox(m, o);
    bool in = true;
    for (int k = 0; k < 3; ++k) in = in && b.min_[k] <= q.max_[k] && q.min_[k] <= b.max_[k];
    if (in) out.push_back(o);
  }
  return out;
}

template <typename S>
std::vector<Obj<S>*> bruteNear(const cube::CubeCollisionManager<S>& m, const V3<S>& p, S r,
                               const std::optional<cube::QueryFilter>& filter = {}) {
  std::vector<Obj<S>*> objs, out;
  m.getObjects(objs);
  for (Obj<S>* o : objs) {
    if (!spatial::lets(m, o, filter)) continue;
    const fcl::AABB<S> b = heldBox(m, o);
    double sum = 0;
    bool far = false;
    for (int k = 0; k < 3; ++k) {
      const double gap = std::max({0.0, double(b.min_[k]) - p[k], double(p[k]) - b.max_[k]});
      far = far || gap > r;
      sum += gap * gap;
    }
    if (!far && sum <= double(r) * double(r)) out.push_back(o);
  }
  return out;
}

template <typename S>
void checkRegions(const cube::CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& objs,
                  std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-60, 60), r(0, 15);
  std::uniform_int_distribution<std::size_t> pick(0, objs.size() - 1);
  for (int i = 0; i < 100; ++i) {
    fcl::AABB<S> q(V3<S>(S(u(rng)), S(u(rng)), S(u(rng))), V3<S>(S(u(rng)), S(u(rng)), S(u(rng))));
    if (i % 4 == 1) q = fcl::AABB<S>(q.center());  // a point
    if (i % 4 == 2) {                              // touching an object's box from +x, face on face
      const fcl::AABB<S>& b = objs[pick(rng)]->getAABB();
      if (std::isfinite(b.max_[0])) q = fcl::AABB<S>(b.max_, b.max_ + V3<S>(5, 5, 5));
    }
    if (i % 4 == 3) q.min_[1] = -std::numeric_limits<S>::infinity();  // a half-open region
    EXPECT_EQ(cube::objectsInBox(m, q), bruteInBox(m, q)) << "box query " << i;
    const V3<S> p(S(u(rng)), S(u(rng)), S(u(rng)));
    const S radius = i % 10 == 0 ? S(0) : S(r(rng));
    EXPECT_EQ(cube::objectsNear(m, p, radius), bruteNear(m, p, radius)) << "near query " << i;
  }
  // Infinite radius: every object, in registration order.
  std::vector<Obj<S>*> all;
  m.getObjects(all);
  EXPECT_EQ(cube::objectsNear(m, V3<S>(0, 0, 0), std::numeric_limits<S>::infinity()), all);
}

// Rays (all and first, boxes and narrow phase) and regions under each query filter of the tests,
// against the loops over every object the filter lets through; and without a filter, every
// object whatever its bits. Counts the answers a filter changed, so that a test can tell the
// filters were not idle.
template <typename S>
std::size_t checkFiltered(const cube::CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& objs,
                          std::uint32_t seed) {
  std::size_t changed = 0;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-60, 60), r(0, 15);
  const auto segs = segments(objs, 24, seed);
  std::vector<std::optional<cube::QueryFilter>> filters = {std::nullopt};
  for (const cube::QueryFilter& f : spatial::queryFilters()) filters.emplace_back(f);
  for (const auto& filter : filters) {
    const std::string name =
        filter ? "filter " + std::to_string(filter->category) + "/" + std::to_string(filter->mask)
               : "no filter";
    for (const bool narrow : {false, true}) {
      cube::RayOptions<S> opt;
      opt.narrow_phase = narrow;
      for (std::size_t i = 0; i < segs.size(); ++i) {
        const auto& [from, to] = segs[i];
        const std::string where =
            name + (narrow ? " narrow" : " box") + " segment " + std::to_string(i);
        const auto want = bruteRay(m, from, to, opt, filter);
        expectSameHits(cube::raycastAll(m, from, to, opt, filter), want, where);
        const auto first = cube::raycastFirst(m, from, to, opt, filter);
        EXPECT_EQ(first.has_value(), !want.empty()) << where;
        if (first && !want.empty()) expectSameHits<S>({*first}, {want.front()}, where + " (first)");
        changed += want.size() != bruteRay(m, from, to, opt).size();
      }
    }
    for (int i = 0; i < 30; ++i) {
      const fcl::AABB<S> q(V3<S>(S(u(rng)), S(u(rng)), S(u(rng))),
                           V3<S>(S(u(rng)), S(u(rng)), S(u(rng))));
      const auto in_box = bruteInBox(m, q, filter);
      EXPECT_EQ(cube::objectsInBox(m, q, filter), in_box) << name << " box query " << i;
      const V3<S> p(S(u(rng)), S(u(rng)), S(u(rng)));
      const S radius = S(r(rng));
      const auto near = bruteNear(m, p, radius, filter);
      EXPECT_EQ(cube::objectsNear(m, p, radius, filter), near) << name << " near query " << i;
      changed += in_box != bruteInBox(m, q);
      changed += near != bruteNear(m, p, radius);
    }
  }
  return changed;
}

template <typename S>
class SpatialQueries : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(SpatialQueries, Scalars);

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

// The narrow-phase t against the analytic first contact of a segment with a sphere and with a
// rotated box (slabs in the box's frame).
TYPED_TEST(SpatialQueries, NarrowPhaseMatchesAnalyticIntersections) {
  using S = TypeParam;
  const double tol = std::is_same<S, float>::value ? 2e-4 : 1e-6;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-6, 6);
  std::normal_distribution<double> g(0, 1);
  const S radius = 2;
  const V3<S> centre(1, -0.5, 0.25);
  Obj<S> ball(std::make_shared<fcl::Sphere<S>>(radius));
  ball.setTranslation(centre);
  ball.computeAABB();
  const V3<S> half(1.5, 0.75, 2);
  Eigen::Quaternion<double> q(0.9, 0.2, -0.3, 0.1);
  q.normalize();
  const fcl::Matrix3<S> R = q.toRotationMatrix().cast<S>();
  Obj<S> box(std::make_shared<fcl::Box<S>>(2 * half), R, centre);
  box.computeAABB();
  int ball_hits = 0, box_hits = 0;
  cube::RayOptions<S> opt;
  opt.tolerance = S(1e-7);
  for (int i = 0; i < 300; ++i) {
    const V3<S> from(S(u(rng)), S(u(rng)), S(u(rng)));
    const V3<S> to(S(u(rng)), S(u(rng)), S(u(rng)));
    const double len = (to - from).template cast<double>().norm();
    const Eigen::Vector3d o = from.template cast<double>(), d = (to - from).template cast<double>();
    // Sphere: |o + t d - c|^2 = r^2.
    {
      const Eigen::Vector3d oc = o - centre.template cast<double>();
      const double a = d.squaredNorm(), b = 2 * oc.dot(d), c = oc.squaredNorm() - radius * radius;
      const double disc = b * b - 4 * a * c;
      double t = -1;
      if (c <= 0)
        t = 0;
      else if (disc >= 0) {
        const double t0 = (-b - std::sqrt(disc)) / (2 * a);
        if (t0 >= 0 && t0 <= 1) t = t0;
      }
      const auto h = cube::raycastObject(ball, ball.getAABB(), from, to, opt);
      // Grazing segments are left to either answer: the margin is what GJK may say there.
      const double line_gap = oc.cross(d).norm() / d.norm();
      const bool grazing = std::abs(line_gap - radius) < 1e-3;
      if (!grazing && std::abs(t - 1) * len > 1e-3) {
        ASSERT_EQ(h.has_value(), t >= 0) << "sphere segment " << i;
        if (h) {
          ++ball_hits;
          EXPECT_EQ(h->kind, cube::HitKind::narrow_phase);
          EXPECT_NEAR(double(h->t) * len, t * len, tol * 10) << "sphere segment " << i;
          EXPECT_NEAR(double(h->distance), t * len, tol * 10);
        }
      }
    }
    // Box: slabs in its frame.
    {
      const Eigen::Matrix3d Rd = R.template cast<double>();
      const Eigen::Vector3d lo = Rd.transpose() * (o - centre.template cast<double>());
      const Eigen::Vector3d ld = Rd.transpose() * d;
      double tn = 0, tf = 1, slack = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        const double h = half[k];
        double a = (-h - lo[k]) / ld[k], b = (h - lo[k]) / ld[k];
        if (a > b) std::swap(a, b);
        tn = std::max(tn, a);
        tf = std::min(tf, b);
      }
      slack = std::min(std::abs(tf - tn), std::min(std::abs(tn - 1), std::abs(tf))) * len;
      const auto h = cube::raycastObject(box, box.getAABB(), from, to, opt);
      if (slack > 1e-3) {
        ASSERT_EQ(h.has_value(), tn <= tf) << "box segment " << i;
        if (h) {
          ++box_hits;
          EXPECT_EQ(h->kind, cube::HitKind::narrow_phase);
          EXPECT_NEAR(double(h->t) * len, tn * len, tol * 10) << "box segment " << i;
        }
      }
    }
  }
  EXPECT_GT(ball_hits, 30);
  EXPECT_GT(box_hits, 30);
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

TYPED_TEST(SpatialQueries, EmptyManagerFindsNothing) {
  using S = TypeParam;
  cube::CubeCollisionManager<S> m;
  EXPECT_FALSE(cube::raycastFirst(m, V3<S>(0, 0, 0), V3<S>(1, 1, 1)).has_value());
  EXPECT_TRUE(cube::raycastAll(m, V3<S>(0, 0, 0), V3<S>(1, 1, 1)).empty());
  EXPECT_TRUE(cube::objectsInBox(m, fcl::AABB<S>(V3<S>(-1, -1, -1), V3<S>(1, 1, 1))).empty());
  EXPECT_TRUE(cube::objectsNear(m, V3<S>(0, 0, 0), S(100)).empty());
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

// ---- The exact per-object tests (spheres, boxes, capsules, cylinders, ellipsoids, planes,
// halfspaces) against the bisection they replace, and against analytic touching cases.

enum Prim { kSphere, kBox, kCapsule, kCylinder, kEllipsoid, kPlane, kHalfspace, kPrims };

const char* primName(int p) {
  static const char* names[] = {"sphere",    "box",   "capsule",  "cylinder",
                                "ellipsoid", "plane", "halfspace"};
  return names[p];
}

// One primitive of sizes a, b, c (and normal n, for planes), every size grown by `grow` (a plane
// moves by it along n): grown and shrunk copies bracket what the bisection may say on a graze.
template <typename S>
std::shared_ptr<fcl::CollisionGeometry<S>> primitive(int p, double a, double b, double c,
                                                     const Eigen::Vector3d& n, double grow) {
  const auto g = [grow](double v) { return S(std::max(0.0, v + grow)); };       // a radius
  const auto g2 = [grow](double v) { return S(std::max(0.0, v + 2 * grow)); };  // a length
  switch (p) {
    case kSphere:
      return std::make_shared<fcl::Sphere<S>>(g(a));
    case kBox:
      return std::make_shared<fcl::Box<S>>(g2(2 * a), g2(2 * b), g2(2 * c));
    case kCapsule:  // the radius grows the ends too
      return std::make_shared<fcl::Capsule<S>>(g(a), S(2 * b));
    case kCylinder:
      return std::make_shared<fcl::Cylinder<S>>(g(a), g2(2 * b));
    case kEllipsoid:
      return std::make_shared<fcl::Ellipsoid<S>>(g(a), g(b), g(c));
    case kPlane:
      return std::make_shared<fcl::Plane<S>>(n.cast<S>(), S(c + grow));
    default:
      return std::make_shared<fcl::Halfspace<S>>(n.cast<S>(), S(c + grow));
  }
}

// The bisection of the contract, written apart from the library's: does fcl::collide find the
// object touching a capsule of radius 0 from `from` to the point at t?
template <typename S>
bool reachesByFcl(const Obj<S>& obj, const V3<S>& from, const V3<S>& to, double t) {
  const V3<S> d = to - from;
  const S len = d.norm();
  fcl::Matrix3<S> R = fcl::Matrix3<S>::Identity();
  if (len > 0) R = Eigen::Quaternion<S>::FromTwoVectors(V3<S>::UnitZ(), d / len).toRotationMatrix();
  Obj<S> seg(std::make_shared<fcl::Capsule<S>>(S(0), S(t * double(len))), R,
             V3<S>(from + S(0.5 * t) * d));
  seg.computeAABB();
  fcl::CollisionRequest<S> request;
  fcl::CollisionResult<S> result;
  return fcl::collide(&seg, &obj, request, result) > 0;
}

// The first contact by bisection on [0, 1] to `tol` (a length), or -1 if the segment misses.
template <typename S>
double bisectByFcl(const Obj<S>& obj, const V3<S>& from, const V3<S>& to, double tol) {
  if (!reachesByFcl(obj, from, to, 1)) return -1;
  if (reachesByFcl(obj, from, to, 0)) return 0;
  const double len = (to - from).template cast<double>().norm();
  double a = 0, b = 1;
  while ((b - a) * len > tol) {
    const double mid = 0.5 * (a + b);
    (reachesByFcl(obj, from, to, mid) ? b : a) = mid;
  }
  return b;
}

template <typename S>
class ExactNarrowPhase : public ::testing::Test {};
TYPED_TEST_SUITE(ExactNarrowPhase, Scalars);

// Random primitives, rotated at random or axis-aligned, and per object: random segments,
// segments starting inside, parallel to a local axis, lying on the surface (tangent) and of
// length 0. Where the exact t and the bisection's differ by more than the bisection's accuracy,
// the segment must graze: the copies grown and shrunk by a hair must bracket the exact answer.
TYPED_TEST(ExactNarrowPhase, ExactTMatchesTheBisectionOnRotatedPrimitives) {
  using S = TypeParam;
  const bool is_float = std::is_same<S, float>::value;
  const double tol = 1e-6;                         // the bisections' tolerance, as a length
  const double accuracy = is_float ? 2e-3 : 2e-5;  // of FCL's GJK plus the tolerance
  const double hair = is_float ? 2e-3 : 2e-5;      // the grown and shrunk copies
  std::mt19937 rng(2020);
  std::uniform_real_distribution<double> size(0.3, 3), u(-1, 1), pos(-20, 20);
  std::normal_distribution<double> g(0, 1);
  int cases[kPrims] = {}, tight[kPrims] = {}, hits[kPrims] = {}, inside = 0;
  for (int i = 0; i < 7 * 40; ++i) {
    const int p = i % kPrims;
    const double a = size(rng), b = size(rng), c = p >= kPlane ? u(rng) : size(rng);
    const Eigen::Vector3d n = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    fcl::Matrix3<S> R = fcl::Matrix3<S>::Identity();
    if (i % 3 == 1) {  // a quarter turn about z: exact, axes still parallel to the world's
      R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
    } else if (i % 3 == 2) {
      Eigen::Quaternion<double> q(g(rng), g(rng), g(rng), g(rng));
      q.normalize();
      R = q.toRotationMatrix().cast<S>();
    }
    const V3<S> T(S(pos(rng)), S(pos(rng)), S(pos(rng)));
    const auto make = [&](double grow) {
      auto o = std::make_unique<Obj<S>>(primitive<S>(p, a, b, c, n, grow), R, T);
      o->computeAABB();
      return o;
    };
    const auto obj = make(0), grown = make(hair), shrunk = make(-hair);
    // Local points and directions, taken to the world by the object's transform.
    const auto world = [&](const Eigen::Vector3d& v) { return V3<S>(R * v.cast<S>() + T); };
    const auto dir = [&](const Eigen::Vector3d& v) { return V3<S>(R * v.cast<S>()); };
    const double reach = 2 * std::max({a, b, c, 1.0});
    std::vector<std::pair<V3<S>, V3<S>>> segs;
    for (int j = 0; j < 6; ++j) {
      const Eigen::Vector3d p0(reach * u(rng), reach * u(rng), reach * u(rng));
      const Eigen::Vector3d p1(reach * u(rng), reach * u(rng), reach * u(rng));
      segs.emplace_back(world(p0), world(p1));
    }
    // Starting inside (for a plane: on it).
    const Eigen::Vector3d in =
        p >= kPlane
            ? Eigen::Vector3d(n * (c - 0.5 * (p == kHalfspace)))
            : Eigen::Vector3d(0.2 * std::min({a, b, c}) * Eigen::Vector3d(u(rng), u(rng), u(rng)));
    segs.emplace_back(world(in), world(Eigen::Vector3d(reach, -reach, reach * u(rng))));
    // Parallel to each local axis, from outside.
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d f(0.5 * a * u(rng), 0.5 * a * u(rng), 0.5 * a * u(rng));
      f[k] = -reach;
      segs.emplace_back(world(f), V3<S>(world(f) + dir(2 * reach * Eigen::Vector3d::Unit(k))));
    }
    // On the surface, moving along it: a box face, the side line of a cylinder or capsule, a
    // tangent of a sphere, the plane itself.
    {
      Eigen::Vector3d f(-reach, 0, 0), t(reach, 0, 0);
      if (p == kBox)
        f = Eigen::Vector3d(-reach, b, 0.5 * c), t = Eigen::Vector3d(reach, b, 0.5 * c);
      if (p == kSphere || p == kCapsule || p == kCylinder)
        f = Eigen::Vector3d(a, 0, -reach), t = Eigen::Vector3d(a, 0, reach);
      if (p == kSphere) f = Eigen::Vector3d(-reach, a, 0), t = Eigen::Vector3d(reach, a, 0);
      if (p == kEllipsoid) f = Eigen::Vector3d(-reach, b, 0), t = Eigen::Vector3d(reach, b, 0);
      if (p >= kPlane) {
        const Eigen::Vector3d side = n.unitOrthogonal();
        f = c * n - reach * side, t = c * n + reach * side;
      }
      segs.emplace_back(world(f), world(t));
    }
    segs.emplace_back(world(in), world(in));  // length 0, inside
    const Eigen::Vector3d out(reach, reach, reach);
    segs.emplace_back(world(out), world(out));  // length 0, outside (or past a plane)

    for (std::size_t j = 0; j < segs.size(); ++j) {
      const auto& [from, to] = segs[j];
      const std::string where = std::string(primName(p)) + " object " + std::to_string(i) +
                                " segment " + std::to_string(j);
      cube::RayOptions<S> opt;
      opt.tolerance = S(tol);
      const auto h = cube::raycastObject(*obj, obj->getAABB(), from, to, opt);
      const double len = (to - from).template cast<double>().norm();
      const double want = bisectByFcl(*obj, from, to, tol);
      ++cases[p];
      if (h) {
        ++hits[p];
        EXPECT_EQ(h->kind, cube::HitKind::narrow_phase) << where;
        EXPECT_GE(double(h->t), 0) << where;
        EXPECT_LE(double(h->t), 1) << where;
      }
      if (h && double(h->t) == 0 && len > 0) ++inside;
      if ((h.has_value() == (want >= 0)) &&
          (!h || std::abs(double(h->t) - want) * len <= accuracy)) {
        ++tight[p];
        continue;
      }
      if (p == kPlane) {
        // A surface has no grown copy: the answers may differ only where an end of the segment
        // lies within a hair of the plane (distances in the world frame, in double).
        const Eigen::Vector3d nw = R.template cast<double>() * n;
        const double off = c + nw.dot(T.template cast<double>());
        const double df = nw.dot(from.template cast<double>()) - off;
        const double dt = nw.dot(to.template cast<double>()) - off;
        EXPECT_LE(std::min(std::abs(df), std::abs(dt)), hair) << where;
        continue;
      }
      // A graze: the grown copy is met no later, the shrunk one no earlier.
      const double tg = bisectByFcl(*grown, from, to, tol),
                   ts = bisectByFcl(*shrunk, from, to, tol);
      const double slack = len > 0 ? accuracy / len : 0;
      if (h) {
        ASSERT_GE(tg, 0) << where << ": the exact test hits, the grown copy is missed";
        EXPECT_GE(double(h->t), tg - slack) << where;
        if (ts >= 0) {
          EXPECT_LE(double(h->t), ts + slack) << where;
        }
      } else {
        EXPECT_LT(ts, 0) << where << ": the exact test misses, the shrunk copy is hit at " << ts;
      }
    }
  }
  for (int p = 0; p < kPrims; ++p) {
    // Grazes are a few of the constructed cases; most answers agree within the accuracy.
    EXPECT_GE(tight[p], cases[p] * 8 / 10) << primName(p);
    EXPECT_GE(hits[p], cases[p] / 5) << primName(p);
  }
  EXPECT_GT(inside, 40);
}

// A segment that crosses a plane hits it, wherever it crosses: planes whose normal is along an
// axis (their box has no thickness along it: the exact crossing and the box's exit are computed
// by different formulas, a few ulps apart) and oblique ones, through raycastObject, raycastFirst
// and raycastAll, at t within rounding of the crossing.
TYPED_TEST(ExactNarrowPhase, SegmentsCrossingAPlaneHitIt) {
  using S = TypeParam;
  std::mt19937 rng(38);
  std::uniform_real_distribution<double> u(-10, 10), side(0.5, 12);
  std::normal_distribution<double> g(0, 1);
  const double tol = std::is_same<S, double>::value ? 1e-9 : 1e-5;
  std::vector<V3<S>> normals = {{1, 0, 0},  {0, 1, 0},  {0, 0, 1},
                                {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
  for (int k = 0; k < 4; ++k)
    normals.push_back(V3<S>(S(g(rng)), S(g(rng)), S(g(rng))).normalized());
  std::size_t tried = 0;
  for (const V3<S>& n : normals) {
    const S d = std::is_same<S, double>::value && n.z() == 1 ? S(1.704196565302869) : S(u(rng));
    auto plane = std::make_unique<Obj<S>>(std::make_shared<fcl::Plane<S>>(n, d));
    plane->computeAABB();
    cube::CubeCollisionManager<S> m;
    m.registerObject(plane.get());
    std::vector<std::pair<V3<S>, V3<S>>> segments;
    if (std::is_same<S, double>::value && n.z() == 1)
      segments.emplace_back(
          V3<S>(S(0.61908092191168773), S(8.1087003765085441), S(12.782941783756129)),
          V3<S>(S(2.0555134614619028), S(1.5661106793651922), S(-0.44045242773822779)));
    for (int i = 0; i < 2000; ++i) {
      // A point on the plane, and the two ends on either side of it by 0.5 to 12.
      const V3<S> on = V3<S>(S(u(rng)), S(u(rng)), S(u(rng)));
      const V3<S> p = on - n * (n.dot(on) - d);
      V3<S> dir(S(g(rng)), S(g(rng)), S(g(rng)));
      if (std::abs(dir.normalized().dot(n)) < S(0.2)) dir += n;
      dir.normalize();
      if (dir.dot(n) < 0) dir = -dir;
      segments.emplace_back(p + dir * S(side(rng)), p - dir * S(side(rng)));
    }
    for (const auto& [from, to] : segments) {
      ++tried;
      // The crossing, in double from the values as stored.
      const double f0 = double(n.x()) * from.x() + double(n.y()) * from.y() +
                        double(n.z()) * from.z() - double(d);
      const double f1 =
          double(n.x()) * to.x() + double(n.y()) * to.y() + double(n.z()) * to.z() - double(d);
      ASSERT_GT(f0, 0.05);
      ASSERT_LT(f1, -0.05);
      const double want = f0 / (f0 - f1);
      const auto one = cube::raycastObject(*plane, plane->getAABB(), from, to);
      ASSERT_TRUE(one.has_value()) << "normal " << n.transpose() << " d " << d << " from "
                                   << from.transpose() << " to " << to.transpose();
      EXPECT_NEAR(double(one->t), want, tol);
      EXPECT_EQ(one->kind, cube::HitKind::narrow_phase);
      const auto first = cube::raycastFirst(m, from, to);
      ASSERT_TRUE(first.has_value());
      EXPECT_EQ(first->object, plane.get());
      EXPECT_EQ(first->t, one->t);
      const auto all = cube::raycastAll(m, from, to);
      ASSERT_EQ(all.size(), 1u);
      EXPECT_EQ(all[0].t, one->t);
    }
  }
  EXPECT_GE(tried, 20000u);
}

// Touching counts, and the degenerate cases, on axis-aligned primitives where the answer is
// exact in both scalars: segments on a box face, along a cylinder's or capsule's side line, in a
// cylinder's cap, tangent to a sphere, in a plane, ending on a halfspace's boundary; zero length
// inside, on and outside; a sphere and a capsule of radius 0.
TYPED_TEST(ExactNarrowPhase, TouchingAndDegenerateSegmentsAreExact) {
  using S = TypeParam;
  const V3<S> c(1, 2, 3);
  const auto object = [&](std::shared_ptr<fcl::CollisionGeometry<S>> geo) {
    auto o = std::make_unique<Obj<S>>(geo, fcl::Matrix3<S>::Identity(), c);
    o->computeAABB();
    return o;
  };
  const auto at = [&](S x, S y, S z) { return V3<S>(c + V3<S>(x, y, z)); };
  // Expect the narrow phase to hit at `t` (to a few ulps: the box entry and the exact t are
  // rounded apart), or to miss (t < 0).
  const auto expectHit = [](const Obj<S>& o, const V3<S>& from, const V3<S>& to, double t,
                            const std::string& what) {
    const auto h = cube::raycastObject(o, o.getAABB(), from, to);
    ASSERT_EQ(h.has_value(), t >= 0) << what;
    if (!h) return;
    EXPECT_EQ(h->kind, cube::HitKind::narrow_phase) << what;
    EXPECT_LE(std::abs(double(h->t) - t), 4 * double(std::numeric_limits<S>::epsilon())) << what;
  };
  // The t at which the segment's coordinate k reaches value v: where a plane is crossed.
  const auto cross = [](const V3<S>& from, const V3<S>& to, int k, S v) {
    return double(S((double(v) - from[k]) / (double(to[k]) - from[k])));
  };
  {
    const auto box = object(std::make_shared<fcl::Box<S>>(2, 4, 6));
    const V3<S> f = at(-10, 2, 0), t = at(10, 2, 0);  // on the face y = +2
    expectHit(*box, f, t, cross(f, t, 0, c[0] - 1), "box face");
    const V3<S> e = at(-10, 2, 3), e2 = at(10, 2, 3);  // along an edge
    expectHit(*box, e, e2, cross(e, e2, 0, c[0] - 1), "box edge");
    expectHit(*box, at(-10, 2.5, 0), at(10, 2.5, 0), -1, "parallel past the face");
    expectHit(*box, at(-1, -2, -3), at(-1, -2, -3), 0, "zero length on a corner");
    expectHit(*box, at(0, 0, 0), at(5, 5, 5), 0, "from inside");
    expectHit(*box, at(-10, 0, 0), at(-1, 0, 0), 1, "ending on the face");
  }
  {
    const auto ball = object(std::make_shared<fcl::Sphere<S>>(2));
    const V3<S> f = at(-4, 2, 0), t = at(4, 2, 0);  // tangent at (0, 2, 0)
    expectHit(*ball, f, t, cross(f, t, 0, c[0]), "sphere tangent");
    expectHit(*ball, at(0, 0, 2), at(0, 0, 2), 0, "zero length on the sphere");
    expectHit(*ball, at(0, 0, 2.5), at(0, 0, 2.5), -1, "zero length outside");
    expectHit(*ball, at(0.5, 0, 0), at(0.5, 0, 0), 0, "zero length inside");
    const V3<S> g = at(0, 0, -10), h = at(0, 0, 10);
    expectHit(*ball, g, h, cross(g, h, 2, c[2] - 2), "sphere through the centre");
  }
  {
    const auto point = object(std::make_shared<fcl::Sphere<S>>(0));
    const V3<S> f = at(-1, 0, 0), t = at(1, 0, 0);
    expectHit(*point, f, t, cross(f, t, 0, c[0]), "radius 0 sphere crossed");
    expectHit(*point, at(-1, 0.25, 0), at(1, 0.25, 0), -1, "radius 0 sphere passed");
  }
  {
    const auto cyl = object(std::make_shared<fcl::Cylinder<S>>(1, 4));
    const V3<S> f = at(1, 0, -10), t = at(1, 0, 10);  // the side line x = 1
    expectHit(*cyl, f, t, cross(f, t, 2, c[2] - 2), "cylinder side line");
    const V3<S> g = at(-5, 0, 2), h = at(5, 0, 2);  // in the top cap's plane
    expectHit(*cyl, g, h, cross(g, h, 0, c[0] - 1), "cylinder cap plane");
    expectHit(*cyl, at(1.5, 0, -10), at(1.5, 0, 10), -1, "parallel to the axis, outside");
    expectHit(*cyl, at(0, 0, 0), at(0, 0, 10), 0, "from inside, along the axis");
  }
  {
    const auto cap = object(std::make_shared<fcl::Capsule<S>>(1, 4));
    const V3<S> f = at(1, 0, -10), t = at(1, 0, 10);  // the side line: touches from z = -2
    expectHit(*cap, f, t, cross(f, t, 2, c[2] - 2), "capsule side line");
    const V3<S> g = at(0, 0, -10), h = at(0, 0, 10);  // along the axis: the end ball at z = -3
    expectHit(*cap, g, h, cross(g, h, 2, c[2] - 3), "capsule axis");
    const V3<S> k = at(-10, 0, 2), l = at(10, 0, 2);  // through the top ball's centre
    expectHit(*cap, k, l, cross(k, l, 0, c[0] - 1), "capsule end ball");
    const V3<S> k2 = at(-10, 0, 3), l2 = at(10, 0, 3);  // tangent at the tip
    expectHit(*cap, k2, l2, cross(k2, l2, 0, c[0]), "capsule tip");
    expectHit(*cap, at(0, 0, 3), at(0, 0, 3), 0, "zero length on the tip");
  }
  {
    const auto line = object(std::make_shared<fcl::Capsule<S>>(0, 4));
    const V3<S> f = at(-1, 0, 1), t = at(1, 0, 1);
    expectHit(*line, f, t, cross(f, t, 0, c[0]), "radius 0 capsule crossed");
    expectHit(*line, at(-1, 0, 2.5), at(1, 0, 2.5), -1, "radius 0 capsule passed");
  }
  {
    const auto ell = object(std::make_shared<fcl::Ellipsoid<S>>(1, 2, 3));
    const V3<S> f = at(0, -10, 0), t = at(0, 10, 0);
    expectHit(*ell, f, t, cross(f, t, 1, c[1] - 2), "ellipsoid");
    const V3<S> g = at(-5, 0, 3), h = at(5, 0, 3);  // tangent at the top
    expectHit(*ell, g, h, cross(g, h, 0, c[0]), "ellipsoid tangent");
  }
  {
    // n.x = d in the object's frame: the plane z = 1 there, z = 4 in the world.
    const auto plane = object(std::make_shared<fcl::Plane<S>>(V3<S>(0, 0, 1), 1));
    expectHit(*plane, at(-5, 0, 1), at(5, 3, 1), 0, "in the plane");
    const V3<S> f = at(0, 0, 3), t = at(0, 0, -1);
    expectHit(*plane, f, t, cross(f, t, 2, c[2] + 1), "crossing the plane");
    expectHit(*plane, at(0, 0, 3), at(0, 0, 1), 1, "ending on the plane");
    expectHit(*plane, at(0, 0, 3), at(0, 0, 2), -1, "short of the plane");
    expectHit(*plane, at(0, 0, -3), at(0, 0, -2), -1, "short of it from below");
    const auto half = object(std::make_shared<fcl::Halfspace<S>>(V3<S>(0, 0, 1), 1));
    expectHit(*half, at(0, 0, -3), at(0, 0, -2), 0, "inside the halfspace");
    expectHit(*half, at(0, 0, 3), at(0, 0, 1), 1, "ending on the boundary");
    expectHit(*half, at(-5, 0, 1.5), at(5, 0, 1.5), -1, "parallel above");
    const V3<S> g = at(0, 0, 3), h = at(0, 0, -1);
    expectHit(*half, g, h, cross(g, h, 2, c[2] + 1), "entering the halfspace");
  }
}

// raycastFirst and raycastAll against loops over every object, on scenes of rotated and
// axis-aligned primitives of every kind solved exactly, among the ones left to the bisection
// (cones, convexes, meshes): exact and bisected hits mix in one answer.
TYPED_TEST(ExactNarrowPhase, RaysEqualBruteForceInPrimitiveScenes) {
  using S = TypeParam;
  World<S> w(200, 71);
  std::mt19937 rng(72);
  std::uniform_real_distribution<double> size(0.3, 3), pos(-45, 45), u(-1, 1);
  std::normal_distribution<double> g(0, 1);
  std::vector<std::unique_ptr<Obj<S>>> more;
  for (int i = 0; i < 250; ++i) {
    const int p = i % 5;  // the bounded kinds; planes are added below
    fcl::Matrix3<S> R = fcl::Matrix3<S>::Identity();
    if (i % 2 == 1) {
      Eigen::Quaternion<double> q(g(rng), g(rng), g(rng), g(rng));
      q.normalize();
      R = q.toRotationMatrix().cast<S>();
    }
    more.push_back(std::make_unique<Obj<S>>(
        primitive<S>(p, size(rng), size(rng), size(rng), Eigen::Vector3d::UnitX(), 0), R,
        V3<S>(S(pos(rng)), S(pos(rng)), S(pos(rng)))));
  }
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d n = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    more.push_back(std::make_unique<Obj<S>>(primitive<S>(kPlane + i % 2, 0, 0, 40 * u(rng), n, 0)));
  }
  for (auto& o : more) {
    o->computeAABB();
    w.objs.push_back(o.get());
  }
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  ASSERT_TRUE(m.validate());
  std::size_t narrow_hits = 0;
  checkRays(m, w.objs, 200, 73, &narrow_hits);
  EXPECT_GT(narrow_hits, 100u);
  // Both paths decided hits: exact kinds and bisected ones.
  std::size_t exact = 0, bisected = 0;
  for (const auto& [from, to] : segments(w.objs, 100, 74))
    for (const auto& h : cube::raycastAll(m, from, to)) {
      const auto type = h.object->collisionGeometry()->getNodeType();
      const bool solved = type == fcl::GEOM_SPHERE || type == fcl::GEOM_BOX ||
                          type == fcl::GEOM_CAPSULE || type == fcl::GEOM_CYLINDER ||
                          type == fcl::GEOM_ELLIPSOID || type == fcl::GEOM_PLANE ||
                          type == fcl::GEOM_HALFSPACE;
      (solved ? exact : bisected) += h.kind == cube::HitKind::narrow_phase;
    }
  EXPECT_GT(exact, 50u);
  EXPECT_GT(bisected, 10u);
}

}  // namespace
