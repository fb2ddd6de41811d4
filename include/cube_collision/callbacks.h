#pragma once

// Default callbacks: FCL's narrow phase (libccd GJK) on every candidate pair that tighter
// volumes than the boxes cannot settle, stopping as FCL's own DefaultCollisionFunction /
// DefaultDistanceFunction do, with the same results (docs/pipeline.md).

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <cstddef>

namespace cube {

/// What defaultCollisionCallback reads and accumulates. The request defaults to FCL's (one
/// contact, libccd GJK); `done` becomes true once the request's contact count is reached.
template <typename S>
struct CollisionData {
  fcl::CollisionRequest<S> request;
  fcl::CollisionResult<S> result;
  bool done = false;
  /// fcl::collide calls made so far; pairs settled without it are not counted: proved apart by
  /// tight volumes, or (for a request without enable_contact, costs or a cached GJK guess)
  /// proved touching by volumes inside two primitive shapes, which get the one contact FCL
  /// would give them (narrow_phase.h, NarrowPhaseStats::proved).
  std::size_t narrow_calls = 0;
};

/// Runs fcl::collide on the pair and accumulates into CollisionData::result, with the result FCL
/// gives, unless tight volumes settle the pair first (CollisionData::narrow_calls says how).
/// Returns true (stop) once the result holds request.num_max_contacts contacts and costs are
/// not requested. A convex polytope against a plane (fcl::collide crashes on it in FCL 0.7) is
/// answered from the polytope's vertices, as collideAll (queries.h) says.
/// Where FCL 0.7's fcl::collide answers a pair wrongly, a cylinder against a plane (its yes/no
/// test projects the length lz where lz/2 belongs) or a cone against a halfspace (one whose apex
/// points into it is tested as if lying on its side), the library answers from the geometry
/// instead, with the contact FCL's correct tests would give.
template <typename S>
bool defaultCollisionCallback(fcl::CollisionObject<S>* o1, fcl::CollisionObject<S>* o2, void* data);

/// What defaultDistanceCallback reads and accumulates: the minimum distance over the pairs seen.
template <typename S>
struct DistanceData {
  fcl::DistanceRequest<S> request;
  fcl::DistanceResult<S> result;
  bool done = false;
  /// fcl::distance calls made so far; pairs whose lower bound ruled them out are not counted.
  std::size_t narrow_calls = 0;
};

/// Runs fcl::distance on the pair, accumulates the minimum into DistanceData::result and writes
/// it to `dist`. Returns true (stop) once the objects touch or penetrate (dist <= 0) or `done`.
/// A pair with a plane or a halfspace (fcl::distance crashes on it in FCL 0.7) gets its exact
/// distance and nearest points in closed form instead (-1 when they meet), as minimumDistance
/// (queries.h) says.
template <typename S>
bool defaultDistanceCallback(fcl::CollisionObject<S>* o1, fcl::CollisionObject<S>* o2, void* data,
                             S& dist);

extern template bool defaultCollisionCallback<double>(fcl::CollisionObject<double>*,
                                                      fcl::CollisionObject<double>*, void*);
extern template bool defaultCollisionCallback<float>(fcl::CollisionObject<float>*,
                                                     fcl::CollisionObject<float>*, void*);
extern template bool defaultDistanceCallback<double>(fcl::CollisionObject<double>*,
                                                     fcl::CollisionObject<double>*, void*, double&);
extern template bool defaultDistanceCallback<float>(fcl::CollisionObject<float>*,
                                                    fcl::CollisionObject<float>*, void*, float&);

}  // namespace cube
