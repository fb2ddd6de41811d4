// One iterative descent for every query: an explicit stack of cube pairs, policies for
// "overlap" (collide) and "closer than the best so far" (distance).

#include "core/traversal.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>  // baseline on x86-64: no -m flag, so no effect on Eigen's ABI
#endif
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>  // AVX2 only inside functions marked target("avx2"), chosen at run time
#define CUBE_HAVE_AVX2_KERNEL 1
#endif

namespace cube {
namespace detail {

namespace {

// A stack that lives in the frame up to N entries and moves to the heap beyond, so that queries
// allocate nothing on ordinary trees and still cope with degenerate deep ones.
template <class T, std::size_t N>
class SmallStack {
 public:
  SmallStack() = default;
  SmallStack(const SmallStack&) = delete;
  SmallStack& operator=(const SmallStack&) = delete;
  bool empty() const { return n_ == 0; }
  void push(const T& t) {
    if (__builtin_expect(n_ == cap_, 0)) grow();
    data_[n_++] = t;
  }
  T pop() { return data_[--n_]; }

 private:
  [[gnu::noinline]] void grow() {
    std::vector<T> bigger(cap_ * 2);
    std::copy(data_, data_ + n_, bigger.begin());
    heap_.swap(bigger);
    data_ = heap_.data();
    cap_ = heap_.size();
  }
  T local_[N];
  T* data_ = local_;
  std::size_t n_ = 0;
  std::size_t cap_ = N;
  std::vector<T> heap_;
};

// Overlap tests are branch-free: their outcome is close to random in a traversal, so a
// mispredicted branch per axis would cost more than the test itself.
inline bool overlap(const Node& a, const Node& b) {
#if defined(__SSE2__)
  // The fourth lane holds first/count; the mask ignores it.
  const __m128 le = _mm_cmple_ps(_mm_loadu_ps(a.lo), _mm_loadu_ps(b.hi));
  const __m128 ge = _mm_cmple_ps(_mm_loadu_ps(b.lo), _mm_loadu_ps(a.hi));
  return (_mm_movemask_ps(_mm_and_ps(le, ge)) & 7) == 7;
#else
  return (a.lo[0] <= b.hi[0]) & (b.lo[0] <= a.hi[0]) & (a.lo[1] <= b.hi[1]) & (b.lo[1] <= a.hi[1]) &
         (a.lo[2] <= b.hi[2]) & (b.lo[2] <= a.hi[2]);
#endif
}

inline bool overlap(const Box<double>& a, const Box<double>& b) {
#if defined(__SSE2__)
  // lo and hi are six contiguous doubles; axes (0,1) and (1,2) cover all three.
  const double* x = a.lo;
  const double* y = b.lo;
  const __m128d m0 = _mm_and_pd(_mm_cmple_pd(_mm_loadu_pd(x), _mm_loadu_pd(y + 3)),
                                _mm_cmple_pd(_mm_loadu_pd(y), _mm_loadu_pd(x + 3)));
  const __m128d m1 = _mm_and_pd(_mm_cmple_pd(_mm_loadu_pd(x + 1), _mm_loadu_pd(y + 4)),
                                _mm_cmple_pd(_mm_loadu_pd(y + 1), _mm_loadu_pd(x + 4)));
  return _mm_movemask_pd(_mm_and_pd(m0, m1)) == 3;
#else
  return (a.lo[0] <= b.hi[0]) & (b.lo[0] <= a.hi[0]) & (a.lo[1] <= b.hi[1]) & (b.lo[1] <= a.hi[1]) &
         (a.lo[2] <= b.hi[2]) & (b.lo[2] <= a.hi[2]);
#endif
}

inline bool overlap(const Box<float>& a, const Box<float>& b) {
  return (a.lo[0] <= b.hi[0]) & (b.lo[0] <= a.hi[0]) & (a.lo[1] <= b.hi[1]) & (b.lo[1] <= a.hi[1]) &
         (a.lo[2] <= b.hi[2]) & (b.lo[2] <= a.hi[2]);
}

// Squared Euclidean gap between two boxes (fcl::AABB::distance squared); square roots are left
// out of the traversal, only the order and the pruning need the distance.
template <typename S, typename B>
inline S gap2(const B& a, const B& b) {
  S sum = 0;
  for (int k = 0; k < 3; ++k) {
    const S d = std::max(S(a.lo[k]) - S(b.hi[k]), S(b.lo[k]) - S(a.hi[k]));
    if (d > 0) sum += d * d;
  }
  return sum;
}

// Squared gap between two exact boxes (fcl::AABB::distance squared). An axis whose difference
// is NaN (both boxes reaching the same infinity) counts as touching, as in gap2.
inline double boxGap2(const Box<double>& a, const Box<double>& b) {
#if defined(__SSE2__)
  const __m128d zero = _mm_setzero_pd();
  const __m128d x01 = _mm_sub_pd(_mm_loadu_pd(a.lo), _mm_loadu_pd(b.hi));
  const __m128d y01 = _mm_sub_pd(_mm_loadu_pd(b.lo), _mm_loadu_pd(a.hi));
  const __m128d x2 = _mm_sub_sd(_mm_load_sd(a.lo + 2), _mm_load_sd(b.hi + 2));
  const __m128d y2 = _mm_sub_sd(_mm_load_sd(b.lo + 2), _mm_load_sd(a.hi + 2));
  __m128d d01 = _mm_andnot_pd(_mm_cmpunord_pd(x01, y01), _mm_max_pd(x01, y01));
  __m128d d2 = _mm_andnot_pd(_mm_cmpunord_sd(x2, y2), _mm_max_sd(x2, y2));
  d01 = _mm_max_pd(d01, zero);
  d2 = _mm_max_sd(d2, zero);
  d01 = _mm_mul_pd(d01, d01);
  // Summed in axis order, as gap2 does.
  const __m128d s01 = _mm_add_sd(d01, _mm_unpackhi_pd(d01, d01));
  return _mm_cvtsd_f64(_mm_add_sd(s01, _mm_mul_sd(d2, d2)));
#else
  return gap2<double>(a, b);
#endif
}

// In double: the square of a float gap beyond 1.8e19 would overflow float.
inline double boxGap2(const Box<float>& a, const Box<float>& b) {
  return gap2<double>(a, b);
}

// Squared gap between two cubes in double, never above the exact value of their float bounds
// (so pruning on it is safe). Computed in float and shrunk by a few ulps to absorb the
// roundings; a float square that overflows (gaps beyond 1.8e19) is redone in double, where the
// float bounds' differences and squares always fit.
[[gnu::noinline]] double cubeGap2Wide(const Node& a, const Node& b) {
  double sum = 0;
  for (int k = 0; k < 3; ++k) {
    const double d = std::max(double(a.lo[k]) - double(b.hi[k]), double(b.lo[k]) - double(a.hi[k]));
    if (d > 0) sum += d * d;
  }
  return sum * (1.0 - 0x1p-40);
}

inline double cubeGap2(const Node& a, const Node& b) {
#if defined(__SSE2__)
  const __m128 d1 = _mm_sub_ps(_mm_loadu_ps(a.lo), _mm_loadu_ps(b.hi));
  const __m128 d2 = _mm_sub_ps(_mm_loadu_ps(b.lo), _mm_loadu_ps(a.hi));
  __m128 d = _mm_max_ps(_mm_max_ps(d1, d2), _mm_setzero_ps());
  d = _mm_mul_ps(d, d);
  alignas(16) float v[4];
  _mm_store_ps(v, d);
  const float sum = (v[0] + v[1] + v[2]) * (1.0f - 0x1p-20f);
#else
  const float sum = gap2<float>(a, b) * (1.0f - 0x1p-20f);
#endif
  if (__builtin_expect(sum <= std::numeric_limits<float>::max(), 1)) return sum;
  return cubeGap2Wide(a, b);
}

struct NoKey {};

// Work counters for QueryStats; the empty one compiles away on the ordinary path.
struct NoCount {
  void visit() const {}
  void test() const {}
  void tests(std::size_t) const {}
  void call() const {}
};
struct Count {
  QueryStats* stats;
  void visit() const { ++stats->cubes_visited; }
  void test() const { ++stats->box_tests; }
  void tests(std::size_t k) const { stats->box_tests += k; }
  void call() const { ++stats->callbacks; }
};

// A self-collide's boxes in float, one column per bound, indexed by slot (see fillColumns).
struct Columns {
  const float* c[6];  // lo 0..2, hi 0..2
};

// What a collide does with a pair whose boxes overlap: call the user's function...
template <typename S>
struct CallFn {
  void* data;
  CollideFn<S> fn;
  bool operator()(const Item<S>& x, const Item<S>& y) const { return fn(x.obj, y.obj, data); }
};

// ...or note the pair's ids (see collectPairs).
template <typename S>
struct RecordIds {
  std::vector<std::uint64_t>* out;
  bool operator()(const Item<S>& x, const Item<S>& y) const {
    out->push_back(std::uint64_t(x.id) << 32 | y.id);
    return false;
  }
};

template <typename S, class Counter, class Sink = CallFn<S>>
struct CollidePolicy {
  using Key = NoKey;
  static constexpr bool kOrdered = false;
  Sink sink;
  Counter count;
  const Columns* columns = nullptr;  // null: leaves are tested on the exact boxes only
  bool enter(const Node& a, const Node& b, Key&) const {
    count.test();
    return overlap(a, b);
  }
  bool keep(Key) const { return true; }
  static bool before(Key, Key) { return false; }
  // Whether an object can meet anything in the cube `n` at all.
  bool reaches(const Item<S>& x, const Box<S>& cube) const {
    count.test();
    return overlap(x.box, cube);
  }
  bool touches(const Item<S>& x, const Item<S>& y) const {
    count.test();
    return overlap(x.box, y.box);
  }
  // Called for boxes that touch. An object never meets itself (two managers may share objects);
  // that check comes after the box test, which rejects most pairs without reading the pointers.
  bool report(const Item<S>& x, const Item<S>& y) const {
    if (x.obj == y.obj) return false;
    count.call();
    return sink(x, y);
  }
  bool leaf(const Item<S>& x, const Item<S>& y) const { return touches(x, y) && report(x, y); }
};

// The callbacks for the set bits of `hits`, in order; apart, so that the test loop stays small.
// Recheck: the bits come from float boxes, and each pair is tested again exactly first.
template <bool Recheck, typename S, class Policy>
[[gnu::noinline]] bool reportHits(std::uint64_t hits, const Item<S>* xs, const Item<S>* ys,
                                  const Policy& p) {
  while (hits != 0) {
    const unsigned b = static_cast<unsigned>(__builtin_ctzll(hits));
    hits &= hits - 1;
    const Item<S>& x = xs[b / kMaskLeaf];
    const Item<S>& y = ys[b % kMaskLeaf];
    if (Recheck && !overlap(x.box, y.box)) continue;
    if (p.report(x, y)) return true;
  }
  return false;
}

// Bit kMaskLeaf i + j set where xs[i] and ys[j] overlap (Self: only j > i), one pair at a time.
template <bool Self, typename S>
std::uint64_t leafHitsPortable(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys,
                               std::uint32_t ny) {
  std::uint64_t hits = 0;
  for (std::uint32_t i = 0; i < nx; ++i)
    for (std::uint32_t j = Self ? i + 1 : 0; j < ny; ++j)
      hits |= std::uint64_t(overlap(xs[i].box, ys[j].box)) << (kMaskLeaf * i + j);
  return hits;
}

#if defined(CUBE_HAVE_AVX2_KERNEL)
// The same mask, four pairs per instruction in exact double: the boxes of ys, four at a time,
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

// leafHitsAvx2 on float columns: eight pairs per instruction, no transpose (the columns are
// laid out for it). Lanes past ny read the next slots and are masked off. The bits are a
// superset of the exact ones (see fillColumns) and are rechecked before any callback.
template <bool Self>
[[gnu::target("avx2")]] std::uint64_t columnHitsAvx2(const Columns& c, std::uint32_t x0,
                                                     std::uint32_t nx, std::uint32_t y0,
                                                     std::uint32_t ny) {
  __m256 lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = _mm256_loadu_ps(c.c[k] + y0);
    hi[k] = _mm256_loadu_ps(c.c[3 + k] + y0);
  }
  const std::uint32_t valid = (1u << ny) - 1;
  std::uint64_t hits = 0;
  for (std::uint32_t i = 0; i < nx; ++i) {
    const std::uint32_t x = x0 + i;
    __m256 hit = _mm256_and_ps(_mm256_cmp_ps(_mm256_broadcast_ss(c.c[0] + x), hi[0], _CMP_LE_OQ),
                               _mm256_cmp_ps(lo[0], _mm256_broadcast_ss(c.c[3] + x), _CMP_LE_OQ));
    for (int k = 1; k < 3; ++k)
      hit = _mm256_and_ps(
          hit,
          _mm256_and_ps(_mm256_cmp_ps(_mm256_broadcast_ss(c.c[k] + x), hi[k], _CMP_LE_OQ),
                        _mm256_cmp_ps(lo[k], _mm256_broadcast_ss(c.c[3 + k] + x), _CMP_LE_OQ)));
    std::uint32_t bits = std::uint32_t(_mm256_movemask_ps(hit)) & valid;
    if (Self) bits &= ~0u << (i + 1);
    hits |= std::uint64_t(bits) << (kMaskLeaf * i);
  }
  return hits;
}
#endif

// The float columns of a view's slots, rounded to nearest. Rounding is monotone (a <= b gives
// float(a) <= float(b)), so boxes that overlap exactly overlap in float too; the few that
// overlap only after rounding fail the exact recheck. Padded by kMaskLeaf slots, which a
// leaf's lanes past its end may read.
template <typename S>
std::unique_ptr<float[]> fillColumns(const View<S>& v, Columns& cols) {
  const std::size_t stride = std::size_t(v.slots) + kMaskLeaf;
  std::unique_ptr<float[]> buf(new float[6 * stride]);
  float* const lo = buf.get();  // column k at lo + k stride; hi's at lo + (3 + k) stride
  float* const hi = lo + 3 * stride;
  for (std::uint32_t p = 0; p < v.slots; ++p) {
    const Box<S>& b = v.items[p].box;
    for (int k = 0; k < 3; ++k) {
      lo[k * stride + p] = static_cast<float>(b.lo[k]);
      hi[k * stride + p] = static_cast<float>(b.hi[k]);
    }
  }
  for (int k = 0; k < 6; ++k) {
    cols.c[k] = lo + k * stride;
    std::fill(lo + k * stride + v.slots, lo + (k + 1) * stride, 0.0f);
  }
  return buf;
}

// Self-collides of at least this many slots test leaves on float columns (24 bytes per slot,
// for the length of the call). At 1,000 objects they already save a quarter of the time; below
// this size the fill is a larger share of a short walk, and scenes up to all_pairs_limit do
// not walk at all.
constexpr std::uint32_t kColumnsMin = 256;

// What the walks use: AVX2 where the CPU has it, except against a single object (a query),
// where the transpose would cost more than the four tests it serves.
template <bool Self, typename S>
std::uint64_t leafHits(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys, std::uint32_t ny) {
#if defined(CUBE_HAVE_AVX2_KERNEL)
  if constexpr (std::is_same_v<S, double>)
    if (ny > 1 && __builtin_cpu_supports("avx2")) return leafHitsAvx2<Self>(xs, nx, ys, ny);
#endif
  return leafHitsPortable<Self>(xs, nx, ys, ny);
}

template <typename S>
std::uint64_t leafHitsWith(PairKernel k, bool self, const Item<S>* xs, std::uint32_t nx,
                           const Item<S>* ys, std::uint32_t ny) {
  if (k == PairKernel::best)
    return self ? leafHits<true>(xs, nx, ys, ny) : leafHits<false>(xs, nx, ys, ny);
  if (k == PairKernel::avx2) {
#if defined(CUBE_HAVE_AVX2_KERNEL)
    if constexpr (std::is_same_v<S, double>)
      return self ? leafHitsAvx2<true>(xs, nx, ys, ny) : leafHitsAvx2<false>(xs, nx, ys, ny);
#endif
    throw std::logic_error("leafOverlapMask: no AVX2 leaf kernel for this scalar type");
  }
  return self ? leafHitsPortable<true>(xs, nx, ys, ny) : leafHitsPortable<false>(xs, nx, ys, ny);
}

// The box tests between two runs of nx and ny objects (Self: one run, each pair once), for
// QueryStats.
template <bool Self, class Policy>
void countLeafTests(const Policy& p, std::uint32_t nx, std::uint32_t ny) {
  p.count.tests(Self ? std::size_t(nx) * (nx - (nx > 0)) / 2 : std::size_t(nx) * ny);
}

// Collide between two small runs of objects (at most kMaskLeaf each; Self: the same run, each
// unordered pair once): all box tests first, into a bit mask (bit kMaskLeaf i + j for xs[i],
// ys[j]), then the callbacks in that order. Whether two boxes overlap is a coin toss for the
// branch predictor; testing every pair without a branch costs less than skipping some behind
// mispredicted branches.
template <bool Self, typename S, class Policy>
bool collideSmall(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys, std::uint32_t ny,
                  const Policy& p) {
  countLeafTests<Self>(p, nx, ny);
  const std::uint64_t hits = leafHits<Self>(xs, nx, ys, ny);
  return hits != 0 && reportHits<false>(hits, xs, ys, p);
}

// The same for two leaves of one view (or a leaf with itself), [x0, x0 + nx) and [y0, y0 + ny),
// tested on the policy's float columns where it has them.
template <bool Self, typename S, class Policy>
bool collideLeaves(const View<S>& v, std::uint32_t x0, std::uint32_t nx, std::uint32_t y0,
                   std::uint32_t ny, const Policy& p) {
#if defined(CUBE_HAVE_AVX2_KERNEL)
  if (p.columns != nullptr) {
    countLeafTests<Self>(p, nx, ny);
    const std::uint64_t hits = columnHitsAvx2<Self>(*p.columns, x0, nx, y0, ny);
    return hits != 0 && reportHits<true>(hits, v.items + x0, v.items + y0, p);
  }
#endif
  return collideSmall<Self>(v.items + x0, nx, v.items + y0, ny, p);
}

// The all-pairs kernel for small scenes. The boxes are copied into float columns, rounded to
// nearest: rounding is monotone (a <= b gives float(a) <= float(b)), so no overlapping pair is
// lost, and the few pairs that overlap only after rounding fail the exact test that follows.
struct FlatBoxes {
  alignas(32) float lo[3][kAllPairsMax];
  alignas(32) float hi[3][kAllPairsMax];
};

// rows[i] gets bit j set for every j > i whose float box overlaps box i (bits of the padding
// columns, from n to the next multiple of 8, may be set too).
using RowMasks = std::uint64_t[kAllPairsMax];

inline std::uint64_t above(std::uint32_t i) {
  return (~std::uint64_t(0) << i) << 1;
}

void rowMasksPortable(const FlatBoxes& f, std::uint32_t n, RowMasks& rows) {
  for (std::uint32_t i = 0; i < n; ++i) {
    std::uint64_t m = 0;
    for (std::uint32_t j = i + 1; j < n; ++j) {
      bool hit = true;
      for (int k = 0; k < 3; ++k) hit &= (f.lo[k][i] <= f.hi[k][j]) & (f.lo[k][j] <= f.hi[k][i]);
      m |= std::uint64_t(hit) << j;
    }
    rows[i] = m;
  }
}

#if defined(__SSE2__)
void rowMasksSse2(const FlatBoxes& f, std::uint32_t n, RowMasks& rows) {
  for (std::uint32_t i = 0; i < n; ++i) {
    __m128 lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = _mm_set1_ps(f.lo[k][i]);
      hi[k] = _mm_set1_ps(f.hi[k][i]);
    }
    std::uint64_t m = 0;
    for (std::uint32_t j = (i + 1) & ~3u; j < n; j += 4) {
      __m128 hit = _mm_castsi128_ps(_mm_set1_epi32(-1));
      for (int k = 0; k < 3; ++k)
        hit = _mm_and_ps(hit, _mm_and_ps(_mm_cmple_ps(lo[k], _mm_load_ps(f.hi[k] + j)),
                                         _mm_cmple_ps(_mm_load_ps(f.lo[k] + j), hi[k])));
      m |= std::uint64_t(_mm_movemask_ps(hit)) << j;
    }
    rows[i] = m & above(i);
  }
}
#endif

#if defined(CUBE_HAVE_AVX2_KERNEL)
[[gnu::target("avx2")]] void rowMasksAvx2(const FlatBoxes& f, std::uint32_t n, RowMasks& rows) {
  for (std::uint32_t i = 0; i < n; ++i) {
    __m256 lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = _mm256_set1_ps(f.lo[k][i]);
      hi[k] = _mm256_set1_ps(f.hi[k][i]);
    }
    std::uint64_t m = 0;
    for (std::uint32_t j = (i + 1) & ~7u; j < n; j += 8) {
      __m256 hit = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
      for (int k = 0; k < 3; ++k)
        hit = _mm256_and_ps(
            hit, _mm256_and_ps(_mm256_cmp_ps(lo[k], _mm256_load_ps(f.hi[k] + j), _CMP_LE_OQ),
                               _mm256_cmp_ps(_mm256_load_ps(f.lo[k] + j), hi[k], _CMP_LE_OQ)));
      m |= std::uint64_t(_mm256_movemask_ps(hit)) << j;
    }
    rows[i] = m & above(i);
  }
}
#endif

