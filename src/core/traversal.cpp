// The queries as visitors of the two walks (core/walk.h): policies for "overlap" (collide) and
// "closer than the best so far" (distance), what they do at the leaves, and the entry points.

#include "core/traversal.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/kernels/box_ops.h"
#include "core/kernels/pair_kernels.h"
#include "core/walk.h"

namespace cube {
namespace detail {

namespace {

struct NoKey {};

// Work counters for QueryStats; the empty one compiles away on the ordinary path.
struct NoCount {
  void visit() const {}
  void test() const {}
  void tests(std::size_t) const {}
  void call() const {}
};
struct Count {
  QueryStats* stats;
  void visit() const { ++stats->cubes_visited; }
  void test() const { ++stats->box_tests; }
  void tests(std::size_t k) const { stats->box_tests += k; }
  void call() const { ++stats->callbacks; }
};

// What a collide does with a pair whose boxes overlap: call the user's function...
template <typename S>
struct CallFn {
  void* data;
  CollideFn<S> fn;
  bool operator()(const Item<S>& x, const Item<S>& y) const {
    return fn(x.obj, x.id, y.obj, y.id, data);
  }
};

// ...or note the pair's ids (see collectPairs).
template <typename S>
struct RecordIds {
  std::vector<std::uint64_t>* out;
  bool operator()(const Item<S>& x, const Item<S>& y) const {
    out->push_back(std::uint64_t(x.id) << 32 | y.id);
    return false;
  }
};

template <typename S, class Counter, class Sink = CallFn<S>>
struct CollidePolicy {
  using Key = NoKey;
  static constexpr bool kOrdered = false;
  Sink sink;
  Counter count;
  const PairKernels<S>* kernels;      // null in object queries, which test one box at a time
  const Columns* columns = nullptr;   // null: leaves are tested on the exact boxes only
  const PairGate<S>* gate = nullptr;  // null: every pair of overlapping boxes is reported
  // Self walks with filter bits: the bits per slot of the view starting at slot_base, gathered
  // once per call, so that a leaf's bits are read from one or two cache lines.
  const Filter* slot_bits = nullptr;
  const Item<S>* slot_base = nullptr;
  bool enter(const Node& a, const Node& b, Key&) const {
    count.test();
    return overlap(a, b);
  }
  bool keep(Key) const { return true; }
  static bool before(Key, Key) { return false; }
  // Whether an object can meet anything in the cube `n` at all.
  bool reaches(const Item<S>& x, const Box<S>& cube) const {
    count.test();
    return overlap(x.box, cube);
  }
  bool touches(const Item<S>& x, const Item<S>& y) const {
    count.test();
    return overlap(x.box, y.box);
  }
  // Called for boxes that touch. An object never meets itself (two managers may share objects);
  // that check comes after the box test, which rejects most pairs without reading the pointers.
  bool report(const Item<S>& x, const Item<S>& y) const {
    if (gate != nullptr && !gate->bitsPass(x.id, y.id)) return false;
    return reportPassed(x, y);
  }
  // A pair of a walk without a gate.
  bool reportUngated(const Item<S>& x, const Item<S>& y) const {
    if (x.obj == y.obj) return false;
    count.call();
    return sink(x, y);
  }
  // The same for a pair whose filter bits are known to pass (see passing()).
  bool reportPassed(const Item<S>& x, const Item<S>& y) const {
    if (gate == nullptr) return reportUngated(x, y);
    if (x.obj == y.obj) return false;
    return gate->finish(
        x, y, [](const Item<S>& i) { return i.id; }, [](const Item<S>& i) { return i.obj; },
        [&](const Item<S>& a, const Item<S>& b) {
          count.call();
          return sink(a, b);
        });
  }
  bool leaf(const Item<S>& x, const Item<S>& y) const { return touches(x, y) && report(x, y); }
  // `hits` without the pairs that the filter bits drop: bit b stands for xs[i(b)], ys[j(b)].
  // Self walks read the bits in slot order (slot_bits); others by id.
  template <class I, class J>
  std::uint64_t passing(std::uint64_t hits, const Item<S>* xs, I&& i, const Item<S>* ys,
                        J&& j) const {
    if (gate == nullptr || !gate->hasBits() || hits == 0) return hits;
    if (slot_bits != nullptr) {
      const Filter* fx = slot_bits + (xs - slot_base);
      const Filter* fy = slot_bits + (ys - slot_base);
      return PairGate<S>::passing(hits,
                                  [&](unsigned b) { return std::make_pair(fx + i(b), fy + j(b)); });
    }
    return PairGate<S>::passing(hits,
                                [&](unsigned b) { return gate->bitsOf(xs[i(b)].id, ys[j(b)].id); });
  }
};

// The callbacks for the set bits of `hits`, in order; apart, so that the test loop stays small.
// Recheck: the bits come from float boxes, and each pair is tested again exactly first.
// Gated: the policy has a gate; bits_pass: the two runs' filter groups are known to pair (no bit
// test needed). Walks without a gate (most) get a loop without the gate's rules, a quarter of
// the gated loop's size.
template <bool Recheck, bool Gated, typename S, class Policy>
[[gnu::noinline]] bool reportLoop(std::uint64_t hits, const Item<S>* xs, const Item<S>* ys,
                                  const Policy& p, bool bits_pass) {
  if constexpr (Gated) {
    if (!bits_pass)
      hits = p.passing(
          hits, xs, [](unsigned b) { return b / kMaskLeaf; }, ys,
          [](unsigned b) { return b % kMaskLeaf; });
  }
  while (hits != 0) {
    const unsigned b = static_cast<unsigned>(__builtin_ctzll(hits));
    hits &= hits - 1;
    const Item<S>& x = xs[b / kMaskLeaf];
    const Item<S>& y = ys[b % kMaskLeaf];
    if (Recheck && !overlap(x.box, y.box)) continue;
    if (Gated ? p.reportPassed(x, y) : p.reportUngated(x, y)) return true;
  }
  return false;
}

template <bool Recheck, typename S, class Policy>
inline bool reportHits(std::uint64_t hits, const Item<S>* xs, const Item<S>* ys, const Policy& p,
                       bool bits_pass) {
  if (p.gate != nullptr) return reportLoop<Recheck, true>(hits, xs, ys, p, bits_pass);
  return reportLoop<Recheck, false>(hits, xs, ys, p, bits_pass);
}

// Self-collides of at least this many slots test leaves on float columns (24 bytes per slot,
// for the length of the call), where the kernels have a column test. At 1,000 objects they
// already save a quarter of the time; below this size the fill is a larger share of a short
// walk, and scenes up to all_pairs_limit do not walk at all.
constexpr std::uint32_t kColumnsMin = 256;

// The box tests between two runs of nx and ny objects (Self: one run, each pair once), for
// QueryStats.
template <bool Self, class Policy>
void countLeafTests(const Policy& p, std::uint32_t nx, std::uint32_t ny) {
  p.count.tests(Self ? std::size_t(nx) * (nx - (nx > 0)) / 2 : std::size_t(nx) * ny);
}

// Collide between two small runs of objects (at most kMaskLeaf each; Self: the same run, each
// unordered pair once): all box tests first, into a bit mask (bit kMaskLeaf i + j for xs[i],
// ys[j]), then the callbacks in that order. Whether two boxes overlap is a coin toss for the
// branch predictor; testing every pair without a branch costs less than skipping some behind
// mispredicted branches.
template <bool Self, typename S, class Policy>
bool collideSmall(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys, std::uint32_t ny,
                  const Policy& p, bool bits_pass = false) {
  countLeafTests<Self>(p, nx, ny);
  // Against a single object (a query) a batch kernel's set-up would cost more than the tests.
  const std::uint64_t hits =
      ny == 1 ? leafHitsPortable<Self>(xs, nx, ys, ny) : p.kernels->leafHits[Self](xs, nx, ys, ny);
  if (hits == 0) return false;
  return reportHits<false>(hits, xs, ys, p, bits_pass);
}

// The same for two leaves of one view (or a leaf with itself), [x0, x0 + nx) and [y0, y0 + ny),
// tested on the policy's float columns where it has them.
template <bool Self, typename S, class Policy>
[[gnu::always_inline]] inline bool collideLeaves(const View<S>& v, std::uint32_t x0,
                                                 std::uint32_t nx, std::uint32_t y0,
                                                 std::uint32_t ny, const Policy& p,
                                                 bool bits_pass) {
  if (p.columns != nullptr) {
    countLeafTests<Self>(p, nx, ny);
    const std::uint64_t hits = p.kernels->columnHits[Self](*p.columns, x0, nx, y0, ny);
    if (hits == 0) return false;
    return reportHits<true>(hits, v.items + x0, v.items + y0, p, bits_pass);
  }
  return collideSmall<Self>(v.items + x0, nx, v.items + y0, ny, p, bits_pass);
}

// The live slots of `v` (at most kAllPairsMax) whose boxes reach the cube `reach` (null: all),
// gathered without a branch per slot, and their boxes in float columns padded with zeros to the
// next multiple of 8 (the kernels read whole blocks of 4 or 8; no box value could be relied on
// to overlap nothing, as an infinite box overlaps every one, so the caller drops the padding's
// bits). Returns the number of slots gathered; `tested` gets the number of reach tests. Inline:
// out of line, its call and spills were 2% of a 32-object self-collide.
template <typename S>
[[gnu::always_inline]] inline std::uint32_t gatherLive(const View<S>& v, const Node* reach,
                                                       std::uint32_t (&slot)[kAllPairsMax],
                                                       SmallColumns& store, std::uint32_t& tested) {
  std::uint32_t n = 0;
  tested = 0;
  if (reach == nullptr) {
    for (std::uint32_t s = 0; s < v.slots; ++s) {
      slot[n] = s;
      n += v.items[s].obj != nullptr;
    }
  } else {
    Box<S> r;
    for (int k = 0; k < 3; ++k) {
      r.lo[k] = S(reach->lo[k]);
      r.hi[k] = S(reach->hi[k]);
    }
    for (std::uint32_t s = 0; s < v.slots; ++s) {
      const bool live = v.items[s].obj != nullptr;
      slot[n] = s;
      tested += live;
      n += live & overlap(v.items[s].box, r);
    }
  }
  fillColumns(
      v.items, [&](std::uint32_t i) { return slot[i]; }, n, store.columns(), 0);
  store.padFrom(n);
  return n;
}

// The all-pairs test for small scenes, and for two small ones: the live boxes in float columns,
// one row mask per object of `a` from the kernels, then the exact test (p.touches) on the pairs
// the float test let through, row by row in slot order. With `self`, b is a and each unordered
// pair comes once. Two views' objects that miss the other's root cube cannot pair and are left
// out first: a robot amid obstacles overlaps few of them.
template <bool Self, typename S, class Policy>
bool allPairs(const View<S>& a, const View<S>& b, const Policy& p) {
  // As descend: two trees whose roots are apart have no pair (the usual answer of a robot
  // away from an obstacle), for one test.
  if (!Self) {
    if (a.root == kNone || b.root == kNone) return false;
    typename Policy::Key key{};
    if (!p.enter(a.nodes[a.root], b.nodes[b.root], key)) return false;
  }
  // Self, a compile-time constant: a self-collide of 32 objects is a few hundred nanoseconds,
  // and the second set's frame and selects cost a quarter of that.
  std::uint32_t slot_a[kAllPairsMax], tested_a = 0, tested_b = 0;
  SmallColumns store_a;
  const std::uint32_t na =
      gatherLive(a, Self ? nullptr : &b.nodes[b.root], slot_a, store_a, tested_a);
  std::uint32_t slot_b_store[Self ? 1 : kAllPairsMax];
  std::conditional_t<Self, char, SmallColumns> store_b_store;
  std::uint32_t nb = na;
  const std::uint32_t* slot_b = slot_a;
  SmallColumns* store_b = &store_a;
  if constexpr (!Self) {
    nb = gatherLive(b, &a.nodes[a.root], slot_b_store, store_b_store, tested_b);
    slot_b = slot_b_store;
    store_b = &store_b_store;
  }
  const std::uint64_t live = nb == 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << nb) - 1;
  p.count.tests(Self ? std::size_t(na) * (na - (na > 0)) / 2
                     : std::size_t(tested_a) + tested_b + std::size_t(na) * nb);
  std::uint64_t rows[kAllPairsMax];
  p.kernels->rowMasks[Self](store_a.columns(), na, store_b->columns(), nb, rows);
  // The rows with hits, gathered without a branch: in a sparse scene whether a row has any is
  // a coin toss for the branch predictor.
  std::uint32_t hit_rows[kAllPairsMax];
  std::uint32_t h = 0;
  for (std::uint32_t i = 0; i < na; ++i) {
    rows[i] &= live;
    hit_rows[h] = i;
    h += rows[i] != 0;
  }
  // As in reportLoop, scenes without a gate get a loop without its rules.
  const auto calls = [&](auto gated) {
    for (std::uint32_t r = 0; r < h; ++r) {
      const std::uint32_t i = hit_rows[r];
      std::uint64_t row = rows[i];
      if constexpr (decltype(gated)::value)
        row = p.passing(
            row, a.items, [&](unsigned) { return slot_a[i]; }, b.items,
            [&](unsigned j) { return slot_b[j]; });
      for (std::uint64_t m = row; m != 0; m &= m - 1) {
        const std::uint32_t j = static_cast<std::uint32_t>(__builtin_ctzll(m));
        const Item<S>& x = a.items[slot_a[i]];
        const Item<S>& y = b.items[slot_b[j]];
        if (!p.touches(x, y)) continue;
        if (decltype(gated)::value ? p.reportPassed(x, y) : p.reportUngated(x, y)) return true;
      }
    }
    return false;
  };
  return p.gate != nullptr ? calls(std::true_type{}) : calls(std::false_type{});
}

template <typename S, class Policy>
bool allPairs(const View<S>& a, const View<S>& b, bool self, const Policy& p) {
  return self ? allPairs<true>(a, a, p) : allPairs<false>(a, b, p);
}

template <typename S, class Counter>
struct DistancePolicy {
  using Key = double;  // squared box gap: in double, so that gaps beyond float's range fit
  static constexpr bool kOrdered = true;
  void* data;
  DistanceFn<S> fn;
  S& best;
  Counter count;
  const PairGate<S>* gate = nullptr;                  // null: every pair near enough is called
  static constexpr const Columns* columns = nullptr;  // leaves are tested on the exact boxes
  // Boxes that overlap are always worth a visit: with a signed-distance callback the best may
  // already be <= 0 and a pair may still penetrate deeper.
  // Keys are finite (cubeGap2's always are; exact boxes' go through gapKey), so one comparison
  // with the bound's square decides, and a bound whose square overflows keeps every key.
  bool keep(Key sq) const {
    const double b = double(best);
    return sq == 0 || (b > 0 && sq < b * b);
  }
  // The squared gap of two exact boxes as a key: a square that overflows (gaps beyond 1.3e154)
  // becomes the largest double, pruned by any bound below 1.3e154 and kept by any above.
  static Key gapKey(const Box<S>& x, const Box<S>& y) {
    return std::min(boxGap2(x, y), std::numeric_limits<double>::max());
  }
  bool enter(const Node& a, const Node& b, Key& key) const {
    count.test();
    key = cubeGap2(a, b);
    return keep(key);
  }
  static bool before(Key x, Key y) { return x < y; }
  // The gap to a cube is never above the gap to a box inside it (each step of boxGap2 is
  // monotone, roundings included), so an object too far from the cube is too far from all its
  // objects, and skipping it changes no call.
  bool reaches(const Item<S>& x, const Box<S>& cube) const {
    count.test();
    return keep(gapKey(x.box, cube));
  }
  bool leaf(const Item<S>& x, const Item<S>& y) const {
    count.test();
    return keep(gapKey(x.box, y.box)) && x.obj != y.obj && call(x, y);
  }
  bool call(const Item<S>& x, const Item<S>& y) const {
    if (gate != nullptr)
      return gate->through(x, y, [&](const Item<S>& a, const Item<S>& b) {
        count.call();
        return fn(a.obj, a.id, b.obj, b.id, data, best);
      });
    count.call();
    return fn(x.obj, x.id, y.obj, y.id, data, best);
  }
};

// A leaf against the query object, nearest object first: the first callbacks then lower `best`
// as much as they can, and fewer narrow-phase calls follow. Small leaves only (a depth-capped
// leaf may be large; it is scanned in order).
template <typename S, class Policy>
[[gnu::always_inline]] inline bool leafNearestFirst(const View<S>& tree, const Node& n,
                                                    const Item<S>& q, const Policy& p) {
  constexpr std::uint32_t kMax = 16;
  typename Policy::Key key[kMax];
  std::uint32_t order[kMax];
  std::uint32_t m = 0;
  for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
    if (tree.items[i].obj == q.obj) continue;
    p.count.test();
    const auto k = Policy::gapKey(tree.items[i].box, q.box);
    std::uint32_t j = m++;
    for (; j > 0 && key[j - 1] > k; --j) {
      key[j] = key[j - 1];
      order[j] = order[j - 1];
    }
    key[j] = k;
    order[j] = i;
  }
  for (std::uint32_t j = 0; j < m; ++j) {
    if (!p.keep(key[j])) continue;  // not break: a callback may raise `best` again
    if (p.call(tree.items[order[j]], q)) return true;
  }
  return false;
}

template <typename S, class Policy>
[[gnu::always_inline]] inline bool leafSelf(const View<S>& v, const Node& n, const Policy& p,
                                            bool bits_pass) {
  if constexpr (!Policy::kOrdered) {
    if (n.count <= kMaskLeaf)
      return collideLeaves<true>(v, n.first, n.count, n.first, n.count, p, bits_pass);
  }
  const std::uint32_t end = n.first + n.count;
  for (std::uint32_t i = n.first; i < end; ++i)
    for (std::uint32_t j = i + 1; j < end; ++j)
      if (p.leaf(v.items[i], v.items[j])) return true;
  return false;
}

template <typename S, class Policy>
[[gnu::always_inline]] inline bool leafPair(const View<S>& va, const Node& na, const View<S>& vb,
                                            const Node& nb, const Policy& p, bool bits_pass) {
  if constexpr (!Policy::kOrdered) {
    if (na.count <= kMaskLeaf && nb.count <= kMaskLeaf) {
      // Columns only in a self walk, where va and vb are the same view.
      if (p.columns != nullptr)
        return collideLeaves<false>(va, na.first, na.count, nb.first, nb.count, p, bits_pass);
      return collideSmall<false>(va.items + na.first, na.count, vb.items + nb.first, nb.count, p,
                                 bits_pass);
    }
  }
  // Large leaves (a depth cap) and distance: objects that cannot reach the other cube skip it.
  // Against a single object the prefilter would only repeat the exact test.
  const bool filter = nb.count > 1;
  Box<S> reach;
  for (int k = 0; k < 3; ++k) {
    reach.lo[k] = S(nb.lo[k]);
    reach.hi[k] = S(nb.hi[k]);
  }
  for (std::uint32_t i = na.first; i < na.first + na.count; ++i) {
    const Item<S>& x = va.items[i];
    if (filter && !p.reaches(x, reach)) continue;
    for (std::uint32_t j = nb.first; j < nb.first + nb.count; ++j)
      if (p.leaf(x, vb.items[j])) return true;
  }
  return false;
}

// Starts loading what a visit of cube `n` will read first (its children, or its objects' boxes),
// so that the load overlaps the work on the entries above it on the stack: a descent is
// otherwise one chain of dependent cache misses. A leaf tested on float columns reads a run of
// each column, not its records (those only for the pairs the floats let through): with the
// records' line prefetched instead, self-collide of 10,000 thin boxes took 10% longer.
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
// cube pairs. Calls p.leaf(tree object, query object).
template <typename S, class Policy, bool Groups>
struct ObjectVisitor {
  using State = typename Policy::Key;
  static constexpr bool kOrdered = Policy::kOrdered;
  const View<S> tree;  // by value, as in PairVisitor
  const Node& qn;
  const Item<S>& q;
  const Policy p;

