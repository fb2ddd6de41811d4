// Rigid transforms from row-major matrices (rigid_rows.h): portable, and AVX2 (four matrices at a
// time, one per lane, and one matrix row per register for the last few). Both compute every test
// with the same operations in the same order, without fused multiply-adds, so they agree bit for
// bit.

#include "core/kernels/rigid_rows.h"

#include <cmath>

#include "core/kernels/avx2_lanes.h"
#include "core/kernels/cpu_features.h"

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

#if defined(CUBE_KERNELS_AVX2)

// (v1, v2, v0, v3): each lane's partner column for the dot products.
[[gnu::target("avx2")]] inline __m256d rotate(__m256d v) {
  return _mm256_permute4x64_pd(v, 0xC9);  // lanes 1, 2, 0, 3
}

using avx2_lanes::add;
using avx2_lanes::halves;
using avx2_lanes::mul;
using avx2_lanes::sub;

// Matrix m (row-major) into o (column-major): column j is (r0[j], r1[j], r2[j], r3[j]).
[[gnu::target("avx2")]] inline void transpose(const double* m, double* o) {
  const __m256d a = halves(m, m + 8), b = halves(m + 4, m + 12);
  const __m256d c = halves(m + 2, m + 10), d = halves(m + 6, m + 14);
  _mm256_storeu_pd(o, _mm256_unpacklo_pd(a, b));
  _mm256_storeu_pd(o + 4, _mm256_unpackhi_pd(a, b));
  _mm256_storeu_pd(o + 8, _mm256_unpacklo_pd(c, d));
  _mm256_storeu_pd(o + 12, _mm256_unpackhi_pd(c, d));
}

// |x| <= tol, false for a NaN.
[[gnu::target("avx2")]] inline __m256d within(__m256d x, __m256d tol) {
  return _mm256_cmp_pd(_mm256_andnot_pd(_mm256_set1_pd(-0.0), x), tol, _CMP_LE_OQ);
}

// Columns j of the four matrices into o (column-major, 16 numbers apart) from their rows' lanes
// e0, e1, e2 (lane p: matrix p's entry in that row and column j) and the last row's entry w.
[[gnu::target("avx2")]] inline void columns(__m256d e0, __m256d e1, __m256d e2, __m256d w,
                                            double* o) {
  const __m256d lo01 = _mm256_unpacklo_pd(e0, e1), hi01 = _mm256_unpackhi_pd(e0, e1);
  const __m256d lo2w = _mm256_unpacklo_pd(e2, w), hi2w = _mm256_unpackhi_pd(e2, w);
  _mm256_storeu_pd(o, _mm256_permute2f128_pd(lo01, lo2w, 0x20));
  _mm256_storeu_pd(o + 16, _mm256_permute2f128_pd(hi01, hi2w, 0x20));
  _mm256_storeu_pd(o + 32, _mm256_permute2f128_pd(lo01, lo2w, 0x31));
  _mm256_storeu_pd(o + 48, _mm256_permute2f128_pd(hi01, hi2w, 0x31));
}

// Whether the four matrices m[0 .. 64) all pass, with lane p holding matrix p's entries and
// rigidPortable's operations in its order per lane; all four written to o if so, none if not
// (from the lanes already loaded: the last row is known once it passed).
[[gnu::target("avx2"), gnu::always_inline]] inline bool fourPass(const double* m, double* o) {
  const __m256d one = _mm256_set1_pd(1.0);
  const __m256d tol = _mm256_set1_pd(kRigidRowsTolerance);
  // e[r][j]: entry (r, j) of the four. Rows 0-2: the last row is compared whole below.
  __m256d e[3][4];
  for (int r = 0; r < 3; ++r) avx2_lanes::lanes(m + 4 * r, e[r]);
  const __m256d last = _mm256_set_pd(1.0, 0.0, 0.0, 0.0);
  __m256d ok =
      _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(_mm256_loadu_pd(m + 12), last, _CMP_EQ_OQ),
                                  _mm256_cmp_pd(_mm256_loadu_pd(m + 28), last, _CMP_EQ_OQ)),
                    _mm256_and_pd(_mm256_cmp_pd(_mm256_loadu_pd(m + 44), last, _CMP_EQ_OQ),
                                  _mm256_cmp_pd(_mm256_loadu_pd(m + 60), last, _CMP_EQ_OQ)));
  for (int j = 0; j < 3; ++j) {
    const int p = (j + 1) % 3;  // the portable lane rotation
    const __m256d s = add(add(mul(e[0][j], e[0][j]), mul(e[1][j], e[1][j])), mul(e[2][j], e[2][j]));
    const __m256d q = add(add(mul(e[0][j], e[0][p]), mul(e[1][j], e[1][p])), mul(e[2][j], e[2][p]));
    ok = _mm256_and_pd(ok, _mm256_and_pd(within(sub(s, one), tol), within(q, tol)));
  }
  const __m256d fin = add(add(sub(e[0][3], e[0][3]), sub(e[1][3], e[1][3])), sub(e[2][3], e[2][3]));
  const __m256d x0 = sub(mul(e[1][1], e[2][2]), mul(e[1][2], e[2][1]));
  const __m256d x1 = sub(mul(e[1][2], e[2][0]), mul(e[1][0], e[2][2]));
  const __m256d x2 = sub(mul(e[1][0], e[2][1]), mul(e[1][1], e[2][0]));
  const __m256d det = add(add(mul(e[0][0], x0), mul(e[0][1], x1)), mul(e[0][2], x2));
  ok = _mm256_and_pd(ok, _mm256_cmp_pd(fin, _mm256_setzero_pd(), _CMP_EQ_OQ));
  ok = _mm256_and_pd(ok, _mm256_cmp_pd(det, _mm256_set1_pd(0.5), _CMP_GT_OQ));
  if (_mm256_movemask_pd(ok) != 15) return false;
  const __m256d zero = _mm256_setzero_pd();
  for (int j = 0; j < 3; ++j) columns(e[0][j], e[1][j], e[2][j], zero, o + 4 * j);
  columns(e[0][3], e[1][3], e[2][3], one, o + 12);
  return true;
}

