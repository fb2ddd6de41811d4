#pragma once

// The query walks: the policies (core/walk_policies.h) as visitors of walkTree (one object
// against a tree) and walkPair (cube pairs), the float columns and filter bits a self walk
// gathers first, and the choice between the plain walk and the one over cubes that carry filter
// groups. Private to the core's walk files, in an unnamed namespace as walk_policies.h.

#include <cstdint>
#include <vector>

#include "core/walk.h"
#include "core/walk_policies.h"

namespace cube {
namespace detail {
namespace {

// Starts loading what a visit of cube `n` will read first (its children, or its objects' boxes),
// so that the load overlaps the work on the entries above it on the stack: a descent is
// otherwise one chain of dependent cache misses. A leaf tested on float columns reads a run of
// each column, not its records (those only for the pairs the floats let through): with the
// records' line prefetched instead, large self-collides of thin boxes were slower.
template <typename S>
inline void prefetchBelow(const View<S>& v, const Node& n, const Columns* columns = nullptr) {
  if (!n.isLeaf()) {
    __builtin_prefetch(v.nodes + n.first);
  } else if (columns != nullptr) {
    for (float* col : columns->col) __builtin_prefetch(col + n.first);
  } else {
    __builtin_prefetch(v.items + n.first);
  }
}

// What the filter groups of cube a of `va` and cube b of `vb` (kNone: the query object) say
// about their pairs: 1 all pass their bits, 0 none does, -1 unknown (see PairGate::groupsPass).
// Only the walks over cubes that carry groups (Groups below) ask.
template <typename S, class Policy>
inline int groupsPass(const Policy& p, const View<S>& va, std::uint32_t a, const View<S>& vb,
                      std::uint32_t b) {
  if (p.gate == nullptr || va.groups == nullptr) return -1;
  const bool query = b == kNone;
  return p.gate->groupsPass(va.groups[a],
                            query || vb.groups == nullptr ? kMixedGroup : vb.groups[b], query);
}

// One object against a tree (walkTree): the common query, with a lighter stack than a walk of
// cube pairs. Calls p.leaf(tree object, query object). Also a query view whose root is a leaf
// of a few objects (a robot's group of links; unordered policies without filter groups only):
// its cube is tested as the one object's would be and the tree's leaves against it as the walk
// of cube pairs tests two leaves (leafPair), so the pairs come in that walk's order. Few: the
// query may hold more than one object (a type of its own, so that one object's walk, the
// common query, carries no test for it).
template <typename S, class Policy, bool Groups, bool Few = false>
struct ObjectVisitor {
  using State = typename Policy::Key;
  static constexpr bool kOrdered = Policy::kOrdered;
  // By reference, unlike PairVisitor: an object query's views were just written by its entry,
  // and a copy's 16-byte loads of them waited for those narrower stores (object queries with
  // the narrow phase on small managers were slower).
  const View<S>& tree;
  const View<S>& query;
  const Node& qn;
  const Item<S>& q;
  const Policy p;

  static bool before(State x, State y) { return Policy::before(x, y); }
  bool worth(State key) const { return p.worth(key); }
  bool enter(std::uint32_t child, int which, State, State& key) const {
    // From the first sibling (child - which): both siblings' addresses then differ by a
    // constant, not each computed from its own 32-bit index.
    const Node& n = (tree.nodes + (child - std::uint32_t(which)))[which];
    if constexpr (Groups) {
      if (groupsPass(p, tree, child, tree, kNone) == 0) return false;
    }
    // Prefetched only if taken: about half the children an object query tests are not.
    if (!p.enter(n, qn, key)) return false;
    prefetchBelow(tree, n);
    return true;
  }
  Step at(std::uint32_t cube, State) const {
    p.count.visit();
    const Node& n = tree.nodes[cube];
    if (!n.isLeaf()) return Step::open;
    if constexpr (Policy::kOrdered) {
      if (n.count <= 16) return leafNearestFirst(tree, n, q, p) ? Step::stop : Step::skip;
    } else {
      static_assert(!(Few && Groups), "a few objects' walk tests no filter groups");
      if constexpr (Few) {
        if (qn.count > 1) return leafPair(tree, n, query, qn, p, false) ? Step::stop : Step::skip;
      }
      if (n.count <= kMaskLeaf) {
        bool bits_pass = false;
        if constexpr (Groups) bits_pass = groupsPass(p, tree, cube, tree, kNone) == 1;
        return collideSmall<false>(tree.items + n.first, n.count, &q, 1, p, bits_pass) ? Step::stop
                                                                                       : Step::skip;
      }
    }
    for (std::uint32_t i = n.first; i < n.first + n.count; ++i)
      if (p.leaf(tree.items[i], q)) return Step::stop;
    return Step::skip;
  }
};

// Cube pairs of two views, or of one view with itself (walkPair).
template <typename S, class Policy, bool Groups>
struct PairVisitor {
  using State = typename Policy::Key;
  static constexpr bool kOrdered = Policy::kOrdered;
  // The views and the policy by value: a walk reads their pointers at every step, and after
  // each callback (an opaque call) it must read them again; a reference would add a load to
  // each such chain. (Policies are immutable during a walk; what they change sits behind
  // pointers, so the copy shares it.)
  const View<S> va;
  const View<S> vb;
  const Policy p;

