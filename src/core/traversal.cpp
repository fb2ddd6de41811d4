// One iterative descent for every query: an explicit stack of cube pairs, policies for
// "overlap" (collide) and "closer than the best so far" (distance).

#include "core/traversal.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#include "core/kernels/box_ops.h"
#include "core/kernels/pair_kernels.h"

namespace cube {
namespace detail {

namespace {

// A stack that lives in the frame up to N entries and moves to the heap beyond, so that queries
// allocate nothing on ordinary trees and still cope with degenerate deep ones.
template <class T, std::size_t N>
class SmallStack {
 public:
  SmallStack() = default;
  SmallStack(const SmallStack&) = delete;
  SmallStack& operator=(const SmallStack&) = delete;
  bool empty() const { return n_ == 0; }
  void push(const T& t) {
    if (__builtin_expect(n_ == cap_, 0)) grow();
    data_[n_++] = t;
  }
  T pop() { return data_[--n_]; }

 private:
  [[gnu::noinline]] void grow() {
    std::vector<T> bigger(cap_ * 2);
    std::copy(data_, data_ + n_, bigger.begin());
    heap_.swap(bigger);
    data_ = heap_.data();
    cap_ = heap_.size();
  }
  T local_[N];
  T* data_ = local_;
  std::size_t n_ = 0;
  std::size_t cap_ = N;
  std::vector<T> heap_;
};

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
  bool operator()(const Item<S>& x, const Item<S>& y) const { return fn(x.obj, y.obj, data); }
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
  const PairKernels<S>* kernels;
  const Columns* columns = nullptr;  // null: leaves are tested on the exact boxes only
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
    if (x.obj == y.obj) return false;
    count.call();
    return sink(x, y);
  }
  bool leaf(const Item<S>& x, const Item<S>& y) const { return touches(x, y) && report(x, y); }
};

// The callbacks for the set bits of `hits`, in order; apart, so that the test loop stays small.
// Recheck: the bits come from float boxes, and each pair is tested again exactly first.
template <bool Recheck, typename S, class Policy>
[[gnu::noinline]] bool reportHits(std::uint64_t hits, const Item<S>* xs, const Item<S>* ys,
                                  const Policy& p) {
  while (hits != 0) {
    const unsigned b = static_cast<unsigned>(__builtin_ctzll(hits));
    hits &= hits - 1;
    const Item<S>& x = xs[b / kMaskLeaf];
    const Item<S>& y = ys[b % kMaskLeaf];
    if (Recheck && !overlap(x.box, y.box)) continue;
    if (p.report(x, y)) return true;
  }
  return false;
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
                  const Policy& p) {
  countLeafTests<Self>(p, nx, ny);
  // Against a single object (a query) a batch kernel's set-up would cost more than the tests.
  const std::uint64_t hits =
      ny == 1 ? leafHitsPortable<Self>(xs, nx, ys, ny) : p.kernels->leafHits[Self](xs, nx, ys, ny);
  return hits != 0 && reportHits<false>(hits, xs, ys, p);
}

// The same for two leaves of one view (or a leaf with itself), [x0, x0 + nx) and [y0, y0 + ny),
// tested on the policy's float columns where it has them.
template <bool Self, typename S, class Policy>
bool collideLeaves(const View<S>& v, std::uint32_t x0, std::uint32_t nx, std::uint32_t y0,
                   std::uint32_t ny, const Policy& p) {
  if (p.columns != nullptr) {
    countLeafTests<Self>(p, nx, ny);
    const std::uint64_t hits = p.kernels->columnHits[Self](*p.columns, x0, nx, y0, ny);
    return hits != 0 && reportHits<true>(hits, v.items + x0, v.items + y0, p);
  }
  return collideSmall<Self>(v.items + x0, nx, v.items + y0, ny, p);
}

// The all-pairs test for small scenes: the live boxes in float columns, one row mask per object
// from the kernels, then the exact test (p.leaf) on the pairs the float test let through, in
// slot order.
template <typename S, class Policy>
bool allPairs(const View<S>& v, const Policy& p) {
  // The live slots, without a branch per slot.
  std::uint32_t slot[kAllPairsMax];
  std::uint32_t n = 0;
  for (std::uint32_t s = 0; s < v.slots; ++s) {
    slot[n] = s;
    n += v.items[s].obj != nullptr;
  }
  const ColumnStore store(n);  // the padding up to the next multiple of 8 is zeroed
  p.kernels->fill(v.items, slot, n, store.columns(), 0);
  // The kernels read whole blocks of 4 or 8 columns; the bits of the padding are dropped below
  // (no box value could be relied on to overlap nothing: an infinite box overlaps every one).
  const std::uint64_t live = n == 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << n) - 1;
  p.count.tests(std::size_t(n) * (n - (n > 0)) / 2);
  std::uint64_t rows[kAllPairsMax];
  p.kernels->rowMasks(store.columns(), n, rows);
  // The rows with hits, gathered without a branch: in a sparse scene whether a row has any is
  // a coin toss for the branch predictor.
  std::uint32_t hit_rows[kAllPairsMax];
  std::uint32_t h = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    rows[i] &= live;
    hit_rows[h] = i;
    h += rows[i] != 0;
  }
  for (std::uint32_t r = 0; r < h; ++r) {
    const std::uint32_t i = hit_rows[r];
    for (std::uint64_t m = rows[i]; m != 0; m &= m - 1) {
      const std::uint32_t j = static_cast<std::uint32_t>(__builtin_ctzll(m));
      if (p.leaf(v.items[slot[i]], v.items[slot[j]])) return true;
    }
  }
  return false;
}

