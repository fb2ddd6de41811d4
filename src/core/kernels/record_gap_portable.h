#pragma once

// The gap of two records' boxes (core/volume.h) by the separating-axis test, in plain C++: the
// reference that record_gap_sse2.h equals bit for bit. It keeps four lanes per step, as the SSE2
// version does, so that both round and reduce in the same order.

#include <cmath>
#include <limits>

#include "core/volume.h"

namespace cube {
namespace detail {
namespace portable {

namespace record_gap_detail {

// Four float lanes; lane 3 carries whatever the loads gave and is never part of a result.
struct Lanes {
  float v[4];
};

// SSE2's maxps, lane by lane: a unless b is larger or either is NaN.
inline float maxLane(float a, float b) {
  return a > b ? a : b;
}
inline Lanes maxLanes(const Lanes& a, const Lanes& b) {
  return {{maxLane(a.v[0], b.v[0]), maxLane(a.v[1], b.v[1]), maxLane(a.v[2], b.v[2]),
           maxLane(a.v[3], b.v[3])}};
}
// The largest of lanes 0-2 (lane 3 set to -infinity first), reduced as the SSE2 version does:
// lanes (0, 2) and (1, 3), then those two.
inline float maxOfThree(Lanes x) {
  x.v[3] = -std::numeric_limits<float>::infinity();
  const float m02 = maxLane(x.v[0], x.v[2]), m13 = maxLane(x.v[1], x.v[3]);
  return maxLane(m02, m13);
}

}  // namespace record_gap_detail

/// A lower bound on the distance of two records' oriented boxes (centre sphere.c, axes the
/// columns of the row-major shape.R, half extents shape.e): the largest gap along the 15 axes of
/// the separating-axis test (three face normals of each box, then the nine cross products of an
/// axis of each, each gap divided by its axis' length, counted only where positive). When the
/// face normals' gap alone exceeds `stop`, that gap (the caller needs no more). The records' axes
/// are orthonormal to a few ulps only, and dividing by an axis' length magnifies that error, so
/// |R| gets 16 ulps, cross products shorter than 0.1 are left out, and the others' slack loses
/// 16 ulps of its terms first: every gap it gives is a gap of the true boxes. Both records must
/// have volumes (r >= 0).
inline float recordBoxGap(const VolumeSphere& sa, const VolumeShape& a, const VolumeSphere& sb,
                          const VolumeShape& b, float stop) {
  using record_gap_detail::Lanes;
  using record_gap_detail::maxLanes;
  using record_gap_detail::maxOfThree;
  constexpr float kUlps = 16.f * std::numeric_limits<float>::epsilon();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  // d: the centres' difference; t: b's centre in a's frame; R[i]: b's axes on a's axis i; A: |R|
  // plus the ulps.
  float d[3], t[3], R[3][3], A[3][3];
  for (int k = 0; k < 3; ++k) d[k] = sb.c[k] - sa.c[k];
  for (int i = 0; i < 3; ++i) {
    t[i] = a.R[i] * d[0] + a.R[3 + i] * d[1] + a.R[6 + i] * d[2];
    for (int j = 0; j < 3; ++j) {
      R[i][j] = a.R[i] * b.R[j] + a.R[3 + i] * b.R[3 + j] + a.R[6 + i] * b.R[6 + j];
      A[i][j] = std::fabs(R[i][j]) + kUlps;
    }
  }
  const float *ea = a.e, *eb = b.e;
  // Lane i: a's face normal i; lane j: b's face normal j.
  Lanes face_a{}, face_b{};
  for (int i = 0; i < 3; ++i)
    face_a.v[i] = std::fabs(t[i]) - ea[i] - (eb[0] * A[i][0] + eb[1] * A[i][1] + eb[2] * A[i][2]);
  for (int j = 0; j < 3; ++j) {
    const float tj = t[0] * R[0][j] + t[1] * R[1][j] + t[2] * R[2][j];
    face_b.v[j] = std::fabs(tj) - (ea[0] * A[0][j] + ea[1] * A[1][j] + ea[2] * A[2][j]) - eb[j];
  }
  face_a.v[3] = face_b.v[3] = -kInf;
  Lanes acc = maxLanes(face_b, face_a);
  const float faces = maxOfThree(acc);
  if (faces > stop) return faces;
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    Lanes edge{};
    // Lane j: a's axis i cross b's axis j.
    for (int j = 0; j < 3; ++j) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const float len2 = 1.f - R[i][j] * R[i][j];
      const float dist = std::fabs(t[i2] * R[i1][j] - t[i1] * R[i2][j]);
      const float ra = ea[i1] * A[i2][j] + ea[i2] * A[i1][j];
      const float rb = eb[j1] * A[i][j2] + eb[j2] * A[i][j1];
      float slack = dist - ra - rb;
      slack = slack - kUlps * (std::fabs(t[i1]) + std::fabs(t[i2]) + ra + rb);
      edge.v[j] = len2 >= 1e-2f && slack > 0.f ? slack / std::sqrt(len2) : -kInf;
    }
    edge.v[3] = -kInf;
    acc = maxLanes(edge, acc);
  }
  return maxOfThree(acc);
}

}  // namespace portable
}  // namespace detail
}  // namespace cube
