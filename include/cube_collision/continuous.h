#pragma once

// Continuous collision over a CubeCollisionManager: which pairs can meet while some objects move
// from their current transform to another, and FCL's continuous collision on those pairs.
// fcl::continuousCollide checks one pair at a time and FCL has no broadphase for it (fcl#419):
// these functions bound each mover's whole motion by one box (its swept box) and ask the cube
// hierarchy which boxes meet.
//
// Motion models: the swept box must contain the object at every pose FCL's motion visits, so it
// follows FCL 0.7's own motion classes for fcl::CCDMotionType:
//  - CCDM_TRANS (fcl::TranslationMotion): the start rotation kept, the translation interpolated
//    linearly. The swept box is the start box and its translate: exact for the box.
//  - CCDM_SCREW (fcl::ScrewMotion): a rotation about an axis of at most pi with a translation
//    along it. The swept box bounds the object by a sphere around its box's centre and the
//    centre's helix by an arc bound; it is looser than TRANS's. FCL 0.7's screw without a turn
//    (under 1e-10 rad) moves by |d| d for a displacement d, not by d; the box follows FCL.
//  - CCDM_LINEAR and CCDM_SPLINE are refused (std::invalid_argument): FCL 0.7 builds
//    fcl::InterpMotion from two transforms without setting its reference point (left
//    uninitialized: fcl PR #662), and fcl::SplineMotion from two transforms is an empty TODO, so
//    the poses they visit are undefined and nothing can bound them.

#include <fcl/math/bv/AABB.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/continuous_collision_request.h>

#include <utility>
#include <vector>

#include "cube_collision/cube_collision_manager.h"

namespace cube {

/// One moving object: from its current transform (getTransform() at the call) to `end`.
/// Registered objects not listed in a motion list stay where they are.
template <typename S>
struct Motion {
  fcl::CollisionObject<S>* object = nullptr;
  fcl::Transform3<S> end = fcl::Transform3<S>::Identity();
};

/// A pair that FCL's continuous collision reports colliding: `a` registered before `b`, the time
/// of first contact in [0, 1] (as fcl::ContinuousCollisionResult::time_of_contact), and both
/// objects' transforms at that time (contact_tf1, contact_tf2).
struct ContinuousContact {
  fcl::CollisionObject<double>* a = nullptr;
  fcl::CollisionObject<double>* b = nullptr;
  double time_of_contact = 1;
  fcl::Transform3<double> tf_a = fcl::Transform3<double>::Identity();
  fcl::Transform3<double> tf_b = fcl::Transform3<double>::Identity();
};

/// A box holding `object` at every pose of FCL's motion of `motion_type` from its current
/// transform to `end`, built from the geometry's local AABB (not from getAABB()); padded by a
/// few units of rounding so that FCL's own evaluation of the motion stays inside. An infinite
/// local AABB (planes, halfspaces) gives the whole space. Throws std::invalid_argument for
/// CCDM_LINEAR, CCDM_SPLINE or an unknown type, a null geometry, or a transform with a NaN or
/// infinite entry.
template <typename S>
fcl::AABB<S> sweptBox(const fcl::CollisionObject<S>& object, const fcl::Transform3<S>& end,
                      fcl::CCDMotionType motion_type = fcl::CCDM_TRANS);

/// Every unordered pair of registered objects, at least one of them listed in `motions`, whose
/// boxes overlap (touching counts): a mover's box is its sweptBox, a still object's is the AABB
/// the manager holds (keep it current with update(), as for any query). Pairs of two still
/// objects are not continuous questions and are never listed: ask manager.collide for them.
/// Each pair once, the earlier registered object first, sorted by registration order.
/// Throws std::invalid_argument, before any work, for a null or unregistered object, an object
/// listed twice, a NaN or infinite transform (start or end), or a motion type sweptBox refuses.
/// Const and thread-safe like the manager's queries; the manager is not changed. The manager's
/// filter bits, pair predicate and margins apply as in its queries; a mutation of the manager
/// from the pair predicate is refused with std::logic_error, as from its queries' callbacks.
template <typename S>
std::vector<std::pair<fcl::CollisionObject<S>*, fcl::CollisionObject<S>*>> sweptPairs(
    const CubeCollisionManager<S>& manager, const std::vector<Motion<S>>& motions,
    fcl::CCDMotionType motion_type = fcl::CCDM_TRANS);

/// fcl::continuousCollide(a, end_a, b, end_b, request) on every pair sweptPairs lists (a still
/// object's end is its current transform) and the pairs it reports colliding, sorted by time of
/// contact, ties in the order of sweptPairs. The answer equals fcl::continuousCollide over every
/// pair with a mover that passes the manager's filter bits and pair predicate (with margins,
/// boxes grown by them as in sweptPairs: a margin lists more pairs, never changes FCL's answer
/// for one): a pair left out cannot collide at any pose FCL visits. Where FCL 0.7's fcl::collide
/// answers a pair wrongly, a cylinder against a plane (its yes/no test projects the length lz
/// where lz/2 belongs) or a cone against a halfspace (one whose apex points into it is tested as
/// if lying on its side), the library answers from the geometry instead: such a pair is sampled
/// at FCL's times (t = i / (n - 1)) with the true contact test. With `earliest_only`, only the
/// first contact (or none). Double only: FCL 0.7's float continuousCollide does not compile (its
/// float motion classes are abstract). Accepts what FCL's continuous collision answers by
/// intersections: request.ccd_solver_type CCDC_NAIVE (FCL's default; fcl::collide at evenly spaced
/// times), with motion types TRANS and SCREW. Throws std::invalid_argument, before any work, for
/// another solver type (conservative advancement reports contact within a tolerance, not an
/// intersection; ray shooting and the polynomial solver answer nothing for most geometry), for a
/// request that samples fewer than two times (FCL would divide by zero: min(num_max_iterations,
/// ceil(1 / toc_err)) < 2, or a toc_err that is not a positive number), and for what sweptPairs
/// refuses.
std::vector<ContinuousContact> continuousCollideAll(
    const CubeCollisionManager<double>& manager, const std::vector<Motion<double>>& motions,
    const fcl::ContinuousCollisionRequest<double>& request =
        fcl::ContinuousCollisionRequest<double>(),
    bool earliest_only = false);

}  // namespace cube
