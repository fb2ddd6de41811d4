// Rigid transforms from row-major matrices (rigid_rows.h): portable, and AVX2 (one matrix row
// per register). Both compute every test with the same operations in the same order, without
// fused multiply-adds, so they agree bit for bit.

#include "core/kernels/rigid_rows.h"

#include <cmath>

#include "core/kernels/cpu_features.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define CUBE_RIGID_AVX2 1
#endif

namespace cube {
namespace detail {

namespace {

// Whether matrix m (row-major) passes rigidRows' checks. With rows r_i = (a_i, b_i, c_i, t_i):
// the columns' squared norms and dot products are sums over the rows taken in row order, and
// the determinant is r_0 . (r_1 x r_2).
bool rigidPortable(const double* m) {
  const double* r0 = m;
  const double* r1 = m + 4;
  const double* r2 = m + 8;
  double s[4], q[4];
  for (int j = 0; j < 4; ++j) {
    const int p = j == 3 ? 3 : (j + 1) % 3;  // the lane rotation (b, c, a, t)
    s[j] = (r0[j] * r0[j] + r1[j] * r1[j]) + r2[j] * r2[j];
    q[j] = (r0[j] * r0[p] + r1[j] * r1[p]) + r2[j] * r2[p];
  }
  // x - x is 0 for a finite x, NaN otherwise.
  const double t = ((r0[3] - r0[3]) + (r1[3] - r1[3])) + (r2[3] - r2[3]);
  const double x0 = r1[1] * r2[2] - r1[2] * r2[1];
  const double x1 = r1[2] * r2[0] - r1[0] * r2[2];
  const double x2 = r1[0] * r2[1] - r1[1] * r2[0];
  const double det = (r0[0] * x0 + r0[1] * x1) + r0[2] * x2;
  constexpr double tol = kRigidRowsTolerance;
  return (t == 0) & (m[12] == 0) & (m[13] == 0) & (m[14] == 0) & (m[15] == 1) &
         (std::fabs(s[0] - 1) <= tol) & (std::fabs(s[1] - 1) <= tol) &
         (std::fabs(s[2] - 1) <= tol) & (std::fabs(q[0]) <= tol) & (std::fabs(q[1]) <= tol) &
         (std::fabs(q[2]) <= tol) & (det > 0.5);
}

std::size_t portable(const double* rows, std::size_t begin, std::size_t n, double* cols) {
  for (std::size_t k = begin; k < n; ++k) {
    const double* m = rows + 16 * k;
    if (!rigidPortable(m)) return k;
    double* o = cols + 16 * k;
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 4; ++row) o[4 * col + row] = m[4 * row + col];
  }
  return n;
}

#if defined(CUBE_RIGID_AVX2)

// (v1, v2, v0, v3): each lane's partner column for the dot products.
[[gnu::target("avx2")]] inline __m256d rotate(__m256d v) {
  return _mm256_permute4x64_pd(v, 0xC9);  // lanes 1, 2, 0, 3
}

[[gnu::target("avx2")]] std::size_t avx2(const double* rows, std::size_t n, double* cols) {
  const __m256d sign = _mm256_set1_pd(-0.0);
  const __m256d one = _mm256_set1_pd(1.0);
  const __m256d tol = _mm256_set1_pd(kRigidRowsTolerance);
  const __m256d last = _mm256_set_pd(1.0, 0.0, 0.0, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const double* m = rows + 16 * k;
    const __m256d r0 = _mm256_loadu_pd(m), r1 = _mm256_loadu_pd(m + 4);
    const __m256d r2 = _mm256_loadu_pd(m + 8), r3 = _mm256_loadu_pd(m + 12);
    const __m256d s = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(r0, r0), _mm256_mul_pd(r1, r1)),
                                    _mm256_mul_pd(r2, r2));
    const __m256d q =
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(r0, rotate(r0)), _mm256_mul_pd(r1, rotate(r1))),
                      _mm256_mul_pd(r2, rotate(r2)));
    const __m256d fin = _mm256_add_pd(_mm256_add_pd(_mm256_sub_pd(r0, r0), _mm256_sub_pd(r1, r1)),
                                      _mm256_sub_pd(r2, r2));
    // The determinant from the matrix in memory, in the portable order: in registers, the
    // cross product's lane rotations would queue behind the transpose's on the one shuffle port.
    const double x0 = m[5] * m[10] - m[6] * m[9];
    const double x1 = m[6] * m[8] - m[4] * m[10];
    const double x2 = m[4] * m[9] - m[5] * m[8];
    const double det = (m[0] * x0 + m[1] * x1) + m[2] * x2;
    // Lanes 0-2: norms and dot products; lane 3: the translation finite; and the last row. One
    // mask for all of them.
    const __m256d norm_ok =
        _mm256_cmp_pd(_mm256_andnot_pd(sign, _mm256_sub_pd(s, one)), tol, _CMP_LE_OQ);
    const __m256d dot_ok = _mm256_cmp_pd(_mm256_andnot_pd(sign, q), tol, _CMP_LE_OQ);
    const __m256d fin_ok = _mm256_cmp_pd(fin, _mm256_setzero_pd(), _CMP_EQ_OQ);
    const __m256d last_ok = _mm256_cmp_pd(r3, last, _CMP_EQ_OQ);
    const __m256d ok =
        _mm256_and_pd(_mm256_blend_pd(_mm256_and_pd(norm_ok, dot_ok), fin_ok, 0x8), last_ok);
    if (!((_mm256_movemask_pd(ok) == 15) & (det > 0.5))) return k;
    // The transpose: column j is (r0[j], r1[j], r2[j], r3[j]).
    const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
    const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
    double* o = cols + 16 * k;
    _mm256_storeu_pd(o, _mm256_permute2f128_pd(t0, t2, 0x20));
    _mm256_storeu_pd(o + 4, _mm256_permute2f128_pd(t1, t3, 0x20));
    _mm256_storeu_pd(o + 8, _mm256_permute2f128_pd(t0, t2, 0x31));
    _mm256_storeu_pd(o + 12, _mm256_permute2f128_pd(t1, t3, 0x31));
  }
  return n;
}

#endif

}  // namespace

std::size_t rigidRows(const double* rows, std::size_t n, double* cols) {
#if defined(CUBE_RIGID_AVX2)
  if (cpuHasAvx2()) return avx2(rows, n, cols);
#endif
  return portable(rows, 0, n, cols);
}

std::size_t rigidRowsPortable(const double* rows, std::size_t n, double* cols) {
  return portable(rows, 0, n, cols);
}

}  // namespace detail
}  // namespace cube