template <typename S, class Counter>
struct DistancePolicy {
  using Key = double;  // squared box gap: in double, so that gaps beyond float's range fit
  static constexpr bool kOrdered = true;
  void* data;
  DistanceFn<S> fn;
  S& best;
  Counter count;
  // Boxes that overlap are always worth a visit: with a signed-distance callback the best may
  // already be <= 0 and a pair may still penetrate deeper.
  // A square that overflows (gaps beyond 1.3e154) is infinite: pruned below a finite bound, kept
  // while the bound's own square overflows too (the search has not found anything yet).
  bool keep(Key sq) const {
    const double b2 = double(best) * double(best);
    return sq == 0 || (best > 0 && (sq < b2 || b2 == std::numeric_limits<double>::infinity()));
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
    return keep(boxGap2(x.box, cube));
  }
  bool leaf(const Item<S>& x, const Item<S>& y) const {
    count.test();
    return keep(boxGap2(x.box, y.box)) && x.obj != y.obj && call(x, y);
  }
  bool call(const Item<S>& x, const Item<S>& y) const {
    count.call();
    return fn(x.obj, y.obj, data, best);
  }
};

// A leaf against the query object, nearest object first: the first callbacks then lower `best`
// as much as they can, and fewer narrow-phase calls follow. Small leaves only (a depth-capped
// leaf may be large; it is scanned in order).
template <typename S, class Policy>
bool leafNearestFirst(const View<S>& tree, const Node& n, const Item<S>& q, const Policy& p) {
  constexpr std::uint32_t kMax = 16;
  typename Policy::Key key[kMax];
  std::uint32_t order[kMax];
  std::uint32_t m = 0;
  for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
    if (tree.items[i].obj == q.obj) continue;
    p.count.test();
    const auto k = boxGap2(tree.items[i].box, q.box);
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

template <class Key>
struct Entry {
  std::uint32_t a, b;
  Key key;
};

template <typename S, class Policy>
bool leafSelf(const View<S>& v, const Node& n, const Policy& p) {
  if constexpr (!Policy::kOrdered) {
    if (n.count <= kMaskLeaf) return collideLeaves<true>(v, n.first, n.count, n.first, n.count, p);
  }
  const std::uint32_t end = n.first + n.count;
  for (std::uint32_t i = n.first; i < end; ++i)
    for (std::uint32_t j = i + 1; j < end; ++j)
      if (p.leaf(v.items[i], v.items[j])) return true;
  return false;
}

template <typename S, class Policy>
bool leafPair(const View<S>& va, const Node& na, const View<S>& vb, const Node& nb,
              const Policy& p) {
  if constexpr (!Policy::kOrdered) {
    if (na.count <= kMaskLeaf && nb.count <= kMaskLeaf) {
      // Columns only in a self walk, where va and vb are the same view.
      if (p.columns != nullptr)
        return collideLeaves<false>(va, na.first, na.count, nb.first, nb.count, p);
      return collideSmall<false>(va.items + na.first, na.count, vb.items + nb.first, nb.count, p);
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

// Chooses what the walk does next among the taken entries of `e`: the most promising one (for
// distance the nearest, for collide the first) goes into `next` and is visited straight away;
// the others wait on the stack, the next most promising on top. Returns false if none was taken.
// Going straight on, and choosing with branches on registers rather than by compacting the
// taken entries through memory (each store and load of which waits on the last), more than
// doubled the speed of object queries.
template <class Policy, class Stack, class E, int N>
bool continueWithBest(Stack& stack, const bool (&take)[N], const E (&e)[N], E& next) {
  if constexpr (!Policy::kOrdered) {
    int first = 0;
    while (first < N && !take[first]) ++first;
    if (first == N) return false;
    for (int i = N - 1; i > first; --i)
      if (take[i]) stack.push(e[i]);
    next = e[first];
    return true;
  } else if constexpr (N == 2) {
    if (take[0] && take[1]) {
      const int near = Policy::before(e[1].key, e[0].key) ? 1 : 0;
      stack.push(e[1 - near]);
      next = e[near];
      return true;
    }
    if (!take[0] && !take[1]) return false;
    next = e[take[0] ? 0 : 1];
    return true;
  } else {
    int order[N];
    int m = 0;
    for (int i = 0; i < N; ++i)
      if (take[i]) order[m++] = i;
    if (m == 0) return false;
    // Insertion sort, nearest first (stable: equal keys keep their order).
    for (int i = 1; i < m; ++i)
      for (int j = i; j > 0 && Policy::before(e[order[j]].key, e[order[j - 1]].key); --j)
        std::swap(order[j - 1], order[j]);
    for (int j = m - 1; j > 0; --j) stack.push(e[order[j]]);
    next = e[order[0]];
    return true;
  }
}

// Starts loading what a visit of cube `n` will read first (its children, or its objects), so
// that the load overlaps the work on the entries above it on the stack: a descent is otherwise
// one chain of dependent cache misses.
template <typename S>
inline void prefetchBelow(const View<S>& v, const Node& n) {
  if (n.isLeaf())
    __builtin_prefetch(v.items + n.first);
  else
    __builtin_prefetch(v.nodes + n.first);
}

template <class Key>
struct OneEntry {
  std::uint32_t node;
  Key key;
};

// One object against a tree: the common query, with a lighter stack than the pair descent.
// Calls p.leaf(tree object, query object).
template <typename S, class Policy>
bool descendOne(const View<S>& tree, const Node& qn, const Item<S>& q, const Policy& p) {
  using E = OneEntry<typename Policy::Key>;
  E start{tree.root, {}};
  if (!p.enter(tree.nodes[tree.root], qn, start.key)) return false;
  SmallStack<E, 64> stack;
  stack.push(start);
  while (!stack.empty()) {
    E e = stack.pop();
    if (!p.keep(e.key)) continue;
    for (bool more = true; more;) {
      more = false;
      p.count.visit();
      const Node& n = tree.nodes[e.node];
      if (n.isLeaf()) {
        if constexpr (Policy::kOrdered) {
          if (n.count <= 16) {
            if (leafNearestFirst(tree, n, q, p)) return true;
            break;
          }
        }
        if constexpr (!Policy::kOrdered) {
          if (n.count <= kMaskLeaf) {
            if (collideSmall<false>(tree.items + n.first, n.count, &q, 1, p)) return true;
            break;
          }
        }
        for (std::uint32_t i = n.first; i < n.first + n.count; ++i)
          if (p.leaf(tree.items[i], q)) return true;
        break;
      }
      E e2[2] = {{n.first, {}}, {n.first + 1, {}}};
      bool take[2];
      for (int i = 0; i < 2; ++i) {
        take[i] = p.enter(tree.nodes[e2[i].node], qn, e2[i].key);
        prefetchBelow(tree, tree.nodes[e2[i].node]);
      }
      more = continueWithBest<Policy>(stack, take, e2, e);
    }
  }
  return false;
}

template <typename S, class Policy>
bool descend(const View<S>& va, const View<S>& vb, bool self, const Policy& p) {
  using E = Entry<typename Policy::Key>;
  if (va.root == kNone || vb.root == kNone) return false;
  const Node& qb = vb.nodes[vb.root];
  if (!self && qb.count == 1) return descendOne(va, qb, vb.items[qb.first], p);
  SmallStack<E, 128> stack;
  E start{va.root, vb.root, {}};
  if (!self && !p.enter(va.nodes[va.root], vb.nodes[vb.root], start.key)) return false;
  stack.push(start);
  while (!stack.empty()) {
    E e = stack.pop();
    if (!p.keep(e.key)) continue;  // the best distance may have dropped since the push
    for (bool more = true; more;) {
      more = false;
      p.count.visit();
      const Node& na = va.nodes[e.a];
      const Node& nb = vb.nodes[e.b];
      if (self && e.a == e.b) {
        if (na.isLeaf()) {
          if (leafSelf(va, na, p)) return true;
          break;
        }
        // Within a cube: within each child, then across the two.
        const std::uint32_t c = na.first;
        E e3[3] = {{c, c, {}}, {c + 1, c + 1, {}}, {c, c + 1, {}}};
        bool take[3] = {true, true, false};
        take[2] = p.enter(va.nodes[c], va.nodes[c + 1], e3[2].key);
        prefetchBelow(va, va.nodes[c]);
        prefetchBelow(va, va.nodes[c + 1]);
        more = continueWithBest<Policy>(stack, take, e3, e);
        continue;
      }
      const bool la = na.isLeaf(), lb = nb.isLeaf();
      if (la && lb) {
        if (leafPair(va, na, vb, nb, p)) return true;
        break;
      }
      if (!la && !lb) {
        // Open both cubes: one visit settles four child pairs.
        const std::uint32_t ca = na.first, cb = nb.first;
        E e4[4] = {{ca, cb, {}}, {ca, cb + 1, {}}, {ca + 1, cb, {}}, {ca + 1, cb + 1, {}}};
        bool take[4];
        for (int i = 0; i < 4; ++i)
          take[i] = p.enter(va.nodes[e4[i].a], vb.nodes[e4[i].b], e4[i].key);
        for (int i = 0; i < 2; ++i) {
          prefetchBelow(va, va.nodes[ca + i]);
          prefetchBelow(vb, vb.nodes[cb + i]);
        }
        more = continueWithBest<Policy>(stack, take, e4, e);
      } else if (lb) {
        const std::uint32_t c = na.first;
        E e2[2] = {{c, e.b, {}}, {c + 1, e.b, {}}};
        bool take[2];
        for (int i = 0; i < 2; ++i) {
          take[i] = p.enter(va.nodes[c + i], nb, e2[i].key);
          prefetchBelow(va, va.nodes[c + i]);
        }
        more = continueWithBest<Policy>(stack, take, e2, e);
      } else {
        const std::uint32_t c = nb.first;
        E e2[2] = {{e.a, c, {}}, {e.a, c + 1, {}}};
        bool take[2];
        for (int i = 0; i < 2; ++i) {
          take[i] = p.enter(na, vb.nodes[c + i], e2[i].key);
          prefetchBelow(vb, vb.nodes[c + i]);
        }
        more = continueWithBest<Policy>(stack, take, e2, e);
      }
    }
  }
  return false;
}

template <typename S, class Sink>
bool collideWith(const View<S>& a, const View<S>& b, bool self, const Sink& sink,
                 QueryStats* stats) {
  const PairKernels<S>& kernels = pairKernels<S>();
  std::unique_ptr<ColumnStore> store;
  if (self && a.slots >= kColumnsMin && kernels.columnHits[1] != nullptr) {
    store = std::make_unique<ColumnStore>(a.slots);
    kernels.fill(a.items, nullptr, a.slots, store->columns(), 0);
  }
  const Columns* use = store ? &store->columns() : nullptr;
  if (stats)
    return descend(a, b, self, CollidePolicy<S, Count, Sink>{sink, Count{stats}, &kernels, use});
  return descend(a, b, self, CollidePolicy<S, NoCount, Sink>{sink, NoCount{}, &kernels, use});
}

}  // namespace

template <typename S>
bool collidePairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFn<S> fn,
                  QueryStats* stats) {
  return collideWith(a, b, self, CallFn<S>{data, fn}, stats);
}

template <typename S>
void collectPairs(const View<S>& a, const View<S>& b, bool self, std::size_t all_pairs_limit,
                  std::vector<std::uint64_t>& out) {
  const RecordIds<S> sink{&out};
  if (self && a.slots <= all_pairs_limit)
    allPairs(a, CollidePolicy<S, NoCount, RecordIds<S>>{sink, NoCount{}, &pairKernels<S>()});
  else
    collideWith(a, b, self, sink, nullptr);
}

template <typename S>
bool collideAllPairs(const View<S>& v, void* data, CollideFn<S> fn, QueryStats* stats,
                     PairKernel kernel) {
  if (v.slots > kAllPairsMax) throw std::logic_error("collideAllPairs: view too large");
  if (!pairKernelAvailable(kernel)) throw std::logic_error("collideAllPairs: kernel unavailable");
  const PairKernels<S>* k = &pairKernels<S>(kernel);
  if (stats) return allPairs(v, CollidePolicy<S, Count>{{data, fn}, Count{stats}, k});
  return allPairs(v, CollidePolicy<S, NoCount>{{data, fn}, NoCount{}, k});
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
bool distancePairs(const View<S>& a, const View<S>& b, bool self, void* data, DistanceFn<S> fn,
                   S& best, QueryStats* stats) {
  if (stats) return descend(a, b, self, DistancePolicy<S, Count>{data, fn, best, Count{stats}});
  return descend(a, b, self, DistancePolicy<S, NoCount>{data, fn, best, NoCount{}});
}

template <typename S>
SingleView<S>::SingleView(fcl::CollisionObject<S>* obj, const Box<S>& box, ObjectId id) {
  item = Item<S>{box, obj, 0, id};
  roundOut(box, node.lo, node.hi);
  node.first = 0;
  node.count = 1;
}

template bool collidePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                  CollideFn<float>, QueryStats*);
template bool collidePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                   CollideFn<double>, QueryStats*);
template void collectPairs<float>(const View<float>&, const View<float>&, bool, std::size_t,
                                  std::vector<std::uint64_t>&);
template void collectPairs<double>(const View<double>&, const View<double>&, bool, std::size_t,
                                   std::vector<std::uint64_t>&);
template bool collideAllPairs<float>(const View<float>&, void*, CollideFn<float>, QueryStats*,
                                     PairKernel);
template bool collideAllPairs<double>(const View<double>&, void*, CollideFn<double>, QueryStats*,
                                      PairKernel);
template std::uint64_t leafOverlapMask<float>(const Item<float>*, std::uint32_t, const Item<float>*,
                                              std::uint32_t, bool, PairKernel);
template std::uint64_t leafOverlapMask<double>(const Item<double>*, std::uint32_t,
                                               const Item<double>*, std::uint32_t, bool,
                                               PairKernel);
template bool distancePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                   DistanceFn<float>, float&, QueryStats*);
template bool distancePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                    DistanceFn<double>, double&, QueryStats*);
template struct SingleView<float>;
template struct SingleView<double>;

}  // namespace detail
}  // namespace cube
