#pragma once

// One-call helpers for the common queries. They work with any fcl::BroadPhaseCollisionManager
// (cube, FCL's own, or yours): they only call its public collide/distance with a callback. FCL's
// own managers need setup() after registration before these are called; ours does not.
// Compiled into the library for S = double and S = float.

#include <fcl/broadphase/broadphase_collision_manager.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <utility>
#include <vector>

namespace cube {

/// A pair of objects in the order the manager's callback received them.
template <typename S>
using ObjectPair = std::pair<fcl::CollisionObject<S>*, fcl::CollisionObject<S>*>;

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
/// their contacts merged into one result. Stops, as FCL's default callback does, once the result
/// holds request.num_max_contacts contacts (unless request.enable_cost): the default request
/// answers "does anything collide?"; raise num_max_contacts to collect every contact.
template <typename S>
fcl::CollisionResult<S> collideAll(
    const fcl::BroadPhaseCollisionManager<S>& manager,
    const fcl::CollisionRequest<S>& request = fcl::CollisionRequest<S>());

/// collideAll for manager.collide(obj): the contacts of obj with the managed objects.
template <typename S>
fcl::CollisionResult<S> collideAll(
    const fcl::BroadPhaseCollisionManager<S>& manager, fcl::CollisionObject<S>* obj,
    const fcl::CollisionRequest<S>& request = fcl::CollisionRequest<S>());

/// collideAll for manager.collide(&other): the contacts between the two managers' objects.
template <typename S>
fcl::CollisionResult<S> collideAll(
    const fcl::BroadPhaseCollisionManager<S>& manager, fcl::BroadPhaseCollisionManager<S>& other,
    const fcl::CollisionRequest<S>& request = fcl::CollisionRequest<S>());

/// The smallest distance between two managed objects, with the nearest points if `request` asks
/// for them (fcl::distance on the pairs the branch and bound visits). min_distance is the largest
/// value of S when the manager holds fewer than two objects; it is <= 0 for touching objects
/// (the search stops at the first such pair).
template <typename S>
fcl::DistanceResult<S> minimumDistance(
    const fcl::BroadPhaseCollisionManager<S>& manager,
    const fcl::DistanceRequest<S>& request = fcl::DistanceRequest<S>());

/// minimumDistance between obj and the managed objects.
template <typename S>
fcl::DistanceResult<S> minimumDistance(
    const fcl::BroadPhaseCollisionManager<S>& manager, fcl::CollisionObject<S>* obj,
    const fcl::DistanceRequest<S>& request = fcl::DistanceRequest<S>());

/// minimumDistance between the objects of manager and those of other.
template <typename S>
fcl::DistanceResult<S> minimumDistance(
    const fcl::BroadPhaseCollisionManager<S>& manager, fcl::BroadPhaseCollisionManager<S>& other,
    const fcl::DistanceRequest<S>& request = fcl::DistanceRequest<S>());

}  // namespace cube
