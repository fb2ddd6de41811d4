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

/// Surface area of an object's box in double.
template <typename S>
double surfaceArea(const Box<S>& b) {
  const double dx = double(b.hi[0]) - b.lo[0];
  const double dy = double(b.hi[1]) - b.lo[1];
  const double dz = double(b.hi[2]) - b.lo[2];
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

/// An object's collision filter bits (as Box2D's, Bullet's and Jolt's): two objects pair only if
/// each one's category meets the other's mask. The default pairs with everything.
struct Filter {
  std::uint64_t category = 1;
  std::uint64_t mask = ~std::uint64_t(0);
  bool isDefault() const { return category == 1 && mask == ~std::uint64_t(0); }
};
inline bool filtersPass(const Filter& a, const Filter& b) {
  return ((a.category & b.mask) != 0) & ((b.category & a.mask) != 0);
}
inline bool operator==(const Filter& a, const Filter& b) {
  return a.category == b.category && a.mask == b.mask;
}

/// A filter group: the index of one distinct Filter value in the object table's interned list,
/// the same for every object with those bits. Cubes carry the group of all their objects, so
/// that a walk drops a pair of cubes whose groups cannot pair without looking at an object.
using Group = std::uint8_t;
/// A cube whose objects are of several groups, or an object whose bits found no free group.
inline constexpr Group kMixedGroup = 0xff;

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
  /// Per cube: the filter group of all its objects, or kMixedGroup; null: unknown (all mixed).
  const Group* groups = nullptr;
};

/// What the build permutes: 32 bytes per object (the float bounds the cubes are made of), so that
/// median selection streams through one array instead of chasing indices into the items.
struct BuildRecord {
  float lo[3];
  float hi[3];
  std::uint32_t seq;   ///< registration number: ties in the build's order go by it
  std::uint32_t item;  ///< where the object's Item is
};
static_assert(sizeof(BuildRecord) == 32, "two records per cache line");

}  // namespace detail
}  // namespace cube
