#pragma once

// The one pair gate: every rule a pair of overlapping boxes must pass besides its boxes, asked by
// every path that reports pairs (walk leaves, the all-pairs test, the pair list, distance, and
// through those the object, body, swept and batch queries). A new rule is a member here and a
// line in finish(); Broadphase::gate() is where queries build it.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <utility>

#include "core/geometry.h"

namespace cube {
namespace detail {

/// The user's pair predicate (CubeCollisionManager::setPairFilter): false drops the pair before
/// any callback.
template <typename S>
using PairPredicate = std::function<bool(fcl::CollisionObject<S>*, fcl::CollisionObject<S>*)>;

/// The key of the unordered pair of ids x != y (both below kNone): never kNoPair.
inline std::uint64_t pairKey(ObjectId x, ObjectId y) {
  return x < y ? std::uint64_t(x) << 32 | y : std::uint64_t(y) << 32 | x;
}
inline constexpr std::uint64_t kNoPair = ~std::uint64_t(0);
/// A 64-bit finalizer: the slot of a key (a pointer, a pair key) in an open-addressed table.
inline std::size_t hashKey(std::uint64_t x) {
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  return static_cast<std::size_t>(x);
}

/// An object table's excluded pairs as queries read them (ObjectTable::exclusions): the pairs'
/// keys in open addressing (kNoPair: an empty slot), and per id below n the number of pairs it
/// is in, so that most pairs are passed without a probe.
struct ExcludedSet {
  const std::uint32_t* count = nullptr;
  std::size_t n = 0;
  const std::uint64_t* keys = nullptr;
  std::size_t mask = 0;
  /// Whether the pair of ids x and y is excluded (false for an id not below n, kNone included).
  bool has(ObjectId x, ObjectId y) const {
    if (x >= n || y >= n || count[x] == 0 || count[y] == 0) return false;
    const std::uint64_t k = pairKey(x, y);
    for (std::size_t i = hashKey(k) & mask;; i = (i + 1) & mask) {
      if (keys[i] == k) return true;
      if (keys[i] == kNoPair) return false;
    }
  }
};

/// One table's excluded pairs seen from a query's two sides: side a's and side b's ids in that
/// table (a null map: the side's ids are the table's own; side b's query object, id kNone, is
/// `query`, kNone if not registered there). A null set: none. No initializers: a query's room
/// for it costs nothing until a gate fills it (Broadphase::gate).
struct ExcludedView {
  const ExcludedSet* set;
  const ObjectId* a;
  const ObjectId* b;
  ObjectId query;
  bool has(ObjectId x, ObjectId y) const {
    return set != nullptr && set->has(a != nullptr ? a[x] : x, y == kNone     ? query
                                                               : b != nullptr ? b[y]
                                                                              : y);
  }
};

/// The excluded pairs a query honours (CubeCollisionManager::excludePair): the querying table's,
/// and against another table also that one's, so that either manager's exclusion drops a pair.
struct Exclusions {
  ExcludedView mine, theirs;
  /// Whether the pair of side a's x and side b's y is excluded.
  bool has(ObjectId x, ObjectId y) const { return mine.has(x, y) || theirs.has(x, y); }
};

/// What a pair of overlapping boxes must also pass to reach a callback: the two objects' filter
/// bits, the pairs excluded by id, the user's predicate, and, in self queries, the orientation
/// (lower registration number first). A null member leaves its rule out; walks without a gate test
/// nothing more. The rules are asked in two steps, so that walks test the bits of many pairs at
/// once without a branch per pair: the bits (bitsPass, passing, groupsPass), then finish() for the
/// pairs left; admit() is both for one pair.
template <typename S>
struct PairGate {
  const Filter* filters_a = nullptr;  ///< per id of side a's objects; null: all default
  const Filter* filters_b = nullptr;  ///< per id of side b's objects; null: all default
  const Filter* groups_a = nullptr;   ///< per filter group of side a (View::groups index it)
  const Filter* groups_b = nullptr;   ///< per filter group of side b
  Filter query;                       ///< side b's object when its id is kNone
  const PairPredicate<S>* predicate = nullptr;  ///< the user's predicate, if any
  const std::uint32_t* seq = nullptr;           ///< self queries: orient pairs by these numbers
  /// A body's excluded pairs (BodySet::excludePair): an n x n matrix over its ids, nonzero for
  /// a pair never reported; null: none.
  const std::uint8_t* excluded = nullptr;
  std::size_t excluded_n = 0;
  /// The object tables' excluded pairs (CubeCollisionManager::excludePair), in the query's room
  /// for them; null: none.
  const Exclusions* excluded_ids = nullptr;

