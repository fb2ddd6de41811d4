#pragma once

// The library's own ways into a CubeCollisionManager's collide walks, beside FCL's interface:
// walks that hand the pipeline (queries.h) each pair's object ids, so that it reads the object
// tables' per-id volumes, and a self-collide whose walk runs on several threads. Not
// public: users get them through collideAll and collideConcurrently.

#include "core/task_sink.h"
#include "core/traversal.h"
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

/// manager.collide(cdata, fn), manager.collide(obj, cdata, fn) and manager.collide(other,
/// cdata, fn) with a callback that may take ids (detail::CollideFn): the same checks, pairs,
/// order, query guard and errors, but never Config::cull_pairs (the caller culls). Ids are the
/// object tables' (the first of the manager, the second of `other` when that is a cube manager),
/// kNone for an object that is not registered (the query object; other's objects when `other`
/// is another kind of manager).
template <typename S>
void collideWithIds(const CubeCollisionManager<S>& manager, void* cdata, CollideFn<S> fn);
template <typename S>
void collideWithIds(const CubeCollisionManager<S>& manager, fcl::CollisionObject<S>* obj,
                    void* cdata, CollideFn<S> fn);
template <typename S>
void collideWithIds(const CubeCollisionManager<S>& manager,
                    fcl::BroadPhaseCollisionManager<S>* other, void* cdata, CollideFn<S> fn);
/// The same for manager.distance in its three forms.
template <typename S>
void distanceWithIds(const CubeCollisionManager<S>& manager, void* cdata, DistanceFn<S> fn);
template <typename S>
void distanceWithIds(const CubeCollisionManager<S>& manager, fcl::CollisionObject<S>* obj,
                     void* cdata, DistanceFn<S> fn);
template <typename S>
void distanceWithIds(const CubeCollisionManager<S>& manager,
                     fcl::BroadPhaseCollisionManager<S>* other, void* cdata, DistanceFn<S> fn);
/// A self-collide whose split walk hands each task's pairs to `sink` on the thread that walked
/// it (Broadphase::collideSelfTasks), under the query guard: false (nothing done) where the
/// core does not split it that way; true with nothing handed over for fewer than two objects.
template <typename S>
bool collideSelfInTasks(const CubeCollisionManager<S>& manager, TaskSink<S>& sink, int threads);
/// collideSelfOnThreads with such a callback, and without Config::cull_pairs.
template <typename S>
void collideSelfOnThreadsWithIds(const CubeCollisionManager<S>& manager, void* cdata,
                                 CollideFn<S> fn, int threads);

extern template void collideSelfOnThreads<double>(const CubeCollisionManager<double>&, void*,
                                                  fcl::CollisionCallBack<double>, int);
extern template void collideSelfOnThreads<float>(const CubeCollisionManager<float>&, void*,
                                                 fcl::CollisionCallBack<float>, int);

}  // namespace detail
}  // namespace cube
