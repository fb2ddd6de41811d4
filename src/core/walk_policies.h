#pragma once

// What the queries do on the two walks (core/walk.h): the policies for "overlap" (collide) and
// "closer than the best so far" (distance), and their work at the leaves (mask kernels, the
// all-pairs test of small views, the nearest-first leaf of distance). Private to the core's walk
// files (traversal.cpp, split_walk.cpp). In an unnamed namespace: each of them gets its own
// instances, which the compiler inlines as it would within one file.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/kernels/box_ops.h"
#include "core/kernels/pair_kernels.h"
#include "core/pair_gate.h"
#include "core/traversal.h"
#include "cube_collision/query_stats.h"

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
  // With columns: each leaf's entries are written at its test with itself rather than all before
  // the walk, so that a query its callback stops early reads only what it visits. A self walk
  // tests both children with themselves before pairing them (childPairs), so every leaf is
  // written before any pair test reads it; not with filter groups, which may skip a cube's pairs
  // with itself and still pair it with others.
  bool fill_columns = false;
  // Self walks with filter bits: the bits per slot of the view starting at slot_base, gathered
  // once per call, so that a leaf's bits are read from one or two cache lines.
  const Filter* slot_bits = nullptr;
  const Item<S>* slot_base = nullptr;
  bool enter(const Node& a, const Node& b, Key&) const {
    count.test();
    return overlap(a, b);
  }
  bool worth(Key) const { return true; }
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

// The float columns of a serial self walk of up to about 4,000 slots live in its frame (96 KB
// of the calling thread's stack), so that the first self-collide of a new manager does not
// fault in a fresh heap block page by page.
constexpr std::size_t kFrameColumnFloats = 24 * 1024;

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
  std::uint64_t hits;
  if constexpr (Self)
    hits = ny == 1 ? leafHitsPortable<Self>(xs, nx, ys, ny)
                   : p.kernels->leafHits[Self](xs, nx, ys, ny);
  else
    hits = ny == 1 ? leafHitsOne(xs, nx, FixedBox<S>(ys->box))
                   : p.kernels->leafHits[Self](xs, nx, ys, ny);
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
    if constexpr (Self) {
      if (p.fill_columns)
        fillColumns(
            v.items, [x0](std::uint32_t i) { return x0 + i; }, nx, *p.columns, x0);
    }
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
// out of line, its call and spills weigh on small self-collides.
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
  bool worth(Key sq) const {
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
    return worth(key);
  }
  static bool before(Key x, Key y) { return x < y; }
  // The gap to a cube is never above the gap to a box inside it (each step of boxGap2 is
  // monotone, roundings included), so an object too far from the cube is too far from all its
  // objects, and skipping it changes no call.
  bool reaches(const Item<S>& x, const Box<S>& cube) const {
    count.test();
    return worth(gapKey(x.box, cube));
  }
  // Inline, with the gate's rules out of line: inlined, they made the leaf too large for the
  // walk to inline, and every box test of a distance walk became a call.
  [[gnu::always_inline]] bool leaf(const Item<S>& x, const Item<S>& y) const {
    count.test();
    return worth(gapKey(x.box, y.box)) && x.obj != y.obj && call(x, y);
  }
  bool call(const Item<S>& x, const Item<S>& y) const {
    if (gate != nullptr) return callGated(x, y);
    count.call();
    return fn(x.obj, x.id, y.obj, y.id, data, best);
  }
  [[gnu::noinline]] bool callGated(const Item<S>& x, const Item<S>& y) const {
    return gate->admit(x, y, [&](const Item<S>& a, const Item<S>& b) {
      count.call();
      return fn(a.obj, a.id, b.obj, b.id, data, best);
    });
  }
};

// A leaf against the query object, nearest object first: the first callbacks then lower `best`
// as much as they can, and fewer narrow-phase calls follow. Small leaves only (a depth-capped
// leaf may be large; it is scanned in order). The nearest is selected afresh before each call
// rather than the leaf sorted: most leaves make one or two calls before `best` prunes the rest,
// and an insertion sort's branches mispredicted on about every other key. Among equal keys the
// first slot goes first, as a stable sort would have it.
template <typename S, class Policy>
[[gnu::always_inline]] inline bool leafNearestFirst(const View<S>& tree, const Node& n,
                                                    const Item<S>& q, const Policy& p) {
  constexpr std::uint32_t kMax = 16;
  using Key = typename Policy::Key;
  constexpr Key kDone = std::numeric_limits<Key>::infinity();  // gapKey's keys are finite
  Key key[kMax];
  const Item<S>* items = tree.items + n.first;
  for (std::uint32_t i = 0; i < n.count; ++i) {
    key[i] = kDone;
    if (items[i].obj == q.obj) continue;
    p.count.test();
    key[i] = Policy::gapKey(items[i].box, q.box);
  }
  for (;;) {
    std::uint32_t near = 0;
    for (std::uint32_t i = 1; i < n.count; ++i) near = key[i] < key[near] ? i : near;
    // Every key left is at least this one: none is worth a call if it is not.
    if (key[near] == kDone || !p.worth(key[near])) return false;
    key[near] = kDone;
    if (p.call(items[near], q)) return true;
  }
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

}  // namespace
}  // namespace detail
}  // namespace cube
