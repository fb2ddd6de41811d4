#pragma once

// The one pair gate: every rule a pair of overlapping boxes must pass besides its boxes, asked by
// every path that reports pairs (walk leaves, the all-pairs test, the pair list, distance, and
// through those the object, body, swept and batch queries). A new rule is a member here and a
// line in admit(); Broadphase::gate() is where queries build it.

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

/// What a pair of overlapping boxes must also pass to reach a callback: the two objects' filter
/// bits, the user's predicate, and, in self queries, the orientation (lower registration number
/// first). A null member leaves its rule out; walks without a gate test nothing more. The rules
/// are asked in two steps, so that walks test the bits of many pairs at once without a branch
/// per pair: the bits (bitsPass, passing, groupsPass), then finish() for the pairs left; admit()
/// is both for one pair.
template <typename S>
struct PairGate {
  const Filter* filters_a = nullptr;  ///< per id of side a's objects; null: all default
  const Filter* filters_b = nullptr;  ///< per id of side b's objects; null: all default
  const Filter* groups_a = nullptr;   ///< per filter group of side a (View::groups index it)
  const Filter* groups_b = nullptr;   ///< per filter group of side b
  Filter query;                       ///< side b's object when its id is kNone
  const PairPredicate<S>* predicate = nullptr;  ///< the user's predicate, if any
  const std::uint32_t* seq = nullptr;           ///< self queries: orient pairs by these numbers
  /// Pairs ruled out by name: an n x n matrix over ids, nonzero for a pair never reported (a
  /// body's allowed pairs, BodySet::allowPair); null: none.
  const std::uint8_t* excluded = nullptr;
  std::size_t excluded_n = 0;

  /// Whether any rule is set: a walk without one reports every pair of overlapping boxes.
  bool active() const {
    return filters_a != nullptr || filters_b != nullptr || !query.isDefault() ||
           predicate != nullptr || seq != nullptr || excluded != nullptr;
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
