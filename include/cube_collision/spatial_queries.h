#pragma once

// Queries that FCL's managers do not have: the objects a segment (a ray of finite length) meets,
// first or all, and the objects in a region (a box, within a distance of a point, or touching a
// capsule). They walk the manager's cube hierarchy, so a query reads the few cubes near the
// segment or region instead of every object. Each may take filter bits (QueryFilter) that the
// objects' bits must let through. Compiled into the library for S = double and S = float. Const
// and safe from any number of threads at once, like the manager's other queries; they may be
// called from inside a manager callback.

#include <fcl/math/bv/AABB.h>
#include <fcl/narrowphase/collision_object.h>

#include <cstdint>
#include <optional>
#include <vector>

#include "cube_collision/cube_collision_manager.h"

namespace cube {

/// Filter bits of a ray or region query (as Box2D's b2QueryFilter): the query reports an object
/// only if its bits (CubeCollisionManager::setFilter; default category 1, mask all ones) and
/// these let the two pair by the rule pairs of objects follow: (object.category & mask) != 0 and
/// (category & object.mask) != 0. The pair predicate (setPairFilter) rules pairs of objects and
/// is not asked. A query given no filter (std::nullopt, the default) reports every object,
/// whatever its bits; QueryFilter{} is the default bits, which an object whose mask leaves out
/// category 1 rejects.
struct QueryFilter {
  std::uint64_t category = 1;
  std::uint64_t mask = ~std::uint64_t(0);
};

/// What decided a ray hit.
enum class HitKind {
  narrow_phase,  ///< the object's geometry: exact for spheres, boxes, capsules, cylinders,
                 ///< ellipsoids, planes and halfspaces; FCL's narrow phase, t within the
                 ///< tolerance, for the others (see raycastObject)
  box,           ///< the object's AABB: asked for (RayOptions::narrow_phase off) or no geometry
                 ///< FCL can test a segment against (octrees, triangles, custom, none)
};

/// One object a segment meets.
template <typename S>
struct RayHit {
  fcl::CollisionObject<S>* object = nullptr;
  /// Where along the segment, in [0, 1]: the point is from + t (to - from). 0 if `from` is
  /// already inside (a mesh is a surface: inside a closed mesh, t is where the segment leaves it).
  S t = 0;
  S distance = 0;         ///< t |to - from|
  fcl::Vector3<S> point;  ///< from + t (to - from)
  HitKind kind = HitKind::box;
};

/// How a ray query decides a hit.
template <typename S>
struct RayOptions {
  /// Test the geometry of the objects whose AABB the segment meets (see raycastObject); off: the
  /// AABB decides every hit and t is where the segment enters it.
  bool narrow_phase = true;
  /// For the geometries found by bisection (meshes, cones, convexes; see raycastObject): length
  /// along the segment within which t is found, the reported point lying at most this far beyond
  /// the first contact (or as close as S can say, for tiny values). The geometries solved exactly
  /// do not use it. >= 0.
  S tolerance = S(1e-6);
};

/// The first object the segment from `from` to `to` meets (the hit with the smallest t; equal t:
/// the earliest registered, i.e. first in getObjects()). Each object is tested exactly as
/// raycastObject() tests it, against the box the manager holds for it: its AABB as of the last
/// registration or update(), grown by its margin if margins are set (setMargin). The answer
/// equals the minimum of raycastObject() with that box over every registered object that
/// `filter` lets through (QueryFilter; none: every object). A segment of length 0 is the point
/// `from`. Throws std::invalid_argument if `from` or `to` is not finite (or their difference
/// overflows) or the tolerance is negative or NaN.
template <typename S>
std::optional<RayHit<S>> raycastFirst(const CubeCollisionManager<S>& manager,
                                      const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
                                      const RayOptions<S>& options = {},
                                      std::optional<QueryFilter> filter = std::nullopt);

/// Every object the segment meets, by t (equal t: registration order); equal to raycastObject()
/// on every registered object that `filter` lets through (none: every object), kept where it
/// hits. Same input checks as raycastFirst.
template <typename S>
std::vector<RayHit<S>> raycastAll(const CubeCollisionManager<S>& manager,
                                  const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
                                  const RayOptions<S>& options = {},
                                  std::optional<QueryFilter> filter = std::nullopt);

/// The per-object test behind raycastFirst and raycastAll, against `box` (the object's AABB as
/// the manager holds it; obj.getAABB() outside one).
///
/// Box test, in double: per axis with to_k != from_k, the segment's parameters inside the slab
/// lo_k <= x_k <= hi_k are the interval from (lo_k - from_k) * (1 / (to_k - from_k)) to the same
/// with hi_k (swapped if the factor is negative); an axis where the segment does not move (or
/// moves less than 1 / DBL_MAX) requires lo_k <= from_k <= hi_k. The box is met (closed:
/// touching counts) if the intersection of [0, 1] with every axis' interval is not empty: its
/// start (the largest of 0 and the entries) is the box's entry, its end (the smallest of 1 and
/// the exits) the box's exit. So a segment that ends before the box, or starts after it, misses
/// it. No hit if it is not met.
///
/// Narrow phase (options.narrow_phase, and a geometry FCL can test: meshes (BVHModel), box,
/// sphere, ellipsoid, capsule, cone, cylinder, convex, plane, halfspace): t is the first point of
/// the segment, up to the box's exit, in the object (closed: touching counts; 0 if `from` is
/// already inside a solid), raised to the box's entry if below it; no hit if there is none. t is
/// never below the box's entry nor above its exit. For the exact geometries, a first point up
/// to 1e-9 (in t) past the box's exit counts, at the exit: the box and the exact test compute a
/// crossing by different formulas, and a box of zero thickness (a plane with an axis-aligned
/// normal) puts the exact crossing a few ulps past it.
/// - Exact, in double, for spheres, boxes, capsules, cylinders, ellipsoids (all radii > 0),
///   planes and halfspaces whose sizes are finite and >= 0: the segment is taken into the
///   object's frame (FCL 0.7's: centred on the origin; box: `side` full lengths; capsule and
///   cylinder: axis z from -lz/2 to lz/2; ellipsoid: `radii` along x, y, z; plane: the surface
///   n.x = d; halfspace: the solid n.x <= d) and met with slabs and quadratics. Rounding aside,
///   this is the exact first contact; options.tolerance is not used.
/// - By bisection for the others (meshes, cones, convexes, and the primitives above with other
///   sizes): fcl::collide of the object with a capsule of radius 0 along the segment from `from`
///   to the point at t; as t grows the capsule only grows, so bisection between the box's entry
///   and exit finds the first contact to options.tolerance, as FCL's GJK sees contact.
/// Both give kind narrow_phase. Other geometries (octree, triangle, custom, none) get the box
/// hit, kind box. Same input checks as raycastFirst.
template <typename S>
std::optional<RayHit<S>> raycastObject(const fcl::CollisionObject<S>& obj, const fcl::AABB<S>& box,
                                       const fcl::Vector3<S>& from, const fcl::Vector3<S>& to,
                                       const RayOptions<S>& options = {});

/// Every registered object that `filter` lets through (QueryFilter; none: every object) and
/// whose AABB (the box the manager holds, as for raycastFirst) overlaps `box` (closed: touching
/// counts), in registration order. Infinite bounds are allowed (a half-open region). Throws
/// std::invalid_argument if a bound is NaN or box.min_ exceeds box.max_ on some axis.
template <typename S>
std::vector<fcl::CollisionObject<S>*> objectsInBox(
    const CubeCollisionManager<S>& manager, const fcl::AABB<S>& box,
    std::optional<QueryFilter> filter = std::nullopt);

/// Every registered object that `filter` lets through (QueryFilter; none: every object) and
/// whose AABB (the box the manager holds, as for raycastFirst) lies within `radius` of `point`
/// (closed), in registration order. The distance is the Euclidean one
/// from the point to the box (0 inside), tested in double as: every per-axis gap at most radius,
/// and the sum of the squared gaps at most radius squared (for radius above 1e150, of the squared
/// gaps divided by radius, at most 1). This is the box's distance, not the geometry's: a box
/// corner may be near where the object is not. radius may be infinite (every object). Throws
/// std::invalid_argument if `point` is not finite or radius is negative or NaN.
template <typename S>
std::vector<fcl::CollisionObject<S>*> objectsNear(const CubeCollisionManager<S>& manager,
                                                  const fcl::Vector3<S>& point, S radius,
                                                  std::optional<QueryFilter> filter = std::nullopt);

/// Every registered object that `filter` lets through (QueryFilter; none: every object) and that
/// the capsule of radius `radius` about the segment from `a` to `b` touches, in registration
/// order. The capsule is FCL's: fcl::Capsule<S>(radius, lz = (b - a).norm()), its axis (local z)
/// turned onto the segment by Eigen::Quaternion<S>::FromTwoVectors(UnitZ, b - a) (the identity
/// where lz is 0), centred at a + (b - a) / 2. A segment of length 0 is a ball of that radius about
/// `a`; radius 0 is the segment itself.
///
/// An object is reported if and only if FCL's narrow phase (fcl::collide with a default request,
/// the library's answers where FCL 0.7 is wrong, as the manager's collide pipeline) says the
/// capsule and the object, at its current transform, collide; touching counts as FCL counts it.
/// The boxes the manager holds (as for raycastFirst) only choose the objects put to FCL: those
/// whose box, widened per axis by radius plus a rounding allowance (1e-5 times radius + 1 + the
/// largest |coordinate| of a and b), the segment meets; an object whose box is current (update()
/// since it last moved) and farther from the segment than that cannot touch the capsule. Objects
/// without a geometry are never reported.
///
/// Throws std::invalid_argument (nothing read) if `a` or `b` is not finite, their difference
/// overflows, radius is negative, NaN or infinite, or the square of the capsule's extent
/// (|b - a| + 2 radius) overflows in S.
template <typename S>
std::vector<fcl::CollisionObject<S>*> objectsInCapsule(
    const CubeCollisionManager<S>& manager, const fcl::Vector3<S>& a, const fcl::Vector3<S>& b,
    S radius, std::optional<QueryFilter> filter = std::nullopt);

}  // namespace cube
