#pragma once

// The split rule of the cube tree, written once for the build (cube_tree_build.cpp) and for a
// leaf that overflows (cube_tree.cpp): along the longest side at the median object, found by a
// selection on order keys of the centres; plus the small node helpers both use. Private to the
// tree's two files, in an unnamed namespace so that each inlines it as within one file.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

#include "core/cube_tree.h"
#include "core/kernels/box_ops.h"

namespace cube {
namespace detail {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

inline void setEmpty(Node& n) {
  for (int k = 0; k < 3; ++k) {
    n.lo[k] = kInf;
    n.hi[k] = -kInf;
  }
}

// Of an object box or a cube; sides in double, exact for float bounds.
template <class B>
int longestAxis(const B& b) {
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (double(b.hi[k]) - double(b.lo[k]) > double(b.hi[axis]) - double(b.lo[axis])) axis = k;
  return axis;
}

// Objects in the lower child of a cube of `count` objects: the median, rounded up to a multiple
// of the leaf size so that leaves come out full (a halving split of 10,000 objects with leaves
// of 4 would give leaves of 2.4 on average, and a third more cubes to store and visit).
inline std::uint32_t splitCount(std::uint32_t count, int leaf_size) {
  const std::uint32_t l = static_cast<std::uint32_t>(leaf_size);
  const std::uint32_t m = (count / 2 + l - 1) / l * l;
  return m < count ? m : count / 2;
}

// A leaf's bounds: the union of its objects' exact boxes, rounded out.
template <typename S>
void fitLeaf(Node& n, const Item<S>* items) {
  Box<S> box;
  unionOfItems(items, n.first, n.count, box);
  roundOut(box, n.lo, n.hi);
}

// An internal cube's bounds: the union of its two children's.
inline void fitParent(Node& n, const Node& a, const Node& b) {
  unionOfCubes(n, a, b);
}

inline bool isDead(const Node& n) {
  return n.count == 0 && n.first == kNone;
}

// Twice a record's centre along an axis (the sum of its bounds: only the order matters). A box
// reaching both infinities has no centre; it counts as 0, so that the order stays total.
inline float centre2(const BuildRecord& r, int axis) {
  const float c = r.lo[axis] + r.hi[axis];
  return c == c ? c : 0.0f;
}

// An unsigned integer in the order of the float x (not NaN); -0 and +0 give the same one.
inline std::uint32_t orderedBits(float x) {
  std::uint32_t u;
  const float y = x + 0.0f;  // -0 + 0 is +0
  std::memcpy(&u, &y, sizeof u);
  // Negative: all bits flipped; otherwise the sign bit set. Without a branch: the build's
  // centres fall on both sides of 0 at random, and a branch here mispredicted on those.
  const std::uint32_t neg = static_cast<std::uint32_t>(static_cast<std::int32_t>(u) >> 31);
  return u ^ (neg | 0x80000000u);
}

// The build's order as one integer: by centre along `axis`, ties by registration order (a strict
// total order, so the same objects always give the same tree); axis < 0: registration order.
inline std::uint64_t orderKey(const BuildRecord& r, int axis) {
  return (axis < 0 ? 0 : std::uint64_t(orderedBits(centre2(r, axis))) << 32) | r.seq;
}

inline bool before(const BuildRecord& x, const BuildRecord& y, int axis) {
  return orderKey(x, axis) < orderKey(y, axis);
}

// Runs this short are sorted by rank.
constexpr std::ptrdiff_t kRankMax = 16;

// Sorts [first, last) (at most kRankMax records) in the build's order along `axis`, or by
// registration order alone if axis < 0: each record goes to the place given by the number of
// records before it, counted without a branch. An insertion sort here mispredicted on about
// every other comparison, and builds happen in the middle of update().
inline void rankSort(BuildRecord* first, BuildRecord* last, int axis) {
  const std::ptrdiff_t c = last - first;
  BuildRecord tmp[kRankMax];
  std::uint64_t key[kRankMax];  // the order as one integer: one compare per pair
  for (std::ptrdiff_t i = 0; i < c; ++i) {
    tmp[i] = first[i];
    key[i] = orderKey(first[i], axis);
  }
  for (std::ptrdiff_t i = 0; i < c; ++i) {
    int rank = 0;
    for (std::ptrdiff_t j = 0; j < c; ++j) rank += key[j] < key[i];
    first[rank] = tmp[i];
  }
}

// Ranges at least this long take their pivot from a sample instead of a median of three.
constexpr std::ptrdiff_t kSampleMin = 256;
constexpr std::ptrdiff_t kSampleMax = 128;

// The key of a pivot that leaves *nth on the smaller side of the partition when it can: from
// evenly spaced records, the one just beyond nth's estimated place (by two standard deviations
// of the estimate), or at that place when nth is near the middle, where either side is about
// half. The sample's smallest key is never the pivot, so both sides get at least one record.
inline std::uint64_t samplePivot(const BuildRecord* first, const BuildRecord* nth,
                                 const BuildRecord* last, int axis) {
  const std::ptrdiff_t n = last - first;
  std::ptrdiff_t s = 1;
  while (s * s < 4 * n && s < kSampleMax) s *= 2;
  std::uint64_t key[kSampleMax];
  for (std::ptrdiff_t i = 0; i < s; ++i) key[i] = orderKey(first[(2 * i + 1) * n / (2 * s)], axis);
  const double q = (double(nth - first) + 0.5) / double(n);
  const double margin = 2.0 * std::sqrt(double(s) * q * (1.0 - q)) + 1.0;
  double r = q * double(s);
  if (std::min(q, 1.0 - q) * double(s) + margin < 0.5 * double(s)) r += q < 0.5 ? margin : -margin;
  const std::ptrdiff_t i =
      std::max<std::ptrdiff_t>(1, std::min<std::ptrdiff_t>(s - 1, std::ptrdiff_t(r)));
  std::nth_element(key, key + i, key + s);  // the sample's i-th key; the rest needs no order
  return key[i];
}

// Puts into *nth the record that a sort in the build's order along `axis` would put there,
// smaller ones before it and larger ones after (std::nth_element's contract). `scratch` is as
// long as [first, last). Quickselect whose partition writes each record to both ends of the
// other buffer and advances one of them: no branch on the comparison and no load that waits for
// it. Whether a record goes left is a coin toss, so std::nth_element's branches mispredicted on
// half the records, most of the build time. Long ranges pick the pivot from a sample, so that
// about one and a half passes find the median instead of about three. The passes alternate
// between the buffers; only what a pass into `scratch` leaves behind is copied back.
inline void selectNth(BuildRecord* first, BuildRecord* nth, BuildRecord* last, int axis,
                      BuildRecord* scratch) {
  BuildRecord* const home = first;
  BuildRecord* src = first;
  std::ptrdiff_t lo_off = 0, hi_off = last - first, nth_off = nth - first;
  bool in_scratch = false;
  while (hi_off - lo_off > kRankMax) {
    const BuildRecord* f = src + lo_off;
    const BuildRecord* l = src + hi_off;
    std::uint64_t pivot_key;
    if (l - f >= kSampleMin) {
      pivot_key = samplePivot(f, src + nth_off, l, axis);
    } else {
      // Median of three distinct records: both sides get at least one, so every pass shrinks.
      const BuildRecord& x = *f;
      const BuildRecord& y = f[(l - f) / 2];
      const BuildRecord& z = *(l - 1);
      const BuildRecord pivot = before(x, y, axis)
                                    ? (before(y, z, axis) ? y : (before(x, z, axis) ? z : x))
                                    : (before(x, z, axis) ? x : (before(y, z, axis) ? z : y));
      pivot_key = orderKey(pivot, axis);
    }
    BuildRecord* const dst = in_scratch ? home : scratch;
    BuildRecord* lo = dst + lo_off;
    BuildRecord* hi = dst + hi_off;
    // One loop per axis, so that the centre is read at a fixed offset.
    const auto pass = [&](auto axis_constant) {
      constexpr int a = decltype(axis_constant)::value;
      for (const BuildRecord* p = f; p < l; ++p) {
        const BuildRecord r = *p;
        const bool left = orderKey(r, a) < pivot_key;
        *lo = r;
        *(hi - 1) = r;
        lo += left;
        hi -= !left;
      }
    };
    if (axis == 0)
      pass(std::integral_constant<int, 0>());
    else if (axis == 1)
      pass(std::integral_constant<int, 1>());
    else
      pass(std::integral_constant<int, 2>());
    const std::ptrdiff_t mid = lo - dst;
    // The side without nth is final; in scratch it goes home now.
    if (nth_off < mid) {
      if (!in_scratch) std::copy(dst + mid, dst + hi_off, home + mid);
      hi_off = mid;
    } else {
      if (!in_scratch) std::copy(dst + lo_off, dst + mid, home + lo_off);
      lo_off = mid;
    }
    src = dst;
    in_scratch = !in_scratch;
  }
  if (in_scratch) std::copy(src + lo_off, src + hi_off, home + lo_off);
  rankSort(home + lo_off, home + hi_off, axis);
}

// The seed's split rule, written once for the build and for a leaf that overflows: along the
// longest side of `bounds` (the union of the records), the records ordered by centre (ties by
// registration order), the first `mid - first` of them for the lower child.
inline void splitRecords(BuildRecord* first, BuildRecord* mid, BuildRecord* last,
                         const Node& bounds, BuildRecord* scratch) {
  selectNth(first, mid, last, longestAxis(bounds), scratch);
}

// Where a cube whose records are sorted by filter group (rg, per record) and hold more than
// one group splits: at the group boundary nearest its median, so that both children get some.
inline std::uint32_t groupBoundary(const Group* rg, std::uint32_t b, std::uint32_t e) {
  const std::uint32_t mid = b + (e - b) / 2;
  const auto lo = std::uint32_t(std::lower_bound(rg + b, rg + e, rg[mid]) - rg);
  const auto hi = std::uint32_t(std::upper_bound(rg + b, rg + e, rg[mid]) - rg);
  if (lo == b) return hi;
  if (hi == e) return lo;
  return mid - lo <= hi - mid ? lo : hi;
}

// Within a leaf, registration order: the callback order does not depend on history.
inline void sortLeaf(BuildRecord* first, BuildRecord* last) {
  if (last - first <= kRankMax)
    rankSort(first, last, -1);
  else
    std::sort(first, last,
              [](const BuildRecord& x, const BuildRecord& y) { return x.seq < y.seq; });
}

}  // namespace
}  // namespace detail
}  // namespace cube
