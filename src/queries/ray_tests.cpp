// The exact first hits of a segment on FCL's convex shapes (slabs, quadratics in the object's
// frame) and the narrow phase of hitOne (ray_tests.h): exact where it can, else the bisection.

#include "queries/ray_tests.h"

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace cube {
namespace detail {

namespace {

// The closed interval of t, on the whole line o + t d, where the line is inside a convex set;
// empty when lo > hi.
struct Span {
  double lo, hi;
};
constexpr Span kAll{-kInf, kInf};
constexpr Span kEmpty{kInf, -kInf};

Span meet(Span a, Span b) {
  return {a.lo > b.lo ? a.lo : b.lo, a.hi < b.hi ? a.hi : b.hi};
}

// Within r of the origin, over the first `dims` coordinates (3: a ball, 2: an infinite cylinder
// along z). Solved from the line's closest point to the centre rather than from |o|^2 - r^2, so
// that a distant origin loses no precision in the discriminant; a tangent line gives one point.
Span ball(const double* o, const double* d, double r, int dims) {
  double a = 0, b = 0, oo = 0;
  for (int k = 0; k < dims; ++k) {
    a += d[k] * d[k];
    b += o[k] * d[k];
    oo += o[k] * o[k];
  }
  if (a == 0) return oo <= r * r ? kAll : kEmpty;  // no motion in these coordinates
  const double mid = -b / a;                       // t of the closest point
  double q2 = 0;
  for (int k = 0; k < dims; ++k) {
    const double q = o[k] + mid * d[k];
    q2 += q * q;
  }
  const double gap = r * r - q2;
  if (!(gap >= 0)) return kEmpty;
  const double half = std::sqrt(gap / a);
  return {mid - half, mid + half};
}

// lo <= o + t d <= hi on one coordinate.
Span slab(double o, double d, double lo, double hi) {
  if (d == 0) return lo <= o && o <= hi ? kAll : kEmpty;
  double a = (lo - o) / d, b = (hi - o) / d;  // finite or infinite, never NaN: d != 0
  if (d < 0) std::swap(a, b);
  return {a, b};
}

// The first t in [0, 1] of a span, or kInf.
double firstIn(Span s) {
  s = meet(s, Span{0, 1});
  return s.lo <= s.hi ? s.lo : kInf;
}

}  // namespace

// The first t in [0, 1] at which the segment o + t d (in the geometry's frame) is in the closed
// solid, kInf if never; false if the geometry is not one solved here (or its sizes are not
// finite and >= 0), which leaves it to the bisection. FCL 0.7's frames: everything centred on the
// origin; box: `side` full lengths; capsule and cylinder: axis z, from -lz/2 to lz/2; ellipsoid:
// `radii` along x, y, z; plane n.x = d (a surface); halfspace n.x <= d (solid).
template <typename S>
bool exactFirst(const fcl::CollisionGeometry<S>& geo, const double* o, const double* d, double& t) {
  const auto ok = [](double v) { return v >= 0 && v < kInf; };
  switch (geo.getNodeType()) {
    case fcl::GEOM_SPHERE: {
      const double r = static_cast<const fcl::Sphere<S>&>(geo).radius;
      if (!ok(r)) return false;
      t = firstIn(ball(o, d, r, 3));
      return true;
    }
    case fcl::GEOM_ELLIPSOID: {
      // Scaled to the unit ball: t is unchanged by a linear map of the segment.
      const auto& radii = static_cast<const fcl::Ellipsoid<S>&>(geo).radii;
      double so[3], sd[3];
      for (int k = 0; k < 3; ++k) {
        const double r = radii[k];
        if (!(ok(r) && r > 0)) return false;
        so[k] = o[k] / r;
        sd[k] = d[k] / r;
      }
      t = firstIn(ball(so, sd, 1, 3));
      return true;
    }
    case fcl::GEOM_BOX: {
      const auto& side = static_cast<const fcl::Box<S>&>(geo).side;
      Span s = kAll;
      for (int k = 0; k < 3; ++k) {
        const double h = 0.5 * double(side[k]);
        if (!ok(h)) return false;
        s = meet(s, slab(o[k], d[k], -h, h));
      }
      t = firstIn(s);
      return true;
    }
    case fcl::GEOM_CYLINDER: {
      const auto& c = static_cast<const fcl::Cylinder<S>&>(geo);
      const double r = c.radius, h = 0.5 * double(c.lz);
      if (!ok(r) || !ok(h)) return false;
      t = firstIn(meet(ball(o, d, r, 2), slab(o[2], d[2], -h, h)));
      return true;
    }
    case fcl::GEOM_CAPSULE: {
      // A union of convex parts: the cylinder between the end centres and the two end balls;
      // the first t in the union is the first over the parts.
      const auto& c = static_cast<const fcl::Capsule<S>&>(geo);
      const double r = c.radius, h = 0.5 * double(c.lz);
      if (!ok(r) || !ok(h)) return false;
      t = firstIn(meet(ball(o, d, r, 2), slab(o[2], d[2], -h, h)));
      for (const double z : {-h, h}) {
        const double oz[3] = {o[0], o[1], o[2] - z};
        t = std::min(t, firstIn(ball(oz, d, r, 3)));
      }
      return true;
    }
    case fcl::GEOM_HALFSPACE:
    case fcl::GEOM_PLANE: {
      const bool solid = geo.getNodeType() == fcl::GEOM_HALFSPACE;
      const fcl::Vector3<S>& n = solid ? static_cast<const fcl::Halfspace<S>&>(geo).n
                                       : static_cast<const fcl::Plane<S>&>(geo).n;
      const double off = solid ? double(static_cast<const fcl::Halfspace<S>&>(geo).d)
                               : double(static_cast<const fcl::Plane<S>&>(geo).d);
      const double f0 = double(n[0]) * o[0] + double(n[1]) * o[1] + double(n[2]) * o[2] - off;
      const double slope = double(n[0]) * d[0] + double(n[1]) * d[1] + double(n[2]) * d[2];
      if (!std::isfinite(f0) || !std::isfinite(slope)) return false;
      t = kInf;
      if (f0 == 0 || (solid && f0 < 0)) {
        t = 0;
      } else if ((f0 > 0 && slope < 0) || (f0 < 0 && slope > 0)) {
        const double at = -f0 / slope;  // > 0; infinite if slope is tiny
        if (at <= 1) t = at;
      }
      return true;
    }
    default:
      return false;
  }
}

// How far past the box's exit (in t) an exact hit may fall and still count (hitOne's contract in
// spatial_queries.h): far above the few ulps by which the box's and the exact test's formulas
// differ, far below anything a caller could see as a distance.
constexpr double kExitRounding = 1e-9;

// The narrow phase of hitOne, given where the segment enters and leaves the object's box. Kept
// out of line: the box test it follows is the walk's inner loop, and stays small.
template <typename S>
[[gnu::noinline]] bool narrowHit(const fcl::CollisionObject<S>& obj, Narrow<S>& narrow,
                                 double enter, double exit, double bound, double& t) {
  double first;
  if (narrow.exact(obj, first)) {
    // The answer the bisection converges to: no hit unless the segment meets the object by the
    // box's exit, and never before the box's entry. The object lies in its box, so an exact hit
    // past the exit is rounding: the two compute the crossing of a box of zero thickness (an
    // axis-aligned plane's) by different formulas, a few ulps apart.
    if (first > exit + kExitRounding) return false;
    t = first > enter ? (first < exit ? first : exit) : enter;
    return true;
  }
  Caster<S>& caster = narrow.caster();
  if (!caster.reaches(obj, exit)) return false;
  double a = enter, b = exit;  // a: no contact yet (or enter), b: contact
  if (caster.reaches(obj, a)) b = a;
  while (b - a > narrow.tolT()) {
    if (a > bound) return false;
    const double mid = a + (b - a) * 0.5;
    if (!(mid > a && mid < b)) break;  // as close as double can say
    (caster.reaches(obj, mid) ? b : a) = mid;
  }
  t = b;
  return true;
}

template <typename S>
fcl::Matrix3<S> rotationFromZ(const fcl::Vector3<S>& v) {
  return Eigen::Quaternion<S>::FromTwoVectors(fcl::Vector3<S>::UnitZ(), v).toRotationMatrix();
}

template fcl::Matrix3<double> rotationFromZ<double>(const fcl::Vector3<double>&);
template fcl::Matrix3<float> rotationFromZ<float>(const fcl::Vector3<float>&);
template bool exactFirst<double>(const fcl::CollisionGeometry<double>&, const double*,
                                 const double*, double&);
template bool exactFirst<float>(const fcl::CollisionGeometry<float>&, const double*, const double*,
                                double&);
template bool narrowHit<double>(const fcl::CollisionObject<double>&, Narrow<double>&, double,
                                double, double, double&);
template bool narrowHit<float>(const fcl::CollisionObject<float>&, Narrow<float>&, double, double,
                               double, double&);

}  // namespace detail
}  // namespace cube
