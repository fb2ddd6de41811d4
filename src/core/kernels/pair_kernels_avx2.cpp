// The AVX2 kernels: four double or eight float pairs per instruction. Each function carries
// target("avx2") and runs only after the CPU said it has AVX2: the rest of the library, Eigen
// and FCL stay built for the baseline, so their ABI is untouched.

#include <algorithm>
#include <utility>

#include "core/kernels/cpu_features.h"
#include "core/kernels/pair_kernels.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define CUBE_AVX2_KERNELS 1
#endif

namespace cube {
namespace detail {

#if defined(CUBE_AVX2_KERNELS)

namespace {

// The exact leaf mask four pairs per instruction in double: the boxes of ys, four at a time,
// are transposed into one register per coordinate, and each box of xs is compared with all four
// at once. Lanes past ny repeat a valid box and are masked off.
template <bool Self>
[[gnu::target("avx2")]] std::uint64_t leafHitsAvx2(const Item<double>* xs, std::uint32_t nx,
                                                   const Item<double>* ys, std::uint32_t ny) {
  std::uint64_t hits = 0;
  for (std::uint32_t j0 = 0; j0 < ny; j0 += 4) {
    const std::uint32_t m = std::min<std::uint32_t>(4, ny - j0);
    const Item<double>* y[4];
    for (std::uint32_t l = 0; l < 4; ++l) y[l] = ys + j0 + (l < m ? l : m - 1);
    // (lo0 lo1 lo2 hi0) of each, transposed; then (hi1 hi2) of each, interleaved.
    const __m256d r0 = _mm256_loadu_pd(y[0]->box.lo), r1 = _mm256_loadu_pd(y[1]->box.lo);
    const __m256d r2 = _mm256_loadu_pd(y[2]->box.lo), r3 = _mm256_loadu_pd(y[3]->box.lo);
    const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
    const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
    const __m256d lo0 = _mm256_permute2f128_pd(t0, t2, 0x20);
    const __m256d lo1 = _mm256_permute2f128_pd(t1, t3, 0x20);
    const __m256d lo2 = _mm256_permute2f128_pd(t0, t2, 0x31);
    const __m256d hi0 = _mm256_permute2f128_pd(t1, t3, 0x31);
    const __m256d a =
        _mm256_set_m128d(_mm_loadu_pd(y[2]->box.hi + 1), _mm_loadu_pd(y[0]->box.hi + 1));
    const __m256d b =
        _mm256_set_m128d(_mm_loadu_pd(y[3]->box.hi + 1), _mm_loadu_pd(y[1]->box.hi + 1));
    const __m256d hi1 = _mm256_unpacklo_pd(a, b), hi2 = _mm256_unpackhi_pd(a, b);
    const std::uint32_t valid = (1u << m) - 1;
    for (std::uint32_t i = 0; i < nx; ++i) {
      const double* x = xs[i].box.lo;
      __m256d hit = _mm256_and_pd(_mm256_cmp_pd(_mm256_broadcast_sd(x), hi0, _CMP_LE_OQ),
                                  _mm256_cmp_pd(lo0, _mm256_broadcast_sd(x + 3), _CMP_LE_OQ));
      hit = _mm256_and_pd(hit, _mm256_cmp_pd(_mm256_broadcast_sd(x + 1), hi1, _CMP_LE_OQ));
      hit = _mm256_and_pd(hit, _mm256_cmp_pd(lo1, _mm256_broadcast_sd(x + 4), _CMP_LE_OQ));
      hit = _mm256_and_pd(hit, _mm256_cmp_pd(_mm256_broadcast_sd(x + 2), hi2, _CMP_LE_OQ));
      hit = _mm256_and_pd(hit, _mm256_cmp_pd(lo2, _mm256_broadcast_sd(x + 5), _CMP_LE_OQ));
      std::uint32_t bits = std::uint32_t(_mm256_movemask_pd(hit)) & valid;
      if (Self) bits &= ~0u << std::min<std::uint32_t>(31, i + 1 > j0 ? i + 1 - j0 : 0);
      hits |= std::uint64_t(bits) << (kMaskLeaf * i + j0);
    }
  }
  return hits;
}

// The exact leaf mask in float, eight pairs per instruction: the boxes of ys (at most
// kMaskLeaf) transposed into one register per coordinate, each box of xs compared with all of
// them. Lanes past ny repeat a valid box and are masked off. Transposed in registers: copied
// through memory, each register's load waited for the eight narrower stores.
template <bool Self>
[[gnu::target("avx2")]] std::uint64_t leafHitsAvx2(const Item<float>* xs, std::uint32_t nx,
                                                   const Item<float>* ys, std::uint32_t ny) {
  static_assert(kMaskLeaf == 8, "one register of eight floats holds a leaf's coordinate");
  const Box<float>* y[8];
  for (std::uint32_t l = 0; l < 8; ++l) y[l] = &ys[l < ny ? l : ny - 1].box;
  // (lo0 lo1 lo2 hi0) of boxes l and l + 4 in the two halves, transposed half by half.
  __m256 r[4];
  for (int l = 0; l < 4; ++l)
    r[l] = _mm256_set_m128(_mm_loadu_ps(y[l + 4]->lo), _mm_loadu_ps(y[l]->lo));
  const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
  const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
  __m256 lo[3], hi[3];
  lo[0] = _mm256_shuffle_ps(t0, t2, 0x44);
  lo[1] = _mm256_shuffle_ps(t0, t2, 0xee);
  lo[2] = _mm256_shuffle_ps(t1, t3, 0x44);
  hi[0] = _mm256_shuffle_ps(t1, t3, 0xee);
  // (hi1 hi2) of each: four boxes per half.
  const auto half = [&](int l) {
    const auto pair = [](const Box<float>* b) {
      return _mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(b->hi + 1));
    };
    const __m128 u = _mm_unpacklo_ps(pair(y[l]), pair(y[l + 1]));      // a1 b1 a2 b2
    const __m128 v = _mm_unpacklo_ps(pair(y[l + 2]), pair(y[l + 3]));  // c1 d1 c2 d2
    return std::make_pair(_mm_movelh_ps(u, v), _mm_movehl_ps(v, u));
  };
  const auto h0 = half(0), h4 = half(4);
  hi[1] = _mm256_set_m128(h4.first, h0.first);
  hi[2] = _mm256_set_m128(h4.second, h0.second);
  const std::uint32_t valid = (1u << ny) - 1;
  std::uint64_t hits = 0;
  for (std::uint32_t i = 0; i < nx; ++i) {
    const float* x = xs[i].box.lo;  // lo0 lo1 lo2 hi0 hi1 hi2
    __m256 hit = _mm256_and_ps(_mm256_cmp_ps(_mm256_broadcast_ss(x), hi[0], _CMP_LE_OQ),
                               _mm256_cmp_ps(lo[0], _mm256_broadcast_ss(x + 3), _CMP_LE_OQ));
    for (int k = 1; k < 3; ++k)
      hit = _mm256_and_ps(
          hit, _mm256_and_ps(_mm256_cmp_ps(_mm256_broadcast_ss(x + k), hi[k], _CMP_LE_OQ),
                             _mm256_cmp_ps(lo[k], _mm256_broadcast_ss(x + 3 + k), _CMP_LE_OQ)));
    std::uint32_t bits = std::uint32_t(_mm256_movemask_ps(hit)) & valid;
    if (Self) bits &= ~0u << (i + 1);
    hits |= std::uint64_t(bits) << (kMaskLeaf * i);
  }
  return hits;
}

// The leaf mask from columns, eight pairs per instruction and no transpose. Lanes past ny read
// the next entries (the padding at the end) and are masked off.
template <bool Self>
[[gnu::target("avx2")]] std::uint64_t columnHitsAvx2(const Columns& c, std::uint32_t x0,
                                                     std::uint32_t nx, std::uint32_t y0,
                                                     std::uint32_t ny) {
  __m256 lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = _mm256_loadu_ps(c.lo(k) + y0);
    hi[k] = _mm256_loadu_ps(c.hi(k) + y0);
  }
  const std::uint32_t valid = (1u << ny) - 1;
  std::uint64_t hits = 0;
  for (std::uint32_t i = 0; i < nx; ++i) {
    const std::uint32_t x = x0 + i;
    // Started from axis 0's test, not from all ones: GCC keeps an and with an all-ones register
    // in the loop, one more instruction on its dependency chain.
    __m256 hit = _mm256_and_ps(_mm256_cmp_ps(_mm256_broadcast_ss(c.lo(0) + x), hi[0], _CMP_LE_OQ),
                               _mm256_cmp_ps(lo[0], _mm256_broadcast_ss(c.hi(0) + x), _CMP_LE_OQ));
    for (int k = 1; k < 3; ++k)
      hit = _mm256_and_ps(
          hit, _mm256_and_ps(_mm256_cmp_ps(_mm256_broadcast_ss(c.lo(k) + x), hi[k], _CMP_LE_OQ),
                             _mm256_cmp_ps(lo[k], _mm256_broadcast_ss(c.hi(k) + x), _CMP_LE_OQ)));
    std::uint32_t bits = std::uint32_t(_mm256_movemask_ps(hit)) & valid;
    if (Self) bits &= ~0u << (i + 1);
    hits |= std::uint64_t(bits) << (kMaskLeaf * i);
  }
  return hits;
}

template <bool Self>
[[gnu::target("avx2")]] void rowMasksAvx2(const Columns& xs, std::uint32_t nx,
                                          const Columns& ys_arg, std::uint32_t ny,
                                          std::uint64_t* rows) {
  // One set of columns when Self: the compiler then keeps six column pointers in registers,
  // not twelve (which it reloaded at every row, a sixth more instructions).
  const Columns& ys = Self ? xs : ys_arg;
  for (std::uint32_t i = 0; i < nx; ++i) {
    __m256 lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = _mm256_set1_ps(xs.lo(k)[i]);
      hi[k] = _mm256_set1_ps(xs.hi(k)[i]);
    }
    std::uint64_t m = 0;
    for (std::uint32_t j = Self ? (i + 1) & ~7u : 0; j < ny; j += 8) {
      __m256 hit =  // from axis 0's test, as in columnHitsAvx2
          _mm256_and_ps(_mm256_cmp_ps(lo[0], _mm256_load_ps(ys.hi(0) + j), _CMP_LE_OQ),
                        _mm256_cmp_ps(_mm256_load_ps(ys.lo(0) + j), hi[0], _CMP_LE_OQ));
      for (int k = 1; k < 3; ++k)
        hit = _mm256_and_ps(
            hit, _mm256_and_ps(_mm256_cmp_ps(lo[k], _mm256_load_ps(ys.hi(k) + j), _CMP_LE_OQ),
                               _mm256_cmp_ps(_mm256_load_ps(ys.lo(k) + j), hi[k], _CMP_LE_OQ)));
      m |= std::uint64_t(_mm256_movemask_ps(hit)) << j;
    }
    rows[i] = Self ? m & ((~std::uint64_t(0) << i) << 1) : m;
  }
}

template <typename S>
PairKernels<S> makeAvx2() {
  PairKernels<S> k = *sse2Kernels<S>();  // what AVX2 does not replace
  k.isa = PairKernel::avx2;
  k.rowMasks[0] = &rowMasksAvx2<false>;
  k.rowMasks[1] = &rowMasksAvx2<true>;
  // Float boxes are exact in float columns (their recheck always passes).
  k.columnHits[0] = &columnHitsAvx2<false>;
  k.columnHits[1] = &columnHitsAvx2<true>;
  k.leafHits[0] = &leafHitsAvx2<false>;
  k.leafHits[1] = &leafHitsAvx2<true>;
  return k;
}

}  // namespace

template <typename S>
const PairKernels<S>* avx2Kernels() {
  static const PairKernels<S> table = makeAvx2<S>();
  return cpuHasAvx2() ? &table : nullptr;
}

#else

template <typename S>
const PairKernels<S>* avx2Kernels() {
  return nullptr;
}

#endif

template const PairKernels<float>* avx2Kernels<float>();
template const PairKernels<double>* avx2Kernels<double>();

}  // namespace detail
}  // namespace cube
