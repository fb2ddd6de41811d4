#pragma once

// The overlapping pairs of a broadphase's objects, kept from one update() to the next so that a
// self-collide after a small motion need not walk the cubes (Config::keep_pairs). Keyed by
// ObjectId: rebuilds and compactions of the cubes leave it untouched.

#include <cstdint>
#include <string>
#include <vector>

#include "core/object_table.h"
#include "core/traversal.h"
#include "cube_collision/query_stats.h"

namespace cube {
namespace detail {

/// Every pair of distinct objects whose boxes overlap (closed), as two ids, valid for the boxes
/// the objects had when the list was last made valid. 8 bytes per pair and 8 per id (each id's
/// object, so that reporting a pair reads two entries of one array rather than two slots), plus
/// a bit per id while refreshing.
template <typename S>
class PairList {
 public:
  /// Whether the list holds the overlapping pairs; the owner invalidates it whenever an object
  /// comes, goes or moves without a refresh.
  bool valid() const { return valid_; }
  /// Forgets the pairs (keeps the memory for the next listing).
  void invalidate() { valid_ = false; }
  /// Frees the memory too.
  void release();
  /// Lists the pairs of `scene` afresh (one self walk, as a self-collide) and the objects of
  /// `table`'s ids (its scene).
  void list(const Scene<S>& scene, const ObjectTable<S>& table);
  /// Brings a valid list up to date after the objects `moved` (ids, each once) changed boxes:
  /// drops their pairs and finds theirs anew, one query each. `id_bound`: one past the largest id.
  /// The objects stay as listed: ids neither come nor go while the list is valid.
  void refresh(const Scene<S>& scene, const std::vector<ObjectId>& moved, std::size_t id_bound);
  /// Calls fn(a, b, data) for every pair; stops and returns true as soon as fn does. Requires
  /// valid(). Right after a listing, the pairs come in the order and argument order of a
  /// self-collide; a refresh puts the moved objects' pairs last.
  bool collide(void* data, CollideFn<S> fn, QueryStats* stats) const;
  /// The same for the pairs that pass `gate` (oriented by it).
  bool collide(const PairGate<S>& gate, void* data, CollideFn<S> fn, QueryStats* stats) const;
  /// Appends the pairs that pass `gate`, oriented by it, as id << 32 | id.
  void collect(const PairGate<S>& gate, std::vector<std::uint64_t>& out) const;
  /// Pairs listed.
  std::size_t size() const { return pairs_.size(); }
  /// Bytes of heap memory owned.
  std::size_t bytes() const;
  /// If valid(): whether the list equals a fresh listing (as a set, each pair once) and names
  /// each live id's object.
  bool validate(const Scene<S>& scene, const ObjectTable<S>& table, std::string* why) const;

 private:
  // Calls then(a, b) on the ids of each pair that passes `gate`, oriented; stops when it says so.
  template <class Then>
  bool forPassing(const PairGate<S>& gate, Then&& then) const;

  std::vector<std::uint64_t> pairs_;  // id of the callback's first object << 32 | second's
  std::vector<std::uint64_t> marks_;  // refresh: one bit per id, the moved ones set
  std::vector<std::uint64_t> found_;  // refresh: the moved objects' pairs
  std::vector<fcl::CollisionObject<S>*> objs_;  // per id: its object (list)
  bool valid_ = false;
};

extern template class PairList<float>;
extern template class PairList<double>;

}  // namespace detail
}  // namespace cube
