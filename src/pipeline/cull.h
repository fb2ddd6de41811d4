#pragma once

// Exact conservative culling between the box test and FCL's narrow phase: one engine, on two
// objects' float records (separationOf, verdictOf: the bounds in record_bounds.h; the records are
// built in volume_build.cpp), the object tables' or, for objects of no table, built on the fly
// (verdictOnTheFly, separationOnTheFly: cull.cpp). The pair judge (pair_judge.h) is what the
// queries call. FCL gives a rotated object the box of its bounding sphere, so most pairs whose
// boxes overlap are apart (three in four in the benchmark's scenes). Tighter volumes, built from
// what FCL keeps per object (the geometry's local AABB and the object's transform), prove many
// of them apart for a few dozen flops instead of a narrow-phase call of microseconds.

#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/collision_request.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/volume.h"
#include "pipeline/record_bounds.h"

namespace cube {
namespace detail {

/// What the records settle about a pair.
enum class Verdict : unsigned char {
  kApart,     ///< FCL would report no contact
  kTouching,  ///< FCL would report a contact
  kUnknown,   ///< FCL must decide
};

/// Whether a collision request's answer for a pair that the records prove touching is known
/// without FCL: no contact geometry, no costs, no GJK guess carried, and room for a contact.
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
/// The spheres' part of separationOf, all that a sphere-level record (VolumeBall) allows: the
/// distance of the centres, the spheres' gap, and the margin for the larger scale.
struct SphereGap {
  float centres;
  float gap;
  float margin;
};
inline SphereGap sphereGap(const VolumeSphere& sa, float scale_a, const VolumeSphere& sb,
                           float scale_b, float rate) {
  const float dx = sb.c[0] - sa.c[0], dy = sb.c[1] - sa.c[1], dz = sb.c[2] - sa.c[2];
  const float d = std::sqrt(dx * dx + dy * dy + dz * dz);
  return {d, d - sa.r - sb.r, rate * (1.f + std::max(scale_a, scale_b))};
}

inline VolumeGap separationOf(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
                              const VolumeShape& hb, float rate, float enough);

/// separationOf past its spheres, `s` being sphereGap of the two records (both with volumes):
/// what a caller that tested the spheres already calls. Always inlined: separationOf is then the
/// one body the table's streams inline as a whole.
[[gnu::always_inline]] inline VolumeGap separationPastSpheres(const SphereGap& s,
                                                              const VolumeSphere& sa,
                                                              const VolumeShape& ha,
                                                              const VolumeSphere& sb,
                                                              const VolumeShape& hb, float enough) {
  const float d = s.centres, margin = s.margin, spheres = s.gap;
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

inline VolumeGap separationOf(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
                              const VolumeShape& hb, float rate, float enough) {
  if (!(sa.r >= 0.f) || !(sb.r >= 0.f)) return {-std::numeric_limits<float>::infinity(), 0.f};
  return separationPastSpheres(sphereGap(sa, ha.scale, sb, hb.scale, rate), sa, ha, sb, hb, enough);
}

/// Whether the records' inscribed balls (inner_r > 0 on both) overlap by more than rate x (1 +
/// scale + both inner radii): looseVerdictOf's proof of contact. Always inlined, as
/// separationPastSpheres.
[[gnu::always_inline]] inline bool innerBallsMeet(const VolumeSphere& sa, const VolumeShape& ha,
                                                  const VolumeSphere& sb, const VolumeShape& hb,
                                                  float rate) {
  float gap2 = 0.f;
  for (int k = 0; k < 3; ++k) {
    const float g =
        (sb.c[k] + hb.inner_z * hb.R[3 * k + 2]) - (sa.c[k] + ha.inner_z * ha.R[3 * k + 2]);
    gap2 += g * g;
  }
  const float scale = std::max(ha.scale, hb.scale);
  const float reach_in = ha.inner_r + hb.inner_r - rate * (1.f + scale + ha.inner_r + hb.inner_r);
  return reach_in > 0.f && gap2 < reach_in * reach_in;
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
  if (prove && ha.inner_r > 0.f && hb.inner_r > 0.f && innerBallsMeet(sa, ha, sb, hb, rate))
    return Verdict::kTouching;
  return Verdict::kUnknown;
}

/// The rest of verdictOf, for a pair looseVerdictOf left kUnknown: kApart when, for a capsule,
/// cylinder or cone, the capsule about its axis (outerCapsule) is apart from the other's (a
/// sphere's, capsule's, cylinder's or cone's) or from the other's box by more than innerMargin
/// plus `beyond` (>= 0: a margin the pair must be farther apart than, already rounded up);
/// kTouching, with `prove`, when the inner volumes meet by more than innerMargin
/// (innerVolumesMeet: spheres, boxes, capsules, cylinders); else kUnknown.
inline Verdict tightVerdictOf(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
                              const VolumeShape& hb, float rate, bool prove, float beyond = 0.f) {
  using namespace volume_detail;
  if (!(sa.r >= 0.f) || !(sb.r >= 0.f)) return Verdict::kUnknown;
  const bool round_a = (ha.flags & kRoundKinds) != 0, round_b = (hb.flags & kRoundKinds) != 0;
  const bool sphere_pair = (ha.flags & hb.flags & kVolumeSphere) != 0;  // looseVerdictOf's exact
  if (sphere_pair) return Verdict::kUnknown;
  const float m = innerMargin(sa, ha, sb, hb, rate);
  const float apart = m + beyond;
  if (round_a && round_b) {
    if (capsuleGap(sa, ha, outerCapsule(sa, ha), sb, hb, outerCapsule(sb, hb)) > apart)
      return Verdict::kApart;
  } else if (round_a || round_b) {
    // A capsule, cylinder or cone against another's box (a sphere's gap to it was exact).
    const bool a_round = round_a && (ha.flags & kVolumeSphere) == 0;
    const bool b_round = round_b && (hb.flags & kVolumeSphere) == 0;
    if ((a_round && capsuleBoxGap(sa, ha, outerCapsule(sa, ha), sb, hb) > apart) ||
        (b_round && capsuleBoxGap(sb, hb, outerCapsule(sb, hb), sa, ha) > apart))
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

/// looseVerdictOf for two objects of no table (no records kept: another kind of manager, pair
/// lists, FCL's callbacks), on records built on the fly level by level (core/volume.h), each
/// only where the last leaves the pair open: the spheres (buildBall: what FCL keeps per geometry,
/// placed), then the boxes (buildBox), then, with `prove`, the balls inside (buildInner). The
/// round and inner bounds of tightVerdictOf are left to FCL: an FCL call follows for most pairs
/// they would decide, and the full records cost more than the objects' boxes. kUnknown for an
/// object without volumes (buildVolume's). What it proves, the records prove.
template <typename S>
Verdict verdictOnTheFly(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                        float rate, bool prove);

/// One object's records built on the fly and kept, each level built the first time a verdict
/// reads it (the sphere at start(), the box and the ball inside on demand): a query that meets an
/// object in several pairs builds them once (PairVolumes' memo). Valid while the object stays as
/// it was at start().
template <typename S>
struct FlyVolumes {
  VolumeBall<S> ball;
  VolumeShape shape;
  std::int8_t box;    // -1: not built yet; else buildBox's answer
  std::int8_t inner;  // the same for buildInner (after the box)
  void start(const fcl::CollisionObject<S>& o) {
    buildBall(o, ball);
    box = inner = -1;
  }
  bool hasBox() {
    if (box < 0) box = buildBox(ball, shape) ? 1 : 0;
    return box != 0;
  }
  bool hasInner() {
    if (inner < 0) inner = buildInner(ball, shape) ? 1 : 0;
    return inner != 0;
  }
};

/// verdictOnTheFly on two objects' kept levels (a and b distinct), building what it reads.
template <typename S>
Verdict verdictOnTheFly(FlyVolumes<S>& a, FlyVolumes<S>& b, float rate, bool prove);

/// separationOf for two objects of no table, on records built as verdictOnTheFly builds them:
/// the spheres' gap where it exceeds enough + margin or both objects are spheres, else
/// separationOf on the spheres and boxes (all it reads).
template <typename S>
VolumeGap separationOnTheFly(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                             float rate, float enough);

/// separationOnTheFly on two objects' kept levels (a and b distinct), building what it reads.
template <typename S>
VolumeGap separationOnTheFly(FlyVolumes<S>& a, FlyVolumes<S>& b, float rate, float enough);

/// separationOnTheFly for FCL's `tolerance` (volumeMarginRate), in S: a lower bound on the
/// objects' distance (-infinity when unknown) and the margin it must beat a distance by.
template <typename S>
struct Separation {
  S lower_bound;
  S margin;
};
template <typename S>
Separation<S> separation(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                         S tolerance, S enough = std::numeric_limits<S>::infinity()) {
  const float e = enough >= S(FLT_MAX) ? std::numeric_limits<float>::infinity() : float(enough);
  const VolumeGap g = separationOnTheFly(a, b, volumeMarginRate(tolerance), e);
  return {S(g.lower_bound), S(g.margin)};
}

/// verdictOnTheFly for FCL's `tolerance`.
template <typename S>
Verdict verdict(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance,
                bool prove) {
  return verdictOnTheFly(a, b, volumeMarginRate(tolerance), prove);
}

/// True only if objects a and b certainly do not touch, even within FCL's `tolerance`.
template <typename S>
bool surelyApart(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b, S tolerance) {
  return verdict(a, b, tolerance, false) == Verdict::kApart;
}

/// True only if objects a and b certainly overlap by more than the records' margin: volumes
/// inside two occupied primitives (spheres, boxes, capsules, cylinders, cones, ellipsoids) meet.
/// For a request that is provable(), such a pair gets from FCL exactly one contact,
/// Contact(a's geometry, b's geometry, NONE, NONE), when the result has room.
template <typename S>
bool surelyTouching(const fcl::CollisionObject<S>& a, const fcl::CollisionObject<S>& b,
                    S tolerance) {
  return verdict(a, b, tolerance, true) == Verdict::kTouching;
}

extern template Verdict verdictOnTheFly<double>(const fcl::CollisionObject<double>&,
                                                const fcl::CollisionObject<double>&, float, bool);
extern template Verdict verdictOnTheFly<float>(const fcl::CollisionObject<float>&,
                                               const fcl::CollisionObject<float>&, float, bool);
extern template Verdict verdictOnTheFly<double>(FlyVolumes<double>&, FlyVolumes<double>&, float,
                                                bool);
extern template Verdict verdictOnTheFly<float>(FlyVolumes<float>&, FlyVolumes<float>&, float, bool);
extern template VolumeGap separationOnTheFly<double>(FlyVolumes<double>&, FlyVolumes<double>&,
                                                     float, float);
extern template VolumeGap separationOnTheFly<float>(FlyVolumes<float>&, FlyVolumes<float>&, float,
                                                    float);
extern template VolumeGap separationOnTheFly<double>(const fcl::CollisionObject<double>&,
                                                     const fcl::CollisionObject<double>&, float,
                                                     float);
extern template VolumeGap separationOnTheFly<float>(const fcl::CollisionObject<float>&,
                                                    const fcl::CollisionObject<float>&, float,
                                                    float);

}  // namespace detail
}  // namespace cube
