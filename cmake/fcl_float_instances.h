// Build-time helper for the tests (not installed, not part of the library).
//
// FCL 0.7 declares its double instantiations `extern template` and ships them in libfcl, but
// not the float ones: every translation unit that calls fcl::collide or fcl::distance on float
// objects, or uses a float broadphase manager, compiles FCL's whole narrow phase (every shape
// and BVH pair, GJK, EPA) again, which was most of the build time. The build force-includes this
// header into the tests (cmake/CubeBuildSpeed.cmake), so that they only declare the float
// instantiations. fcl::collide and fcl::distance are defined in the library, whose own narrow
// phase instantiates them (src/pipeline/callbacks.cpp); the float managers and CollisionObject
// in the static library cube_fcl_float, from a file that defines CUBE_FCL_FLOAT_INSTANTIATE
// before including this header.
#pragma once

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/distance.h>

#ifdef CUBE_FCL_FLOAT_INSTANTIATE
#define CUBE_FCL_FLOAT_EXTERN
#else
#define CUBE_FCL_FLOAT_EXTERN extern
#endif

namespace fcl {

// Defined in the library (src/pipeline/callbacks.cpp).
extern template std::size_t collide(const CollisionObject<float>* o1,
                                    const CollisionObject<float>* o2,
                                    const CollisionRequest<float>& request,
                                    CollisionResult<float>& result);
extern template std::size_t collide(const CollisionGeometry<float>* o1,
                                    const Transform3<float>& tf1,
                                    const CollisionGeometry<float>* o2,
                                    const Transform3<float>& tf2,
                                    const CollisionRequest<float>& request,
                                    CollisionResult<float>& result);
extern template float distance(const CollisionObject<float>* o1, const CollisionObject<float>* o2,
                               const DistanceRequest<float>& request,
                               DistanceResult<float>& result);
extern template float distance(const CollisionGeometry<float>* o1, const Transform3<float>& tf1,
                               const CollisionGeometry<float>* o2, const Transform3<float>& tf2,
                               const DistanceRequest<float>& request,
                               DistanceResult<float>& result);

// Defined in cube_fcl_float.
CUBE_FCL_FLOAT_EXTERN template class CollisionObject<float>;
CUBE_FCL_FLOAT_EXTERN template class NaiveCollisionManager<float>;
CUBE_FCL_FLOAT_EXTERN template class DynamicAABBTreeCollisionManager<float>;

}  // namespace fcl

#undef CUBE_FCL_FLOAT_EXTERN
