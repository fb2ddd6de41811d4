// The column storage, the portable kernels, and the one choice of kernel table.

#include "core/kernels/pair_kernels.h"

#include <algorithm>
#include <cstdlib>
#include <new>
#include <stdexcept>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace cube {
namespace detail {

ColumnStore::ColumnStore(std::uint32_t n, float* local, std::size_t local_floats) {
  const std::uint32_t stride = (n + kMaskLeaf + 7) & ~7u;
  const std::size_t floats = 6 * std::size_t(stride);
  float* cols = nullptr;
  if (floats <= local_floats) {
    cols = local;
  } else if (floats * sizeof(float) >= kHugeColumnBytes) {
    constexpr std::size_t kHuge = std::size_t(2) << 20;  // x86-64's huge page
    const std::size_t size = (floats * sizeof(float) + kHuge - 1) / kHuge * kHuge;
    huge_ = static_cast<float*>(std::aligned_alloc(kHuge, size));
    if (huge_ == nullptr) throw std::bad_alloc();
#if defined(__linux__)
    madvise(huge_, size, MADV_HUGEPAGE);  // advice only: small pages if refused
#endif
    cols = huge_;
  } else {
    // 32-byte alignment by hand: 7 floats of slack.
    heap_.reset(new float[floats + 7]);
    const auto addr = reinterpret_cast<std::uintptr_t>(heap_.get());
    cols = heap_.get() + ((32 - addr % 32) % 32) / sizeof(float);
  }
  cols_ = Columns::packed(cols, stride);
  for (int k = 0; k < 6; ++k) std::fill(cols_.col[k] + n, cols_.col[k] + stride, 0.0f);
}

ColumnStore::~ColumnStore() {
  std::free(huge_);
}

namespace {

template <bool Self>
void rowMasksPortable(const Columns& xs, std::uint32_t nx, const Columns& ys_arg, std::uint32_t ny,
                      std::uint64_t* rows) {
  // One set of columns when Self: the compiler then keeps six column pointers in registers,
  // not twelve (which it reloaded at every row, a sixth more instructions).
  const Columns& ys = Self ? xs : ys_arg;
  for (std::uint32_t i = 0; i < nx; ++i) {
    std::uint64_t m = 0;
    for (std::uint32_t j = Self ? i + 1 : 0; j < ny; ++j) {
      bool hit = true;
      // Branch-free on purpose: & of the comparisons, as the SIMD tables compute them.
      for (int k = 0; k < 3; ++k)
        hit = hit & (xs.lo(k)[i] <= ys.hi(k)[j]) & (ys.lo(k)[j] <= xs.hi(k)[i]);
      m |= std::uint64_t(hit) << j;
    }
    rows[i] = m;
  }
}

template <typename S>
const PairKernels<S> kPortable = {PairKernel::portable,
                                  {&rowMasksPortable<false>, &rowMasksPortable<true>},
                                  {&leafHitsPortable<false, S>, &leafHitsPortable<true, S>},
                                  {nullptr, nullptr}};

PairKernel resolveBest() {
  if (pairKernelAvailable(PairKernel::avx2)) return PairKernel::avx2;
  if (pairKernelAvailable(PairKernel::sse2)) return PairKernel::sse2;
  return PairKernel::portable;
}

}  // namespace

template <typename S>
const PairKernels<S>* portableKernels() {
  return &kPortable<S>;
}

bool pairKernelAvailable(PairKernel k) {
  switch (k) {
    case PairKernel::best:
    case PairKernel::portable:
      return true;
    case PairKernel::sse2:
      return sse2Kernels<double>() != nullptr;
    case PairKernel::avx2:
      return avx2Kernels<double>() != nullptr;
  }
  return false;
}

template <typename S>
const PairKernels<S>& pairKernels(PairKernel k) {
  if (k == PairKernel::best) {
    // Resolved once (thread-safe static initialisation), read-only afterwards: every query asks.
    static const PairKernels<S>* const best = &pairKernels<S>(resolveBest());
    return *best;
  }
  const PairKernels<S>* table = nullptr;
  switch (k) {
    case PairKernel::best:
    case PairKernel::portable:
      table = portableKernels<S>();
      break;
    case PairKernel::sse2:
      table = sse2Kernels<S>();
      break;
    case PairKernel::avx2:
      table = avx2Kernels<S>();
      break;
  }
  if (table == nullptr) throw std::logic_error("pairKernels: this CPU or build lacks the kernel");
  return *table;
}

template const PairKernels<float>* portableKernels<float>();
template const PairKernels<double>* portableKernels<double>();
template const PairKernels<float>& pairKernels<float>(PairKernel);
template const PairKernels<double>& pairKernels<double>(PairKernel);

}  // namespace detail
}  // namespace cube
