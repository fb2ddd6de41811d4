// Posed boxes (pose_boxes.h): portable, and AVX2 for double (four objects per instruction).

#include "core/kernels/pose_boxes.h"

#include <algorithm>
#include <cmath>

#include "core/kernels/cpu_features.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define CUBE_POSE_AVX2 1
#endif

namespace cube {
namespace detail {

namespace {

template <typename S>
void portable(const S* poses, std::size_t begin, std::size_t n, const PoseBoxes<S>& io) {
  for (std::size_t k = begin; k < n; ++k) {
    const S* m = poses + 16 * k;  // m[4 column + row]
    const S mid[3] = {io.mid[0][k], io.mid[1][k], io.mid[2][k]};
    const S half[3] = {io.half[0][k], io.half[1][k], io.half[2][k]};
    for (int r = 0; r < 3; ++r) {
      io.c[r][k] = m[r] * mid[0] + m[4 + r] * mid[1] + m[8 + r] * mid[2] + m[12 + r];
      io.h[r][k] =
          std::fabs(m[r]) * half[0] + std::fabs(m[4 + r]) * half[1] + std::fabs(m[8 + r]) * half[2];
    }
  }
}

// The walk's boxes of objects begin .. n-1; whether their c and h are finite.
template <typename S>
bool walkPortable(std::size_t begin, std::size_t n, const WalkBoxes<S>& io) {
  bool ok = true;
  for (std::size_t k = begin; k < n; ++k) {
    const S c[3] = {io.c[0][k], io.c[1][k], io.c[2][k]};
    const S h[3] = {io.h[0][k], io.h[1][k], io.h[2][k]};
    // x - x is 0 for a finite x and NaN otherwise.
    const S zero = ((c[0] - c[0]) + (c[1] - c[1])) + ((c[2] - c[2]) + (h[0] - h[0])) +
                   ((h[1] - h[1]) + (h[2] - h[2]));
    ok = ok && zero == S(0);
    const S far = std::max(std::max(std::fabs(c[0]), std::fabs(c[1])), std::fabs(c[2]));
    const S wide = std::max(std::max(h[0], h[1]), h[2]);
    const S g = io.rate * (S(1) + (far + wide));
    io.grow[k] = g;
    const S w = g + io.margin[k];
    for (int d = 0; d < 3; ++d) {
      io.lo[d][k] = (c[d] - h[d]) - w;
      io.hi[d][k] = (c[d] + h[d]) + w;
    }
  }
  return ok;
}

// The sum of finite numbers is finite or overflows; one with a NaN or an infinity is not.
template <typename S>
bool sumPortable(const S* x, std::size_t begin, std::size_t n, S sum) {
  for (std::size_t k = begin; k < n; ++k) sum += x[k];
  return sum - sum == S(0);
}

// Objects begin .. end-1 of positionBoxes; whether their translations are finite.
template <typename S>
bool positionsPortable(const S* const* states, std::size_t count, std::size_t begin,
                       std::size_t end, S* const lo[3], S* const hi[3]) {
  S zero = 0;  // x - x is 0 for a finite x and NaN otherwise
  for (std::size_t k = begin; k < end; ++k) {
    const S* t = states[0] + 16 * k + 12;
    S a[3] = {t[0], t[1], t[2]}, b[3] = {t[0], t[1], t[2]};
    for (std::size_t j = 0; j < count; ++j) {
      t = states[j] + 16 * k + 12;
      for (int d = 0; d < 3; ++d) {
        a[d] = std::min(a[d], t[d]);
        b[d] = std::max(b[d], t[d]);
        zero += t[d] - t[d];
      }
    }
    for (int d = 0; d < 3; ++d) {
      lo[d][k] = a[d];
      hi[d][k] = b[d];
    }
  }
  return zero == S(0);
}

#if defined(CUBE_POSE_AVX2)

// positionsPortable one object at a time, its three coordinates (and the pose's last entry as
// a fourth lane) in one instruction; min and max give what the portable version does.
[[gnu::target("avx2")]] bool positionsAvx2(const double* const* states, std::size_t count,
                                           std::size_t begin, std::size_t end, double* const lo[3],
                                           double* const hi[3]) {
  __m256d zero = _mm256_setzero_pd();
  for (std::size_t k = begin; k < end; ++k) {
    __m256d a = _mm256_loadu_pd(states[0] + 16 * k + 12), b = a;
    for (std::size_t j = 0; j < count; ++j) {
      const __m256d t = _mm256_loadu_pd(states[j] + 16 * k + 12);
      a = _mm256_min_pd(t, a);  // t < a ? t : a, as std::min(a, t)
      b = _mm256_max_pd(t, b);  // t > b ? t : b, as std::max(b, t)
      zero = _mm256_add_pd(zero, _mm256_sub_pd(t, t));
    }
    double x[4], y[4];
    _mm256_storeu_pd(x, a);
    _mm256_storeu_pd(y, b);
    for (int d = 0; d < 3; ++d) {
      lo[d][k] = x[d];
      hi[d][k] = y[d];
    }
  }
  // The fourth lane (the pose's last entry, which the portable version does not read) is left out.
  return (_mm256_movemask_pd(_mm256_cmp_pd(zero, _mm256_setzero_pd(), _CMP_NEQ_UQ)) & 7) == 0;
}

[[gnu::target("avx2")]] std::size_t sumAvx2(const double* x, std::size_t n, double& sum) {
  __m256d a = _mm256_setzero_pd(), b = a, c = a, d = a;
  std::size_t k = 0;
  for (; k + 16 <= n; k += 16) {
    a = _mm256_add_pd(a, _mm256_loadu_pd(x + k));
    b = _mm256_add_pd(b, _mm256_loadu_pd(x + k + 4));
    c = _mm256_add_pd(c, _mm256_loadu_pd(x + k + 8));
    d = _mm256_add_pd(d, _mm256_loadu_pd(x + k + 12));
  }
  double lanes[4];
  _mm256_storeu_pd(lanes, _mm256_add_pd(_mm256_add_pd(a, b), _mm256_add_pd(c, d)));
  sum = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
  return k;
}

// walkPortable four objects at a time, the same operations per lane in the same order; the
// objects done (a multiple of four).
[[gnu::target("avx2")]] std::size_t walkAvx2(std::size_t n, const WalkBoxes<double>& io, bool& ok) {
  const __m256d sign = _mm256_set1_pd(-0.0), one = _mm256_set1_pd(1.0);
  const __m256d rate = _mm256_set1_pd(io.rate), zero = _mm256_setzero_pd();
  __m256d bad = zero;
  std::size_t k = 0;
  for (; k + 4 <= n; k += 4) {
    __m256d c[3], h[3];
    for (int d = 0; d < 3; ++d) {
      c[d] = _mm256_loadu_pd(io.c[d] + k);
      h[d] = _mm256_loadu_pd(io.h[d] + k);
    }
    const __m256d z = _mm256_add_pd(
        _mm256_add_pd(_mm256_add_pd(_mm256_sub_pd(c[0], c[0]), _mm256_sub_pd(c[1], c[1])),
                      _mm256_add_pd(_mm256_sub_pd(c[2], c[2]), _mm256_sub_pd(h[0], h[0]))),
        _mm256_add_pd(_mm256_sub_pd(h[1], h[1]), _mm256_sub_pd(h[2], h[2])));
    bad = _mm256_or_pd(bad, _mm256_cmp_pd(z, zero, _CMP_NEQ_UQ));
    const __m256d far =
        _mm256_max_pd(_mm256_max_pd(_mm256_andnot_pd(sign, c[0]), _mm256_andnot_pd(sign, c[1])),
                      _mm256_andnot_pd(sign, c[2]));
    const __m256d wide = _mm256_max_pd(_mm256_max_pd(h[0], h[1]), h[2]);
    const __m256d g = _mm256_mul_pd(rate, _mm256_add_pd(one, _mm256_add_pd(far, wide)));
    _mm256_storeu_pd(io.grow + k, g);
    const __m256d w = _mm256_add_pd(g, _mm256_loadu_pd(io.margin + k));
    for (int d = 0; d < 3; ++d) {
      _mm256_storeu_pd(io.lo[d] + k, _mm256_sub_pd(_mm256_sub_pd(c[d], h[d]), w));
      _mm256_storeu_pd(io.hi[d] + k, _mm256_add_pd(_mm256_add_pd(c[d], h[d]), w));
    }
  }
  ok = _mm256_movemask_pd(bad) == 0;
  return k;
}

// Entry e of four consecutive poses, one per lane.
[[gnu::target("avx2")]] inline __m256d lanes(const double* p, int e) {
  return _mm256_set_pd(p[48 + e], p[32 + e], p[16 + e], p[e]);
}

[[gnu::target("avx2")]] std::size_t avx2(const double* poses, std::size_t n,
                                         const PoseBoxes<double>& io) {
  const __m256d sign = _mm256_set1_pd(-0.0);
  std::size_t k = 0;
  for (; k + 4 <= n; k += 4) {
    const double* p = poses + 16 * k;
    __m256d mid[3], half[3];
    for (int d = 0; d < 3; ++d) {
      mid[d] = _mm256_loadu_pd(io.mid[d] + k);
      half[d] = _mm256_loadu_pd(io.half[d] + k);
    }
    for (int r = 0; r < 3; ++r) {
      const __m256d a = lanes(p, r), b = lanes(p, 4 + r), c = lanes(p, 8 + r);
      // The same operations in the same order as the portable version: same results.
      __m256d centre = _mm256_add_pd(
          _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(a, mid[0]), _mm256_mul_pd(b, mid[1])),
                        _mm256_mul_pd(c, mid[2])),
          lanes(p, 12 + r));
      __m256d extent =
          _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_andnot_pd(sign, a), half[0]),
                                      _mm256_mul_pd(_mm256_andnot_pd(sign, b), half[1])),
                        _mm256_mul_pd(_mm256_andnot_pd(sign, c), half[2]));
      _mm256_storeu_pd(io.c[r] + k, centre);
      _mm256_storeu_pd(io.h[r] + k, extent);
    }
  }
  return k;
}

