// The narrow phase of ray queries (raycastObject): the entry t against the analytic intersections
// of a segment with a sphere and a rotated box, the exact per-primitive t against FCL's bisection
// on rotated primitives, and rays over scenes that mix exact and bisected hits against loops over
// every object.

#include <gtest/gtest.h>

#include "support/spatial_brute.h"

namespace {

using namespace spatialbrute;

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
