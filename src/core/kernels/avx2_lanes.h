#pragma once

// AVX2 pieces shared by the kernels that read four 4x4 matrices at a time (rigid_rows.cpp,
// se3_bounds.cpp), each with a per-function target: those files run them only where the CPU has
// AVX2. No Eigen here.

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define CUBE_KERNELS_AVX2 1

namespace cube {
namespace detail {
namespace avx2_lanes {

/// (lo[0], lo[1], hi[0], hi[1]): the upper half loaded into place (a load, not a shuffle).
[[gnu::target("avx2")]] inline __m256d halves(const double* lo, const double* hi) {
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(lo)), _mm_loadu_pd(hi), 1);
}

/// Four consecutive numbers of four matrices 16 numbers apart as lanes: lane k of v[i] is
/// p[16 k + i].
[[gnu::target("avx2")]] inline void lanes(const double* p, __m256d v[4]) {
  const __m256d t0 = halves(p, p + 32), t1 = halves(p + 16, p + 48);
  const __m256d t2 = halves(p + 2, p + 34), t3 = halves(p + 18, p + 50);
  v[0] = _mm256_unpacklo_pd(t0, t1);
  v[1] = _mm256_unpackhi_pd(t0, t1);
  v[2] = _mm256_unpacklo_pd(t2, t3);
  v[3] = _mm256_unpackhi_pd(t2, t3);
}

[[gnu::target("avx2")]] inline __m256d mul(__m256d x, __m256d y) {
  return _mm256_mul_pd(x, y);
}
[[gnu::target("avx2")]] inline __m256d add(__m256d x, __m256d y) {
  return _mm256_add_pd(x, y);
}
[[gnu::target("avx2")]] inline __m256d sub(__m256d x, __m256d y) {
  return _mm256_sub_pd(x, y);
}

}  // namespace avx2_lanes
}  // namespace detail
}  // namespace cube

#endif
