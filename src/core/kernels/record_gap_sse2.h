#pragma once

// recordBoxGap with SSE2, x86-64's baseline (no -m flag): the three axes of a box in one register,
// the same operations in the same order as record_gap_portable.h, so the same result bit for bit.
// Only record_gap.h includes this file, and only where the compiler targets SSE2.

#include <emmintrin.h>

#include <limits>

#include "core/kernels/record_gap_portable.h"
#include "core/volume.h"

namespace cube {
namespace detail {
namespace sse2 {

namespace record_gap_detail {

template <int i0, int i1, int i2, int i3>
inline __m128 shuffle(__m128 x) {
  return _mm_shuffle_ps(x, x, _MM_SHUFFLE(i3, i2, i1, i0));
}
template <int i>
inline __m128 broadcast(__m128 x) {
  return shuffle<i, i, i, i>(x);
}
// Lanes 0-2 of x, lane 3 -infinity.
inline __m128 firstThree(__m128 x) {
  const __m128 keep = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
  const __m128 minus_inf = _mm_set_ps(-std::numeric_limits<float>::infinity(), 0.f, 0.f, 0.f);
  return _mm_or_ps(_mm_and_ps(x, keep), minus_inf);
}
// portable's maxOfThree: lanes (0, 2) and (1, 3), then those two.
inline float maxOfThree(__m128 x) {
  x = firstThree(x);
  const __m128 m = _mm_max_ps(x, shuffle<2, 3, 0, 1>(x));
  return _mm_cvtss_f32(_mm_max_ps(m, shuffle<1, 0, 3, 2>(m)));
}
inline __m128 absLanes(__m128 x) {
  return _mm_and_ps(x, _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff)));
}

}  // namespace record_gap_detail

/// portable::recordBoxGap, bit for bit. Reads four floats from each row of R and from e (the
/// records' own fields follow them).
inline float recordBoxGap(const VolumeSphere& sa, const VolumeShape& a, const VolumeSphere& sb,
                          const VolumeShape& b, float stop) {
  using namespace record_gap_detail;
  static_assert(sizeof(VolumeShape) >= 13 * sizeof(float), "e is read as four floats");
  const __m128 ulps = _mm_set1_ps(16.f * std::numeric_limits<float>::epsilon());
  const __m128 d = _mm_sub_ps(_mm_loadu_ps(sb.c), _mm_loadu_ps(sa.c));
  // Row k of a's and b's R: component k of each axis, lane by axis.
  const __m128 a0 = _mm_loadu_ps(a.R), a1 = _mm_loadu_ps(a.R + 3), a2 = _mm_loadu_ps(a.R + 6);
  const __m128 b0 = _mm_loadu_ps(b.R), b1 = _mm_loadu_ps(b.R + 3), b2 = _mm_loadu_ps(b.R + 6);
  // t, lane i: b's centre on a's axis i.
  const __m128 t = _mm_add_ps(
      _mm_add_ps(_mm_mul_ps(a0, broadcast<0>(d)), _mm_mul_ps(a1, broadcast<1>(d))),
      _mm_mul_ps(a2, broadcast<2>(d)));
  // Ri, lane j: a's axis i . b's axis j.
  auto row = [&](__m128 x0, __m128 x1, __m128 x2) {
    return _mm_add_ps(_mm_add_ps(_mm_mul_ps(x0, b0), _mm_mul_ps(x1, b1)), _mm_mul_ps(x2, b2));
  };
  const __m128 R0 = row(broadcast<0>(a0), broadcast<0>(a1), broadcast<0>(a2));
  const __m128 R1 = row(broadcast<1>(a0), broadcast<1>(a1), broadcast<1>(a2));
  const __m128 R2 = row(broadcast<2>(a0), broadcast<2>(a1), broadcast<2>(a2));
  const __m128 A0 = _mm_add_ps(absLanes(R0), ulps), A1 = _mm_add_ps(absLanes(R1), ulps),
               A2 = _mm_add_ps(absLanes(R2), ulps);
  // A's columns, lane i: A[i][j].
  __m128 C0 = A0, C1 = A1, C2 = A2, C3 = _mm_setzero_ps();
  _MM_TRANSPOSE4_PS(C0, C1, C2, C3);
  const __m128 ea = _mm_loadu_ps(a.e), eb = _mm_loadu_ps(b.e);
  const __m128 ea0 = broadcast<0>(ea), ea1 = broadcast<1>(ea), ea2 = broadcast<2>(ea);
  const __m128 eb0 = broadcast<0>(eb), eb1 = broadcast<1>(eb), eb2 = broadcast<2>(eb);
  const __m128 face_a = _mm_sub_ps(
      _mm_sub_ps(absLanes(t), ea),
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(eb0, C0), _mm_mul_ps(eb1, C1)), _mm_mul_ps(eb2, C2)));
  const __m128 t0 = broadcast<0>(t), t1 = broadcast<1>(t), t2 = broadcast<2>(t);
  const __m128 tj =
      _mm_add_ps(_mm_add_ps(_mm_mul_ps(t0, R0), _mm_mul_ps(t1, R1)), _mm_mul_ps(t2, R2));
  const __m128 face_b = _mm_sub_ps(
      _mm_sub_ps(absLanes(tj),
                 _mm_add_ps(_mm_add_ps(_mm_mul_ps(ea0, A0), _mm_mul_ps(ea1, A1)),
                            _mm_mul_ps(ea2, A2))),
      eb);
  __m128 acc = _mm_max_ps(firstThree(face_b), firstThree(face_a));
  const float faces = maxOfThree(acc);
  if (faces > stop) return faces;
  const __m128 one = _mm_set1_ps(1.f), min_len2 = _mm_set1_ps(1e-2f), zero = _mm_setzero_ps();
  const __m128 minus_inf = _mm_set1_ps(-std::numeric_limits<float>::infinity());
  // b's extents turned: lane j holds eb[(j + 1) % 3], eb[(j + 2) % 3].
  const __m128 eb_1 = shuffle<1, 2, 0, 3>(eb), eb_2 = shuffle<2, 0, 1, 3>(eb);
  const __m128 abs_t = absLanes(t);
  // Lane j of row i: a's axis i cross b's axis j.
  auto edges = [&](__m128 Ri, __m128 Ai, __m128 R_1, __m128 A_1, __m128 R_2, __m128 A_2,
                   __m128 t_1, __m128 t_2, __m128 ea_1, __m128 ea_2, __m128 abs_t1,
                   __m128 abs_t2) {
    const __m128 len2 = _mm_sub_ps(one, _mm_mul_ps(Ri, Ri));
    const __m128 dist = absLanes(_mm_sub_ps(_mm_mul_ps(t_2, R_1), _mm_mul_ps(t_1, R_2)));
    const __m128 ra = _mm_add_ps(_mm_mul_ps(ea_1, A_2), _mm_mul_ps(ea_2, A_1));
    const __m128 rb = _mm_add_ps(_mm_mul_ps(eb_1, shuffle<2, 0, 1, 3>(Ai)),
                                 _mm_mul_ps(eb_2, shuffle<1, 2, 0, 3>(Ai)));
    __m128 slack = _mm_sub_ps(_mm_sub_ps(dist, ra), rb);
    slack = _mm_sub_ps(
        slack, _mm_mul_ps(ulps, _mm_add_ps(_mm_add_ps(_mm_add_ps(abs_t1, abs_t2), ra), rb)));
    const __m128 use = _mm_and_ps(_mm_cmpge_ps(len2, min_len2), _mm_cmpgt_ps(slack, zero));
    const __m128 gap = _mm_div_ps(slack, _mm_sqrt_ps(_mm_max_ps(len2, min_len2)));
    acc = _mm_max_ps(firstThree(_mm_or_ps(_mm_and_ps(use, gap), _mm_andnot_ps(use, minus_inf))),
                     acc);
  };
  const __m128 at0 = broadcast<0>(abs_t), at1 = broadcast<1>(abs_t), at2 = broadcast<2>(abs_t);
  edges(R0, A0, R1, A1, R2, A2, t1, t2, ea1, ea2, at1, at2);
  edges(R1, A1, R2, A2, R0, A0, t2, t0, ea2, ea0, at2, at0);
  edges(R2, A2, R0, A0, R1, A1, t0, t1, ea0, ea1, at0, at1);
  return maxOfThree(acc);
}

}  // namespace sse2
}  // namespace detail
}  // namespace cube