  static bool before(State x, State y) { return Policy::before(x, y); }
  bool worth(State key) const { return p.worth(key); }
  void visit() const { p.count.visit(); }
  bool enter(std::uint32_t a, std::uint32_t b, State& key) const {
    if constexpr (Groups) {
      if (groupsPass(p, va, a, vb, b) == 0) return false;
    }
    return p.enter(va.nodes[a], vb.nodes[b], key);
  }
  // Whether the pairs within cube a (self walks) may pass the filter bits.
  bool enterSelf(std::uint32_t a) const {
    if constexpr (Groups) return groupsPass(p, va, a, va, a) != 0;
    return true;
  }
  void prefetch(bool in_a, std::uint32_t cube) const {
    // Columns only in a self walk, where va and vb are the same view.
    if (in_a)
      prefetchBelow(va, va.nodes[cube], p.columns);
    else
      prefetchBelow(vb, vb.nodes[cube], p.columns);
  }
  bool leafSelf(std::uint32_t a) const {
    bool bits_pass = false;
    if constexpr (Groups) bits_pass = groupsPass(p, va, a, va, a) == 1;
    return detail::leafSelf(va, va.nodes[a], p, bits_pass);
  }
  bool leafPair(std::uint32_t a, std::uint32_t b) const {
    bool bits_pass = false;
    if constexpr (Groups) bits_pass = groupsPass(p, va, a, vb, b) == 1;
    return detail::leafPair(va, va.nodes[a], vb, vb.nodes[b], p, bits_pass);
  }
};

// The walk below the roots of a tree `va` and a view `vb` whose root is a leaf: one object, or
// (unordered policies without filter groups) a few (ObjectVisitor).
template <bool Groups, typename S, class Policy, bool Few = false>
inline bool walkObject(const View<S>& va, const View<S>& vb, const Policy& p,
                       typename Policy::Key key) {
  const Node& qb = vb.nodes[vb.root];
  ObjectVisitor<S, Policy, Groups, Few> v{va, vb, qb, vb.items[qb.first], p};
  return walkTree(va.nodes, va.root, key, v);
}

// The walk below the roots: a single object (one-leaf view) against a tree goes through
// walkTree, and so does a leaf of a few objects where ObjectVisitor takes one; anything else
// through walkPair. Groups: whether cubes' filter groups are tested.
template <bool Groups, typename S, class Policy>
inline bool walkFrom(const View<S>& va, const View<S>& vb, bool self, const Policy& p,
                     typename Policy::Key key) {
  const Node& qb = vb.nodes[vb.root];
  if (!self && qb.count == 1) return walkObject<Groups>(va, vb, p, key);
  if constexpr (!Policy::kOrdered && !Groups) {
    if (!self && qb.isLeaf() && qb.count <= kMaskLeaf)
      return walkObject<Groups, S, Policy, true>(va, vb, p, key);
  }
  PairVisitor<S, Policy, Groups> v{va, vb, p};
  return walkPair(va.nodes, vb.nodes, va.root, vb.root, key, self, v);
}

// Every query's walk. Groups: whether the cubes' filter groups are tested (the caller knows:
// a gate and cubes that carry groups); the walk without, which most queries take, tests nothing
// for them.
// OneObject: the caller knows vb is one object (and self false): the walk of cube pairs is not
// compiled in.
template <bool Groups, typename S, class Policy, bool OneObject = false>
bool descend(const View<S>& va, const View<S>& vb, bool self, const Policy& p) {
  if (va.root == kNone || vb.root == kNone) return false;
  typename Policy::Key key{};
  if (!self && !p.enter(va.nodes[va.root], vb.nodes[vb.root], key)) return false;
  if constexpr (OneObject) return walkObject<Groups>(va, vb, p, key);
  return walkFrom<Groups>(va, vb, self, p, key);
}

// Whether a walk of `a` with itself tests its leaves on float columns (see kColumnsMin).
template <typename S>
bool wantsColumns(const View<S>& a, bool self, const PairKernels<S>* kernels) {
  return self && a.slots >= kColumnsMin && kernels->columnHits[1] != nullptr;
}

// A self walk with filter bits reads them per slot (CollidePolicy::slot_bits): gathered here.
// Not for cubes that carry filter groups: their one-group leaves need no bits, and the few mixed
// ones read them by id.
template <typename S>
void gatherSlotBits(const View<S>& a, bool self, const PairGate<S>* gate,
                    std::vector<Filter>& bits) {
  if (!self || gate == nullptr || gate->filters_a == nullptr || a.groups != nullptr) return;
  bits.resize(a.slots);  // dead slots keep the default bits; no pair reaches them
  for (std::uint32_t s = 0; s < a.slots; ++s)
    if (a.items[s].obj != nullptr) bits[s] = gate->filters_a[a.items[s].id];
}

// The walk proper, given the kernel table (null in object queries) and the float columns of a
// self walk (null: leaves are tested on the exact boxes).
template <bool Groups, typename S, class Sink>
[[gnu::always_inline]] inline bool collideRun(const View<S>& a, const View<S>& b, bool self,
                                              const Sink& sink, QueryStats* stats,
                                              const PairGate<S>* gate,
                                              const PairKernels<S>* kernels, const Columns* use,
                                              bool fill_columns = false) {
  std::vector<Filter> bits;
  gatherSlotBits(a, self, gate, bits);
  const auto run = [&](auto count) {
    CollidePolicy<S, decltype(count), Sink> p{sink, count, kernels, use, gate, fill_columns};
    if (!bits.empty()) {
      p.slot_bits = bits.data();
      p.slot_base = a.items;
    }
    return descend<Groups>(a, b, self, p);
  };
  return stats ? run(Count{stats}) : run(NoCount{});
}

// Self walks of many slots, with their float columns (in this frame up to kFrameColumnFloats,
// beyond on the heap).
template <bool Groups, typename S, class Sink>
[[gnu::noinline]] bool collideColumns(const View<S>& a, const View<S>& b, const Sink& sink,
                                      QueryStats* stats, const PairGate<S>* gate,
                                      const PairKernels<S>* kernels) {
  alignas(32) float frame[kFrameColumnFloats];
  const ColumnStore store(a.slots, frame, kFrameColumnFloats);
  // Without groups the walk writes each leaf's entries as it reaches it (CollidePolicy::
  // fill_columns): a self-collide its callback stops at the first contact, as in "is anything
  // touching?", then costs what it visits, not a pass over every object.
  if (Groups)
    fillColumns(
        a.items, [](std::uint32_t i) { return i; }, a.slots, store.columns(), 0);
  return collideRun<Groups>(a, b, true, sink, stats, gate, kernels, &store.columns(), !Groups);
}

template <bool Groups, typename S, class Sink>
[[gnu::always_inline]] inline bool collideBody(const View<S>& a, const View<S>& b, bool self,
                                               const Sink& sink, QueryStats* stats,
                                               const PairGate<S>* gate) {
  // Against a single object (an object query) the walk tests one box at a time and needs no
  // kernel table: most calls are those, and small.
  const bool one = !self && b.root != kNone && b.nodes[b.root].count == 1;
  const PairKernels<S>* kernels = one ? nullptr : &pairKernels<S>();
  if (wantsColumns(a, self, kernels))
    return collideColumns<Groups>(a, b, sink, stats, gate, kernels);
  return collideRun<Groups>(a, b, self, sink, stats, gate, kernels, nullptr);
}

// Out of line: the walks over cubes that carry filter groups are a separate instance, so that
// the plain one is compiled as if they did not exist.
template <typename S, class Sink>
[[gnu::noinline]] bool collideGrouped(const View<S>& a, const View<S>& b, bool self,
                                      const Sink& sink, QueryStats* stats,
                                      const PairGate<S>* gate) {
  return collideBody<true>(a, b, self, sink, stats, gate);
}

template <typename S, class Sink>
bool cubeWalk(const View<S>& a, const View<S>& b, bool self, const Sink& sink, QueryStats* stats,
              const PairGate<S>* gate) {
  if (gate != nullptr && a.groups != nullptr) return collideGrouped(a, b, self, sink, stats, gate);
  return collideBody<false>(a, b, self, sink, stats, gate);
}

template <typename S, class Policy>
[[gnu::noinline]] bool distanceGrouped(const View<S>& a, const View<S>& b, bool self,
                                       const Policy& p) {
  return descend<true>(a, b, self, p);
}

template <typename S, class Policy>
bool distanceWalk(const View<S>& a, const View<S>& b, bool self, const Policy& p) {
  if (p.gate != nullptr && a.groups != nullptr) return distanceGrouped(a, b, self, p);
  return descend<false>(a, b, self, p);
}

// One object `q` against `tree` without a gate, straight into the walk: none of the set-up that
// pairs of trees need (kernel table, filter bits), which was a tenth of a short query's time.
// Object queries (collideObject) and the pair list's query per moved object (collectPairs) run it.
template <typename S, class Sink>
bool objectWalk(const View<S>& tree, const View<S>& q, const Sink& sink, QueryStats* stats) {
  if (stats)
    return descend<false, S, CollidePolicy<S, Count, Sink>, true>(
        tree, q, false, CollidePolicy<S, Count, Sink>{sink, Count{stats}, nullptr});
  return descend<false, S, CollidePolicy<S, NoCount, Sink>, true>(
      tree, q, false, CollidePolicy<S, NoCount, Sink>{sink, NoCount{}, nullptr});
}

}  // namespace
}  // namespace detail
}  // namespace cube