  static bool before(State x, State y) { return Policy::before(x, y); }
  bool keep(State key) const { return p.keep(key); }
  bool enter(std::uint32_t child, int, State, State& key) const {
    const Node& n = tree.nodes[child];
    if constexpr (Groups) {
      if (groupsPass(p, tree, child, tree, kNone) == 0) return false;
    }
    prefetchBelow(tree, n);
    return p.enter(n, qn, key);
  }
  Step at(std::uint32_t cube, State) const {
    p.count.visit();
    const Node& n = tree.nodes[cube];
    if (!n.isLeaf()) return Step::open;
    if constexpr (Policy::kOrdered) {
      if (n.count <= 16) return leafNearestFirst(tree, n, q, p) ? Step::stop : Step::skip;
    } else {
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
  bool keep(State key) const { return p.keep(key); }
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

// The walk below the roots: a single object (one-leaf view) against a tree goes through
// walkTree, anything else through walkPair. Groups: whether cubes' filter groups are tested.
template <bool Groups, typename S, class Policy>
inline bool walkFrom(const View<S>& va, const View<S>& vb, bool self, const Policy& p,
                     typename Policy::Key key) {
  const Node& qb = vb.nodes[vb.root];
  if (!self && qb.count == 1) {
    ObjectVisitor<S, Policy, Groups> v{va, qb, vb.items[qb.first], p};
    return walkTree(va.nodes, va.root, key, v);
  }
  PairVisitor<S, Policy, Groups> v{va, vb, p};
  return walkPair(va.nodes, vb.nodes, va.root, vb.root, key, self, v);
}

// Every query's walk. Groups: whether the cubes' filter groups are tested (the caller knows:
// a gate and cubes that carry groups); the walk without, which most queries take, tests nothing
// for them.
template <bool Groups, typename S, class Policy>
bool descend(const View<S>& va, const View<S>& vb, bool self, const Policy& p) {
  if (va.root == kNone || vb.root == kNone) return false;
  typename Policy::Key key{};
  if (!self && !p.enter(va.nodes[va.root], vb.nodes[vb.root], key)) return false;
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
                                              const PairKernels<S>* kernels, const Columns* use) {
  std::vector<Filter> bits;
  gatherSlotBits(a, self, gate, bits);
  const auto run = [&](auto count) {
    CollidePolicy<S, decltype(count), Sink> p{sink, count, kernels, use, gate};
    if (!bits.empty()) {
      p.slot_bits = bits.data();
      p.slot_base = a.items;
    }
    return descend<Groups>(a, b, self, p);
  };
  return stats ? run(Count{stats}) : run(NoCount{});
}

// Self walks of many slots, with their float columns (on the heap, in this frame only).
template <bool Groups, typename S, class Sink>
[[gnu::noinline]] bool collideColumns(const View<S>& a, const View<S>& b, const Sink& sink,
                                      QueryStats* stats, const PairGate<S>* gate,
                                      const PairKernels<S>* kernels) {
  const ColumnStore store(a.slots);
  fillColumns(
      a.items, [](std::uint32_t i) { return i; }, a.slots, store.columns(), 0);
  return collideRun<Groups>(a, b, true, sink, stats, gate, kernels, &store.columns());
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
bool collideWith(const View<S>& a, const View<S>& b, bool self, const Sink& sink, QueryStats* stats,
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
bool distanceWith(const View<S>& a, const View<S>& b, bool self, const Policy& p) {
  if (p.gate != nullptr && a.groups != nullptr) return distanceGrouped(a, b, self, p);
  return descend<false>(a, b, self, p);
}

}  // namespace

template <typename S>
bool collidePairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFnArg<S> fn,
                  QueryStats* stats, const PairGate<S>* gate) {
  return collideWith(a, b, self, CallFn<S>{data, fn}, stats, gate);
}

// One object `q` against `tree` without a gate, straight into the walk: none of the set-up that
// pairs of trees need (kernel table, filter bits), which was a tenth of a short query's time.
// Object queries (collideObject) and the pair list's query per moved object (collectPairs) run it.
template <typename S, class Sink>
bool objectWalk(const View<S>& tree, const View<S>& q, const Sink& sink, QueryStats* stats) {
  if (stats)
    return descend<false>(tree, q, false,
                          CollidePolicy<S, Count, Sink>{sink, Count{stats}, nullptr});
  return descend<false>(tree, q, false, CollidePolicy<S, NoCount, Sink>{sink, NoCount{}, nullptr});
}

template <typename S>
[[gnu::flatten]] bool collideObject(const View<S>& tree, const SingleView<S>& query, void* data,
                                    CollideFnArg<S> fn, QueryStats* stats) {
  return objectWalk(tree, query.view(), CallFn<S>{data, fn}, stats);
}

template <typename S>
void collectPairs(const View<S>& a, const View<S>& b, bool self, std::size_t all_pairs_limit,
                  std::vector<std::uint64_t>& out, const PairGate<S>* gate) {
  const RecordIds<S> sink{&out};
  using Policy = CollidePolicy<S, NoCount, RecordIds<S>>;
  // The rule of a collide first (collideViews), so that the pairs come in its order.
  if (allPairsFit(a, b, self, all_pairs_limit))
    allPairs(a, b, self, Policy{sink, NoCount{}, &pairKernels<S>(), nullptr, gate});
  else if (gate == nullptr && !self && b.root != kNone && b.nodes[b.root].count == 1)
    objectWalk(a, b, sink, nullptr);  // one object (the pair list's query per moved object)
  else
    collideWith(a, b, self, sink, nullptr, gate);
}

template <typename S>
SplitWalk<S>::SplitWalk(const View<S>& a, const View<S>& b, bool self, std::size_t all_pairs_limit,
                        const PairGate<S>* gate, std::size_t min_tasks)
    : a_(a), b_(b), self_(self), gate_(gate) {
  // As descend and collectPairs begin.
  if (a.root == kNone || b.root == kNone) return;
  if (allPairsFit(a, b, self, all_pairs_limit)) {
    all_pairs_ = true;
    tasks_.push_back(Task{a.root, a.root});
    return;
  }
  if (!self && !overlap(a.nodes[a.root], b.nodes[b.root])) return;
  tasks_.push_back(Task{a.root, b.root});
  // One level of the walk per round: each task gives way to the child pairs walkPair would take
  // from it, in the order it would visit them; a pair of leaves (or a leaf with itself) stays.
  std::vector<Task> next;
  while (tasks_.size() < min_tasks) {
    next.clear();
    bool opened = false;
    for (const Task& t : tasks_) {
      const Node& na = a.nodes[t.a];
      const Node& nb = b.nodes[t.b];
      const auto take = [&](std::uint32_t x, std::uint32_t y) {
        if (overlap(a.nodes[x], b.nodes[y])) next.push_back(Task{x, y});
      };
      if (self && t.a == t.b) {
        if (na.isLeaf()) {
          next.push_back(t);
          continue;
        }
        const std::uint32_t c = na.first;
        next.push_back(Task{c, c});
        next.push_back(Task{c + 1, c + 1});
        take(c, c + 1);
      } else if (na.isLeaf() && nb.isLeaf()) {
        next.push_back(t);
        continue;
      } else if (!na.isLeaf() && !nb.isLeaf()) {
        for (std::uint32_t i = 0; i < 2; ++i)
          for (std::uint32_t j = 0; j < 2; ++j) take(na.first + i, nb.first + j);
      } else if (nb.isLeaf()) {
        for (std::uint32_t i = 0; i < 2; ++i) take(na.first + i, t.b);
      } else {
        for (std::uint32_t j = 0; j < 2; ++j) take(t.a, nb.first + j);
      }
      opened = true;
    }
    tasks_.swap(next);
    if (!opened) break;
  }
  const PairKernels<S>* kernels = &pairKernels<S>();
  if (wantsColumns(a, self, kernels)) {
    store_ = std::make_unique<ColumnStore>(a.slots);
    fillColumns(
        a.items, [](std::uint32_t i) { return i; }, a.slots, store_->columns(), 0);
  }
  gatherSlotBits(a, self, gate, bits_);
}

template <typename S>
SplitWalk<S>::~SplitWalk() = default;

template <typename S>
void SplitWalk<S>::collect(std::size_t i, std::vector<std::uint64_t>& out) const {
  using Policy = CollidePolicy<S, NoCount, RecordIds<S>>;
  const Task t = tasks_[i];
  if (all_pairs_) {
    allPairs(a_, b_, self_,
             Policy{RecordIds<S>{&out}, NoCount{}, &pairKernels<S>(), nullptr, gate_});
    return;
  }
  Policy p{RecordIds<S>{&out}, NoCount{}, &pairKernels<S>(), store_ ? &store_->columns() : nullptr,
           gate_};
  if (!bits_.empty()) {
    p.slot_bits = bits_.data();
    p.slot_base = a_.items;
  }
  // As collideWith chooses: cubes that carry filter groups are tested for them.
  if (gate_ != nullptr && a_.groups != nullptr) {
    PairVisitor<S, Policy, true> v{a_, b_, p};
    walkPair(a_.nodes, b_.nodes, t.a, t.b, NoKey{}, self_, v);
  } else {
    PairVisitor<S, Policy, false> v{a_, b_, p};
    walkPair(a_.nodes, b_.nodes, t.a, t.b, NoKey{}, self_, v);
  }
}

template <typename S>
bool collideAllPairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFnArg<S> fn,
                     QueryStats* stats, PairKernel kernel, const PairGate<S>* gate) {
  if (a.slots > kAllPairsMax || b.slots > kAllPairsMax)
    throw std::logic_error("collideAllPairs: view too large");
  if (!pairKernelAvailable(kernel)) throw std::logic_error("collideAllPairs: kernel unavailable");
  const PairKernels<S>* k = &pairKernels<S>(kernel);
  if (stats)
    return allPairs(a, b, self,
                    CollidePolicy<S, Count>{{data, fn}, Count{stats}, k, nullptr, gate});
  return allPairs(a, b, self, CollidePolicy<S, NoCount>{{data, fn}, NoCount{}, k, nullptr, gate});
}

template <typename S>
std::uint64_t leafOverlapMask(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys,
                              std::uint32_t ny, bool self, PairKernel kernel) {
  if (nx > kMaskLeaf || ny > kMaskLeaf || (self && (xs != ys || nx != ny)))
    throw std::logic_error("leafOverlapMask: runs too long, or not one run for self");
  if (!pairKernelAvailable(kernel)) throw std::logic_error("leafOverlapMask: kernel unavailable");
  if (kernel == PairKernel::avx2 && !std::is_same_v<S, double>)
    throw std::logic_error("leafOverlapMask: no AVX2 leaf kernel for this scalar type");
  return pairKernels<S>(kernel).leafHits[self](xs, nx, ys, ny);
}

template <typename S>
bool distancePairs(const View<S>& a, const View<S>& b, bool self, void* data, DistanceFnArg<S> fn,
                   S& best, QueryStats* stats, const PairGate<S>* gate) {
  if (stats)
    return distanceWith(a, b, self, DistancePolicy<S, Count>{data, fn, best, Count{stats}, gate});
  return distanceWith(a, b, self, DistancePolicy<S, NoCount>{data, fn, best, NoCount{}, gate});
}

template bool collidePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                  CollideFn<float>, QueryStats*, const PairGate<float>*);
template bool collidePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                   CollideFn<double>, QueryStats*, const PairGate<double>*);
template bool collideObject<float>(const View<float>&, const SingleView<float>&, void*,
                                   CollideFn<float>, QueryStats*);
template bool collideObject<double>(const View<double>&, const SingleView<double>&, void*,
                                    CollideFn<double>, QueryStats*);
template void collectPairs<float>(const View<float>&, const View<float>&, bool, std::size_t,
                                  std::vector<std::uint64_t>&, const PairGate<float>*);
template void collectPairs<double>(const View<double>&, const View<double>&, bool, std::size_t,
                                   std::vector<std::uint64_t>&, const PairGate<double>*);
template bool collideAllPairs<float>(const View<float>&, const View<float>&, bool, void*,
                                     CollideFn<float>, QueryStats*, PairKernel,
                                     const PairGate<float>*);
template bool collideAllPairs<double>(const View<double>&, const View<double>&, bool, void*,
                                      CollideFn<double>, QueryStats*, PairKernel,
                                      const PairGate<double>*);
template std::uint64_t leafOverlapMask<float>(const Item<float>*, std::uint32_t, const Item<float>*,
                                              std::uint32_t, bool, PairKernel);
template std::uint64_t leafOverlapMask<double>(const Item<double>*, std::uint32_t,
                                               const Item<double>*, std::uint32_t, bool,
                                               PairKernel);
template bool distancePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                   DistanceFn<float>, float&, QueryStats*, const PairGate<float>*);
template bool distancePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                    DistanceFn<double>, double&, QueryStats*,
                                    const PairGate<double>*);
template class SplitWalk<float>;
template class SplitWalk<double>;

}  // namespace detail
}  // namespace cube