#endif

}  // namespace

void poseBoxes(const double* poses, std::size_t n, const PoseBoxes<double>& io) {
  std::size_t done = 0;
#if defined(CUBE_POSE_AVX2)
  if (cpuHasAvx2()) done = avx2(poses, n, io);
#endif
  portable(poses, done, n, io);
}

void poseBoxes(const float* poses, std::size_t n, const PoseBoxes<float>& io) {
  portable(poses, 0, n, io);
}

void poseBoxesPortable(const double* poses, std::size_t n, const PoseBoxes<double>& io) {
  portable(poses, 0, n, io);
}

bool walkBoxes(std::size_t n, const WalkBoxes<double>& io) {
  std::size_t done = 0;
  bool ok = true;
#if defined(CUBE_POSE_AVX2)
  if (cpuHasAvx2()) done = walkAvx2(n, io, ok);
#endif
  return walkPortable(done, n, io) && ok;
}

bool walkBoxes(std::size_t n, const WalkBoxes<float>& io) {
  return walkPortable(0, n, io);
}

bool walkBoxesPortable(std::size_t n, const WalkBoxes<double>& io) {
  return walkPortable(0, n, io);
}

bool sumIsFinite(const double* x, std::size_t n) {
  std::size_t done = 0;
  double sum = 0;
#if defined(CUBE_POSE_AVX2)
  if (cpuHasAvx2()) done = sumAvx2(x, n, sum);
#endif
  return sumPortable(x, done, n, sum);
}

bool positionBoxes(const double* const* states, std::size_t count, std::size_t first, std::size_t n,
                   double* const lo[3], double* const hi[3]) {
#if defined(CUBE_POSE_AVX2)
  if (cpuHasAvx2()) return positionsAvx2(states, count, first, first + n, lo, hi);
#endif
  return positionsPortable(states, count, first, first + n, lo, hi);
}

bool positionBoxes(const float* const* states, std::size_t count, std::size_t first, std::size_t n,
                   float* const lo[3], float* const hi[3]) {
  return positionsPortable(states, count, first, first + n, lo, hi);
}

bool positionBoxesPortable(const double* const* states, std::size_t count, std::size_t first,
                           std::size_t n, double* const lo[3], double* const hi[3]) {
  return positionsPortable(states, count, first, first + n, lo, hi);
}

bool sumIsFinite(const float* x, std::size_t n) {
  return sumPortable(x, 0, n, 0.0f);
}

bool sumIsFinitePortable(const double* x, std::size_t n) {
  return sumPortable(x, 0, n, 0.0);
}

}  // namespace detail
}  // namespace cube
