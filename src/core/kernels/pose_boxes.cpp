// Posed boxes (pose_boxes.h): portable, and AVX2 for double (four objects per instruction).

#include "core/kernels/pose_boxes.h"

#include <cmath>

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

#if defined(CUBE_POSE_AVX2)

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

bool hasAvx2() {
  static const bool yes = __builtin_cpu_supports("avx2");
  return yes;
}

#endif

}  // namespace

void poseBoxes(const double* poses, std::size_t n, const PoseBoxes<double>& io) {
  std::size_t done = 0;
#if defined(CUBE_POSE_AVX2)
  if (hasAvx2()) done = avx2(poses, n, io);
#endif
  portable(poses, done, n, io);
}

void poseBoxes(const float* poses, std::size_t n, const PoseBoxes<float>& io) {
  portable(poses, 0, n, io);
}

void poseBoxesPortable(const double* poses, std::size_t n, const PoseBoxes<double>& io) {
  portable(poses, 0, n, io);
}

}  // namespace detail
}  // namespace cube
