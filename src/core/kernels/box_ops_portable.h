#pragma once

// The per-box operations in plain C++: the reference that box_ops_sse2.h must match bit for
// bit (tests/test_kernels.cpp compares them), and what box_ops.h uses where SSE2 is missing.
// Branch-free where the outcome is close to random in a walk or a build: a mispredicted branch
// per axis would cost more than the test itself.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "core/geometry.h"

namespace cube {
namespace detail {
namespace portable {

/// A float no greater than x (x not NaN), within a few float ulps of it. Branch-free instead of
/// exact: a cube may be a hair larger than needed, never smaller. Values beyond float's range
/// become infinite (the clamp keeps the conversion defined).
inline float floatBelow(double x) {
  constexpr double kMax = std::numeric_limits<float>::max();
  const float f = static_cast<float>(std::min(std::max(x, -kMax), kMax));
  return f - (std::fabs(f) * 0x1p-22f + std::numeric_limits<float>::min());
}

/// Outward-rounded float copy of an exact box (lo by floatBelow, hi the mirror image).
template <typename S>
inline void roundOut(const Box<S>& b, float lo[3], float hi[3]) {
  for (int k = 0; k < 3; ++k) {
    if constexpr (std::is_same_v<S, float>) {
      lo[k] = b.lo[k];
      hi[k] = b.hi[k];
    } else {
      lo[k] = floatBelow(double(b.lo[k]));
      hi[k] = -floatBelow(-double(b.hi[k]));
    }
  }
}

/// Whether two boxes are equal coordinate by coordinate (update() asks it of every object).
template <typename S>
inline bool sameBox(const Box<S>& a, const Box<S>& b) {
  return (a.lo[0] == b.lo[0]) & (a.lo[1] == b.lo[1]) & (a.lo[2] == b.lo[2]) & (a.hi[0] == b.hi[0]) &
         (a.hi[1] == b.hi[1]) & (a.hi[2] == b.hi[2]);
}

/// Whether two cubes have the same bounds (first/count ignored).
inline bool sameBounds(const Node& a, const Node& b) {
  return (a.lo[0] == b.lo[0]) & (a.lo[1] == b.lo[1]) & (a.lo[2] == b.lo[2]) & (a.hi[0] == b.hi[0]) &
         (a.hi[1] == b.hi[1]) & (a.hi[2] == b.hi[2]);
}

/// Closed overlap of two cubes or two boxes.
template <class B>
inline bool overlap(const B& a, const B& b) {
  return (a.lo[0] <= b.hi[0]) & (b.lo[0] <= a.hi[0]) & (a.lo[1] <= b.hi[1]) & (b.lo[1] <= a.hi[1]) &
         (a.lo[2] <= b.hi[2]) & (b.lo[2] <= a.hi[2]);
}

/// A box that many boxes are tested against (one query object down the leaves of a tree):
/// overlaps(x) is overlap(x, box), bit for bit.
template <typename S>
struct FixedBox {
  explicit FixedBox(const Box<S>& b) : box(b) {}
  bool overlaps(const Box<S>& x) const { return overlap(x, box); }
  Box<S> box;
};

/// Squared Euclidean gap between two boxes in type T (fcl::AABB::distance squared), summed in
/// axis order. An axis whose difference is NaN (both boxes reaching the same infinity) counts
/// as touching.
template <typename T, class B>
inline T gap2(const B& a, const B& b) {
  T sum = 0;
  for (int k = 0; k < 3; ++k) {
    const T d = std::max(T(a.lo[k]) - T(b.hi[k]), T(b.lo[k]) - T(a.hi[k]));
    if (d > 0) sum += d * d;
  }
  return sum;
}

/// Squared gap between two exact boxes, in double: the square of a float gap beyond 1.8e19
/// would overflow float.
template <typename S>
inline double boxGap2(const Box<S>& a, const Box<S>& b) {
  return gap2<double>(a, b);
}

/// cubeGap2 in double, for gaps whose float square overflows: the float bounds' differences and
/// squares always fit.
[[gnu::noinline]] inline double cubeGap2Wide(const Node& a, const Node& b) {
  return gap2<double>(a, b) * (1.0 - 0x1p-40);
}

/// Squared gap between two cubes, never above the exact value of their float bounds (so that
/// pruning on it is safe): computed in float and shrunk by a few ulps to absorb the roundings.
inline double cubeGap2(const Node& a, const Node& b) {
  const float sum = gap2<float>(a, b) * (1.0f - 0x1p-20f);
  if (__builtin_expect(sum <= std::numeric_limits<float>::max(), 1)) return sum;
  return cubeGap2Wide(a, b);
}

/// Sets `out` to the union of the boxes of items[first, first + count).
template <typename S>
inline void unionOfItems(const Item<S>* items, std::uint32_t first, std::uint32_t count,
                         Box<S>& out) {
  for (int k = 0; k < 3; ++k) {
    out.lo[k] = std::numeric_limits<S>::infinity();
    out.hi[k] = -std::numeric_limits<S>::infinity();
  }
  for (std::uint32_t p = first; p < first + count; ++p)
    for (int k = 0; k < 3; ++k) {
      out.lo[k] = std::min(out.lo[k], items[p].box.lo[k]);
      out.hi[k] = std::max(out.hi[k], items[p].box.hi[k]);
    }
}

/// Sets n's bounds (not first/count) to the union of a's and b's.
inline void unionOfCubes(Node& n, const Node& a, const Node& b) {
  for (int k = 0; k < 3; ++k) {
    n.lo[k] = std::min(a.lo[k], b.lo[k]);
    n.hi[k] = std::max(a.hi[k], b.hi[k]);
  }
}

/// Sets n's bounds (not first/count) to the union of the records' bounds ([first, last) not
/// empty).
inline void unionOfRecords(const BuildRecord* first, const BuildRecord* last, Node& n) {
  for (int k = 0; k < 3; ++k) {
    n.lo[k] = std::numeric_limits<float>::infinity();
    n.hi[k] = -std::numeric_limits<float>::infinity();
  }
  for (const BuildRecord* r = first; r < last; ++r)
    for (int k = 0; k < 3; ++k) {
      n.lo[k] = std::min(n.lo[k], r->lo[k]);
      n.hi[k] = std::max(n.hi[k], r->hi[k]);
    }
}

/// Four boxes rounded to nearest (as static_cast) into entries 0-3 of six float columns: lo[k]
/// and hi[k] for bound k.
template <typename S>
inline void fourToColumns(const Box<S>* const b[4], float* const lo[3], float* const hi[3]) {
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k][i] = static_cast<float>(b[i]->lo[k]);
      hi[k][i] = static_cast<float>(b[i]->hi[k]);
    }
}

}  // namespace portable
}  // namespace detail
}  // namespace cube
