// objectsInCapsule (spatial_queries.h) against fcl::collide of an fcl::Capsule, placed on the
// segment as the contract says, with every registered object the query's filter lets through.

#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/spatial_queries.h"
#include "support/spatial_world.h"

namespace {

using spatial::heldBox;
using spatial::Obj;
using spatial::V3;
using spatial::World;

// The capsule of the contract: radius, length |b - a|, axis z turned onto b - a, centred
// between a and b.
template <typename S>
std::unique_ptr<Obj<S>> capsuleOn(const V3<S>& a, const V3<S>& b, S radius) {
  const V3<S> d = b - a;
  const S length = d.norm();
  fcl::Matrix3<S> rot = fcl::Matrix3<S>::Identity();
  if (length != S(0))
    rot = Eigen::Quaternion<S>::FromTwoVectors(V3<S>::UnitZ(), d).toRotationMatrix();
  return std::make_unique<Obj<S>>(std::make_shared<fcl::Capsule<S>>(radius, length), rot,
                                  V3<S>(a + d / S(2)));
}

// Every registered object the filter lets through, put to fcl::collide with the capsule.
template <typename S>
std::vector<Obj<S>*> bruteCapsule(const cube::CubeCollisionManager<S>& m, const V3<S>& a,
                                  const V3<S>& b, S radius,
                                  const std::optional<cube::QueryFilter>& filter = {}) {
  const auto cap = capsuleOn(a, b, radius);
  std::vector<Obj<S>*> objs, out;
  m.getObjects(objs);
  for (Obj<S>* o : objs) {
    if (!spatial::lets(m, o, filter)) continue;
    fcl::CollisionRequest<S> request;
    fcl::CollisionResult<S> result;
    if (fcl::collide(cap.get(), o, request, result) > 0) out.push_back(o);
  }
  return out;
}

// Objects whose held box comes within radius of the segment's bounding box: a superset of those
// a box-only query would report, to show the narrow phase decided.
template <typename S>
std::size_t boxesNear(const cube::CubeCollisionManager<S>& m, const V3<S>& a, const V3<S>& b,
                      S radius) {
  std::vector<Obj<S>*> objs;
  m.getObjects(objs);
  std::size_t n = 0;
  for (Obj<S>* o : objs) {
    const fcl::AABB<S> box = heldBox(m, o);
    bool near = true;
    for (int k = 0; k < 3; ++k)
      near = near && box.min_[k] <= std::max(a[k], b[k]) + radius &&
             std::min(a[k], b[k]) - radius <= box.max_[k];
    n += near;
  }
  return n;
}

// Capsules along the test segments (random, axis-parallel, zero-length, from inside an object,
// on and ending on box faces), radius 0, small and large, against the brute force. Returns how
// many objects were reported and how many more had boxes near the capsule.
template <typename S>
std::pair<std::size_t, std::size_t> checkCapsules(
    const cube::CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& objs, int n,
    std::uint32_t seed, const std::optional<cube::QueryFilter>& filter = {}) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> r(0.1, 8);
  std::size_t found = 0, near = 0;
  const auto segs = spatial::segments(objs, n, seed);
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const auto& [a, b] = segs[i];
    const S radius = i % 5 == 0 ? S(0) : S(r(rng));
    const auto want = bruteCapsule(m, a, b, radius, filter);
    EXPECT_EQ(cube::objectsInCapsule(m, a, b, radius, filter), want)
        << "capsule " << i << " radius " << radius;
    found += want.size();
    near += boxesNear(m, a, b, radius);
  }
  return {found, near};
}

template <typename S>
class CapsuleQuery : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(CapsuleQuery, Scalars);

// Every shape kind: boxes, spheres and cylinders (half as meshes), cones, ellipsoids, capsules,
// convexes, a plane and a halfspace; then after motions, unregistration and with margins.
TYPED_TEST(CapsuleQuery, EqualsFclCollideOnEveryObject) {
  using S = TypeParam;
  World<S> w(400, 81);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  const auto [found, near] = checkCapsules(m, w.objs, 120, 82);
  EXPECT_GT(found, 100u) << "the capsules should meet many objects";
  EXPECT_GT(near, found + 50) << "the narrow phase should turn away many objects whose boxes "
                                 "are near";
  std::mt19937 rng(83);
  std::uniform_real_distribution<double> step(-6, 6);
  for (std::size_t i = 0; i < w.objs.size(); i += 3) {
    Obj<S>* o = w.objs[i];
    o->setTranslation(o->getTranslation() + V3<S>(S(step(rng)), S(step(rng)), S(step(rng))));
    o->computeAABB();
  }
  m.update();
  for (std::size_t i = 0; i < w.objs.size(); i += 11) m.unregisterObject(w.objs[i]);
  ASSERT_TRUE(m.validate());
  std::vector<Obj<S>*> left;
  m.getObjects(left);
  checkCapsules(m, left, 60, 84);
  // Margins grow the boxes the search reads; FCL still decides on the geometry.
  m.setMargin(S(1.5));
  for (std::size_t i = 0; i < left.size(); i += 4) m.setMargin(left[i], S(4));
  ASSERT_TRUE(m.validate());
  checkCapsules(m, left, 60, 85);
}

