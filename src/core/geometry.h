#pragma once

// What every part of the core shares: exact object boxes, the float cubes, the slots that hold
// an object in a leaf, and the read-only view the traversals walk. No FCL or Eigen types beyond a
// forward declaration, so that this code could be built with any instruction set without
// touching Eigen's ABI.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <new>
#include <string>
#include <type_traits>
#include <vector>

#include "cube_collision/config.h"

#if defined(__SSE2__)
#include <emmintrin.h>  // baseline on x86-64: no -m flag, so no effect on Eigen's ABI
#endif

namespace fcl {
template <typename S>
class CollisionObject;
}  // namespace fcl

namespace cube {
namespace detail {

/// Allocator that puts element 0 `Offset` bytes past a cache-line (64-byte) boundary. Sibling
/// cubes sit at an odd index and the next one, so with Offset 32 each sibling pair fills exactly
/// one line (glibc's malloc would start the array 16 bytes past a line and split half the cubes
/// in two); with Offset 0 each 64-byte object record fills one line.
template <class T, std::size_t Offset>
struct LineAllocator {
  static_assert(Offset < 64 && Offset % alignof(T) == 0, "offset within a line, T aligned");
  using value_type = T;
  template <class U>
  struct rebind {
    using other = LineAllocator<U, Offset>;
  };
  LineAllocator() = default;
  template <class U>
  LineAllocator(const LineAllocator<U, Offset>&) noexcept {}
  T* allocate(std::size_t n) {
    auto* base =
        static_cast<unsigned char*>(::operator new(n * sizeof(T) + Offset, std::align_val_t(64)));
    return reinterpret_cast<T*>(base + Offset);
  }
  void deallocate(T* p, std::size_t) noexcept {
    ::operator delete(reinterpret_cast<unsigned char*>(p) - Offset, std::align_val_t(64));
  }
  template <class U>
  bool operator==(const LineAllocator<U, Offset>&) const noexcept {
    return true;
  }
  template <class U>
  bool operator!=(const LineAllocator<U, Offset>&) const noexcept {
    return false;
  }
};

/// Index meaning "no cube" / "no object".
inline constexpr std::uint32_t kNone = 0xffffffffu;

/// An axis-aligned box in the objects' scalar type.
template <typename S>
struct Box {
  S lo[3];
  S hi[3];
};

/// Where an object's AABB puts it.
enum class BoxKind { finite, unbounded, invalid };

/// Classifies a box: any NaN makes it invalid, any coordinate beyond +-limit unbounded. Inline:
/// registration calls it once per object, update() once per moved one.
template <typename S>
inline BoxKind classify(const Box<S>& b, double limit) {
  // update() classifies every object on every call: one branch-free test for the common case
  // (a NaN fails every comparison, so it lands in the slow path too).
  const double l = limit;
  const bool inside = (std::fabs(double(b.lo[0])) <= l) & (std::fabs(double(b.lo[1])) <= l) &
                      (std::fabs(double(b.lo[2])) <= l) & (std::fabs(double(b.hi[0])) <= l) &
                      (std::fabs(double(b.hi[1])) <= l) & (std::fabs(double(b.hi[2])) <= l);
  if (inside) return BoxKind::finite;
  for (int k = 0; k < 3; ++k)
    if (std::isnan(b.lo[k]) || std::isnan(b.hi[k])) return BoxKind::invalid;
  return BoxKind::unbounded;
}

/// One cube of the hierarchy. Its bounds are floats rounded outward, so that a cube always
/// contains its objects' exact boxes and two cubes fit in a cache line; the exact boxes are
/// tested at the leaves, so results do not depend on the rounding. Each corner is followed by a
/// 32-bit field so that a corner loads as one 4-wide SIMD register.
struct Node {
  float lo[3];
  /// Leaf: position of its first object in the object array. Internal: index of its first child
  /// cube; the second child is first + 1. Dead (unreachable, awaiting compaction): kNone.
  std::uint32_t first;
  float hi[3];
  /// Leaf: number of objects (>= 1), the seed's children range [first, first + count).
  /// Internal and dead cubes: 0.
  std::uint32_t count;

