#include "cube_collision/callbacks.h"

#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "pipeline/collectors.h"
#include "pipeline/fcl_narrow.h"
#include "pipeline/pair_judge.h"
#include "pipeline/plane_geometry.h"

namespace cube {

template <typename S>
bool defaultCollisionCallback(fcl::CollisionObject<S>* o1, fcl::CollisionObject<S>* o2,
                              void* data) {
  auto& d = *static_cast<CollisionData<S>*>(data);
  if (d.done) return true;
  // The caller's result, kept as FCL's calls in turn keep it (AllContacts: full at the budget,
  // never with costs).
  detail::AllContacts<S> all(d.request, d.result);
  // A pair proved apart adds nothing to the result, so the narrow phase is skipped. Not with
  // costs: an octree's cost sources come from cells its box does not bound. A pair proved
  // touching, for a request without contact geometry, gets the one contact FCL would add.
  const detail::PairJudge<S> judge(S(d.request.gjk_tolerance), detail::provable(d.request),
                                   !d.request.enable_cost);
  switch (judge.collide(*o1, *o2)) {
    case detail::Answer::kApart:
      return false;
    case detail::Answer::kProved:
      all.addProved(ObjectPair<S>(o1, o2));
      break;
    default:
      ++d.narrow_calls;
      all.collide(ObjectPair<S>(o1, o2));
      break;
  }
  d.done = all.full();
  return d.done;
}

template <typename S>
bool defaultDistanceCallback(fcl::CollisionObject<S>* o1, fcl::CollisionObject<S>* o2, void* data,
                             S& dist) {
  auto& d = *static_cast<DistanceData<S>*>(data);
  detail::Closest<S> closest(d.result);
  if (!d.done) {
    // A pair that cannot beat the best distance so far would leave the result as it is.
    if (detail::PairJudge<S>(d.request).mayBeat(*o1, *o2, closest.bound())) {
      ++d.narrow_calls;
      closest.collide(o1, o2, d.request);
    }
  }
  dist = closest.bound();
  return d.done || closest.done();
}

namespace detail {

namespace {

// A convex polytope against a plane, which FCL 0.7's fcl::collide crashes on: they meet where
// the polytope's vertices are on both sides of the plane or on it. The contact, as FCL gives for
// a box and a plane: depth the lesser push to either side, normal the plane's (from a to b),
// position the deepest vertex on that side moved half the depth towards the plane.
template <typename S>
std::size_t convexPlane(const fcl::CollisionObject<S>* a, const fcl::CollisionObject<S>* b,
                        const fcl::CollisionRequest<S>& request, fcl::CollisionResult<S>& result) {
  const bool convex_first = a->getNodeType() == fcl::GEOM_CONVEX;
  const fcl::CollisionObject<S>* cv = convex_first ? a : b;
  const fcl::CollisionObject<S>* pl = convex_first ? b : a;
  const auto& convex = static_cast<const fcl::Convex<S>&>(*cv->collisionGeometry());
  const auto& plane = static_cast<const fcl::Plane<S>&>(*pl->collisionGeometry());
  // The plane in the convex's frame: n . x = d.
  const fcl::Transform3<S> rel = pl->getTransform().inverse() * cv->getTransform();
  S lo = std::numeric_limits<S>::infinity(), hi = -lo;
  fcl::Vector3<S> at_lo = fcl::Vector3<S>::Zero(), at_hi = at_lo;
  for (const fcl::Vector3<S>& v : convex.getVertices()) {
    const fcl::Vector3<S> w = rel * v;  // in the plane's frame
    const S s = plane.n.dot(w) - plane.d;
    if (s < lo) lo = s, at_lo = w;
    if (s > hi) hi = s, at_hi = w;
  }
  if (!(lo <= 0 && hi >= 0)) return 0;
  if (result.numContacts() >= request.num_max_contacts) return result.numContacts();
  fcl::Contact<S> c(a->collisionGeometry().get(), b->collisionGeometry().get(),
                    fcl::Contact<S>::NONE, fcl::Contact<S>::NONE);
  if (request.enable_contact) {
    // Push the convex up (its deepest vertex below the plane) or down, whichever is less.
    const bool up = -lo <= hi;
    const S depth = up ? -lo : hi;
    const fcl::Vector3<S> deepest = up ? at_lo : at_hi;
    const fcl::Vector3<S> n_world = pl->getTransform().linear() * plane.n;
    // The normal points from a to b: from the convex into the plane's side it leaves.
    const fcl::Vector3<S> from_convex = up ? -n_world : n_world;
    c.normal = convex_first ? from_convex : fcl::Vector3<S>(-from_convex);
    c.penetration_depth = depth;
    c.pos = pl->getTransform() * (deepest + (up ? S(0.5) : S(-0.5)) * depth * plane.n);
  }
  result.addContact(c);
  return result.numContacts();
}

}  // namespace

template <typename S>
std::size_t fclCollide(const fcl::CollisionObject<S>* a, const fcl::CollisionObject<S>* b,
                       const fcl::CollisionRequest<S>& request, fcl::CollisionResult<S>& result) {
  const fcl::NODE_TYPE ta = a->getNodeType(), tb = b->getNodeType();
  if ((ta == fcl::GEOM_CONVEX && tb == fcl::GEOM_PLANE) ||
      (ta == fcl::GEOM_PLANE && tb == fcl::GEOM_CONVEX))
    return convexPlane(a, b, request, result);
  if (contactDefective(ta, tb))
    return planes::defectiveCollide(a->collisionGeometry().get(), a->getTransform(),
                                    b->collisionGeometry().get(), b->getTransform(), request,
                                    result);
  return fcl::collide(a, b, request, result);
}

namespace {

// A coordinate of the nearest points of two AABBs that overlap on this axis: inside the overlap
// [lo, hi], finite where the overlap allows (an unbounded side of a plane's box).
template <typename S>
S inOverlap(S lo, S hi) {
  if (std::isfinite(lo) && std::isfinite(hi)) return lo + (hi - lo) / 2;
  if (std::isfinite(lo)) return lo;
  if (std::isfinite(hi)) return hi;
  return S(0);
}

}  // namespace

template <typename S>
S fclDistance(const fcl::CollisionObject<S>* a, const fcl::CollisionObject<S>* b,
              const fcl::DistanceRequest<S>& request, fcl::DistanceResult<S>& result) {
  if (!distanceCrashes(*a) && !distanceCrashes(*b)) return fcl::distance(a, b, request, result);
  // FCL 0.7's fcl::distance runs its GJK on a plane or a halfspace, which give libccd no support
  // function: a call through a null pointer. The distance in closed form instead.
  S d;
  if (planes::planeDistance(*a, *b, result, d)) return d;
  // A geometry of no kind FCL ships, or an empty one: the AABBs' distance, with their nearest
  // points (each coordinate inside the overlap where the boxes overlap on that axis).
  const fcl::AABB<S>& x = a->getAABB();
  const fcl::AABB<S>& y = b->getAABB();
  fcl::Vector3<S> p, q;
  for (int k = 0; k < 3; ++k) {
    const S lo = std::max(x.min_[k], y.min_[k]), hi = std::min(x.max_[k], y.max_[k]);
    if (lo <= hi) {
      p[k] = q[k] = inOverlap(lo, hi);
    } else if (x.max_[k] < y.min_[k]) {
      p[k] = x.max_[k];
      q[k] = y.min_[k];
    } else {
      p[k] = x.min_[k];
      q[k] = y.max_[k];
    }
  }
  d = (p - q).norm();
  result.update(d, a->collisionGeometry().get(), b->collisionGeometry().get(),
                fcl::DistanceResult<S>::NONE, fcl::DistanceResult<S>::NONE, p, q);
  return d;
}

template <typename S>
std::size_t collideDefective(const fcl::CollisionGeometry<S>* ga, const fcl::Transform3<S>& tfa,
                             const fcl::CollisionGeometry<S>* gb, const fcl::Transform3<S>& tfb,
                             const fcl::CollisionRequest<S>& request,
                             fcl::CollisionResult<S>& result) {
  return planes::defectiveCollide(ga, tfa, gb, tfb, request, result);
}

template std::size_t collideDefective<double>(const fcl::CollisionGeometry<double>*,
                                              const fcl::Transform3<double>&,
                                              const fcl::CollisionGeometry<double>*,
                                              const fcl::Transform3<double>&,
                                              const fcl::CollisionRequest<double>&,
                                              fcl::CollisionResult<double>&);
template std::size_t collideDefective<float>(const fcl::CollisionGeometry<float>*,
                                             const fcl::Transform3<float>&,
                                             const fcl::CollisionGeometry<float>*,
                                             const fcl::Transform3<float>&,
                                             const fcl::CollisionRequest<float>&,
                                             fcl::CollisionResult<float>&);
template std::size_t fclCollide<double>(const fcl::CollisionObject<double>*,
                                        const fcl::CollisionObject<double>*,
                                        const fcl::CollisionRequest<double>&,
                                        fcl::CollisionResult<double>&);
template std::size_t fclCollide<float>(const fcl::CollisionObject<float>*,
                                       const fcl::CollisionObject<float>*,
                                       const fcl::CollisionRequest<float>&,
                                       fcl::CollisionResult<float>&);
template double fclDistance<double>(const fcl::CollisionObject<double>*,
                                    const fcl::CollisionObject<double>*,
                                    const fcl::DistanceRequest<double>&,
                                    fcl::DistanceResult<double>&);
template float fclDistance<float>(const fcl::CollisionObject<float>*,
                                  const fcl::CollisionObject<float>*,
                                  const fcl::DistanceRequest<float>&, fcl::DistanceResult<float>&);

}  // namespace detail

template bool defaultCollisionCallback<double>(fcl::CollisionObject<double>*,
                                               fcl::CollisionObject<double>*, void*);
template bool defaultCollisionCallback<float>(fcl::CollisionObject<float>*,
                                              fcl::CollisionObject<float>*, void*);
template bool defaultDistanceCallback<double>(fcl::CollisionObject<double>*,
                                              fcl::CollisionObject<double>*, void*, double&);
template bool defaultDistanceCallback<float>(fcl::CollisionObject<float>*,
                                             fcl::CollisionObject<float>*, void*, float&);

}  // namespace cube

