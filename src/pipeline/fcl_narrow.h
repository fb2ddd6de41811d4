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

/// Whether FCL 0.7's fcl::collide answers pairs of these kinds wrongly: a cylinder and a plane
/// (its yes/no test, used without enable_contact, projects the cylinder's length lz where lz/2
/// belongs, so it reports contacts that are not there) and a cone and a halfspace (a cone whose
/// apex points into the halfspace is tested as if it lay on its side).
inline bool contactDefective(fcl::NODE_TYPE ta, fcl::NODE_TYPE tb) {
  const auto either = [&](fcl::NODE_TYPE x, fcl::NODE_TYPE y) {
    return (ta == x && tb == y) || (ta == y && tb == x);
  };
  return either(fcl::GEOM_CYLINDER, fcl::GEOM_PLANE) || either(fcl::GEOM_CONE, fcl::GEOM_HALFSPACE);
}

/// For a pair contactDefective lists, geometries ga and gb at poses tfa and tfb: what fclCollide
/// gives two objects so placed, the true answer from the geometry with contacts, costs and the
/// result's limits as FCL's shape collision treats them.
template <typename S>
std::size_t collideDefective(const fcl::CollisionGeometry<S>* ga, const fcl::Transform3<S>& tfa,
                             const fcl::CollisionGeometry<S>* gb, const fcl::Transform3<S>& tfb,
                             const fcl::CollisionRequest<S>& request,
                             fcl::CollisionResult<S>& result);

/// fcl::collide(a, b, request, result), except for pairs FCL 0.7 crashes on or answers wrongly:
/// a convex polytope against a plane, on which FCL crashes (its GJK on a plane), is answered
/// from the polytope's vertices (they meet where vertices lie on both sides of the plane or on
/// it), with one contact as FCL gives a box and a plane (the lesser push to either side as
/// depth, the plane's normal); a pair contactDefective lists is answered from the geometry
/// (collideDefective).
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
/// (distanceCrashes): there the exact distance in closed form (planes::planeDistance), into
/// `result` as fcl::distance would put its answer, -1 when the pair meets.
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
extern template std::size_t collideDefective<double>(const fcl::CollisionGeometry<double>*,
                                                     const fcl::Transform3<double>&,
                                                     const fcl::CollisionGeometry<double>*,
                                                     const fcl::Transform3<double>&,
                                                     const fcl::CollisionRequest<double>&,
                                                     fcl::CollisionResult<double>&);
extern template std::size_t collideDefective<float>(const fcl::CollisionGeometry<float>*,
                                                    const fcl::Transform3<float>&,
                                                    const fcl::CollisionGeometry<float>*,
                                                    const fcl::Transform3<float>&,
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
