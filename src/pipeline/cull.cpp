// The cull on two FCL objects (cull.h: separation, surelyApart, surelyTouching, verdict): tight
// volumes built per pair from what FCL keeps per object, and the separating-axis tests on them.

#include "pipeline/cull.h"

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/cone.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/ellipsoid.h>
#include <fcl/geometry/shape/sphere.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>

namespace cube {
namespace detail {

namespace {

// An object's tight volumes in world coordinates: a sphere (centre c, radius r) and an oriented
// box about the same centre (axes the columns of R, half extents e). The sphere comes first and
// costs one matrix-vector product; the box only when the spheres do not settle the pair.
template <typename S>
struct Tight {
  const fcl::Transform3<S>* tf;
  const fcl::CollisionGeometry<S>* g;
  fcl::Vector3<S> c;
  S r;
  bool sphere;  // the geometry is a sphere: r is exact and the box adds nothing
  fcl::Matrix3<S> R;
  fcl::Vector3<S> e;

  // The box from the geometry's local AABB (its centre replaces c); false if not finite.
  // computeLocalAABB() sets aabb_center to that centre, so c usually stands as it is.
  bool withBox() {
    const fcl::AABB<S>& local = g->aabb_local;
    e = (local.max_ - local.min_) * S(0.5);
    R = tf->linear();
    const fcl::Vector3<S> mid = (local.max_ + local.min_) * S(0.5);
    if (mid != g->aabb_center) {
      c = R * mid + tf->translation();
      if (!c.allFinite()) return false;
    }
    return e.allFinite() && R.allFinite() && (e.array() >= S(0)).all();
  }
};

// The sphere of an object, from what FCL keeps per geometry (aabb_center, aabb_radius: the
// local AABB's circumscribed sphere); false if the object has none that is finite.
template <typename S>
bool tightOf(const fcl::CollisionObject<S>& o, Tight<S>& t) {
  const fcl::CollisionGeometry<S>* g = o.collisionGeometry().get();
  if (g == nullptr) return false;
  const fcl::NODE_TYPE type = g->getNodeType();
  switch (type) {
    case fcl::GEOM_PLANE:
    case fcl::GEOM_HALFSPACE:
    case fcl::GEOM_OCTREE:  // its cells, not its box, decide; and it may carry costs
      return false;
    default:
      break;
  }
  t.g = g;
  t.tf = &o.getTransform();
  t.sphere = type == fcl::GEOM_SPHERE;
  t.c = t.tf->linear() * g->aabb_center + t.tf->translation();
  t.r = t.sphere ? static_cast<const fcl::Sphere<S>*>(g)->radius : g->aabb_radius;
  return t.c.allFinite() && std::isfinite(t.r) && t.r >= S(0);
}

// Distance from point p to the box b (0 inside).
template <typename S>
S pointBoxDistance(const fcl::Vector3<S>& p, const Tight<S>& b) {
  const fcl::Vector3<S> q = b.R.transpose() * (p - b.c);
  const fcl::Vector3<S> out = (q.cwiseAbs() - b.e).cwiseMax(S(0));
  return out.norm();
}

// A lower bound on the distance between two oriented boxes: the separating-axis test of the
// records (volume_detail::axisGap) on the objects' own boxes, in S.
template <typename S>
S boxGap(const Tight<S>& a, const Tight<S>& b, S stop) {
  // b's axes (R) and centre (t) in a's frame, straight into axisGap's arrays.
  const fcl::Vector3<S> d = b.c - a.c;
  S R[3][3], t[3];
  for (int i = 0; i < 3; ++i) {
    t[i] = a.R(0, i) * d[0] + a.R(1, i) * d[1] + a.R(2, i) * d[2];
    for (int j = 0; j < 3; ++j)
      R[i][j] = a.R(0, i) * b.R(0, j) + a.R(1, i) * b.R(1, j) + a.R(2, i) * b.R(2, j);
  }
  return volume_detail::axisGap<S, false>(R, t, a.e.data(), b.e.data(), stop);
}

// A ball inside the geometry (centre c in world coordinates, radius r), for the shapes that
// have an obvious one; false for the others and for non-finite or non-positive sizes. FCL's
// primitives are centred on their frame's origin; a cone's base is at z = -lz/2 and its apex at
// +lz/2.
template <typename S>
bool inscribedBall(const fcl::CollisionObject<S>& o, fcl::Vector3<S>& c, S& r) {
  const fcl::CollisionGeometry<S>* g = o.collisionGeometry().get();
  if (g == nullptr || !g->isOccupied()) return false;
  const fcl::Transform3<S>& tf = o.getTransform();
  c = tf.translation();
  switch (g->getNodeType()) {
    case fcl::GEOM_SPHERE:
      r = static_cast<const fcl::Sphere<S>*>(g)->radius;
      break;
    case fcl::GEOM_BOX:
      r = S(0.5) * static_cast<const fcl::Box<S>*>(g)->side.minCoeff();
      break;
    case fcl::GEOM_CAPSULE: {
      const auto* cap = static_cast<const fcl::Capsule<S>*>(g);
      if (!(cap->lz >= S(0))) return false;
      r = cap->radius;
      break;
    }
    case fcl::GEOM_CYLINDER: {
      const auto* cyl = static_cast<const fcl::Cylinder<S>*>(g);
      r = std::min(cyl->radius, S(0.5) * cyl->lz);
      break;
    }
    case fcl::GEOM_ELLIPSOID:
      r = static_cast<const fcl::Ellipsoid<S>*>(g)->radii.minCoeff();
      break;
    case fcl::GEOM_CONE: {
      // The ball touching the base and the side: r = R h / (R + slant), centred r above the base.
      const auto* cone = static_cast<const fcl::Cone<S>*>(g);
      const S h = cone->lz, R = cone->radius;
      if (!(h > S(0) && R > S(0))) return false;
      r = R * h / (R + std::hypot(R, h));
      c = tf * fcl::Vector3<S>(0, 0, r - S(0.5) * h);
      break;
    }
    default:
      return false;
  }
  return c.allFinite() && std::isfinite(r) && r > S(0) && tf.linear().allFinite();
}

}  // namespace

template <typename S>
Separation<S> separation(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                         S tolerance, S enough) {
  Tight<S> ta, tb;
  if (!tightOf(a, ta) || !tightOf(b, tb)) return {-std::numeric_limits<S>::infinity(), S(0)};
  const S floor = sizeof(S) >= 8 ? S(1e-6) : S(1e-4);
  const S scale = std::max({ta.c.cwiseAbs().maxCoeff(), tb.c.cwiseAbs().maxCoeff(), ta.r, tb.r});
  const S margin = std::max(S(2) * tolerance, floor) * (S(1) + scale);
  // The spheres: the cheapest bound, and exact for spheres.
  const S centres = (ta.c - tb.c).norm();
  const S spheres = centres - ta.r - tb.r;
  if ((ta.sphere && tb.sphere) || spheres > enough + margin) return {spheres, margin};
  if (!ta.withBox() || !tb.withBox()) return {spheres, margin};
  // Each box holds the ball of its smallest half extent about its centre, so no gap of the
  // boxes exceeds the gap of those balls; when that cannot clear `enough`, the boxes' tests
  // could not settle the pair and are skipped (most pairs a distance search offers).
  const S inner =
      centres - (ta.sphere ? ta.r : ta.e.minCoeff()) - (tb.sphere ? tb.r : tb.e.minCoeff());
  if (enough < std::numeric_limits<S>::infinity() && !(inner > enough + margin))
    return {spheres, margin};
  if (ta.sphere) return {std::max(spheres, pointBoxDistance(ta.c, tb) - ta.r), margin};
  if (tb.sphere) return {std::max(spheres, pointBoxDistance(tb.c, ta) - tb.r), margin};
  return {std::max(spheres, boxGap(ta, tb, enough + margin)), margin};
}

template <typename S>
bool surelyApart(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance) {
  const Separation<S> s = separation(a, b, tolerance, S(0));
  return s.lower_bound > s.margin;
}

template <typename S>
bool surelyTouching(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                    S tolerance) {
  fcl::Vector3<S> ca, cb;
  S ra, rb;
  if (!inscribedBall(a, ca, ra) || !inscribedBall(b, cb, rb)) return false;
  // separation's margin, from the same scale: the balls' centres and radii bound it from below
  // (each ball lies in its object's bounding sphere), so the margin here is at least as large.
  const S floor = sizeof(S) >= 8 ? S(1e-6) : S(1e-4);
  const S scale =
      std::max({ca.cwiseAbs().maxCoeff(), cb.cwiseAbs().maxCoeff(),
                S(a.collisionGeometry()->aabb_radius), S(b.collisionGeometry()->aabb_radius)});
  const S margin = std::max(S(2) * tolerance, floor) * (S(1) + scale + ra + rb);
  return (ca - cb).norm() < ra + rb - margin;
}

template <typename S>
Verdict verdict(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance,
                bool prove) {
  if (surelyApart(a, b, tolerance)) return Verdict::kApart;
  if (prove && surelyTouching(a, b, tolerance)) return Verdict::kTouching;
  return Verdict::kUnknown;
}

template Separation<double> separation<double>(const fcl::CollisionObject<double>&,
                                               const fcl::CollisionObject<double>&, double, double);
template Separation<float> separation<float>(const fcl::CollisionObject<float>&,
                                             const fcl::CollisionObject<float>&, float, float);
template bool surelyApart<double>(const fcl::CollisionObject<double>&,
                                  const fcl::CollisionObject<double>&, double);
template bool surelyApart<float>(const fcl::CollisionObject<float>&,
                                 const fcl::CollisionObject<float>&, float);
template bool surelyTouching<double>(const fcl::CollisionObject<double>&,
                                     const fcl::CollisionObject<double>&, double);
template bool surelyTouching<float>(const fcl::CollisionObject<float>&,
                                    const fcl::CollisionObject<float>&, float);
template Verdict verdict<double>(const fcl::CollisionObject<double>&,
                                 const fcl::CollisionObject<double>&, double, bool);
template Verdict verdict<float>(const fcl::CollisionObject<float>&,
                                const fcl::CollisionObject<float>&, float, bool);

}  // namespace detail
}  // namespace cube