// FCL's float narrow phase (libfcl holds only the double one) is compiled here for the library;
// kept as out-of-line definitions, it also serves the tests' FCL oracles, which declare them
// extern (cmake/fcl_float_instances.h) instead of compiling FCL's float narrow phase again.
template std::size_t fcl::collide(const fcl::CollisionObject<float>*,
                                  const fcl::CollisionObject<float>*,
                                  const fcl::CollisionRequest<float>&,
                                  fcl::CollisionResult<float>&);
template std::size_t fcl::collide(const fcl::CollisionGeometry<float>*,
                                  const fcl::Transform3<float>&,
                                  const fcl::CollisionGeometry<float>*,
                                  const fcl::Transform3<float>&,
                                  const fcl::CollisionRequest<float>&,
                                  fcl::CollisionResult<float>&);
template float fcl::distance(const fcl::CollisionObject<float>*, const fcl::CollisionObject<float>*,
                             const fcl::DistanceRequest<float>&, fcl::DistanceResult<float>&);
template float fcl::distance(const fcl::CollisionGeometry<float>*, const fcl::Transform3<float>&,
                             const fcl::CollisionGeometry<float>*, const fcl::Transform3<float>&,
                             const fcl::DistanceRequest<float>&, fcl::DistanceResult<float>&);