// Columns n.. of f get the boxes of items[slot[0..count)] rounded to float.
inline void toColumns(const Item<float>* items, const std::uint32_t* slot, std::uint32_t count,
                      FlatBoxes& f, std::uint32_t n) {
  for (std::uint32_t c = 0; c < count; ++c)
    for (int k = 0; k < 3; ++k) {
      f.lo[k][n + c] = items[slot[c]].box.lo[k];
      f.hi[k][n + c] = items[slot[c]].box.hi[k];
    }
}

inline void toColumns(const Item<double>* items, const std::uint32_t* slot, std::uint32_t count,
                      FlatBoxes& f, std::uint32_t n) {
#if defined(__SSE2__)
  // Four boxes at a time: each becomes (lo0 lo1 lo2 hi0) and (hi1 hi2) in float, and a 4 x 4
  // transpose makes columns of those (a third of the instructions of a box-by-box copy).
  for (; count >= 4; count -= 4, slot += 4, n += 4) {
    __m128 r[4], t[2];
    for (int i = 0; i < 4; ++i) {
      const double* c = items[slot[i]].box.lo;  // lo0 lo1 lo2 hi0 hi1 hi2, contiguous
      r[i] = _mm_movelh_ps(_mm_cvtpd_ps(_mm_loadu_pd(c)), _mm_cvtpd_ps(_mm_loadu_pd(c + 2)));
    }
    for (int i = 0; i < 2; ++i)
      t[i] = _mm_movelh_ps(_mm_cvtpd_ps(_mm_loadu_pd(items[slot[2 * i]].box.hi + 1)),
                           _mm_cvtpd_ps(_mm_loadu_pd(items[slot[2 * i + 1]].box.hi + 1)));
    _MM_TRANSPOSE4_PS(r[0], r[1], r[2], r[3]);
    _mm_store_ps(f.lo[0] + n, r[0]);
    _mm_store_ps(f.lo[1] + n, r[1]);
    _mm_store_ps(f.lo[2] + n, r[2]);
    _mm_store_ps(f.hi[0] + n, r[3]);
    _mm_store_ps(f.hi[1] + n, _mm_shuffle_ps(t[0], t[1], _MM_SHUFFLE(2, 0, 2, 0)));
    _mm_store_ps(f.hi[2] + n, _mm_shuffle_ps(t[0], t[1], _MM_SHUFFLE(3, 1, 3, 1)));
  }
#endif
  for (std::uint32_t c = 0; c < count; ++c)
    for (int k = 0; k < 3; ++k) {
      f.lo[k][n + c] = float(items[slot[c]].box.lo[k]);
      f.hi[k][n + c] = float(items[slot[c]].box.hi[k]);
    }
}

