#pragma once

// Exact conservative culling between the box test and FCL's narrow phase. FCL gives a rotated
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

namespace volume_detail {

// Distance from point p to the box (centre c, axes the columns of row-major R, half extents e).
inline float pointBox(const float* p, const VolumeSphere& s, const VolumeShape& h) {
  const float d[3] = {p[0] - s.c[0], p[1] - s.c[1], p[2] - s.c[2]};
  float out2 = 0.f;
  for (int i = 0; i < 3; ++i) {
    const float q = h.R[i] * d[0] + h.R[3 + i] * d[1] + h.R[6 + i] * d[2];
    const float o = std::max(std::fabs(q) - h.e[i], 0.f);
    out2 += o * o;
  }
  return std::sqrt(out2);
}

// separation's boxGap on the records: the largest separating-axis gap of the two boxes, or the
// first one above `stop`.
inline float boxGap(const VolumeSphere& sa, const VolumeShape& a, const VolumeSphere& sb,
                    const VolumeShape& b, float stop) {
  const float d[3] = {sb.c[0] - sa.c[0], sb.c[1] - sa.c[1], sb.c[2] - sa.c[2]};
  float R[3][3], A[3][3], t[3];
  for (int i = 0; i < 3; ++i) {
    t[i] = a.R[i] * d[0] + a.R[3 + i] * d[1] + a.R[6 + i] * d[2];
    for (int j = 0; j < 3; ++j) {
      R[i][j] = a.R[i] * b.R[j] + a.R[3 + i] * b.R[3 + j] + a.R[6 + i] * b.R[6 + j];
      A[i][j] = std::fabs(R[i][j]) + 16.f * FLT_EPSILON;
    }
  }
  float gap = -std::numeric_limits<float>::infinity();
  for (int i = 0; i < 3; ++i)
    gap = std::max(
        gap, std::fabs(t[i]) - a.e[i] - (b.e[0] * A[i][0] + b.e[1] * A[i][1] + b.e[2] * A[i][2]));
  for (int j = 0; j < 3; ++j) {
    const float tj = t[0] * R[0][j] + t[1] * R[1][j] + t[2] * R[2][j];
    gap = std::max(
        gap, std::fabs(tj) - (a.e[0] * A[0][j] + a.e[1] * A[1][j] + a.e[2] * A[2][j]) - b.e[j]);
  }
  if (gap > stop) return gap;
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const float len2 = 1.f - R[i][j] * R[i][j];
      // The float axes are orthonormal to a few ulps only, and dividing by the axis' length
      // magnifies that error: near-parallel edges (length below 0.1) are left out, and the
      // others' slack loses 16 ulps of its terms first.
      if (!(len2 >= 1e-2f)) continue;
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const float dist = std::fabs(t[i2] * R[i1][j] - t[i1] * R[i2][j]);
      const float ra = a.e[i1] * A[i2][j] + a.e[i2] * A[i1][j];
      const float rb = b.e[j1] * A[i][j2] + b.e[j2] * A[i][j1];
      const float slack =
          dist - ra - rb - 16.f * FLT_EPSILON * (std::fabs(t[i1]) + std::fabs(t[i2]) + ra + rb);
      if (slack <= 0.f) continue;
      gap = std::max(gap, slack / std::sqrt(len2));
      if (gap > stop) return gap;
    }
  }
  return gap;
}

}  // namespace volume_detail

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
/// inner radii); else kUnknown, and always kUnknown for a record without volumes. Inline: the
/// stream calls it for every candidate pair.
inline Verdict verdictOf(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
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