// The filter's bits against the objects', in each layout of spatial::setBits, before and after
// the update that lets the cubes keep filter groups apart.
TYPED_TEST(CapsuleQuery, FilterBitsRuleOutObjectsAsBruteForce) {
  using S = TypeParam;
  World<S> w(300, 91);
  for (const int kinds : {4, 6, 0}) {
    cube::CubeCollisionManager<S> m;
    m.registerObjects(w.objs);
    spatial::setBits(m, w.objs, kinds, 92);
    for (const bool updated : {false, true}) {
      if (updated) m.update();
      std::size_t changed = 0;
      for (const cube::QueryFilter& f : spatial::queryFilters()) {
        const auto [found, near] = checkCapsules(m, w.objs, 20, 93 + kinds, f);
        changed += checkCapsules(m, w.objs, 20, 93 + kinds).first - found;
        (void)near;
      }
      EXPECT_GT(changed, 20u) << "kinds " << kinds << ": the filters should rule out objects";
    }
  }
}

// A segment of length 0 is a ball: against spheres, reported where the centres are within the
// sum of the radii (grazing cases left out: FCL's rounding may say either).
TYPED_TEST(CapsuleQuery, ZeroLengthSegmentIsABall) {
  using S = TypeParam;
  std::mt19937 rng(101);
  std::uniform_real_distribution<double> u(-30, 30), size(0.2, 3);
  std::vector<std::unique_ptr<Obj<S>>> own;
  cube::CubeCollisionManager<S> m;
  for (int i = 0; i < 300; ++i) {
    own.push_back(std::make_unique<Obj<S>>(std::make_shared<fcl::Sphere<S>>(S(size(rng)))));
    own.back()->setTranslation(V3<S>(S(u(rng)), S(u(rng)), S(u(rng))));
    own.back()->computeAABB();
    m.registerObject(own.back().get());
  }
  std::size_t met = 0;
  for (int q = 0; q < 100; ++q) {
    const V3<S> p(S(u(rng)), S(u(rng)), S(u(rng)));
    const S radius = S(size(rng) * 2);
    const auto got = cube::objectsInCapsule(m, p, p, radius);
    for (const auto& o : own) {
      const double gap =
          (o->getTranslation() - p).template cast<double>().norm() -
          double(static_cast<const fcl::Sphere<S>*>(o->collisionGeometry().get())->radius) -
          double(radius);
      if (std::abs(gap) < 1e-3) continue;
      const bool reported = std::count(got.begin(), got.end(), o.get()) > 0;
      EXPECT_EQ(reported, gap < 0) << "query " << q << " gap " << gap;
      met += gap < 0;
    }
  }
  EXPECT_GT(met, 20u);
}

TYPED_TEST(CapsuleQuery, EmptyManagerFindsNothing) {
  using S = TypeParam;
  cube::CubeCollisionManager<S> m;
  EXPECT_TRUE(cube::objectsInCapsule(m, V3<S>(0, 0, 0), V3<S>(1, 1, 1), S(5)).empty());
}

TYPED_TEST(CapsuleQuery, BadInputThrowsAndChangesNothing) {
  using S = TypeParam;
  World<S> w(100, 111);
  cube::CubeCollisionManager<S> m;
  m.registerObjects(w.objs);
  const S nan = std::numeric_limits<S>::quiet_NaN(), inf = std::numeric_limits<S>::infinity();
  const S big = std::numeric_limits<S>::max();
  const V3<S> ok(0, 0, 0), far(10, 10, 10);
  for (const V3<S>& bad : {V3<S>(nan, 0, 0), V3<S>(0, inf, 0), V3<S>(0, 0, -inf)}) {
    EXPECT_THROW(cube::objectsInCapsule(m, bad, far, S(1)), std::invalid_argument);
    EXPECT_THROW(cube::objectsInCapsule(m, ok, bad, S(1)), std::invalid_argument);
  }
  // to - from overflows; the extent |b - a| + 2 radius overflows.
  EXPECT_THROW(cube::objectsInCapsule(m, V3<S>(-big, 0, 0), V3<S>(big, 0, 0), S(1)),
               std::invalid_argument);
  const S root = std::sqrt(big);
  EXPECT_THROW(cube::objectsInCapsule(m, ok, ok, root), std::invalid_argument);
  EXPECT_THROW(cube::objectsInCapsule(m, V3<S>(0, 0, 0), V3<S>(2 * root, 0, 0), S(1)),
               std::invalid_argument);
  for (const S r : {S(-1), nan, inf, -inf})
    EXPECT_THROW(cube::objectsInCapsule(m, ok, far, r), std::invalid_argument);
  // With a filter too: the input is checked first.
  EXPECT_THROW(cube::objectsInCapsule(m, ok, far, nan, cube::QueryFilter{}), std::invalid_argument);
  EXPECT_TRUE(m.validate());
  EXPECT_EQ(m.size(), w.objs.size());
  // A query after the refused ones answers as before them.
  EXPECT_EQ(cube::objectsInCapsule(m, ok, far, S(3)), bruteCapsule(m, ok, far, S(3)));
}

}  // namespace