  /// Whether any rule is set: a walk without one reports every pair of overlapping boxes.
  bool active() const {
    return filters_a != nullptr || filters_b != nullptr || !query.isDefault() ||
           predicate != nullptr || seq != nullptr || excluded != nullptr || excluded_ids != nullptr;
  }
  /// The gate without the predicate: for walks on other threads, whose pairs are put to the
  /// predicate (user code) on the calling thread with predicatePasses.
  PairGate withoutPredicate() const {
    PairGate g = *this;
    g.predicate = nullptr;
    return g;
  }
  /// Whether the predicate (if any) lets the objects pair, in this order.
  bool predicatePasses(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b) const {
    return predicate == nullptr || (*predicate)(a, b);
  }
  /// The filter bits of the objects with ids x and y (y may be kNone: the query object).
  std::pair<const Filter*, const Filter*> bitsOf(ObjectId x, ObjectId y) const {
    static constexpr Filter kAll{};
    const Filter* fx = filters_a != nullptr ? filters_a + x : &kAll;
    const Filter* fy = y == kNone ? &query : filters_b != nullptr ? filters_b + y : &kAll;
    return {fx, fy};
  }
  /// Whether the filter bits let the objects with ids x and y pair.
  bool bitsPass(ObjectId x, ObjectId y) const {
    const auto f = bitsOf(x, y);
    return filtersPass(*f.first, *f.second);
  }
  /// Whether there are bits to test (else every pair passes them).
  bool hasBits() const { return filters_a != nullptr || filters_b != nullptr; }
  /// Whether every object of a cube of group ga (side a) may pair with every object of a cube
  /// of group gb (side b; kNone: the query object) by their bits: true (pass), false (none
  /// can), or unknown (a mixed cube, or no groups). Returns 1, 0 or -1.
  int groupsPass(Group ga, Group gb, bool query_b) const {
    if (ga == kMixedGroup || groups_a == nullptr) return -1;
    if (query_b) return filtersPass(groups_a[ga], query);
    if (gb == kMixedGroup || groups_b == nullptr) return -1;
    return filtersPass(groups_a[ga], groups_b[gb]);
  }
  /// `bits` with the pairs whose filter bits do not pass cleared; bits_of(b) points at bit b's
  /// two Filters. No branch per pair: whether a pair passes is a coin toss for the branch predictor
  /// when groups are mixed, and a mispredicted branch costs more than the test.
  template <class BitsOf>
  static std::uint64_t passing(std::uint64_t bits, BitsOf&& bits_of) {
    std::uint64_t out = bits;
    for (std::uint64_t m = bits; m != 0; m &= m - 1) {
      const unsigned b = static_cast<unsigned>(__builtin_ctzll(m));
      const auto f = bits_of(b);
      out &= ~(std::uint64_t(!filtersPass(*f.first, *f.second)) << b);
    }
    return out;
  }
  /// The rules after the bits, for a pair whose bits passed: the excluded pairs, orientation and
  /// the predicate.
  /// x and y are records or ids; obj(x) gives the object. Calls then(first, second) if it passes;
  /// false (the query goes on) otherwise.
  template <class T, class IdOf, class ObjOf, class Then>
  bool finish(const T& x, const T& y, IdOf&& id, ObjOf&& obj, Then&& then) const {
    if (excluded != nullptr && excluded[std::size_t(id(x)) * excluded_n + id(y)]) return false;
    if (excluded_ids != nullptr && excluded_ids->has(id(x), id(y))) return false;
    const bool swap = seq != nullptr && seq[id(y)] < seq[id(x)];
    const T& first = swap ? y : x;
    const T& second = swap ? x : y;
    if (!predicatePasses(obj(first), obj(second))) return false;
    return then(first, second);
  }
  /// Calls then(x, y) on the pair, oriented, if it passes every rule; false (the query goes on)
  /// otherwise.
  template <class Then>
  bool admit(const Item<S>& x, const Item<S>& y, Then&& then) const {
    if (!bitsPass(x.id, y.id)) return false;
    return finish(
        x, y, [](const Item<S>& i) { return i.id; }, [](const Item<S>& i) { return i.obj; }, then);
  }
};

}  // namespace detail
}  // namespace cube