PairKernel resolve(PairKernel k) {
  if (k != PairKernel::best) return k;
  if (pairKernelAvailable(PairKernel::avx2)) return PairKernel::avx2;
  if (pairKernelAvailable(PairKernel::sse2)) return PairKernel::sse2;
  return PairKernel::portable;
}

template <typename S, class Policy>
bool allPairs(const View<S>& v, const Policy& p, PairKernel kernel) {
  // The live slots, without a branch per slot.
  std::uint32_t slot[kAllPairsMax];
  std::uint32_t n = 0;
  for (std::uint32_t s = 0; s < v.slots; ++s) {
    slot[n] = s;
    n += v.items[s].obj != nullptr;
  }
  FlatBoxes f;
  toColumns(v.items, slot, n, f, 0);
  // The kernels read whole blocks of 4 or 8 columns; the bits of the padding are dropped below
  // (no box value could be relied on to overlap nothing: an infinite box overlaps every one).
  for (std::uint32_t j = n; j < ((n + 7) & ~7u); ++j)
    for (int k = 0; k < 3; ++k) f.lo[k][j] = f.hi[k][j] = 0.0f;
  const std::uint64_t live = n == 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << n) - 1;
  p.count.tests(std::size_t(n) * (n - (n > 0)) / 2);
  RowMasks rows;
  switch (resolve(kernel)) {
#if defined(CUBE_HAVE_AVX2_KERNEL)
    case PairKernel::avx2:
      rowMasksAvx2(f, n, rows);
      break;
#endif
#if defined(__SSE2__)
    case PairKernel::sse2:
      rowMasksSse2(f, n, rows);
      break;
#endif
    default:
      rowMasksPortable(f, n, rows);
      break;
  }
  // The rows with hits, gathered without a branch: in a sparse scene whether a row has any is
  // a coin toss for the branch predictor.
  std::uint32_t hit_rows[kAllPairsMax];
  std::uint32_t h = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    rows[i] &= live;
    hit_rows[h] = i;
    h += rows[i] != 0;
  }
  for (std::uint32_t r = 0; r < h; ++r) {
    const std::uint32_t i = hit_rows[r];
    for (std::uint64_t m = rows[i]; m != 0; m &= m - 1) {
      const std::uint32_t j = static_cast<std::uint32_t>(__builtin_ctzll(m));
      if (p.leaf(v.items[slot[i]], v.items[slot[j]])) return true;
    }
  }
  return false;
}

