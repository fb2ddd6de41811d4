// The SSE2 kernels: four float pairs per instruction. SSE2 is x86-64's baseline (no -m flag,
// so no effect on Eigen's ABI); elsewhere this table does not exist.

#include "core/kernels/pair_kernels.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace cube {
namespace detail {

#if defined(__SSE2__)

namespace {

inline std::uint64_t above(std::uint32_t i) {
  return (~std::uint64_t(0) << i) << 1;
}

void rowMasksSse2(const Columns& f, std::uint32_t n, std::uint64_t* rows) {
  for (std::uint32_t i = 0; i < n; ++i) {
    __m128 lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = _mm_set1_ps(f.lo(k)[i]);
      hi[k] = _mm_set1_ps(f.hi(k)[i]);
    }
    std::uint64_t m = 0;
    for (std::uint32_t j = (i + 1) & ~3u; j < n; j += 4) {
      __m128 hit = _mm_castsi128_ps(_mm_set1_epi32(-1));
      for (int k = 0; k < 3; ++k)
        hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmple_ps(lo[k], _mm_load_ps(f.hi(k) + j)),
                                         _mm_cmple_ps(_mm_load_ps(f.lo(k) + j), hi[k])));
      m |= std::uint64_t(_mm_movemask_ps(hit)) << j;
    }
    rows[i] = m & above(i);
  }
}

// Four boxes at a time: each becomes (lo0 lo1 lo2 hi0) and (hi1 hi2) in float, and a 4 x 4
// transpose makes columns of those (a third of the instructions of a box-by-box copy). The
// conversion rounds to nearest, as static_cast does.
void fillSse2(const Item<double>* items, const std::uint32_t* slot, std::uint32_t count,
              const Columns& f, std::uint32_t at) {
  std::uint32_t i = 0;
  auto box = [&](std::uint32_t j) -> const Box<double>& { return items[slot ? slot[j] : j].box; };
  for (; i + 4 <= count; i += 4) {
    __m128 r[4], t[2];
    for (std::uint32_t l = 0; l < 4; ++l) {
      const double* c = box(i + l).lo;  // lo0 lo1 lo2 hi0 hi1 hi2, contiguous
      r[l] = _mm_movelh_ps(_mm_cvtpd_ps(_mm_loadu_pd(c)), _mm_cvtpd_ps(_mm_loadu_pd(c + 2)));
    }
    for (std::uint32_t l = 0; l < 2; ++l)
      t[l] = _mm_movelh_ps(_mm_cvtpd_ps(_mm_loadu_pd(box(i + 2 * l).hi + 1)),
                           _mm_cvtpd_ps(_mm_loadu_pd(box(i + 2 * l + 1).hi + 1)));
    _MM_TRANSPOSE4_PS(r[0], r[1], r[2], r[3]);
    const std::uint32_t n = at + i;
    _mm_storeu_ps(f.lo(0) + n, r[0]);
    _mm_storeu_ps(f.lo(1) + n, r[1]);
    _mm_storeu_ps(f.lo(2) + n, r[2]);
    _mm_storeu_ps(f.hi(0) + n, r[3]);
    _mm_storeu_ps(f.hi(1) + n, _mm_shuffle_ps(t[0], t[1], _MM_SHUFFLE(2, 0, 2, 0)));
    _mm_storeu_ps(f.hi(2) + n, _mm_shuffle_ps(t[0], t[1], _MM_SHUFFLE(3, 1, 3, 1)));
  }
  for (; i < count; ++i)
    for (int k = 0; k < 3; ++k) {
      f.lo(k)[at + i] = static_cast<float>(box(i).lo[k]);
      f.hi(k)[at + i] = static_cast<float>(box(i).hi[k]);
    }
}

template <typename S>
PairKernels<S> makeSse2() {
  PairKernels<S> k = *portableKernels<S>();
  k.isa = PairKernel::sse2;
  k.rowMasks = &rowMasksSse2;
  if constexpr (std::is_same_v<S, double>) k.fill = &fillSse2;
  return k;
}

}  // namespace

template <typename S>
const PairKernels<S>* sse2Kernels() {
  static const PairKernels<S> table = makeSse2<S>();
  return &table;
}

#else

template <typename S>
const PairKernels<S>* sse2Kernels() {
  return nullptr;
}

#endif

template const PairKernels<float>* sse2Kernels<float>();
template const PairKernels<double>* sse2Kernels<double>();

}  // namespace detail
}  // namespace cube
