#pragma once

// One-call helpers for the common queries. They work with any fcl::BroadPhaseCollisionManager
// (cube, FCL's own, or yours): they only call its public collide/distance with a callback. FCL's
// own managers need setup() after registration before these are called; ours does not.
// Compiled into the library for S = double and S = float. The narrow-phase helpers run FCL's
// narrow phase through the pipeline of narrow_phase.h: culled, cached if asked, on threads.

#include <fcl/broadphase/broadphase_collision_manager.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <utility>
#include <vector>

#include "cube_collision/narrow_phase.h"

namespace cube {

/// Every candidate pair of a self-collide of `manager` (pairs whose AABBs overlap, as the manager
/// decides), in the order the manager reported them. No narrow phase is run.
template <typename S>
std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>& manager);

/// Every candidate pair of manager.collide(obj): (managed object, obj) with our manager and FCL's
/// tree managers. Note that fcl::NaiveCollisionManager reports (obj, managed object) for every
/// managed object, overlapping or not.
template <typename S>
std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>& manager,
                                            fcl::CollisionObject<S>* obj);

/// Every candidate pair (object of manager, object of other) of manager.collide(&other).
template <typename S>
std::vector<ObjectPair<S>> overlappingPairs(const fcl::BroadPhaseCollisionManager<S>& manager,
                                            fcl::BroadPhaseCollisionManager<S>& other);

/// Runs fcl::collide (with `request`) on the candidate pairs of a self-collide and returns all
/// their contacts merged into one result: the contacts, in the order, that fcl::collide called
/// on each pair in the manager's order with one accumulating result gives (FCL's default
/// callback), whatever options.threads is. Stops once the result holds
/// request.num_max_contacts contacts (unless request.enable_cost): the default request answers
/// "does anything collide?"; raise num_max_contacts to collect every contact. Requests with
/// costs or a cached GJK guess run on this thread, without culling or cache. The cull reads the
/// per-object volumes of a CubeCollisionManager (Config::tight_volumes: built by the first such
/// query, as of its last update() from then on) and builds them from the objects otherwise. A
/// convex polytope against a plane, on which FCL 0.7's fcl::collide crashes (its GJK on a plane),
/// is answered from the polytope's vertices instead: they meet where vertices lie on both sides of
/// the plane or on it; one contact, normal the plane's, depth the lesser push to either side,
/// position the deepest vertex on that side moved half the depth towards the plane.
/// Where FCL 0.7's fcl::collide answers a pair wrongly, a cylinder against a plane (its yes/no
/// test projects the length lz where lz/2 belongs) or a cone against a halfspace (one whose apex
/// points into it is tested as if lying on its side), the library answers from the geometry
/// instead, with the contact FCL's correct tests would give.
template <typename S>
fcl::CollisionResult<S> collideAll(
    const fcl::BroadPhaseCollisionManager<S>& manager,
    const fcl::CollisionRequest<S>& request = fcl::CollisionRequest<S>(),
    const NarrowPhaseOptions<S>& options = {});

/// collideAll for manager.collide(obj): the contacts of obj with the managed objects.
template <typename S>
fcl::CollisionResult<S> collideAll(
    const fcl::BroadPhaseCollisionManager<S>& manager, fcl::CollisionObject<S>* obj,
    const fcl::CollisionRequest<S>& request = fcl::CollisionRequest<S>(),
    const NarrowPhaseOptions<S>& options = {});

/// collideAll for manager.collide(&other): the contacts between the two managers' objects.
template <typename S>
fcl::CollisionResult<S> collideAll(
    const fcl::BroadPhaseCollisionManager<S>& manager, fcl::BroadPhaseCollisionManager<S>& other,
    const fcl::CollisionRequest<S>& request = fcl::CollisionRequest<S>(),
    const NarrowPhaseOptions<S>& options = {});

/// manager.collide(cdata, callback) with the callback called on options.threads threads, for a
/// callback that is safe to call concurrently (on cdata too). Pairs are gathered in chunks from
/// the walk; once a call returns true no new call starts and the walk stops, but calls of the
/// same chunk already running finish. The order of the calls is not specified. An exception
/// from the callback is rethrown here; a null callback throws std::invalid_argument. On a
/// CubeCollisionManager, a mutation of it from the callback is refused with std::logic_error on
/// every thread, as from its own queries' callbacks.
/// `split_walk`: as NarrowPhaseOptions::split_walk.
template <typename S>
void collideConcurrently(const fcl::BroadPhaseCollisionManager<S>& manager, void* cdata,
                         fcl::CollisionCallBack<S> callback, int threads = 0,
                         bool split_walk = false);

/// The smallest distance between two managed objects, with the nearest points if `request` asks
/// for them (fcl::distance on the pairs the branch and bound visits). min_distance is the largest
/// value of S when the manager holds fewer than two objects; it is <= 0 for touching objects
/// (the search stops at the first such pair). Without a cache it runs on the calling thread
/// whatever options.threads says, as FCL's default callback does (one accumulating result, which
/// prunes mesh pairs' searches): a branch and bound is sequential, and pairs answered in batches
/// would each miss the bound the others set. With a cache each pair gets a fresh
/// fcl::distance, options.threads pairs at a time, on the threads when they hold meshes or
/// octrees. The minimum is the same for every thread count, and its nearest points are those of
/// the first pair in walk order that reaches it. A pair with a plane or a halfspace, on which FCL
/// 0.7's fcl::distance crashes (its GJK calls a support function libccd lacks for them), gets
/// its exact distance in closed form instead (fcl::Plane the two-sided plane n . x = d,
/// fcl::Halfspace the solid n . x <= d): the least gap along the normal between the plane and
/// the other object's convex parts (a primitive or convex polytope itself, by its exact extent
/// along the normal; a mesh's triangles; an octree's occupied cells), for a halfspace the
/// height of the object's lowest point above it, with the nearest points in the world frame; -1,
/// as FCL answers objects that meet, when they meet; two planes or halfspaces are apart only
/// when parallel (a geometry of a kind FCL does not ship, or an empty mesh or octree, gets the
/// AABBs' distance).
/// FCL's own managers crash on such a pair.
template <typename S>
fcl::DistanceResult<S> minimumDistance(
    const fcl::BroadPhaseCollisionManager<S>& manager,
    const fcl::DistanceRequest<S>& request = fcl::DistanceRequest<S>(),
    const NarrowPhaseOptions<S>& options = {});

/// minimumDistance between obj and the managed objects.
template <typename S>
fcl::DistanceResult<S> minimumDistance(
    const fcl::BroadPhaseCollisionManager<S>& manager, fcl::CollisionObject<S>* obj,
    const fcl::DistanceRequest<S>& request = fcl::DistanceRequest<S>(),
    const NarrowPhaseOptions<S>& options = {});

/// minimumDistance between the objects of manager and those of other.
template <typename S>
fcl::DistanceResult<S> minimumDistance(
    const fcl::BroadPhaseCollisionManager<S>& manager, fcl::BroadPhaseCollisionManager<S>& other,
    const fcl::DistanceRequest<S>& request = fcl::DistanceRequest<S>(),
    const NarrowPhaseOptions<S>& options = {});

}  // namespace cube