template <typename S, class Counter>
struct DistancePolicy {
  using Key = double;  // squared box gap: in double, so that gaps beyond float's range fit
  static constexpr bool kOrdered = true;
  void* data;
  DistanceFn<S> fn;
  S& best;
  Counter count;
  // Boxes that overlap are always worth a visit: with a signed-distance callback the best may
  // already be <= 0 and a pair may still penetrate deeper.
  // A square that overflows (gaps beyond 1.3e154) is infinite: pruned below a finite bound, kept
  // while the bound's own square overflows too (the search has not found anything yet).
  bool keep(Key sq) const {
    const double b2 = double(best) * double(best);
    return sq == 0 || (best > 0 && (sq < b2 || b2 == std::numeric_limits<double>::infinity()));
  }
  bool enter(const Node& a, const Node& b, Key& key) const {
    count.test();
    key = cubeGap2(a, b);
    return keep(key);
  }
  static bool before(Key x, Key y) { return x < y; }
  // The gap to a cube is never above the gap to a box inside it (each step of boxGap2 is
  // monotone, roundings included), so an object too far from the cube is too far from all its
  // objects, and skipping it changes no call.
  bool reaches(const Item<S>& x, const Box<S>& cube) const {
    count.test();
    return keep(boxGap2(x.box, cube));
  }
  bool leaf(const Item<S>& x, const Item<S>& y) const {
    count.test();
    return keep(boxGap2(x.box, y.box)) && x.obj != y.obj && call(x, y);
  }
  bool call(const Item<S>& x, const Item<S>& y) const {
    count.call();
    return fn(x.obj, y.obj, data, best);
  }
};

