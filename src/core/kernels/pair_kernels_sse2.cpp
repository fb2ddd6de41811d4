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

template <bool Self>
void rowMasksSse2(const Columns& xs, std::uint32_t nx, const Columns& ys_arg, std::uint32_t ny,
                  std::uint64_t* rows) {
  // One set of columns when Self: the compiler then keeps six column pointers in registers,
  // not twelve (which it reloaded at every row, a sixth more instructions).
  const Columns& ys = Self ? xs : ys_arg;
  for (std::uint32_t i = 0; i < nx; ++i) {
    __m128 lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = _mm_set1_ps(xs.lo(k)[i]);
      hi[k] = _mm_set1_ps(xs.hi(k)[i]);
    }
    std::uint64_t m = 0;
    for (std::uint32_t j = Self ? (i + 1) & ~3u : 0; j < ny; j += 4) {
      // Started from axis 0's test, not from all ones (see columnHitsAvx2).
      __m128 hit = _mm_and_ps(_mm_cmple_ps(lo[0], _mm_load_ps(ys.hi(0) + j)),
                              _mm_cmple_ps(_mm_load_ps(ys.lo(0) + j), hi[0]));
      for (int k = 1; k < 3; ++k)
        hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmple_ps(lo[k], _mm_load_ps(ys.hi(k) + j)),
                                         _mm_cmple_ps(_mm_load_ps(ys.lo(k) + j), hi[k])));
      m |= std::uint64_t(_mm_movemask_ps(hit)) << j;
    }
    rows[i] = Self ? m & above(i) : m;
  }
}

template <typename S>
PairKernels<S> makeSse2() {
  PairKernels<S> k = *portableKernels<S>();
  k.isa = PairKernel::sse2;
  k.rowMasks[0] = &rowMasksSse2<false>;
  k.rowMasks[1] = &rowMasksSse2<true>;
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
