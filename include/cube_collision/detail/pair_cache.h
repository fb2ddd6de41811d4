#pragma once

// The overlapping pairs of a manager's objects, kept from one update() to the next so that a
// self-collide after a small motion need not walk the cubes (Config::keep_pairs).

#include <cstdint>
#include <string>
#include <vector>

#include "cube_collision/detail/hierarchy.h"
#include "cube_collision/detail/traversal.h"
#include "cube_collision/query_stats.h"

namespace cube {
namespace detail {

/// Every pair of distinct objects of a hierarchy whose boxes overlap (closed), as two locations
/// (Hierarchy::objectAt), valid for one layout of the hierarchy and the boxes it had when the
/// list was last made current. 8 bytes per pair, plus a bit per location while refreshing.
template <typename S>
class PairCache {
 public:
  /// Whether the list holds exactly the overlapping pairs of `tree` as it is now. The owner
  /// must invalidate() or refresh the list whenever a box changes; layout changes are caught
  /// here.
  bool current(const Hierarchy<S>& tree) const { return valid_ && layout_ == tree.layoutVersion(); }
  /// Forgets the pairs (keeps the memory for the next listing).
  void invalidate() { valid_ = false; }
  /// Frees the memory too.
  void release();
  /// Lists the pairs of `tree` afresh: one self walk, as a self-collide.
  void recompute(const Hierarchy<S>& tree);
  /// Brings a list that was current before the boxes at `changed` (locations) moved up to date:
  /// drops their pairs and finds theirs anew, one query each. If the layout changed meanwhile,
  /// lists afresh instead.
  void refresh(const Hierarchy<S>& tree, const std::vector<std::uint32_t>& changed);
  /// Follows a rebuild that took the cubes' objects from `old_slot[p]` to slot p (the boxes
  /// unchanged), if the list was made for the layout `layout_before` that the rebuild replaced:
  /// renumbers the pairs and `changed` (locations awaiting a refresh) instead of listing
  /// afresh. Otherwise does nothing, and the next refresh lists afresh.
  void remap(const Hierarchy<S>& tree, std::uint64_t layout_before,
             const std::vector<std::uint32_t>& old_slot, std::vector<std::uint32_t>& changed);
  /// Calls fn(a, b, data) for every pair; stops and returns true as soon as fn does. Requires
  /// current(tree). Right after a listing, the pairs come in the order and argument order of
  /// a self-collide; a refresh puts the moved objects' pairs last.
  bool collide(const Hierarchy<S>& tree, void* data, CollideFn<S> fn, QueryStats* stats) const;
  /// Pairs listed.
  std::size_t size() const { return pairs_.size(); }
  /// Bytes of heap memory owned.
  std::size_t bytes() const;
  /// If current(tree): whether the list equals a fresh listing (as a set, each pair once).
  bool validate(const Hierarchy<S>& tree, std::string* why) const;

 private:
  std::vector<std::uint64_t> pairs_;  // location of the callback's first object << 32 | second's
  std::vector<std::uint64_t> marks_;  // refresh: one bit per location, the changed ones set
  std::vector<std::uint64_t> found_;  // refresh: the changed objects' pairs
  std::uint64_t layout_ = 0;
  bool valid_ = false;
};

extern template class PairCache<float>;
extern template class PairCache<double>;

}  // namespace detail
}  // namespace cube
