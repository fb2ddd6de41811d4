// Build-time helper for the tests, examples and benchmark (not installed, not part of the library).
//
// FCL 0.7 declares its double instantiations `extern template` and ships them in libfcl, but
// not the float ones: every translation unit that calls fcl::collide or fcl::distance on float
// objects, or uses a float broadphase manager, compiles FCL's whole narrow phase (every shape
// and BVH pair, GJK, EPA) again, which was most of the build time. The build force-includes this
// header (-include) into those targets, so that they only declare the float instantiations, and
// compiles them once into the static library cube_fcl_float, from a file that defines
// CUBE_FCL_FLOAT_INSTANTIATE before including this header (cmake/CubeBuildSpeed.cmake).
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

CUBE_FCL_FLOAT_EXTERN template std::size_t collide(const CollisionObject<float>* o1,
                                                   const CollisionObject<float>* o2,
                                                   const CollisionRequest<float>& request,
                                                   CollisionResult<float>& result);
CUBE_FCL_FLOAT_EXTERN template std::size_t collide(const CollisionGeometry<float>* o1,
                                                   const Transform3<float>& tf1,
                                                   const CollisionGeometry<float>* o2,
                                                   const Transform3<float>& tf2,
                                                   const CollisionRequest<float>& request,
                                                   CollisionResult<float>& result);
CUBE_FCL_FLOAT_EXTERN template float distance(const CollisionObject<float>* o1,
                                              const CollisionObject<float>* o2,
                                              const DistanceRequest<float>& request,
                                              DistanceResult<float>& result);
CUBE_FCL_FLOAT_EXTERN template float distance(const CollisionGeometry<float>* o1,
                                              const Transform3<float>& tf1,
                                              const CollisionGeometry<float>* o2,
                                              const Transform3<float>& tf2,
                                              const DistanceRequest<float>& request,
                                              DistanceResult<float>& result);

CUBE_FCL_FLOAT_EXTERN template class CollisionObject<float>;
CUBE_FCL_FLOAT_EXTERN template class NaiveCollisionManager<float>;
CUBE_FCL_FLOAT_EXTERN template class DynamicAABBTreeCollisionManager<float>;

}  // namespace fcl

#undef CUBE_FCL_FLOAT_EXTERN
