// One iterative descent for every query: an explicit stack of cube pairs, policies for
// "overlap" (collide) and "closer than the best so far" (distance).

#include "cube_collision/detail/traversal.h"

#include <cmath>
#include <vector>

namespace cube {
namespace detail {

namespace {

// A stack that lives in the frame up to N entries and spills to the heap beyond, so that queries
// allocate nothing on ordinary trees and still cope with degenerate deep ones.
template <class T, std::size_t N>
class SmallStack {
 public:
  bool empty() const { return n_ == 0 && spill_.empty(); }
  void push(const T& t) {
    if (n_ < N) {
      local_[n_++] = t;
    } else {
      spill_.push_back(t);
    }
  }
  T pop() {
    if (!spill_.empty()) {
      T t = spill_.back();
      spill_.pop_back();
      return t;
    }
    return local_[--n_];
  }

 private:
  T local_[N];
  std::size_t n_ = 0;
  std::vector<T> spill_;
};

inline bool overlap(const Node& a, const Node& b) {
  return a.lo[0] <= b.hi[0] && b.lo[0] <= a.hi[0] && a.lo[1] <= b.hi[1] && b.lo[1] <= a.hi[1] &&
         a.lo[2] <= b.hi[2] && b.lo[2] <= a.hi[2];
}

template <typename S>
inline bool overlap(const Box<S>& a, const Box<S>& b) {
  return a.lo[0] <= b.hi[0] && b.lo[0] <= a.hi[0] && a.lo[1] <= b.hi[1] && b.lo[1] <= a.hi[1] &&
         a.lo[2] <= b.hi[2] && b.lo[2] <= a.hi[2];
}

// Euclidean gap between two boxes, as fcl::AABB::distance computes it.
template <typename S, typename B>
inline S gap(const B& a, const B& b) {
  S sum = 0;
  for (int k = 0; k < 3; ++k) {
    if (a.lo[k] > b.hi[k]) {
      const S d = S(a.lo[k]) - S(b.hi[k]);
      sum += d * d;
    } else if (b.lo[k] > a.hi[k]) {
      const S d = S(b.lo[k]) - S(a.hi[k]);
      sum += d * d;
    }
  }
  return std::sqrt(sum);
}

inline float extent(const Node& n) {
  return (n.hi[0] - n.lo[0]) + (n.hi[1] - n.lo[1]) + (n.hi[2] - n.lo[2]);
}

// Work counters for QueryStats; the empty one compiles away on the ordinary path.
struct NoCount {
  void visit() const {}
  void test() const {}
  void call() const {}
};
struct Count {
  QueryStats* stats;
  void visit() const { ++stats->cubes_visited; }
  void test() const { ++stats->box_tests; }
  void call() const { ++stats->callbacks; }
};

template <typename S, class Counter>
struct CollidePolicy {
  static constexpr bool kOrdered = false;
  void* data;
  CollideFn<S> fn;
  Counter count;
  bool enter(const Node& a, const Node& b, S& key) const {
    count.test();
    key = 0;
    return overlap(a, b);
  }
  bool keep(S) const { return true; }
  bool leaf(const Item<S>& x, const Item<S>& y) const {
    count.test();
    if (!overlap(x.box, y.box)) return false;
    count.call();
    return fn(x.obj, y.obj, data);
  }
};

template <typename S, class Counter>
struct DistancePolicy {
  static constexpr bool kOrdered = true;
  void* data;
  DistanceFn<S> fn;
  S& best;
  Counter count;
  // Boxes that overlap are always worth a visit: with a signed-distance callback the best may
  // already be <= 0 and a pair may still penetrate deeper.
  bool keep(S key) const { return key < best || key <= 0; }
  bool enter(const Node& a, const Node& b, S& key) const {
    count.test();
    key = gap<S>(a, b);
    return keep(key);
  }
  bool leaf(const Item<S>& x, const Item<S>& y) const {
    count.test();
    if (!keep(gap<S>(x.box, y.box))) return false;
    count.call();
    return fn(x.obj, y.obj, data, best);
  }
};

template <typename S>
struct Entry {
  std::uint32_t a, b;
  S key;
};

template <typename S, class Policy>
bool leafSelf(const View<S>& v, const Node& n, const Policy& p) {
  const std::uint32_t end = n.first + n.count;
  for (std::uint32_t i = n.first; i < end; ++i)
    for (std::uint32_t j = i + 1; j < end; ++j)
      if (v.items[i].obj != v.items[j].obj && p.leaf(v.items[i], v.items[j])) return true;
  return false;
}

template <typename S, class Policy>
bool leafPair(const View<S>& va, const Node& na, const View<S>& vb, const Node& nb,
              const Policy& p) {
  for (std::uint32_t i = na.first; i < na.first + na.count; ++i)
    for (std::uint32_t j = nb.first; j < nb.first + nb.count; ++j)
      if (va.items[i].obj != vb.items[j].obj && p.leaf(va.items[i], vb.items[j])) return true;
  return false;
}

// Pushes up to two entries so that the more promising one is popped first.
template <typename S, class Policy, class Stack>
void pushPair(Stack& stack, bool take0, const Entry<S>& e0, bool take1, const Entry<S>& e1) {
  if (take0 && take1) {
    if (Policy::kOrdered && e1.key < e0.key) {
      stack.push(e0);
      stack.push(e1);
    } else {
      stack.push(e1);
      stack.push(e0);
    }
  } else if (take0) {
    stack.push(e0);
  } else if (take1) {
    stack.push(e1);
  }
}

template <typename S, class Policy>
bool descend(const View<S>& va, const View<S>& vb, bool self, const Policy& p) {
  if (va.root == kNone || vb.root == kNone) return false;
  SmallStack<Entry<S>, 128> stack;
  Entry<S> start{va.root, vb.root, S(0)};
  if (!self && !p.enter(va.nodes[va.root], vb.nodes[vb.root], start.key)) return false;
  stack.push(start);
  while (!stack.empty()) {
    const Entry<S> e = stack.pop();
    if (!p.keep(e.key)) continue;  // the best distance may have dropped since the push
    p.count.visit();
    const Node& na = va.nodes[e.a];
    const Node& nb = vb.nodes[e.b];
    if (self && e.a == e.b) {
      if (na.isLeaf()) {
        if (leafSelf(va, na, p)) return true;
        continue;
      }
      const std::uint32_t c = na.first;
      Entry<S> cross{c, c + 1, S(0)};
      if (p.enter(va.nodes[c], va.nodes[c + 1], cross.key)) stack.push(cross);
      stack.push(Entry<S>{c + 1, c + 1, S(0)});
      stack.push(Entry<S>{c, c, S(0)});
      continue;
    }
    if (na.isLeaf() && nb.isLeaf()) {
      if (leafPair(va, na, vb, nb, p)) return true;
      continue;
    }
    const bool split_a = nb.isLeaf() || (!na.isLeaf() && extent(na) >= extent(nb));
    if (split_a) {
      const std::uint32_t c = na.first;
      Entry<S> e0{c, e.b, S(0)}, e1{c + 1, e.b, S(0)};
      const bool t0 = p.enter(va.nodes[c], nb, e0.key);
      const bool t1 = p.enter(va.nodes[c + 1], nb, e1.key);
      pushPair<S, Policy>(stack, t0, e0, t1, e1);
    } else {
      const std::uint32_t c = nb.first;
      Entry<S> e0{e.a, c, S(0)}, e1{e.a, c + 1, S(0)};
      const bool t0 = p.enter(na, vb.nodes[c], e0.key);
      const bool t1 = p.enter(na, vb.nodes[c + 1], e1.key);
      pushPair<S, Policy>(stack, t0, e0, t1, e1);
    }
  }
  return false;
}

}  // namespace

template <typename S>
bool collidePairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFn<S> fn,
                  QueryStats* stats) {
  if (stats) return descend(a, b, self, CollidePolicy<S, Count>{data, fn, Count{stats}});
  return descend(a, b, self, CollidePolicy<S, NoCount>{data, fn, NoCount{}});
}

template <typename S>
bool distancePairs(const View<S>& a, const View<S>& b, bool self, void* data, DistanceFn<S> fn,
                   S& best, QueryStats* stats) {
  if (stats) return descend(a, b, self, DistancePolicy<S, Count>{data, fn, best, Count{stats}});
  return descend(a, b, self, DistancePolicy<S, NoCount>{data, fn, best, NoCount{}});
}

template <typename S>
SingleView<S>::SingleView(fcl::CollisionObject<S>* obj, const Box<S>& box) {
  item = Item<S>{box, obj, 0, 0};
  roundOut(box, node.lo, node.hi);
  node.first = 0;
  node.count = 1;
}

template bool collidePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                  CollideFn<float>, QueryStats*);
template bool collidePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                   CollideFn<double>, QueryStats*);
template bool distancePairs<float>(const View<float>&, const View<float>&, bool, void*,
                                   DistanceFn<float>, float&, QueryStats*);
template bool distancePairs<double>(const View<double>&, const View<double>&, bool, void*,
                                    DistanceFn<double>, double&, QueryStats*);
template struct SingleView<float>;
template struct SingleView<double>;

}  // namespace detail
}  // namespace cube
