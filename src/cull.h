#pragma once

// Exact conservative culling between the box test and FCL's narrow phase. FCL gives a rotated
// object the box of its bounding sphere, so most pairs whose boxes overlap are apart (three in
// four in the benchmark's scenes). Tighter volumes, built from what FCL keeps per object (the
// geometry's local AABB and the object's transform), prove many of them apart for a few dozen
// flops instead of a narrow-phase call of microseconds.

#include <fcl/narrowphase/collision_object.h>

namespace cube {
namespace detail {

/// True only if objects a and b certainly do not touch, even within the narrow phase's
/// `tolerance` (fcl::CollisionRequest::gjk_tolerance): their tight volumes are apart by more
/// than a margin of max(2 tolerance, 1e-6 for double or 1e-4 for float) times (1 + the largest
/// coordinate or extent involved), which also covers this test's own rounding. The volumes: the
/// oriented box of the geometry's local AABB (exact for a box; a mesh's or a convex's box
/// otherwise) and the bounding sphere (exact for a sphere). False whenever the answer is not
/// certain: a plane, a halfspace, an octree, a non-finite extent or transform.
template <typename S>
bool surelyApart(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance);

extern template bool surelyApart<double>(const fcl::CollisionObject<double>&,
                                         const fcl::CollisionObject<double>&, double);
extern template bool surelyApart<float>(const fcl::CollisionObject<float>&,
                                        const fcl::CollisionObject<float>&, float);

}  // namespace detail
}  // namespace cube