// Whether matrix m passes (one row per register); written to o if so.
[[gnu::target("avx2")]] inline bool onePasses(const double* m, double* o) {
  const __m256d one = _mm256_set1_pd(1.0);
  const __m256d tol = _mm256_set1_pd(kRigidRowsTolerance);
  const __m256d last = _mm256_set_pd(1.0, 0.0, 0.0, 0.0);
  const __m256d r0 = _mm256_loadu_pd(m), r1 = _mm256_loadu_pd(m + 4);
  const __m256d r2 = _mm256_loadu_pd(m + 8), r3 = _mm256_loadu_pd(m + 12);
  const __m256d s = add(add(mul(r0, r0), mul(r1, r1)), mul(r2, r2));
  const __m256d q = add(add(mul(r0, rotate(r0)), mul(r1, rotate(r1))), mul(r2, rotate(r2)));
  const __m256d fin = add(add(sub(r0, r0), sub(r1, r1)), sub(r2, r2));
  // The determinant from the matrix in memory, in the portable order: in registers, the cross
  // product's lane rotations would queue behind the transpose's on the one shuffle port.
  const double x0 = m[5] * m[10] - m[6] * m[9];
  const double x1 = m[6] * m[8] - m[4] * m[10];
  const double x2 = m[4] * m[9] - m[5] * m[8];
  const double det = (m[0] * x0 + m[1] * x1) + m[2] * x2;
  // Lanes 0-2: norms and dot products; lane 3: the translation finite; and the last row. One
  // mask for all of them.
  const __m256d fin_ok = _mm256_cmp_pd(fin, _mm256_setzero_pd(), _CMP_EQ_OQ);
  const __m256d last_ok = _mm256_cmp_pd(r3, last, _CMP_EQ_OQ);
  const __m256d ok = _mm256_and_pd(
      _mm256_blend_pd(_mm256_and_pd(within(sub(s, one), tol), within(q, tol)), fin_ok, 0x8),
      last_ok);
  if (!((_mm256_movemask_pd(ok) == 15) & (det > 0.5))) return false;
  transpose(m, o);
  return true;
}

[[gnu::target("avx2")]] std::size_t avx2(const double* rows, std::size_t n, double* cols) {
  std::size_t k = 0;
  // Four at a time while all four pass; from four with one that fails, and for the last few,
  // one at a time up to the first that fails.
  while (k + 4 <= n && fourPass(rows + 16 * k, cols + 16 * k)) k += 4;
  for (; k < n; ++k)
    if (!onePasses(rows + 16 * k, cols + 16 * k)) return k;
  return n;
}

#endif

}  // namespace

std::size_t rigidRows(const double* rows, std::size_t n, double* cols) {
#if defined(CUBE_KERNELS_AVX2)
  if (cpuHasAvx2()) return avx2(rows, n, cols);
#endif
  return portable(rows, 0, n, cols);
}

std::size_t rigidRowsPortable(const double* rows, std::size_t n, double* cols) {
  return portable(rows, 0, n, cols);
}

}  // namespace detail
}  // namespace cube
