// SE(3) motion bounds (se3_bounds.h): portable, and AVX2 for double (four links per
// instruction, every operation of se3Bound and angleAbove in their order per lane, both sides of
// each choice computed and the one taken kept), so that both agree bit for bit.

#include "core/kernels/se3_bounds.h"

#include "core/kernels/avx2_lanes.h"
#include "core/kernels/cpu_features.h"

namespace cube {
namespace detail {

namespace {

template <typename S>
void portable(const S* a, const S* b, const S* reach, std::size_t begin, std::size_t n, S* out) {
  for (std::size_t l = begin; l < n; ++l) out[l] = se3Bound(a + 16 * l, b + 16 * l, reach[l]);
}

#if defined(CUBE_KERNELS_AVX2)

using avx2_lanes::add;
using avx2_lanes::mul;
using avx2_lanes::sub;

[[gnu::target("avx2")]] inline __m256d num(double x) {
  return _mm256_set1_pd(x);
}
// Column i of one rotation . column j of another, lane by lane, in se3Bound's order.
[[gnu::target("avx2")]] inline __m256d dot(const __m256d x[4], const __m256d y[4]) {
  return add(add(mul(x[0], y[0]), mul(x[1], y[1])), mul(x[2], y[2]));
}
// when ? yes : no, lane by lane.
[[gnu::target("avx2")]] inline __m256d pick(__m256d when, __m256d yes, __m256d no) {
  return _mm256_blendv_pd(no, yes, when);
}

// angleAbove, lane by lane.
[[gnu::target("avx2")]] inline __m256d angleAbove4(__m256d sine, __m256d cosine) {
  const __m256d ac = _mm256_andnot_pd(num(-0.0), cosine);
  const __m256d swap = _mm256_cmp_pd(sine, ac, _CMP_GT_OQ);
  const __m256d top = pick(swap, ac, sine), den = pick(swap, sine, ac);
  const __m256d none = _mm256_cmp_pd(den, _mm256_setzero_pd(), _CMP_NGT_UQ);  // !(den > 0)
  const __m256d t = _mm256_div_pd(top, den);
  const __m256d far = _mm256_cmp_pd(t, num(kAngleTanPi8), _CMP_GT_OQ);
  const __m256d u = pick(far, _mm256_div_pd(sub(t, num(1)), add(t, num(1))), t);
  const __m256d z = mul(u, u);
  __m256d p = num(kAngleCoefficients[9]);
  for (int i = 8; i >= 0; --i) p = add(mul(p, z), num(kAngleCoefficients[i]));
  __m256d a = add(u, mul(mul(u, z), p));
  a = pick(far, add(a, num(kAnglePi / 4)), a);
  a = pick(swap, sub(num(kAnglePi / 2), a), a);
  a = pick(_mm256_cmp_pd(cosine, _mm256_setzero_pd(), _CMP_LT_OQ), sub(num(kAnglePi), a), a);
  const __m256d special = add(mul(add(sine, cosine), _mm256_setzero_pd()), num(kAnglePad));
  return pick(none, special, add(a, num(kAnglePad)));
}

[[gnu::target("avx2")]] void avx2(const double* a, const double* b, const double* reach,
                                  std::size_t n, double* out) {
  std::size_t l = 0;
  for (; l + 4 <= n; l += 4) {
    const double* pa = a + 16 * l;
    const double* pb = b + 16 * l;
    __m256d ca[4][4], cb[4][4];  // [column][row] over the four links
    for (int c = 0; c < 4; ++c) {
      avx2_lanes::lanes(pa + 4 * c, ca[c]);
      avx2_lanes::lanes(pb + 4 * c, cb[c]);
    }
    const __m256d sx = sub(dot(ca[2], cb[1]), dot(ca[1], cb[2]));
    const __m256d sy = sub(dot(ca[0], cb[2]), dot(ca[2], cb[0]));
    const __m256d sz = sub(dot(ca[1], cb[0]), dot(ca[0], cb[1]));
    const __m256d sine =
        mul(num(0.5), _mm256_sqrt_pd(add(add(mul(sx, sx), mul(sy, sy)), mul(sz, sz))));
    const __m256d cosine = mul(
        num(0.5), sub(add(add(dot(ca[0], cb[0]), dot(ca[1], cb[1])), dot(ca[2], cb[2])), num(1)));
    const __m256d angle = angleAbove4(sine, cosine);
    const __m256d tx = sub(cb[3][0], ca[3][0]), ty = sub(cb[3][1], ca[3][1]);
    const __m256d tz = sub(cb[3][2], ca[3][2]);
    const __m256d shift = _mm256_sqrt_pd(add(add(mul(tx, tx), mul(ty, ty)), mul(tz, tz)));
    _mm256_storeu_pd(out + l, add(shift, mul(angle, _mm256_loadu_pd(reach + l))));
  }
  portable(a, b, reach, l, n, out);
}

#endif

}  // namespace

void se3Bounds(const double* a, const double* b, const double* reach, std::size_t n, double* out) {
#if defined(CUBE_KERNELS_AVX2)
  if (cpuHasAvx2()) return avx2(a, b, reach, n, out);
#endif
  portable(a, b, reach, 0, n, out);
}

void se3Bounds(const float* a, const float* b, const float* reach, std::size_t n, float* out) {
  portable(a, b, reach, 0, n, out);
}

void se3BoundsPortable(const double* a, const double* b, const double* reach, std::size_t n,
                       double* out) {
  portable(a, b, reach, 0, n, out);
}

}  // namespace detail
}  // namespace cube