  bool isLeaf() const { return count != 0; }
};
static_assert(sizeof(Node) == 32, "two cubes per cache line");

/// The cube array: the root at 0, sibling pairs from odd indices, one pair per cache line.
using NodeArray = std::vector<Node, LineAllocator<Node, 32>>;

/// Surface area of a cube in double; an emptied cube (lo > hi) has none.
inline double surfaceArea(const Node& n) {
  if (n.lo[0] > n.hi[0]) return 0.0;
  const double dx = double(n.hi[0]) - n.lo[0];
  const double dy = double(n.hi[1]) - n.lo[1];
  const double dz = double(n.hi[2]) - n.lo[2];
  return 2.0 * (dx * dy + dy * dz + dz * dx);
}

/// Location bit of an object kept in the unbounded list rather than in the cubes.
inline constexpr std::uint32_t kUnboundedBit = 0x80000000u;

/// A stable object id: dense, 32 bits, reused after unregistration (see ObjectTable).
using ObjectId = std::uint32_t;

/// One object in a leaf (or in the unbounded list): a copy of its cached AABB and of its pointer,
/// so that walks and callbacks read one record, and its stable id.
template <typename S>
struct Item {
  Box<S> box;
  fcl::CollisionObject<S>* obj;  ///< nullptr marks a dead slot (not in any leaf)
  std::uint32_t leaf;            ///< the seed's parentOf: the leaf cube holding this object
  ObjectId id;                   ///< the object's id in the ObjectTable
};
static_assert(sizeof(Item<double>) == 64, "one object per cache line for double");

/// The object records, each starting on a cache line for double.
template <typename S>
using ItemArray = std::vector<Item<S>, LineAllocator<Item<S>, 0>>;

/// A read-only window on a tree for the traversals: either the cubes, or the list of unbounded
/// objects seen as one leaf, or a single query object seen as one leaf.
template <typename S>
struct View {
  const Node* nodes = nullptr;
  const Item<S>* items = nullptr;
  std::uint32_t root = kNone;  ///< kNone: empty
  std::uint32_t slots = 0;     ///< length of `items`, dead slots (obj == nullptr) included
};

/// Whether two boxes are equal coordinate by coordinate. Without branches: update() asks this
/// of every object, and the answer is "yes" for most.
template <typename S>
bool sameBox(const Box<S>& a, const Box<S>& b) {
  return (a.lo[0] == b.lo[0]) & (a.lo[1] == b.lo[1]) & (a.lo[2] == b.lo[2]) & (a.hi[0] == b.hi[0]) &
         (a.hi[1] == b.hi[1]) & (a.hi[2] == b.hi[2]);
}

#if defined(__SSE2__)
inline bool sameBox(const Box<double>& a, const Box<double>& b) {
  // The six coordinates are contiguous: three two-lane compares.
  const __m128d e0 = _mm_cmpeq_pd(_mm_loadu_pd(a.lo), _mm_loadu_pd(b.lo));
  const __m128d e1 = _mm_cmpeq_pd(_mm_loadu_pd(a.lo + 2), _mm_loadu_pd(b.lo + 2));
  const __m128d e2 = _mm_cmpeq_pd(_mm_loadu_pd(a.hi + 1), _mm_loadu_pd(b.hi + 1));
  return _mm_movemask_pd(_mm_and_pd(_mm_and_pd(e0, e1), e2)) == 3;
}
#endif

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
  if constexpr (std::is_same_v<S, float>) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = b.lo[k];
      hi[k] = b.hi[k];
    }
  } else {
#if defined(__SSE2__)
    // The same float operations as floatBelow, four and two lanes at a time (the results are
    // bit for bit the same): builds and refits round every box.
    const __m128d kMax = _mm_set1_pd(std::numeric_limits<float>::max());
    const __m128d kMin = _mm_set1_pd(-std::numeric_limits<float>::max());
    auto narrow = [&](const double* p) {
      return _mm_cvtpd_ps(_mm_min_pd(_mm_max_pd(_mm_loadu_pd(p), kMin), kMax));
    };
    const __m128 a = _mm_movelh_ps(narrow(b.lo), narrow(b.lo + 2));  // lo0 lo1 lo2 hi0
    const __m128 c = narrow(b.hi + 1);                               // hi1 hi2 0 0
    const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    const __m128 scale = _mm_set1_ps(0x1p-22f);
    const __m128 tiny = _mm_set1_ps(std::numeric_limits<float>::min());
    const __m128 da = _mm_add_ps(_mm_mul_ps(_mm_and_ps(a, abs_mask), scale), tiny);
    const __m128 dc = _mm_add_ps(_mm_mul_ps(_mm_and_ps(c, abs_mask), scale), tiny);
    alignas(16) float down[4], up[4], up2[4];
    _mm_store_ps(down, _mm_sub_ps(a, da));
    _mm_store_ps(up, _mm_add_ps(a, da));
    _mm_store_ps(up2, _mm_add_ps(c, dc));
    lo[0] = down[0];
    lo[1] = down[1];
    lo[2] = down[2];
    hi[0] = up[3];
    hi[1] = up2[0];
    hi[2] = up2[1];
#else
    for (int k = 0; k < 3; ++k) {
      lo[k] = floatBelow(double(b.lo[k]));
      hi[k] = -floatBelow(-double(b.hi[k]));
    }
#endif
  }
}

}  // namespace detail
}  // namespace cube