// A leaf against the query object, nearest object first: the first callbacks then lower `best`
// as much as they can, and fewer narrow-phase calls follow. Small leaves only (a depth-capped
// leaf may be large; it is scanned in order).
template <typename S, class Policy>
bool leafNearestFirst(const View<S>& tree, const Node& n, const Item<S>& q, const Policy& p) {
  constexpr std::uint32_t kMax = 16;
  typename Policy::Key key[kMax];
  std::uint32_t order[kMax];
  std::uint32_t m = 0;
  for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
    if (tree.items[i].obj == q.obj) continue;
    p.count.test();
    const auto k = boxGap2(tree.items[i].box, q.box);
    std::uint32_t j = m++;
    for (; j > 0 && key[j - 1] > k; --j) {
      key[j] = key[j - 1];
      order[j] = order[j - 1];
    }
    key[j] = k;
    order[j] = i;
  }
  for (std::uint32_t j = 0; j < m; ++j) {
    if (!p.keep(key[j])) continue;  // not break: a callback may raise `best` again
    if (p.call(tree.items[order[j]], q)) return true;
  }
  return false;
}

template <class Key>
struct Entry {
  std::uint32_t a, b;
  Key key;
};

template <typename S, class Policy>
bool leafSelf(const View<S>& v, const Node& n, const Policy& p) {
  if constexpr (!Policy::kOrdered) {
    if (n.count <= kMaskLeaf) return collideLeaves<true>(v, n.first, n.count, n.first, n.count, p);
  }
  const std::uint32_t end = n.first + n.count;
  for (std::uint32_t i = n.first; i < end; ++i)
    for (std::uint32_t j = i + 1; j < end; ++j)
      if (p.leaf(v.items[i], v.items[j])) return true;
  return false;
}

