#pragma once

// The per-box operations with SSE2, x86-64's baseline (no -m flag, so no effect on Eigen's ABI):
// the same results as box_ops_portable.h, bit for bit, in fewer instructions. Only box_ops.h
// includes this file, and only where the compiler targets SSE2.

#include <emmintrin.h>

#include <cstdint>
#include <limits>

#include "core/kernels/box_ops_portable.h"

namespace cube {
namespace detail {
namespace sse2 {

// What SSE2 does not speed up.
using portable::boxGap2;
using portable::cubeGap2Wide;
using portable::floatBelow;
using portable::fourToColumns;
using portable::gap2;
using portable::overlap;
using portable::roundOut;
using portable::sameBox;
using portable::unionOfItems;

/// roundOut for double: the same float operations as floatBelow, four and two lanes at a time
/// (builds and refits round every box).
inline void roundOut(const Box<double>& b, float lo[3], float hi[3]) {
  const __m128d kMax = _mm_set1_pd(std::numeric_limits<float>::max());
  const __m128d kMin = _mm_set1_pd(-std::numeric_limits<float>::max());
  auto narrow = [&](const double* p) {
    return _mm_cvtpd_ps(_mm_min_pd(_mm_max_pd(_mm_loadu_pd(p), kMin), kMax));
  };
  const __m128 a = _mm_movelh_ps(narrow(b.lo), narrow(b.lo + 2));  // lo0 lo1 lo2 hi0
  const __m128 c = narrow(b.hi + 1);                               // hi1 hi2 0 0
  const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  const __m128 scale = _mm_set1_ps(0x1p-22f);
  const __m128 tiny = _mm_set1_ps(std::numeric_limits<float>::min());
  const __m128 da = _mm_add_ps(_mm_mul_ps(_mm_and_ps(a, abs_mask), scale), tiny);
  const __m128 dc = _mm_add_ps(_mm_mul_ps(_mm_and_ps(c, abs_mask), scale), tiny);
  alignas(16) float down[4], up[4], up2[4];
  _mm_store_ps(down, _mm_sub_ps(a, da));
  _mm_store_ps(up, _mm_add_ps(a, da));
  _mm_store_ps(up2, _mm_add_ps(c, dc));
  lo[0] = down[0];
  lo[1] = down[1];
  lo[2] = down[2];
  hi[0] = up[3];
  hi[1] = up2[0];
  hi[2] = up2[1];
}

/// sameBox for double: the six coordinates are contiguous, three two-lane compares.
inline bool sameBox(const Box<double>& a, const Box<double>& b) {
  const __m128d e0 = _mm_cmpeq_pd(_mm_loadu_pd(a.lo), _mm_loadu_pd(b.lo));
  const __m128d e1 = _mm_cmpeq_pd(_mm_loadu_pd(a.lo + 2), _mm_loadu_pd(b.lo + 2));
  const __m128d e2 = _mm_cmpeq_pd(_mm_loadu_pd(a.hi + 1), _mm_loadu_pd(b.hi + 1));
  return _mm_movemask_pd(_mm_and_pd(_mm_and_pd(e0, e1), e2)) == 3;
}

/// A cube's corners load as one register each; lane 3 (first/count) is ignored.
inline bool sameBounds(const Node& a, const Node& b) {
  const __m128 lo = _mm_cmpeq_ps(_mm_loadu_ps(a.lo), _mm_loadu_ps(b.lo));
  const __m128 hi = _mm_cmpeq_ps(_mm_loadu_ps(a.hi), _mm_loadu_ps(b.hi));
  return (_mm_movemask_ps(_mm_and_ps(lo, hi)) & 7) == 7;
}

inline bool overlap(const Node& a, const Node& b) {
  const __m128 le = _mm_cmple_ps(_mm_loadu_ps(a.lo), _mm_loadu_ps(b.hi));
  const __m128 ge = _mm_cmple_ps(_mm_loadu_ps(b.lo), _mm_loadu_ps(a.hi));
  return (_mm_movemask_ps(_mm_and_ps(le, ge)) & 7) == 7;
}

/// lo and hi are six contiguous doubles; axes (0,1) and (1,2) cover all three.
inline bool overlap(const Box<double>& a, const Box<double>& b) {
  const double* x = a.lo;
  const double* y = b.lo;
  const __m128d m0 = _mm_and_pd(_mm_cmple_pd(_mm_loadu_pd(x), _mm_loadu_pd(y + 3)),
                                _mm_cmple_pd(_mm_loadu_pd(y), _mm_loadu_pd(x + 3)));
  const __m128d m1 = _mm_and_pd(_mm_cmple_pd(_mm_loadu_pd(x + 1), _mm_loadu_pd(y + 4)),
                                _mm_cmple_pd(_mm_loadu_pd(y + 1), _mm_loadu_pd(x + 4)));
  return _mm_movemask_pd(_mm_and_pd(m0, m1)) == 3;
}

template <typename S>
struct FixedBox : portable::FixedBox<S> {
  using portable::FixedBox<S>::FixedBox;
};

/// FixedBox for double: its corners laid out as a tested box's six contiguous doubles are, in
/// pairs (lo0 lo1) (lo2 hi0) (hi1 hi2), with the hi side's bounds negated, so that a test is
/// three two-lane compares of the box as it lies in memory (-x <= -y is y <= x for every value,
/// zeros and infinities included, and false with a NaN as y <= x is).
template <>
struct FixedBox<double> {
  explicit FixedBox(const Box<double>& b)
      : q01(_mm_loadu_pd(b.hi)),
        q2(_mm_xor_pd(_mm_set_pd(b.lo[0], b.hi[2]), _mm_set_pd(-0.0, 0.0))),
        q3(_mm_xor_pd(_mm_set_pd(b.lo[2], b.lo[1]), _mm_set1_pd(-0.0))) {}
  bool overlaps(const Box<double>& x) const {
    const __m128d flip_hi0 = _mm_set_pd(-0.0, 0.0);
    const __m128d flip_both = _mm_set1_pd(-0.0);
    const __m128d c1 = _mm_cmple_pd(_mm_loadu_pd(x.lo), q01);  // lo0 <= b.hi0, lo1 <= b.hi1
    const __m128d c2 = _mm_cmple_pd(_mm_xor_pd(_mm_loadu_pd(x.lo + 2), flip_hi0), q2);
    const __m128d c3 = _mm_cmple_pd(_mm_xor_pd(_mm_loadu_pd(x.hi + 1), flip_both), q3);
    return _mm_movemask_pd(_mm_and_pd(_mm_and_pd(c1, c2), c3)) == 3;
  }
  __m128d q01;  // b.hi0, b.hi1
  __m128d q2;   // b.hi2, -b.lo0
  __m128d q3;   // -b.lo1, -b.lo2
};

/// FixedBox for float: the same negation of the hi side's bounds, the tested box read as it lies
/// in memory, (lo0 lo1 lo2 hi0) and (hi1 hi2): two four-lane compares.
template <>
struct FixedBox<float> {
  explicit FixedBox(const Box<float>& b)
      : q0(_mm_set_ps(-b.lo[0], b.hi[2], b.hi[1], b.hi[0])),
        q1(_mm_set_ps(std::numeric_limits<float>::infinity(),
                      std::numeric_limits<float>::infinity(), -b.lo[2], -b.lo[1])) {}
  bool overlaps(const Box<float>& x) const {
    const __m128 flip_hi0 = _mm_set_ps(-0.0f, 0.0f, 0.0f, 0.0f);
    const __m128 c0 = _mm_cmple_ps(_mm_xor_ps(_mm_loadu_ps(x.lo), flip_hi0), q0);
    // (hi1 hi2) negated in the low lanes; 0 <= infinity in the others.
    const __m128 h = _mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(x.hi + 1));
    const __m128 c1 = _mm_cmple_ps(_mm_xor_ps(h, _mm_set_ps(0.0f, 0.0f, -0.0f, -0.0f)), q1);
    return _mm_movemask_ps(_mm_and_ps(c0, c1)) == 15;
  }
  __m128 q0;  // b.hi0, b.hi1, b.hi2, -b.lo0
  __m128 q1;  // -b.lo1, -b.lo2, inf, inf
};

// The squared gap from the differences a.lo - b.hi (x) and b.lo - a.hi (y) in double, axes 0
// and 1 in one register and axis 2 in another: as gap2, an axis whose difference is NaN counts
// as touching, and the squares are summed in axis order.
inline double gap2FromDifferences(__m128d x01, __m128d y01, __m128d x2, __m128d y2) {
  const __m128d zero = _mm_setzero_pd();
  __m128d d01 = _mm_andnot_pd(_mm_cmpunord_pd(x01, y01), _mm_max_pd(x01, y01));
  __m128d d2 = _mm_andnot_pd(_mm_cmpunord_sd(x2, y2), _mm_max_sd(x2, y2));
  d01 = _mm_max_pd(d01, zero);
  d2 = _mm_max_sd(d2, zero);
  d01 = _mm_mul_pd(d01, d01);
  const __m128d s01 = _mm_add_sd(d01, _mm_unpackhi_pd(d01, d01));
  return _mm_cvtsd_f64(_mm_add_sd(s01, _mm_mul_sd(d2, d2)));
}

inline double boxGap2(const Box<double>& a, const Box<double>& b) {
  return gap2FromDifferences(_mm_sub_pd(_mm_loadu_pd(a.lo), _mm_loadu_pd(b.hi)),
                             _mm_sub_pd(_mm_loadu_pd(b.lo), _mm_loadu_pd(a.hi)),
                             _mm_sub_sd(_mm_load_sd(a.lo + 2), _mm_load_sd(b.hi + 2)),
                             _mm_sub_sd(_mm_load_sd(b.lo + 2), _mm_load_sd(a.hi + 2)));
}

/// boxGap2 for float: the bounds widened to double (exactly), then as for double.
inline double boxGap2(const Box<float>& a, const Box<float>& b) {
  const auto pair = [](const float* p) {
    return _mm_cvtps_pd(_mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(p)));
  };
  const auto one = [](const float* p) { return _mm_cvtss_sd(_mm_setzero_pd(), _mm_load_ss(p)); };
  return gap2FromDifferences(_mm_sub_pd(pair(a.lo), pair(b.hi)), _mm_sub_pd(pair(b.lo), pair(a.hi)),
                             _mm_sub_sd(one(a.lo + 2), one(b.hi + 2)),
                             _mm_sub_sd(one(b.lo + 2), one(a.hi + 2)));
}

inline double cubeGap2(const Node& a, const Node& b) {
  const __m128 d1 = _mm_sub_ps(_mm_loadu_ps(a.lo), _mm_loadu_ps(b.hi));
  const __m128 d2 = _mm_sub_ps(_mm_loadu_ps(b.lo), _mm_loadu_ps(a.hi));
  __m128 d = _mm_max_ps(_mm_max_ps(d1, d2), _mm_setzero_ps());
  d = _mm_mul_ps(d, d);
  alignas(16) float v[4];
  _mm_store_ps(v, d);
  const float sum = (v[0] + v[1] + v[2]) * (1.0f - 0x1p-20f);
  if (__builtin_expect(sum <= std::numeric_limits<float>::max(), 1)) return sum;
  return cubeGap2Wide(a, b);
}

/// Two lanes at a time: every update() refits the leaves of the objects that moved. A zero's
/// sign may differ from the portable union's, which roundOut maps to the same bound.
inline void unionOfItems(const Item<double>* items, std::uint32_t first, std::uint32_t count,
                         Box<double>& out) {
  const double inf = std::numeric_limits<double>::infinity();
  __m128d lo01 = _mm_set1_pd(inf), lo2 = lo01;
  __m128d hi01 = _mm_set1_pd(-inf), hi2 = hi01;
  for (std::uint32_t p = first; p < first + count; ++p) {
    const double* b = items[p].box.lo;  // lo0 lo1 lo2 hi0 hi1 hi2, contiguous
    lo01 = _mm_min_pd(lo01, _mm_loadu_pd(b));
    lo2 = _mm_min_sd(lo2, _mm_load_sd(b + 2));
    hi01 = _mm_max_pd(hi01, _mm_loadu_pd(b + 3));
    hi2 = _mm_max_sd(hi2, _mm_load_sd(b + 5));
  }
  _mm_storeu_pd(out.lo, lo01);
  _mm_store_sd(out.lo + 2, lo2);
  _mm_storeu_pd(out.hi, hi01);
  _mm_store_sd(out.hi + 2, hi2);
}

/// Lane 3 holds first/count: n keeps its own.
inline void unionOfCubes(Node& n, const Node& a, const Node& b) {
  const __m128 own = _mm_castsi128_ps(_mm_set_epi32(-1, 0, 0, 0));
  const __m128 lo = _mm_min_ps(_mm_loadu_ps(a.lo), _mm_loadu_ps(b.lo));
  const __m128 hi = _mm_max_ps(_mm_loadu_ps(a.hi), _mm_loadu_ps(b.hi));
  _mm_storeu_ps(n.lo, _mm_or_ps(_mm_andnot_ps(own, lo), _mm_and_ps(own, _mm_loadu_ps(n.lo))));
  _mm_storeu_ps(n.hi, _mm_or_ps(_mm_andnot_ps(own, hi), _mm_and_ps(own, _mm_loadu_ps(n.hi))));
}

/// A record's two halves: lo0 lo1 lo2 hi0 and hi1 hi2 seq item.
inline void unionOfRecords(const BuildRecord* first, const BuildRecord* last, Node& n) {
  const float inf = std::numeric_limits<float>::infinity();
  __m128 a_min = _mm_set1_ps(inf), a_max = _mm_set1_ps(-inf), b_max = a_max;
  for (const BuildRecord* r = first; r < last; ++r) {
    const __m128 a = _mm_loadu_ps(r->lo);
    a_min = _mm_min_ps(a_min, a);
    a_max = _mm_max_ps(a_max, a);
    b_max = _mm_max_ps(b_max, _mm_loadu_ps(r->hi + 1));
  }
  alignas(16) float lo[4], hi[4], b[4];
  _mm_store_ps(lo, a_min);
  _mm_store_ps(hi, a_max);
  _mm_store_ps(b, b_max);
  n.lo[0] = lo[0];
  n.lo[1] = lo[1];
  n.lo[2] = lo[2];
  n.hi[0] = hi[3];
  n.hi[1] = b[0];
  n.hi[2] = b[1];
}

/// fourToColumns for double: each box becomes (lo0 lo1 lo2 hi0) and (hi1 hi2) in float, and a
/// 4 x 4 transpose makes columns of those (a third of the instructions of a box-by-box copy).
/// The conversion rounds to nearest, as static_cast does.
inline void fourToColumns(const Box<double>* const b[4], float* const lo[3], float* const hi[3]) {
  __m128 r[4], t[2];
  for (int i = 0; i < 4; ++i) {
    const double* c = b[i]->lo;  // lo0 lo1 lo2 hi0 hi1 hi2, contiguous
    r[i] = _mm_movelh_ps(_mm_cvtpd_ps(_mm_loadu_pd(c)), _mm_cvtpd_ps(_mm_loadu_pd(c + 2)));
  }
  for (int i = 0; i < 2; ++i)
    t[i] = _mm_movelh_ps(_mm_cvtpd_ps(_mm_loadu_pd(b[2 * i]->hi + 1)),
                         _mm_cvtpd_ps(_mm_loadu_pd(b[2 * i + 1]->hi + 1)));
  _MM_TRANSPOSE4_PS(r[0], r[1], r[2], r[3]);
  _mm_storeu_ps(lo[0], r[0]);
  _mm_storeu_ps(lo[1], r[1]);
  _mm_storeu_ps(lo[2], r[2]);
  _mm_storeu_ps(hi[0], r[3]);
  _mm_storeu_ps(hi[1], _mm_shuffle_ps(t[0], t[1], _MM_SHUFFLE(2, 0, 2, 0)));
  _mm_storeu_ps(hi[2], _mm_shuffle_ps(t[0], t[1], _MM_SHUFFLE(3, 1, 3, 1)));
}

}  // namespace sse2
}  // namespace detail
}  // namespace cube
