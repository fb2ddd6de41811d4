#pragma once

// The two walks of the library, written once: walkTree visits one tree, walkPair visits pairs of
// cubes of two trees (or of one tree with itself). Both are depth-first with an explicit stack,
// so no recursion grows with the tree's height, and both are templates over a visitor that says
// what to do at each step. Queries (collide, distance), the build, incremental splits,
// compaction, validation and inspection are visitors; nothing else in the library keeps a stack
// of cubes.

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/geometry.h"

namespace cube {
namespace detail {

/// A stack that lives in the frame up to N entries and moves to the heap beyond, so that walks
/// allocate nothing on ordinary trees and still cope with degenerate deep ones.
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

/// Chooses what a walk does next among the taken entries of `e`: the most promising one (with
/// V::kOrdered the smallest state by V::before, otherwise the first) goes into `next` and is
/// visited straight away; the others wait on the stack, the next most promising on top. Returns
/// false if none was taken. Going straight on, and choosing with branches on registers rather
/// than by compacting the taken entries through memory (each store and load of which waits on
/// the last), more than doubled the speed of object queries.
template <class V, class Stack, class E, int N>
bool continueWithBest(Stack& stack, const bool (&take)[N], const E (&e)[N], E& next) {
  if constexpr (!V::kOrdered) {
    // From the last entry down, every index a constant once unrolled: the entry gone on with is
    // copied from registers. (With the first taken index found at run time, e[first] was read
    // back from the array just stored, which slowed the robot query.)
    bool found = false;
#pragma GCC unroll 4
    for (int i = N - 1; i >= 0; --i) {
      if (!take[i]) continue;
      if (found) stack.push(next);
      next = e[i];
      found = true;
    }
    return found;
  } else if constexpr (N == 2) {
    if (take[0] && take[1]) {
      const int near = V::before(e[1].state, e[0].state) ? 1 : 0;
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
    // Insertion sort, nearest first (stable: equal states keep their order).
    for (int i = 1; i < m; ++i)
      for (int j = i; j > 0 && V::before(e[order[j]].state, e[order[j - 1]].state); --j)
        std::swap(order[j - 1], order[j]);
    for (int j = m - 1; j > 0; --j) stack.push(e[order[j]]);
    next = e[order[0]];
    return true;
  }
}

/// What a visitor wants after seeing a cube: open it (its children are offered to enter()),
/// leave it (a leaf, or a subtree not worth it), or end the walk.
enum class Step { open, skip, stop };

/// Visits the tree below `root` depth-first: at each cube, v.at(cube, state); if it says open,
/// v.enter(child, which, state, child_state) for each child (which = 0, 1), and the children it
/// takes are visited next (V::kOrdered: the one V::before puts first; otherwise the first
/// child first, so that an unordered walk is a preorder). A stacked cube is visited only if
/// v.worth(state) still holds when it comes off the stack (a distance bound may have shrunk).
/// `nodes` is read after each v.at, which may append to it (the build grows the tree it walks).
/// Returns true if v.at said stop.
///
/// The visitor: `using State` (copied onto the stack), `static constexpr bool kOrdered`,
/// `static bool before(const State&, const State&)` (used only if kOrdered),
/// `bool worth(const State&)`, `Step at(std::uint32_t, const State&)`,
/// `bool enter(std::uint32_t, int, const State&, State&)`.
template <class Nodes, class V>
bool walkTree(const Nodes& nodes, std::uint32_t root, const typename V::State& start, V& v) {
  struct E {
    std::uint32_t node;
    typename V::State state;
  };
  SmallStack<E, 64> stack;
  stack.push(E{root, start});
  while (!stack.empty()) {
    E e = stack.pop();
    if (!v.worth(e.state)) continue;
    for (bool more = true; more;) {
      const Step step = v.at(e.node, e.state);
      if (step == Step::stop) return true;
      if (step == Step::skip) break;
      const std::uint32_t c = nodes[e.node].first;
      E ch[2] = {{c, {}}, {c + 1, {}}};
      bool take[2];
      for (int i = 0; i < 2; ++i) take[i] = v.enter(c + i, i, e.state, ch[i].state);
      more = continueWithBest<V>(stack, take, ch, e);
    }
  }
  return false;
}

/// The visitor of walkPreorder.
template <class St, class At, class Child>
struct PreorderVisitor {
  using State = St;
  static constexpr bool kOrdered = false;
  At& at_fn;
  Child& child_fn;
  static bool before(const State&, const State&) { return false; }
  bool worth(const State&) const { return true; }
  Step at(std::uint32_t cube, const State& s) { return at_fn(cube, s); }
  bool enter(std::uint32_t, int which, const State& parent, State& out) {
    out = child_fn(which, parent);
    return true;
  }
};

/// walkTree for the walks that open every cube `at` asks them to, first child first (a
/// preorder): the build, incremental splits, compaction, validation and inspection.
/// at(cube, state) returns the Step; child(which, parent_state) gives a child's state, after
/// `at` has run on the parent. Returns true if `at` said stop.
template <class Nodes, class State, class At, class Child>
bool walkPreorder(const Nodes& nodes, std::uint32_t root, const State& start, At&& at,
                  Child&& child) {
  PreorderVisitor<State, std::remove_reference_t<At>, std::remove_reference_t<Child>> v{at, child};
  return walkTree(nodes, root, start, v);
}

/// Two cubes, one of tree A and one of tree B (or both of one tree).
struct CubePair {
  std::uint32_t a, b;
};

/// The expansion step of walkPair, also the one SplitWalk cuts its tasks with: the child pairs a
/// pair of cubes (a, b) opens into, neither a pair of leaves nor (with `self`) a leaf with
/// itself, in the order a walk without preference visits them. A cube with itself (self, a ==
/// b) gives its two children each with itself, then the two together; two internal cubes the
/// four pairs of their children; an internal cube and a leaf the internal one's two children
/// with the leaf. Calls f(pairs, fixed, open_a, open_b) once: `pairs` a std::array of 3, 4 or 2
/// CubePairs (its size a constant, so that the walk's choice among them is unrolled), of which
/// the first `fixed` are visited whatever the visitor says (the children with themselves), and
/// whether a's and b's children are among them.
template <class F>
[[gnu::always_inline]] inline void childPairs(const Node& na, const Node& nb, std::uint32_t a,
                                              std::uint32_t b, bool self, F&& f) {
  if (self && a == b) {
    const std::uint32_t c = na.first;
    f(std::array<CubePair, 3>{{{c, c}, {c + 1, c + 1}, {c, c + 1}}}, 2, true, false);
  } else if (!na.isLeaf() && !nb.isLeaf()) {
    const std::uint32_t ca = na.first, cb = nb.first;
    f(std::array<CubePair, 4>{{{ca, cb}, {ca, cb + 1}, {ca + 1, cb}, {ca + 1, cb + 1}}}, 0, true,
      true);
  } else if (nb.isLeaf()) {
    f(std::array<CubePair, 2>{{{na.first, b}, {na.first + 1, b}}}, 0, true, false);
  } else {
    f(std::array<CubePair, 2>{{{a, nb.first}, {a, nb.first + 1}}}, 0, false, true);
  }
}

/// Visits pairs of cubes (a of tree A, b of tree B) depth-first from (rootA, rootB); with
/// `self` (A and B the same tree), each unordered pair of cubes once: a cube with itself means
/// the pairs within it. At a pair of leaves, v.leafPair(a, b) (or v.leafSelf(a) for a leaf with
/// itself); otherwise the larger step is taken: both cubes opened (four child pairs), or the
/// internal one of an internal cube and a leaf (two). v.enter(a, b, state) decides which child
/// pairs are visited and gives their states; order and worth() as in walkTree. v.visit() is
/// called at each pair visited. Returns true as soon as a leaf call does.
///
/// The visitor: State, kOrdered, before and worth as for walkTree, and `void visit()`,
/// `bool enter(std::uint32_t a, std::uint32_t b, State&)`, `bool leafSelf(std::uint32_t)`,
/// `bool leafPair(std::uint32_t, std::uint32_t)`, `void prefetch(bool in_a, std::uint32_t)`.
// Inlined into each query's walk, as it was before its expansion step became childPairs: out of
// line (GCC's choice once the step was a lambda) the robot query was slower at the same
// instruction count, the visitor's state going through memory.
template <class V>
[[gnu::always_inline]] inline bool walkPair(const Node* na_nodes, const Node* nb_nodes,
                                            std::uint32_t root_a, std::uint32_t root_b,
                                            const typename V::State& start, bool self, V& v) {
  struct E {
    std::uint32_t a, b;
    typename V::State state;
  };
  SmallStack<E, 128> stack;
  stack.push(E{root_a, root_b, start});
  while (!stack.empty()) {
    E e = stack.pop();
    if (!v.worth(e.state)) continue;
    for (bool more = true; more;) {
      more = false;
      v.visit();
      const Node& na = na_nodes[e.a];
      const Node& nb = nb_nodes[e.b];
      if (self && e.a == e.b) {
        if (!v.enterSelf(e.a)) break;  // no pair within it can pass (filter groups)
        if (na.isLeaf()) {
          if (v.leafSelf(e.a)) return true;
          break;
        }
      } else if (na.isLeaf() && nb.isLeaf()) {
        if (v.leafPair(e.a, e.b)) return true;
        break;
      }
      childPairs(na, nb, e.a, e.b, self,
                 [&](const auto& pairs, int fixed, bool open_a, bool open_b) {
                   constexpr int N = int(std::tuple_size<std::decay_t<decltype(pairs)>>::value);
                   E ch[N];
                   bool take[N];
                   for (int i = 0; i < N; ++i) {
                     ch[i] = E{pairs[i].a, pairs[i].b, {}};
                     take[i] = i < fixed || v.enter(ch[i].a, ch[i].b, ch[i].state);
                   }
                   for (std::uint32_t i = 0; i < 2; ++i) {
                     if (open_a) v.prefetch(true, na.first + i);
                     if (open_b) v.prefetch(false, nb.first + i);
                   }
                   more = continueWithBest<V>(stack, take, ch, e);
                 });
    }
  }
  return false;
}

}  // namespace detail
}  // namespace cube