template <typename S, class Policy>
bool leafPair(const View<S>& va, const Node& na, const View<S>& vb, const Node& nb,
              const Policy& p) {
  if constexpr (!Policy::kOrdered) {
    if (na.count <= kMaskLeaf && nb.count <= kMaskLeaf) {
      // Columns only in a self walk, where va and vb are the same view.
      if (p.columns != nullptr)
        return collideLeaves<false>(va, na.first, na.count, nb.first, nb.count, p);
      return collideSmall<false>(va.items + na.first, na.count, vb.items + nb.first, nb.count, p);
    }
  }
  // Large leaves (a depth cap) and distance: objects that cannot reach the other cube skip it.
  // Against a single object the prefilter would only repeat the exact test.
  const bool filter = nb.count > 1;
  Box<S> reach;
  for (int k = 0; k < 3; ++k) {
    reach.lo[k] = S(nb.lo[k]);
    reach.hi[k] = S(nb.hi[k]);
  }
  for (std::uint32_t i = na.first; i < na.first + na.count; ++i) {
    const Item<S>& x = va.items[i];
    if (filter && !p.reaches(x, reach)) continue;
    for (std::uint32_t j = nb.first; j < nb.first + nb.count; ++j)
      if (p.leaf(x, vb.items[j])) return true;
  }
  return false;
}

// Chooses what the walk does next among the taken entries of `e`: the most promising one (for
// distance the nearest, for collide the first) goes into `next` and is visited straight away;
// the others wait on the stack, the next most promising on top. Returns false if none was taken.
// Going straight on, and choosing with branches on registers rather than by compacting the
// taken entries through memory (each store and load of which waits on the last), more than
// doubled the speed of object queries.
template <class Policy, class Stack, class E, int N>
bool continueWithBest(Stack& stack, const bool (&take)[N], const E (&e)[N], E& next) {
  if constexpr (!Policy::kOrdered) {
    int first = 0;
    while (first < N && !take[first]) ++first;
    if (first == N) return false;
    for (int i = N - 1; i > first; --i)
      if (take[i]) stack.push(e[i]);
    next = e[first];
    return true;
  } else if constexpr (N == 2) {
    if (take[0] && take[1]) {
      const int near = Policy::before(e[1].key, e[0].key) ? 1 : 0;
      stack.push(e[1 - near]);
      next = e[near];
      return true;
    }
    if (!take[0] && !take[1]) return false;
    next = e[take[0] ? 0 : 1];
    return true;
  } else {
    int order[N];
    int m = 0;
    for (int i = 0; i < N; ++i)
      if (take[i]) order[m++] = i;
    if (m == 0) return false;
    // Insertion sort, nearest first (stable: equal keys keep their order).
    for (int i = 1; i < m; ++i)
      for (int j = i; j > 0 && Policy::before(e[order[j]].key, e[order[j - 1]].key); --j)
        std::swap(order[j - 1], order[j]);
    for (int j = m - 1; j > 0; --j) stack.push(e[order[j]]);
    next = e[order[0]];
    return true;
  }
}

