#pragma once

// What the tests of the ray and region queries share (test_spatial_queries_*.cpp): two typed
// suites over their files, and loops over every registered object as the reference, with the
// box tests written again here from spatial_queries.h's contract.

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
#include "spatial_world.h"

namespace spatialbrute {

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

template <typename S>
class ExactNarrowPhase : public ::testing::Test {};
TYPED_TEST_SUITE(ExactNarrowPhase, Scalars);

}  // namespace spatialbrute
