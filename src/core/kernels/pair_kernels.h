#pragma once

// The batch box tests: many pairs per call, as bit masks. One layout (float columns, see
// Columns) and one table of kernels per instruction set (pair_kernels_<isa>.cpp), chosen once
// at the first call by what the CPU has. The walks call through the table; nothing outside
// src/core/kernels/ contains an intrinsic or an instruction-set conditional.

#include <cstdint>
#include <memory>

#include "core/geometry.h"
#include "core/kernels/box_ops.h"

namespace cube {
namespace detail {

/// Longest run of objects whose box tests against another run go into one 64-bit mask.
inline constexpr std::uint32_t kMaskLeaf = 8;

/// Largest number of objects whose all-pairs masks (one 64-bit row each) rowMasks computes.
inline constexpr std::uint32_t kAllPairsMax = Config::kMaxAllPairsLimit;
static_assert(kAllPairsMax <= 64, "one 64-bit row per object");

/// Instruction set of a kernel table. `best` is what the CPU runs fastest, resolved once.
enum class PairKernel { best, portable, sse2, avx2 };

/// Boxes in float, one column per bound (structure of arrays): entry i of bound lo[k] at
/// col[k][i], of hi[k] at col[3 + k][i]. Each column is 32-byte aligned and padded to a multiple
/// of 8 entries, so that 8 entries from a multiple of 8 are one aligned AVX load. Boxes are
/// rounded to nearest: rounding is monotone (a <= b gives float(a) <= float(b)), so boxes that
/// overlap exactly overlap in float too, and a float test gives a superset of the exact pairs.
/// Six pointers rather than a base and a stride: the leaf kernels, the heart of large self
/// walks, then address each column directly (a stride cost them an address computation per
/// load).
struct Columns {
  float* col[6] = {};
  float* lo(int k) const { return col[k]; }
  float* hi(int k) const { return col[3 + k]; }
  /// Columns of `stride` floats each, one after the other from `base`.
  static Columns packed(float* base, std::size_t stride) {
    Columns c;
    for (int k = 0; k < 6; ++k) c.col[k] = base + std::size_t(k) * stride;
    return c;
  }
};

/// Entries [at, at + count) of `cols` get the boxes of items[slot(i)], rounded to nearest.
/// Inline, with the instruction set chosen at compile time (box_ops.h): in the all-pairs test of
/// a small scene an out-of-line call cost a tenth of the time.
template <typename S, class Slot>
inline void fillColumns(const Item<S>* items, Slot&& slot, std::uint32_t count, const Columns& cols,
                        std::uint32_t at) {
  float* lo[3] = {cols.lo(0) + at, cols.lo(1) + at, cols.lo(2) + at};
  float* hi[3] = {cols.hi(0) + at, cols.hi(1) + at, cols.hi(2) + at};
  std::uint32_t i = 0;
  for (; i + 4 <= count; i += 4) {
    const Box<S>* const b[4] = {&items[slot(i)].box, &items[slot(i + 1)].box,
                                &items[slot(i + 2)].box, &items[slot(i + 3)].box};
    float* const l[3] = {lo[0] + i, lo[1] + i, lo[2] + i};
    float* const h[3] = {hi[0] + i, hi[1] + i, hi[2] + i};
    fourToColumns(b, l, h);
  }
  for (; i < count; ++i) {
    const Box<S>& b = items[slot(i)].box;
    for (int k = 0; k < 3; ++k) {
      lo[k][i] = static_cast<float>(b.lo[k]);
      hi[k][i] = static_cast<float>(b.hi[k]);
    }
  }
}

/// The storage of a Columns for at least n entries plus kMaskLeaf of padding (read by the lanes
/// of a leaf past its end), padding zeroed: the float columns of a large self walk. In the
/// caller's buffer `local` (32-byte aligned, `local_floats` long) when they fit, else on the
/// heap: a walk's frame is reused call after call, while a fresh heap block of a new manager or
/// after glibc trimmed its heap faults in page by page as the walk first touches it.
/// Stores of kHugeColumnBytes or more ask Linux for huge pages: glibc maps a block that large
/// afresh at every call (smaller ones come back from its heap, already mapped), and the faults
/// and TLB misses of its small pages weighed on a self-collide of millions of objects.
class ColumnStore {
 public:
  explicit ColumnStore(std::uint32_t n, float* local = nullptr, std::size_t local_floats = 0);
  ~ColumnStore();
  ColumnStore(const ColumnStore&) = delete;
  ColumnStore& operator=(const ColumnStore&) = delete;
  const Columns& columns() const { return cols_; }

