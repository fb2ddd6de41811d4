// Segments that touch count as hits, exactly: crossings of planes along and across the axes, and
// the degenerate cases (on a face, along a side line, tangent, zero length, radius 0).

#include <gtest/gtest.h>

#include "support/spatial_brute.h"

namespace {

using namespace spatialbrute;

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

}  // namespace
