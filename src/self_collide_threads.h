#pragma once

// The library's entry to a self-collide whose walk runs on several threads (issue 19): used by
// the narrow-phase helpers of queries.h when the manager is a CubeCollisionManager. Not public:
// users get it through collideAll and collideConcurrently.

#include "cube_collision/cube_collision_manager.h"

namespace cube {
namespace detail {

/// manager.collide(cdata, callback), with the walk of a large scene split over `threads` OpenMP
/// threads (Broadphase::collideSelfSplit): the callback sees the same pairs in the same order, on
/// this thread, under the same rules (Config::cull_pairs, mutations from the callback refused),
/// and may stop the query the same way. Throws std::invalid_argument for a null callback.
template <typename S>
void collideSelfOnThreads(const CubeCollisionManager<S>& manager, void* cdata,
                          fcl::CollisionCallBack<S> callback, int threads);

extern template void collideSelfOnThreads<double>(const CubeCollisionManager<double>&, void*,
                                                  fcl::CollisionCallBack<double>, int);
extern template void collideSelfOnThreads<float>(const CubeCollisionManager<float>&, void*,
                                                 fcl::CollisionCallBack<float>, int);

}  // namespace detail
}  // namespace cube
