#pragma once

// Exact conservative culling between the box test and FCL's narrow phase. FCL gives a rotated
// object the box of its bounding sphere, so most pairs whose boxes overlap are apart (three in
// four in the benchmark's scenes). Tighter volumes, built from what FCL keeps per object (the
// geometry's local AABB and the object's transform), prove many of them apart for a few dozen
// flops instead of a narrow-phase call of microseconds.

#include <fcl/narrowphase/collision_object.h>

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
