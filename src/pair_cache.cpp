// The pair list that update() keeps for the next self-collide: listed by one self walk, then
// brought up to date by querying only the objects that moved.

#include "cube_collision/detail/pair_cache.h"

#include <algorithm>

namespace cube {
namespace detail {

namespace {

template <typename S>
constexpr std::uint32_t kUnbounded = Hierarchy<S>::kUnboundedBit;

// All pairs of `tree` into `out` (appended), in the order of a self-collide's callbacks.
template <typename S>
void listAll(const Hierarchy<S>& tree, std::vector<std::uint64_t>& out) {
  const View<S> cubes = tree.cubes();
  const View<S> unbounded = tree.unbounded();
  const std::size_t limit = tree.config().all_pairs_limit;
  collectPairs(cubes, 0, cubes, 0, true, limit, out);
  if (unbounded.root == kNone) return;
  collectPairs(cubes, 0, unbounded, kUnbounded<S>, false, limit, out);
  collectPairs(unbounded, kUnbounded<S>, unbounded, kUnbounded<S>, true, limit, out);
}

// A pair with the smaller location first: the form in which pairs are compared.
inline std::uint64_t ordered(std::uint64_t p) {
  const std::uint64_t a = p >> 32, b = p & 0xffffffffu;
  return a < b ? p : (b << 32 | a);
}

void orderAll(std::vector<std::uint64_t>& v) {
  for (std::uint64_t& p : v) p = ordered(p);
  std::sort(v.begin(), v.end());
}

}  // namespace

template <typename S>
void PairCache<S>::release() {
  valid_ = false;
  for (auto* v : {&pairs_, &marks_, &found_}) {
    v->clear();
    v->shrink_to_fit();
  }
}

template <typename S>
void PairCache<S>::recompute(const Hierarchy<S>& tree) {
  valid_ = false;
  pairs_.clear();
  listAll(tree, pairs_);
  layout_ = tree.layoutVersion();
  valid_ = true;
}

template <typename S>
void PairCache<S>::refresh(const Hierarchy<S>& tree, const std::vector<std::uint32_t>& changed) {
  if (layout_ != tree.layoutVersion()) {
    recompute(tree);
    return;
  }
  valid_ = false;
  const View<S> cubes = tree.cubes();
  const View<S> unbounded = tree.unbounded();
  // One bit per location: the cubes' slots, then the unbounded list.
  const auto bit = [&](std::uint32_t loc) -> std::size_t {
    return (loc & kUnbounded<S>) ? cubes.slots + (loc & ~kUnbounded<S>) : loc;
  };
  marks_.assign((std::size_t(cubes.slots) + unbounded.slots + 63) / 64, 0);
  found_.clear();
  for (const std::uint32_t loc : changed) {
    const std::size_t b = bit(loc);
    marks_[b / 64] |= std::uint64_t(1) << (b % 64);
    const Item<S>& it =
        (loc & kUnbounded<S>) ? unbounded.items[loc & ~kUnbounded<S>] : cubes.items[loc];
    const SingleView<S> query(it.obj, it.box);
    // The query's one slot is 0, so its tag is its whole location.
    collectPairs(cubes, 0, query.view(), loc, false, 0, found_);
    if (unbounded.root != kNone)
      collectPairs(unbounded, kUnbounded<S>, query.view(), loc, false, 0, found_);
  }
  // A pair of two changed objects was found from both ends.
  orderAll(found_);
  found_.erase(std::unique(found_.begin(), found_.end()), found_.end());
  const auto marked = [&](std::uint32_t loc) {
    const std::size_t b = bit(loc);
    return (marks_[b / 64] >> (b % 64)) & 1;
  };
  // Drop the changed objects' old pairs in one pass, without a branch per pair.
  std::size_t kept = 0;
  for (const std::uint64_t p : pairs_) {
    pairs_[kept] = p;
    kept += !(marked(static_cast<std::uint32_t>(p >> 32)) | marked(static_cast<std::uint32_t>(p)));
  }
  pairs_.resize(kept);
  pairs_.insert(pairs_.end(), found_.begin(), found_.end());
  valid_ = true;
}

template <typename S>
void PairCache<S>::remap(const Hierarchy<S>& tree, std::uint64_t layout_before,
                         const std::vector<std::uint32_t>& old_slot,
                         std::vector<std::uint32_t>& changed) {
  if (layout_ != layout_before) return;
  std::uint32_t slots = 0;
  for (const std::uint32_t s : old_slot) slots = std::max(slots, s + 1);
  std::vector<std::uint32_t> new_slot(slots, kNone);
  for (std::uint32_t p = 0; p < old_slot.size(); ++p) new_slot[old_slot[p]] = p;
  // Every listed or changed object is live, so it has a new slot; unbounded ones stay.
  const auto renumber = [&](std::uint32_t loc) {
    return (loc & kUnbounded<S>) ? loc : new_slot[loc];
  };
  for (std::uint64_t& p : pairs_)
    p = std::uint64_t(renumber(static_cast<std::uint32_t>(p >> 32))) << 32 |
        renumber(static_cast<std::uint32_t>(p));
  for (std::uint32_t& loc : changed) loc = renumber(loc);
  layout_ = tree.layoutVersion();
}

template <typename S>
bool PairCache<S>::collide(const Hierarchy<S>& tree, void* data, CollideFn<S> fn,
                           QueryStats* stats) const {
  const Item<S>* cubes = tree.cubes().items;
  const Item<S>* unbounded = tree.unbounded().items;
  const auto at = [&](std::uint32_t loc) {
    return (loc & kUnbounded<S>) ? unbounded[loc & ~kUnbounded<S>].obj : cubes[loc].obj;
  };
  for (const std::uint64_t p : pairs_) {
    if (stats) ++stats->callbacks;
    if (fn(at(static_cast<std::uint32_t>(p >> 32)), at(static_cast<std::uint32_t>(p)), data))
      return true;
  }
  return false;
}

template <typename S>
std::size_t PairCache<S>::bytes() const {
  return (pairs_.capacity() + marks_.capacity() + found_.capacity()) * sizeof(std::uint64_t);
}

template <typename S>
bool PairCache<S>::validate(const Hierarchy<S>& tree, std::string* why) const {
  if (!current(tree)) return true;
  std::vector<std::uint64_t> want, got(pairs_);
  listAll(tree, want);
  orderAll(want);
  orderAll(got);
  const char* problem = nullptr;
  if (std::adjacent_find(got.begin(), got.end()) != got.end())
    problem = "the pair list holds a pair twice";
  else if (got != want)
    problem = "the pair list differs from the overlapping pairs of the current boxes";
  if (problem == nullptr) return true;
  if (why) *why = problem;
  return false;
}

template class PairCache<float>;
template class PairCache<double>;

}  // namespace detail
}  // namespace cube
