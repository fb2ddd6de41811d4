#pragma once

// Exact conservative culling between the box test and FCL's narrow phase, on two FCL objects
// (separation, verdict: cull.cpp) or on their float records (separationOf, verdictOf: the bounds
// in record_bounds.h; the records are built in volume_build.cpp). The pair judge
// (pair_judge.h) is what the queries call. FCL gives a rotated
// object the box of its bounding sphere, so most pairs whose boxes overlap are apart (three in
// four in the benchmark's scenes). Tighter volumes, built from what FCL keeps per object (the
// geometry's local AABB and the object's transform), prove many of them apart for a few dozen
// flops instead of a narrow-phase call of microseconds.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>

#include "core/volume.h"
#include "pipeline/record_bounds.h"

namespace cube {
namespace detail {

/// What the tight volumes say about two objects: a lower bound on their distance (-infinity when
/// unknown: a plane, a halfspace, an octree, a non-finite extent or transform), and the margin
/// by which a bound must beat a narrow-phase answer to decide for it, max(2 tolerance, 1e-6 for
/// double or 1e-4 for float) x (1 + the largest coordinate or extent involved): FCL may answer
/// within its tolerance, and this bound's own arithmetic errs by a few ulps of the coordinates.
/// The bound is the largest of the bounding spheres' gap (exact for spheres), a sphere's gap to
/// the other's oriented box, and the separating-axis gaps of the two oriented boxes of the
/// geometries' local AABBs (exact along the axes for boxes). The spheres come from what FCL keeps
/// per geometry (aabb_center, aabb_radius, as computeLocalAABB() sets them) and the object's
/// transform; when their gap alone exceeds enough + margin, the boxes are not looked at, nor
/// when `enough` is finite and the boxes' bound could not exceed enough + margin (each box holds
/// the ball of its smallest half extent); the bound is then the spheres' gap.
template <typename S>
struct Separation {
  S lower_bound;
  S margin;
};
template <typename S>
Separation<S> separation(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                         S tolerance, S enough = std::numeric_limits<S>::infinity());

/// True only if objects a and b certainly do not touch, even within the narrow phase's
/// `tolerance` (fcl::CollisionRequest::gjk_tolerance): separation's bound beats its margin.
template <typename S>
bool surelyApart(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance);

/// What the tight volumes settle about a pair for a collision request.
enum class Verdict : unsigned char {
  kApart,     ///< surelyApart: FCL would report no contact
  kTouching,  ///< surelyTouching: FCL would report a contact
  kUnknown,   ///< FCL must decide
};

/// True only if objects a and b certainly overlap, by more than separation's margin (so by more
/// than FCL's `tolerance` with room for rounding): balls inscribed in the two shapes overlap by
/// that much. For spheres, boxes, capsules, cylinders, cones and ellipsoids whose geometries are
/// occupied (cost_density >= threshold_occupied: FCL ignores the others); false for every other
/// geometry (meshes, octrees, convex, triangles, planes, halfspaces) and for non-finite input.
/// For a request without enable_contact and with num_max_contacts > 0, such a pair gets from
/// FCL's shape collision exactly one contact, Contact(a's geometry, b's geometry, NONE, NONE),
/// when the result has room.
template <typename S>
bool surelyTouching(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                    S tolerance);

/// kApart if surelyApart, else kTouching if `prove` and surelyTouching, else kUnknown.
template <typename S>
Verdict verdict(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance,
                bool prove);

/// Whether a collision request's answer for a pair that surelyTouching proves is known without
/// FCL: no contact geometry, no costs, no GJK guess carried, and room for a contact.
template <typename S>
bool provable(const fcl::CollisionRequest<S>& request) {
  return !request.enable_contact && !request.enable_cost && !request.enable_cached_gjk_guess &&
         request.num_max_contacts > 0;
}

/// The margin of verdictOf per unit of scale, for FCL's `tolerance` in scalar type S: separation's
/// rate, max(2 tolerance, 1e-6 for double or 1e-4 for float), plus 32 float ulps for the float
/// records' own arithmetic.
template <typename S>
float volumeMarginRate(S tolerance) {
  const double floor = sizeof(S) >= 8 ? 1e-6 : 1e-4;
  return float(std::max(2.0 * double(tolerance), floor) + 32.0 * FLT_EPSILON);
}

/// separation() from two objects' records (buildVolume), for a distance request whose tolerance
/// gives `rate` (volumeMarginRate): a lower bound on the objects' distance (-infinity for a record
/// without volumes) and the margin it must beat a distance by, rate x (1 + the larger scale). As
/// there, with a finite `enough` the boxes are looked at only where they could lift the bound
/// past enough + margin.
struct VolumeGap {
  float lower_bound;
  float margin;
};
inline VolumeGap separationOf(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
                              const VolumeShape& hb, float rate, float enough) {
  if (!(sa.r >= 0.f) || !(sb.r >= 0.f)) return {-std::numeric_limits<float>::infinity(), 0.f};
  const float dx = sb.c[0] - sa.c[0], dy = sb.c[1] - sa.c[1], dz = sb.c[2] - sa.c[2];
  const float d = std::sqrt(dx * dx + dy * dy + dz * dz);
  const float margin = rate * (1.f + std::max(ha.scale, hb.scale));
  const float spheres = d - sa.r - sb.r;
  const float stop = enough + margin;
  const bool sphere_a = (ha.flags & kVolumeSphere) != 0, sphere_b = (hb.flags & kVolumeSphere) != 0;
  if ((sphere_a && sphere_b) || spheres > stop) return {spheres, margin};
  const float ia = sphere_a ? sa.r : std::min({ha.e[0], ha.e[1], ha.e[2]});
  const float ib = sphere_b ? sb.r : std::min({hb.e[0], hb.e[1], hb.e[2]});
  if (stop < std::numeric_limits<float>::infinity() && !(d - ia - ib > stop))
    return {spheres, margin};
  const float gap = sphere_a   ? volume_detail::pointBox(sa.c, sb, hb) - sa.r
                    : sphere_b ? volume_detail::pointBox(sb.c, sa, ha) - sb.r
                               : volume_detail::boxGap(sa, ha, sb, hb, stop);
  return {std::max(spheres, gap), margin};
}

/// verdict() from two objects' records (buildVolume), for a request whose tolerance gives
/// `rate` (volumeMarginRate): kApart when separationOf's bound (enough 0) beats its margin;
/// kTouching, with `prove`, when the inscribed balls overlap by more than rate x (1 + scale + both
/// inner radii); else kUnknown, and always kUnknown for a record without volumes. The first and
/// cheaper part of verdictOf: a stream with a cache looks the pair up before the rest.
inline Verdict looseVerdictOf(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
                              const VolumeShape& hb, float rate, bool prove) {
  const VolumeGap gap = separationOf(sa, ha, sb, hb, rate, 0.f);
  if (gap.lower_bound > gap.margin) return Verdict::kApart;
  if (!(sa.r >= 0.f) || !(sb.r >= 0.f)) return Verdict::kUnknown;  // no volumes: no proof
  if (prove && ha.inner_r > 0.f && hb.inner_r > 0.f) {
    float gap2 = 0.f;
    for (int k = 0; k < 3; ++k) {
      const float g =
          (sb.c[k] + hb.inner_z * hb.R[3 * k + 2]) - (sa.c[k] + ha.inner_z * ha.R[3 * k + 2]);
      gap2 += g * g;
    }
    const float scale = std::max(ha.scale, hb.scale);
    const float reach_in = ha.inner_r + hb.inner_r - rate * (1.f + scale + ha.inner_r + hb.inner_r);
    if (reach_in > 0.f && gap2 < reach_in * reach_in) return Verdict::kTouching;
  }
  return Verdict::kUnknown;
}

/// The rest of verdictOf, for a pair looseVerdictOf left kUnknown: kApart when, for a capsule,
/// cylinder or cone, the capsule about its axis (outerCapsule) is apart from the other's (a
/// sphere's, capsule's, cylinder's or cone's) or from the other's box by more than innerMargin;
/// kTouching, with `prove`, when the inner volumes meet by more than innerMargin
/// (innerVolumesMeet: spheres, boxes, capsules, cylinders); else kUnknown.
inline Verdict tightVerdictOf(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
                              const VolumeShape& hb, float rate, bool prove) {
  using namespace volume_detail;
  if (!(sa.r >= 0.f) || !(sb.r >= 0.f)) return Verdict::kUnknown;
  const bool round_a = (ha.flags & kRoundKinds) != 0, round_b = (hb.flags & kRoundKinds) != 0;
  const bool sphere_pair = (ha.flags & hb.flags & kVolumeSphere) != 0;  // looseVerdictOf's exact
  if (sphere_pair) return Verdict::kUnknown;
  const float m = innerMargin(sa, ha, sb, hb, rate);
  if (round_a && round_b) {
    if (capsuleGap(sa, ha, outerCapsule(sa, ha), sb, hb, outerCapsule(sb, hb)) > m)
      return Verdict::kApart;
  } else if (round_a || round_b) {
    // A capsule, cylinder or cone against another's box (a sphere's gap to it was exact).
    const bool a_round = round_a && (ha.flags & kVolumeSphere) == 0;
    const bool b_round = round_b && (hb.flags & kVolumeSphere) == 0;
    if ((a_round && capsuleBoxGap(sa, ha, outerCapsule(sa, ha), sb, hb) > m) ||
        (b_round && capsuleBoxGap(sb, hb, outerCapsule(sb, hb), sa, ha) > m))
      return Verdict::kApart;
  }
  if (prove && ha.inner_r > 0.f && hb.inner_r > 0.f && innerVolumesMeet(sa, ha, sb, hb, m))
    return Verdict::kTouching;
  return Verdict::kUnknown;
}

/// looseVerdictOf, then tightVerdictOf where it leaves kUnknown: what the records settle about a
/// pair. Symmetric in its two records. Inline: the streams call it for every candidate pair.
/// verdict() on two FCL objects tests what looseVerdictOf tests.
inline Verdict verdictOf(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
                         const VolumeShape& hb, float rate, bool prove) {
  const Verdict v = looseVerdictOf(sa, ha, sb, hb, rate, prove);
  return v != Verdict::kUnknown ? v : tightVerdictOf(sa, ha, sb, hb, rate, prove);
}

extern template bool surelyTouching<double>(const fcl::CollisionObject<double>&,
                                            const fcl::CollisionObject<double>&, double);
extern template bool surelyTouching<float>(const fcl::CollisionObject<float>&,
                                           const fcl::CollisionObject<float>&, float);
extern template Verdict verdict<double>(const fcl::CollisionObject<double>&,
                                        const fcl::CollisionObject<double>&, double, bool);
extern template Verdict verdict<float>(const fcl::CollisionObject<float>&,
                                       const fcl::CollisionObject<float>&, float, bool);
extern template Separation<double> separation<double>(const fcl::CollisionObject<double>&,
                                                      const fcl::CollisionObject<double>&, double,
                                                      double);
extern template Separation<float> separation<float>(const fcl::CollisionObject<float>&,
                                                    const fcl::CollisionObject<float>&, float,
                                                    float);
extern template bool surelyApart<double>(const fcl::CollisionObject<double>&,
                                         const fcl::CollisionObject<double>&, double);
extern template bool surelyApart<float>(const fcl::CollisionObject<float>&,
                                        const fcl::CollisionObject<float>&, float);

}  // namespace detail
}  // namespace cube