// Starts loading what a visit of cube `n` will read first (its children, or its objects), so
// that the load overlaps the work on the entries above it on the stack: a descent is otherwise
// one chain of dependent cache misses.
template <typename S>
inline void prefetchBelow(const View<S>& v, const Node& n) {
  if (n.isLeaf())
    __builtin_prefetch(v.items + n.first);
  else
    __builtin_prefetch(v.nodes + n.first);
}

template <class Key>
struct OneEntry {
  std::uint32_t node;
  Key key;
};

// One object against a tree: the common query, with a lighter stack than the pair descent.
// Calls p.leaf(tree object, query object).
template <typename S, class Policy>
bool descendOne(const View<S>& tree, const Node& qn, const Item<S>& q, const Policy& p) {
  using E = OneEntry<typename Policy::Key>;
  E start{tree.root, {}};
  if (!p.enter(tree.nodes[tree.root], qn, start.key)) return false;
  SmallStack<E, 64> stack;
  stack.push(start);
  while (!stack.empty()) {
    E e = stack.pop();
    if (!p.keep(e.key)) continue;
    for (bool more = true; more;) {
      more = false;
      p.count.visit();
      const Node& n = tree.nodes[e.node];
      if (n.isLeaf()) {
        if constexpr (Policy::kOrdered) {
          if (n.count <= 16) {
            if (leafNearestFirst(tree, n, q, p)) return true;
            break;
          }
        }
        if constexpr (!Policy::kOrdered) {
          if (n.count <= kMaskLeaf) {
            if (collideSmall<false>(tree.items + n.first, n.count, &q, 1, p)) return true;
            break;
          }
        }
        for (std::uint32_t i = n.first; i < n.first + n.count; ++i)
          if (p.leaf(tree.items[i], q)) return true;
        break;
      }
      E e2[2] = {{n.first, {}}, {n.first + 1, {}}};
      bool take[2];
      for (int i = 0; i < 2; ++i) {
        take[i] = p.enter(tree.nodes[e2[i].node], qn, e2[i].key);
        prefetchBelow(tree, tree.nodes[e2[i].node]);
      }
      more = continueWithBest<Policy>(stack, take, e2, e);
    }
  }
  return false;
}

template <typename S, class Policy>
bool descend(const View<S>& va, const View<S>& vb, bool self, const Policy& p) {
  using E = Entry<typename Policy::Key>;
  if (va.root == kNone || vb.root == kNone) return false;
  const Node& qb = vb.nodes[vb.root];
  if (!self && qb.count == 1) return descendOne(va, qb, vb.items[qb.first], p);
  SmallStack<E, 128> stack;
  E start{va.root, vb.root, {}};
  if (!self && !p.enter(va.nodes[va.root], vb.nodes[vb.root], start.key)) return false;
  stack.push(start);
  while (!stack.empty()) {
    E e = stack.pop();
    if (!p.keep(e.key)) continue;  // the best distance may have dropped since the push
    for (bool more = true; more;) {
      more = false;
      p.count.visit();
      const Node& na = va.nodes[e.a];
      const Node& nb = vb.nodes[e.b];
      if (self && e.a == e.b) {
        if (na.isLeaf()) {
          if (leafSelf(va, na, p)) return true;
          break;
        }
        // Within a cube: within each child, then across the two.
        const std::uint32_t c = na.first;
        E e3[3] = {{c, c, {}}, {c + 1, c + 1, {}}, {c, c + 1, {}}};
        bool take[3] = {true, true, false};
        take[2] = p.enter(va.nodes[c], va.nodes[c + 1], e3[2].key);
        prefetchBelow(va, va.nodes[c]);
        prefetchBelow(va, va.nodes[c + 1]);
        more = continueWithBest<Policy>(stack, take, e3, e);
        continue;
      }
      const bool la = na.isLeaf(), lb = nb.isLeaf();
      if (la && lb) {
        if (leafPair(va, na, vb, nb, p)) return true;
        break;
      }
      if (!la && !lb) {
        // Open both cubes: one visit settles four child pairs.
        const std::uint32_t ca = na.first, cb = nb.first;
        E e4[4] = {{ca, cb, {}}, {ca, cb + 1, {}}, {ca + 1, cb, {}}, {ca + 1, cb + 1, {}}};
        bool take[4];
        for (int i = 0; i < 4; ++i)
          take[i] = p.enter(va.nodes[e4[i].a], vb.nodes[e4[i].b], e4[i].key);
        for (int i = 0; i < 2; ++i) {
          prefetchBelow(va, va.nodes[ca + i]);
          prefetchBelow(vb, vb.nodes[cb + i]);
        }
        more = continueWithBest<Policy>(stack, take, e4, e);
      } else if (lb) {
        const std::uint32_t c = na.first;
        E e2[2] = {{c, e.b, {}}, {c + 1, e.b, {}}};
        bool take[2];
        for (int i = 0; i < 2; ++i) {
          take[i] = p.enter(va.nodes[c + i], nb, e2[i].key);
          prefetchBelow(va, va.nodes[c + i]);
        }
        more = continueWithBest<Policy>(stack, take, e2, e);
      } else {
        const std::uint32_t c = nb.first;
        E e2[2] = {{e.a, c, {}}, {e.a, c + 1, {}}};
        bool take[2];
        for (int i = 0; i < 2; ++i) {
          take[i] = p.enter(na, vb.nodes[c + i], e2[i].key);
          prefetchBelow(vb, vb.nodes[c + i]);
        }
        more = continueWithBest<Policy>(stack, take, e2, e);
      }
    }
  }
  return false;
}

