#pragma once

// Contacts within a margin: the pairs of a cube manager's objects closer than the sum of their
// margins (CubeCollisionManager::setMargin), answered by FCL's narrow phase. What a motion planner
// asks for a contact distance or padding, without inflating AABBs by hand before every update().

#include <fcl/narrowphase/collision_object.h>

#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "cube_collision/narrow_phase.h"

namespace cube {

/// One pair of objects closer than their margins, or colliding.
template <typename S>
struct MarginContact {
  fcl::CollisionObject<S>* a = nullptr;  ///< in the callback's argument order
  fcl::CollisionObject<S>* b = nullptr;
  /// fcl::distance between them; 0 when fcl::collide reports contact (FCL 0.7's distance gives
  /// no depth). For a pair with a plane or halfspace, on which FCL 0.7's fcl::distance crashes,
  /// the exact distance in closed form, with its nearest points (as minimumDistance, queries.h).
  S distance = 0;
  bool colliding = false;  ///< fcl::collide reported contact
  /// Nearest points in world coordinates from fcl::distance (pairs apart).
  fcl::Vector3<S> nearest_points[2] = {fcl::Vector3<S>::Zero(), fcl::Vector3<S>::Zero()};
};

/// Every pair of managed objects (a self-collide of `manager`, filter bits and pair predicate
/// included) whose distance is at most margin(a) + margin(b), or that collide, in the order the
/// manager hands pairs over (canonical with Config::canonical_pairs), whatever `threads` is.
/// Each candidate pair is first tested on its tight volumes (the culling of callbacks.h, widened by
/// the margins): a pair proved farther apart than its margins gets no narrow-phase call. The
/// others get fcl::collide, then fcl::distance if apart (request: `distance_request`, whose
/// distance_tolerance also widens the test of the tight volumes). `threads` (0: the hardware's)
/// run the narrow phase, as forEachPair; `stats`, if given, adds the work done (a pair that
/// needs both fcl::collide and fcl::distance counts two narrow_calls).
template <typename S>
std::vector<MarginContact<S>> contactsWithinMargin(
    const CubeCollisionManager<S>& manager,
    const fcl::DistanceRequest<S>& distance_request = fcl::DistanceRequest<S>(true),
    int threads = 1, NarrowPhaseStats* stats = nullptr);

/// The same for obj against the managed objects (manager.collide(obj)): pairs (managed, obj),
/// obj's margin being its own if it is registered in `manager`, else the manager-wide one.
template <typename S>
std::vector<MarginContact<S>> contactsWithinMargin(
    const CubeCollisionManager<S>& manager, fcl::CollisionObject<S>* obj,
    const fcl::DistanceRequest<S>& distance_request = fcl::DistanceRequest<S>(true),
    int threads = 1, NarrowPhaseStats* stats = nullptr);

}  // namespace cube
