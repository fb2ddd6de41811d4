#pragma once

// Exact conservative culling between the box test and FCL's narrow phase. FCL gives a rotated
// object the box of its bounding sphere, so most pairs whose boxes overlap are apart (three in
// four in the benchmark's scenes). Tighter volumes, built from what FCL keeps per object (the
// geometry's local AABB and the object's transform), prove many of them apart for a few dozen
// flops instead of a narrow-phase call of microseconds.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>

#include <limits>

namespace cube {
namespace detail {

/// What the tight volumes say about two objects: a lower bound on their distance (-infinity when
/// unknown: a plane, a halfspace, an octree, a non-finite extent or transform), and the margin
/// by which a bound must beat a narrow-phase answer to decide for it, max(2 tolerance, 1e-6 for
/// double or 1e-4 for float) x (1 + the largest coordinate or extent involved): FCL may answer
/// within its tolerance, and this bound's own arithmetic errs by a few ulps of the coordinates.
/// The bound is the largest of the bounding spheres' gap (exact for spheres), a sphere's gap to
/// the other's oriented box, and the separating-axis gaps of the two oriented boxes of the
/// geometries' local AABBs (exact along the axes for boxes). The spheres come from what FCL keeps
/// per geometry (aabb_center, aabb_radius, as computeLocalAABB() sets them) and the object's
/// transform; when their gap alone exceeds enough + margin, the boxes are not looked at, nor
/// when `enough` is finite and the boxes' bound could not exceed enough + margin (each box holds
/// the ball of its smallest half extent); the bound is then the spheres' gap.
template <typename S>
struct Separation {
  S lower_bound;
  S margin;
};
template <typename S>
Separation<S> separation(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                         S tolerance, S enough = std::numeric_limits<S>::infinity());

/// True only if objects a and b certainly do not touch, even within the narrow phase's
/// `tolerance` (fcl::CollisionRequest::gjk_tolerance): separation's bound beats its margin.
template <typename S>
bool surelyApart(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance);

/// What the tight volumes settle about a pair for a collision request.
enum class Verdict : unsigned char {
  kApart,     ///< surelyApart: FCL would report no contact
  kTouching,  ///< surelyTouching: FCL would report a contact
  kUnknown,   ///< FCL must decide
};

/// True only if objects a and b certainly overlap, by more than separation's margin (so by more
/// than FCL's `tolerance` with room for rounding): balls inscribed in the two shapes overlap by
/// that much. For spheres, boxes, capsules, cylinders, cones and ellipsoids whose geometries are
/// occupied (cost_density >= threshold_occupied: FCL ignores the others); false for every other
/// geometry (meshes, octrees, convex, triangles, planes, halfspaces) and for non-finite input.
/// For a request without enable_contact and with num_max_contacts > 0, such a pair gets from
/// FCL's shape collision exactly one contact, Contact(a's geometry, b's geometry, NONE, NONE),
/// when the result has room.
template <typename S>
bool surelyTouching(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                    S tolerance);

/// kApart if surelyApart, else kTouching if `prove` and surelyTouching, else kUnknown.
template <typename S>
Verdict verdict(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance,
                bool prove);

/// Whether a collision request's answer for a pair that surelyTouching proves is known without
/// FCL: no contact geometry, no costs, no GJK guess carried, and room for a contact.
template <typename S>
bool provable(const fcl::CollisionRequest<S>& request) {
  return !request.enable_contact && !request.enable_cost && !request.enable_cached_gjk_guess &&
         request.num_max_contacts > 0;
}

extern template bool surelyTouching<double>(const fcl::CollisionObject<double>&,
                                            const fcl::CollisionObject<double>&, double);
extern template bool surelyTouching<float>(const fcl::CollisionObject<float>&,
                                           const fcl::CollisionObject<float>&, float);
extern template Verdict verdict<double>(const fcl::CollisionObject<double>&,
                                        const fcl::CollisionObject<double>&, double, bool);
extern template Verdict verdict<float>(const fcl::CollisionObject<float>&,
                                       const fcl::CollisionObject<float>&, float, bool);
extern template Separation<double> separation<double>(const fcl::CollisionObject<double>&,
                                                      const fcl::CollisionObject<double>&, double,
                                                      double);
extern template Separation<float> separation<float>(const fcl::CollisionObject<float>&,
                                                    const fcl::CollisionObject<float>&, float,
                                                    float);
extern template bool surelyApart<double>(const fcl::CollisionObject<double>&,
                                         const fcl::CollisionObject<double>&, double);
extern template bool surelyApart<float>(const fcl::CollisionObject<float>&,
                                        const fcl::CollisionObject<float>&, float);

}  // namespace detail
}  // namespace cube
