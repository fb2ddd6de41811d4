#pragma once

// FCL's narrow phase, instantiated in one file (src/pipeline/callbacks.cpp). FCL ships only its
// double instantiations prebuilt; the float ones are compiled where fcl::collide / fcl::distance
// are called, which takes minutes (over ten under the sanitizers, where that file is left out).
// Every other file of the library calls FCL's narrow phase through these.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <cstddef>

namespace cube {
namespace detail {

/// Whether FCL 0.7's fcl::distance leaves the object's pairs unanswered (planes, halfspaces:
/// no support function in its GJK; octrees): callers stand in the AABBs' distance.
template <typename S>
bool distanceUnanswered(const fcl::CollisionObject<S>& o) {
  const fcl::NODE_TYPE t = o.getNodeType();
  return t == fcl::GEOM_PLANE || t == fcl::GEOM_HALFSPACE || t == fcl::GEOM_OCTREE;
}

/// fcl::collide(a, b, request, result), except for a convex polytope against a plane, on which
/// FCL 0.7 crashes (its GJK on a plane): answered here from the polytope's vertices (they meet
/// where vertices lie on both sides of the plane or on it), with one contact as FCL gives a box
/// and a plane (the lesser push to either side as depth, the plane's normal).
template <typename S>
std::size_t fclCollide(const fcl::CollisionObject<S>* a, const fcl::CollisionObject<S>* b,
                       const fcl::CollisionRequest<S>& request, fcl::CollisionResult<S>& result);

/// Whether FCL 0.7's fcl::distance crashes on a pair with this object (a plane or a halfspace:
/// its GJK calls a support function libccd lacks for them, a null pointer).
template <typename S>
bool distanceCrashes(const fcl::CollisionObject<S>& o) {
  const fcl::NODE_TYPE t = o.getNodeType();
  return t == fcl::GEOM_PLANE || t == fcl::GEOM_HALFSPACE;
}

/// fcl::distance(a, b, request, result), except for a pair FCL 0.7 crashes on
/// (distanceCrashes): there the distance of the objects' AABBs, with the AABBs' nearest points,
/// into `result` as fcl::distance would put its answer (a lower bound of the true distance,
/// exact for an axis-aligned plane or halfspace against an object beside it).
template <typename S>
S fclDistance(const fcl::CollisionObject<S>* a, const fcl::CollisionObject<S>* b,
              const fcl::DistanceRequest<S>& request, fcl::DistanceResult<S>& result);

extern template std::size_t fclCollide<double>(const fcl::CollisionObject<double>*,
                                               const fcl::CollisionObject<double>*,
                                               const fcl::CollisionRequest<double>&,
                                               fcl::CollisionResult<double>&);
extern template std::size_t fclCollide<float>(const fcl::CollisionObject<float>*,
                                              const fcl::CollisionObject<float>*,
                                              const fcl::CollisionRequest<float>&,
                                              fcl::CollisionResult<float>&);
extern template double fclDistance<double>(const fcl::CollisionObject<double>*,
                                           const fcl::CollisionObject<double>*,
                                           const fcl::DistanceRequest<double>&,
                                           fcl::DistanceResult<double>&);
extern template float fclDistance<float>(const fcl::CollisionObject<float>*,
                                         const fcl::CollisionObject<float>*,
                                         const fcl::DistanceRequest<float>&,
                                         fcl::DistanceResult<float>&);

}  // namespace detail
}  // namespace cube