template <typename S, class Sink>
bool collideWith(const View<S>& a, const View<S>& b, bool self, const Sink& sink,
                 QueryStats* stats) {
  Columns columns;
  const Columns* use = nullptr;
  std::unique_ptr<float[]> storage;
#if defined(CUBE_HAVE_AVX2_KERNEL)
  if constexpr (std::is_same_v<S, double>) {
    if (self && a.slots >= kColumnsMin && __builtin_cpu_supports("avx2")) {
      storage = fillColumns(a, columns);
      use = &columns;
    }
  }
#endif
  if (stats) return descend(a, b, self, CollidePolicy<S, Count, Sink>{sink, Count{stats}, use});
  return descend(a, b, self, CollidePolicy<S, NoCount, Sink>{sink, NoCount{}, use});
}

}  // namespace

template <typename S>
bool collidePairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFn<S> fn,
                  QueryStats* stats) {
  return collideWith(a, b, self, CallFn<S>{data, fn}, stats);
}

template <typename S>
void collectPairs(const View<S>& a, const View<S>& b, bool self, std::size_t all_pairs_limit,
                  std::vector<std::uint64_t>& out) {
  const RecordIds<S> sink{&out};
  if (self && a.slots <= all_pairs_limit)
    allPairs(a, CollidePolicy<S, NoCount, RecordIds<S>>{sink, NoCount{}}, PairKernel::best);
  else
    collideWith(a, b, self, sink, nullptr);
}

bool pairKernelAvailable(PairKernel k) {
  switch (k) {
    case PairKernel::best:
    case PairKernel::portable:
      return true;
    case PairKernel::sse2:
#if defined(__SSE2__)
      return true;
#else
      return false;
#endif
    case PairKernel::avx2:
#if defined(CUBE_HAVE_AVX2_KERNEL)
      return __builtin_cpu_supports("avx2");
#else
      return false;
#endif
  }
  return false;
}

template <typename S>
bool collideAllPairs(const View<S>& v, void* data, CollideFn<S> fn, QueryStats* stats,
                     PairKernel kernel) {
  if (v.slots > kAllPairsMax) throw std::logic_error("collideAllPairs: view too large");
  if (!pairKernelAvailable(kernel)) throw std::logic_error("collideAllPairs: kernel unavailable");
  if (stats) return allPairs(v, CollidePolicy<S, Count>{{data, fn}, Count{stats}}, kernel);
  return allPairs(v, CollidePolicy<S, NoCount>{{data, fn}, NoCount{}}, kernel);
}

template <typename S>
std::uint64_t leafOverlapMask(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys,
                              std::uint32_t ny, bool self, PairKernel kernel) {
  if (nx > kMaskLeaf || ny > kMaskLeaf || (self && (xs != ys || nx != ny)))
    throw std::logic_error("leafOverlapMask: runs too long, or not one run for self");
  if (!pairKernelAvailable(kernel)) throw std::logic_error("leafOverlapMask: kernel unavailable");
  return leafHitsWith(kernel, self, xs, nx, ys, ny);
}

template <typename S>
bool distancePairs(const View<S>& a, const View<S>& b, bool self, void* data, DistanceFn<S> fn,
                   S& best, QueryStats* stats) {
  if (stats) return descend(a, b, self, DistancePolicy<S, Count>{data, fn, best, Count{stats}});
  return descend(a, b, self, DistancePolicy<S, NoCount>{data, fn, best, NoCount{}});
}

template <typename S>
SingleView<S>::SingleView(fcl::CollisionObject<S>* obj, const Box<S>& box, ObjectId id) {
  item = Item<S>{box, obj, 0, id};
  roundOut(box, node.lo, node.hi);
  node.first = 0;
  node.count = 1;
}

template bool collidePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                  CollideFn<float>, QueryStats*);
template bool collidePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                   CollideFn<double>, QueryStats*);
template void collectPairs<float>(const View<float>&, const View<float>&, bool, std::size_t,
                                  std::vector<std::uint64_t>&);
template void collectPairs<double>(const View<double>&, const View<double>&, bool, std::size_t,
                                   std::vector<std::uint64_t>&);
template bool collideAllPairs<float>(const View<float>&, void*, CollideFn<float>, QueryStats*,
                                     PairKernel);
template bool collideAllPairs<double>(const View<double>&, void*, CollideFn<double>, QueryStats*,
                                      PairKernel);
template std::uint64_t leafOverlapMask<float>(const Item<float>*, std::uint32_t, const Item<float>*,
                                              std::uint32_t, bool, PairKernel);
template std::uint64_t leafOverlapMask<double>(const Item<double>*, std::uint32_t,
                                               const Item<double>*, std::uint32_t, bool,
                                               PairKernel);
template bool distancePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                   DistanceFn<float>, float&, QueryStats*);
template bool distancePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                    DistanceFn<double>, double&, QueryStats*);
template struct SingleView<float>;
template struct SingleView<double>;

}  // namespace detail
}  // namespace cube