 private:
  std::unique_ptr<float[]> heap_;  // below kHugeColumnBytes
  float* huge_ = nullptr;          // from kHugeColumnBytes on (aligned_alloc)
  Columns cols_;
};
/// The size from which a ColumnStore asks for huge pages (glibc's largest heap block).
inline constexpr std::size_t kHugeColumnBytes = std::size_t(32) << 20;

/// The columns of an all-pairs test (at most kAllPairsMax boxes), in the object itself: no
/// allocation, and only the padding that rowMasks reads (up to the next multiple of 8) zeroed.
class SmallColumns {
 public:
  SmallColumns() = default;
  SmallColumns(const SmallColumns&) = delete;
  SmallColumns& operator=(const SmallColumns&) = delete;
  /// Zeroes entries [n, next multiple of 8) of every column; n <= kAllPairsMax.
  void padFrom(std::uint32_t n) {
    for (int k = 0; k < 6; ++k)
      for (std::uint32_t j = n; j < ((n + 7) & ~7u); ++j) c_[k * kAllPairsMax + j] = 0.0f;
  }
  Columns columns() { return Columns::packed(c_, kAllPairsMax); }

 private:
  alignas(32) float c_[6 * kAllPairsMax];
};
static_assert(kAllPairsMax % 8 == 0, "SmallColumns' stride is a multiple of 8");

/// One instruction set's kernels. Bit kMaskLeaf i + j of a leaf mask stands for the pair
/// (xs[i], ys[j]); with Self, xs and ys are the same run and only j > i counts.
template <typename S>
struct PairKernels {
  PairKernel isa;
  /// rows[i] for i < nx <= kAllPairsMax: bit j set for every j < ny <= kAllPairsMax whose box
  /// in `ys` overlaps box i of `xs`; bits from ny to the next multiple of 8 may be set too (the
  /// caller masks them). [0] two sets of boxes; [1] Self: xs and ys the same (nx == ny), and
  /// only j > i counts.
  void (*rowMasks[2])(const Columns& xs, std::uint32_t nx, const Columns& ys, std::uint32_t ny,
                      std::uint64_t* rows);
  /// Exact masks between two runs of at most kMaskLeaf objects: [0] pairs, [1] Self.
  std::uint64_t (*leafHits[2])(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys,
                               std::uint32_t ny);
  /// The same from columns [x0, x0 + nx) and [y0, y0 + ny): a superset of the exact mask, to be
  /// rechecked. Null where the instruction set gains nothing over leafHits.
  std::uint64_t (*columnHits[2])(const Columns& cols, std::uint32_t x0, std::uint32_t nx,
                                 std::uint32_t y0, std::uint32_t ny);
};

/// Whether this build and this CPU can run kernel `k`.
bool pairKernelAvailable(PairKernel k);

/// The table of kernel `k` (best: the fastest available, chosen at the first call). Throws
/// std::logic_error if the CPU or the build lacks it.
template <typename S>
const PairKernels<S>& pairKernels(PairKernel k = PairKernel::best);

/// The exact leaf mask one pair at a time: the portable table's leafHits, and what the walks
/// use inline against a single object, where a batch would not pay for its set-up.
template <bool Self, typename S>
inline std::uint64_t leafHitsPortable(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys,
                                      std::uint32_t ny) {
  std::uint64_t hits = 0;
  for (std::uint32_t i = 0; i < nx; ++i)
    for (std::uint32_t j = Self ? i + 1 : 0; j < ny; ++j)
      hits |= std::uint64_t(overlap(xs[i].box, ys[j].box)) << (kMaskLeaf * i + j);
  return hits;
}

/// leafHitsPortable<false>(xs, nx, &y, 1) against a prepared box y (one query object down a
/// tree: its leaves are tested against the same box).
template <typename S>
inline std::uint64_t leafHitsOne(const Item<S>* xs, std::uint32_t nx, const FixedBox<S>& y) {
  const auto hits = [&](std::uint32_t n) {
    std::uint64_t h = 0;
    for (std::uint32_t i = 0; i < n; ++i)
      h |= std::uint64_t(y.overlaps(xs[i].box)) << (kMaskLeaf * i);
    return h;
  };
  // Full leaves (most of them) without a test of the count per object.
  return nx == kMaskLeaf ? hits(kMaskLeaf) : hits(nx);
}

/// Each instruction set's table, or null where this build or this CPU lacks it (only
/// pairKernels() calls these).
template <typename S>
const PairKernels<S>* portableKernels();
template <typename S>
const PairKernels<S>* sse2Kernels();
template <typename S>
const PairKernels<S>* avx2Kernels();

}  // namespace detail
}  // namespace cube
