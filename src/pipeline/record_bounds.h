#pragma once

// The geometric bounds on two objects' float records (core/volume.h) that the record verdicts of
// cull.h combine: box gaps by separating axes, capsules about round shapes' axes, and the volumes
// inside spheres, boxes, capsules and cylinders that prove contact. Each errs only towards "not
// settled", by the slack its comments state.

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/kernels/record_gap.h"
#include "core/volume.h"

namespace cube {
namespace detail {
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

// Record b's box seen from record a's: R[i][j] = a's axis i . b's axis j, t = b's centre in a's
// frame (d = the centres' difference), what the inner boxes' separating-axis tests read.
struct BoxFrame {
  float d[3], R[3][3], t[3];
};
inline BoxFrame boxFrame(const VolumeSphere& sa, const VolumeShape& a, const VolumeSphere& sb,
                         const VolumeShape& b) {
  BoxFrame f;
  for (int k = 0; k < 3; ++k) f.d[k] = sb.c[k] - sa.c[k];
  for (int i = 0; i < 3; ++i) {
    f.t[i] = a.R[i] * f.d[0] + a.R[3 + i] * f.d[1] + a.R[6 + i] * f.d[2];
    for (int j = 0; j < 3; ++j)
      f.R[i][j] = a.R[i] * b.R[j] + a.R[3 + i] * b.R[3 + j] + a.R[6 + i] * b.R[6 + j];
  }
  return f;
}

// separation's box gap on the records: the separating-axis test (core/kernels/record_gap.h).
inline float boxGap(const VolumeSphere& sa, const VolumeShape& a, const VolumeSphere& sb,
                    const VolumeShape& b, float stop) {
  return recordBoxGap(sa, a, sb, b, stop);
}

// A capsule on a record's third axis: the segment from z - half to z + half along it (about the
// record's centre) and a radius; radius < 0: none.
struct AxisCapsule {
  float z, half, radius;
};
inline constexpr AxisCapsule kNoCapsule{0.f, 0.f, -1.f};
inline constexpr std::uint32_t kRoundKinds =
    kVolumeSphere | kVolumeCapsule | kVolumeCylinder | kVolumeCone;

// The capsule holding a sphere, capsule, cylinder or cone (the records' extents are outward
// rounded: volume.h). A cone's (base radius r at z = -h / 2, apex at h / 2): radius r about its
// axis from the base's centre to r below the apex (every point of it within r of that segment
// while r <= h), or the ball of radius r about the base's centre when h < r.
inline AxisCapsule outerCapsule(const VolumeSphere& s, const VolumeShape& h) {
  const std::uint32_t f = h.flags;
  if ((f & kVolumeSphere) != 0) return {0.f, 0.f, s.r};
  if ((f & kVolumeCapsule) != 0) return {0.f, std::max(h.e[2] - h.e[0], 0.f), h.e[0]};
  if ((f & kVolumeCylinder) != 0) return {0.f, h.e[2], h.e[0]};
  if ((f & kVolumeCone) != 0) {
    const float r = h.e[0], half_h = h.e[2];
    return 2.f * half_h > r ? AxisCapsule{-0.5f * r, half_h - 0.5f * r, r}
                            : AxisCapsule{-half_h, 0.f, r};
  }
  return kNoCapsule;
}

// A capsule inside a sphere, capsule or cylinder (the inscribed ball's radius, which is inward
// rounded, about the longest segment that keeps it inside), for records with an inscribed ball.
inline AxisCapsule innerCapsule(const VolumeShape& h) {
  if (!(h.inner_r > 0.f)) return kNoCapsule;
  const std::uint32_t f = h.flags;
  if ((f & kVolumeSphere) != 0) return {0.f, 0.f, h.inner_r};
  if ((f & kVolumeCapsule) != 0) return {0.f, std::max(h.e[2] - h.e[0], 0.f), h.inner_r};
  if ((f & kVolumeCylinder) != 0) return {0.f, std::max(h.e[2] - h.inner_r, 0.f), h.inner_r};
  return kNoCapsule;
}

// The half extents of a box inside a box, cylinder or capsule about its centre, on its axes (a
// cylinder's and a capsule's square section inscribed in their circle), for records with an
// inscribed ball; false for other records.
inline bool innerBox(const VolumeShape& h, float* ie) {
  if (!(h.inner_r > 0.f)) return false;
  const std::uint32_t f = h.flags;
  constexpr float kHalfRoot2 = 0.70710677f;  // rounded down
  if ((f & kVolumeBox) != 0) {
    ie[0] = h.e[0], ie[1] = h.e[1], ie[2] = h.e[2];
  } else if ((f & (kVolumeCylinder | kVolumeCapsule)) != 0) {
    ie[0] = h.e[0] * kHalfRoot2, ie[1] = h.e[1] * kHalfRoot2;
    ie[2] = (f & kVolumeCylinder) != 0 ? h.e[2] : std::max(h.e[2] - h.e[0], 0.f);
  } else {
    return false;
  }
  return true;
}

inline float dot3(const float* a, const float* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// Two capsules' segments (centres p = 0 and w relative to it, unit axes u and v, half lengths a
// and b): out = the vector from a point of b's segment to a point of a's, near the closest pair
// (exact but for rounding when the axes are not parallel; any pair of points serves the bounds).
inline void segmentsApart(const float* w, const float* u, const float* v, float a, float b,
                          float* out) {
  const float uv = dot3(u, v), uw = dot3(u, w), vw = dot3(v, w);
  const float den = 1.f - uv * uv;
  float s = den > 1e-6f ? std::clamp((uw - uv * vw) / den, -a, a) : 0.f;
  const float t = std::clamp(uv * s - vw, -b, b);
  s = std::clamp(uv * t + uw, -a, a);
  for (int k = 0; k < 3; ++k) out[k] = s * u[k] - t * v[k] - w[k];
}

// The capsules ca of record a and cb of record b: their segments' centres relative to a's
// record centre (0 and w) and axes.
inline void capsuleFrame(const VolumeSphere& sa, const VolumeShape& ha, const AxisCapsule& ca,
                         const VolumeSphere& sb, const VolumeShape& hb, const AxisCapsule& cb,
                         float* w, float* u, float* v) {
  for (int k = 0; k < 3; ++k) {
    u[k] = ha.R[3 * k + 2];
    v[k] = hb.R[3 * k + 2];
    w[k] = (sb.c[k] - sa.c[k]) + cb.z * v[k] - ca.z * u[k];
  }
}

// A lower bound on the distance of two capsules: the gap of their segments along the direction
// between segmentsApart's points (every direction gives one: the projection of the segments'
// distance), less both radii. -infinity when those points meet.
inline float capsuleGap(const VolumeSphere& sa, const VolumeShape& ha, const AxisCapsule& ca,
                        const VolumeSphere& sb, const VolumeShape& hb, const AxisCapsule& cb) {
  float w[3], u[3], v[3], n[3];
  capsuleFrame(sa, ha, ca, sb, hb, cb, w, u, v);
  segmentsApart(w, u, v, ca.half, cb.half, n);
  const float len = std::sqrt(dot3(n, n));
  if (!(len > 0.f)) return -std::numeric_limits<float>::infinity();
  for (float& x : n) x /= len;
  return -dot3(n, w) - ca.half * std::fabs(dot3(n, u)) - cb.half * std::fabs(dot3(n, v)) -
         ca.radius - cb.radius;
}

// A lower bound on the distance of capsule c of record a to record b's oriented box: the gap
// along the direction from the box's point nearest the segment to the segment's (three rounds of
// alternate projections come near enough: every direction gives a bound), less the radius.
// -infinity when the segment meets the box.
inline float capsuleBoxGap(const VolumeSphere& sa, const VolumeShape& ha, const AxisCapsule& c,
                           const VolumeSphere& sb, const VolumeShape& hb) {
  float w[3], u[3];  // the segment's centre and axis in b's frame, from b's centre
  for (int i = 0; i < 3; ++i) {
    const float b_axis[3] = {hb.R[i], hb.R[3 + i], hb.R[6 + i]};
    const float a_axis[3] = {ha.R[2], ha.R[5], ha.R[8]};
    const float d[3] = {sa.c[0] - sb.c[0] + c.z * a_axis[0], sa.c[1] - sb.c[1] + c.z * a_axis[1],
                        sa.c[2] - sb.c[2] + c.z * a_axis[2]};
    w[i] = dot3(b_axis, d);
    u[i] = dot3(b_axis, a_axis);
  }
  float s = 0.f, x[3], n[3];
  for (int round = 0; round < 3; ++round) {
    for (int i = 0; i < 3; ++i) n[i] = std::clamp(w[i] + s * u[i], -hb.e[i], hb.e[i]) - w[i];
    s = std::clamp(dot3(u, n), -c.half, c.half);
  }
  for (int i = 0; i < 3; ++i) {
    x[i] = w[i] + s * u[i];
    n[i] = x[i] - std::clamp(x[i], -hb.e[i], hb.e[i]);
  }
  const float len = std::sqrt(dot3(n, n));
  if (!(len > 0.f)) return -std::numeric_limits<float>::infinity();
  for (float& v : n) v /= len;
  return dot3(n, w) - c.half * std::fabs(dot3(n, u)) -
         (hb.e[0] * std::fabs(n[0]) + hb.e[1] * std::fabs(n[1]) + hb.e[2] * std::fabs(n[2])) -
         c.radius;
}

// An upper bound on the distance of two capsules' segments, less both radii: < 0 when they meet.
inline float capsuleReach(const VolumeSphere& sa, const VolumeShape& ha, const AxisCapsule& ca,
                          const VolumeSphere& sb, const VolumeShape& hb, const AxisCapsule& cb) {
  float w[3], u[3], v[3], n[3];
  capsuleFrame(sa, ha, ca, sb, hb, cb, w, u, v);
  segmentsApart(w, u, v, ca.half, cb.half, n);
  return std::sqrt(dot3(n, n)) - ca.radius - cb.radius;
}

// Whether boxes a and b (f: boxFrame of their records; half extents ia and ib) share a point
// with `m` to spare: a's centre clamped into b (shrunk by m) lies in a shrunk by m, or b's centre
// clamped into a lies in b. Sufficient, not necessary: boxes crossing with both centres outside
// the other are left to FCL.
inline bool boxesShareAPoint(const BoxFrame& f, const VolumeShape& b, const float* ia,
                             const float* ib, float m) {
  const auto& R = f.R;
  const auto& t = f.t;
  float u[3];  // a's centre in b's frame
  for (int i = 0; i < 3; ++i) u[i] = -(b.R[i] * f.d[0] + b.R[3 + i] * f.d[1] + b.R[6 + i] * f.d[2]);
  for (int k = 0; k < 3; ++k)
    if (!(ia[k] > m) || !(ib[k] > m)) return false;
  // The clamped point p minus the centre it moved from, in that box's frame (w), then in the
  // other box's frame, relative to the other's centre: p - c_a = R_b w for a's centre clamped
  // into b, p - c_b = R_a w for b's centre clamped into a.
  float w[3];
  for (int j = 0; j < 3; ++j) w[j] = std::clamp(u[j], m - ib[j], ib[j] - m) - u[j];
  bool inside = true;
  for (int i = 0; i < 3 && inside; ++i)
    inside = std::fabs(R[i][0] * w[0] + R[i][1] * w[1] + R[i][2] * w[2]) < ia[i] - m;
  if (inside) return true;
  for (int i = 0; i < 3; ++i) w[i] = std::clamp(t[i], m - ia[i], ia[i] - m) - t[i];
  inside = true;
  for (int j = 0; j < 3 && inside; ++j)
    inside = std::fabs(R[0][j] * w[0] + R[1][j] * w[1] + R[2][j] * w[2]) < ib[j] - m;
  return inside;
}

// Whether boxes a and b (centres and axes of the records, half extents ia and ib) overlap by more
// than m along every axis of the separating-axis test: the three face normals of each and the
// nine cross products of their edges (for boxes, all the directions that can separate them), so
// they share a point with room to spare. Where two edges are near parallel (below a tenth of a
// radian), their cross product is too short to trust in floats: boxesShareAPoint decides.
inline bool boxesOverlap(const VolumeSphere& sa, const VolumeShape& a, const float* ia,
                         const VolumeSphere& sb, const VolumeShape& b, const float* ib, float m) {
  const BoxFrame f = boxFrame(sa, a, sb, b);
  const auto& R = f.R;
  const auto& t = f.t;
  float A[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A[i][j] = std::fabs(R[i][j]);
  for (int i = 0; i < 3; ++i)
    if (!(std::fabs(t[i]) - ia[i] - (ib[0] * A[i][0] + ib[1] * A[i][1] + ib[2] * A[i][2]) < -m))
      return false;
  for (int j = 0; j < 3; ++j) {
    const float tj = t[0] * R[0][j] + t[1] * R[1][j] + t[2] * R[2][j];
    if (!(std::fabs(tj) - (ia[0] * A[0][j] + ia[1] * A[1][j] + ia[2] * A[2][j]) - ib[j] < -m))
      return false;
  }
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const float len2 = 1.f - R[i][j] * R[i][j];
      if (!(len2 >= 1e-2f)) return boxesShareAPoint(f, b, ia, ib, m);
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const float ra = ia[i1] * A[i2][j] + ia[i2] * A[i1][j];
      const float rb = ib[j1] * A[i][j2] + ib[j2] * A[i][j1];
      // Rounded up by 16 ulps of its terms (as boxGap rounds down): the bound must hold for the
      // exact value, which the division by a short axis would magnify.
      const float slack = std::fabs(t[i2] * R[i1][j] - t[i1] * R[i2][j]) - ra - rb +
                          16.f * FLT_EPSILON * (std::fabs(t[i1]) + std::fabs(t[i2]) + ra + rb);
      // slack / sqrt(len2) < -m, without the root
      if (!(slack < 0.f && slack * slack > m * m * len2)) return false;
    }
  }
  return true;
}

// Distance from point p to the box of centre s.c, the record's axes and half extents ie.
inline float pointInBox(const float* p, const VolumeSphere& s, const VolumeShape& h,
                        const float* ie) {
  const float d[3] = {p[0] - s.c[0], p[1] - s.c[1], p[2] - s.c[2]};
  float out2 = 0.f;
  for (int i = 0; i < 3; ++i) {
    const float q = h.R[i] * d[0] + h.R[3 + i] * d[1] + h.R[6 + i] * d[2];
    const float o = std::max(std::fabs(q) - ie[i], 0.f);
    out2 += o * o;
  }
  return std::sqrt(out2);
}

// The round and inner bounds' margin: 4 rate x (1 + scale + both bounding radii), which covers
// the records' outward (inward) rounding of sizes, near 16 float ulps of the scale each, and these
// bounds' own arithmetic on coordinates relative to one centre (the pair's centres are within the
// sum of the bounding radii when these run), on top of separation's margin.
inline float innerMargin(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
                         const VolumeShape& hb, float rate) {
  return 4.f * rate * (1.f + std::max(ha.scale, hb.scale) + sa.r + sb.r);
}

// Whether the inner volumes of two records with inscribed balls overlap by more than m: both
// inner capsules (spheres, capsules, cylinders), a sphere against an inner box (boxes,
// cylinders, capsules), or two inner boxes (boxesOverlap).
inline bool innerVolumesMeet(const VolumeSphere& sa, const VolumeShape& ha, const VolumeSphere& sb,
                             const VolumeShape& hb, float m) {
  const AxisCapsule ca = innerCapsule(ha), cb = innerCapsule(hb);
  if (ca.radius > 0.f && cb.radius > 0.f && capsuleReach(sa, ha, ca, sb, hb, cb) < -m) return true;
  float ia[3], ib[3];
  const bool box_a = innerBox(ha, ia), box_b = innerBox(hb, ib);
  if ((ha.flags & kVolumeSphere) != 0 && box_b)
    return pointInBox(sa.c, sb, hb, ib) < ha.inner_r - m;
  if ((hb.flags & kVolumeSphere) != 0 && box_a)
    return pointInBox(sb.c, sa, ha, ia) < hb.inner_r - m;
  return box_a && box_b && boxesOverlap(sa, ha, ia, sb, hb, ib, m);
}

}  // namespace volume_detail

}  // namespace detail
}  // namespace cube
