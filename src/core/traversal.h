#pragma once

// The traversals over cube hierarchies: one descent engine serves self-collide, pair collide,
// object queries and all distance queries (a query object is a one-leaf view).

#include <cstdint>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "core/geometry.h"
#include "core/kernels/pair_kernels.h"
#include "core/pair_gate.h"
#include "cube_collision/query_stats.h"

namespace cube {
namespace detail {

/// What a collide calls for each pair: an FCL callback (the objects and the caller's data), or,
/// for the library's own queries, a function that is also given the two objects' ids, so that it
/// can read what the object tables keep per id (the cull's volumes). A query object that is not
/// registered has the id kNone; in queries of two managers the first id is the first manager's.
template <typename S>
struct CollideFn {
  using Object = fcl::CollisionObject<S>;
  using Plain = bool (*)(Object*, Object*, void*);
  using WithIds = bool (*)(Object*, ObjectId, Object*, ObjectId, void*);
  Plain plain = nullptr;
  WithIds with_ids = nullptr;

  CollideFn(Plain f) : plain(f) {}       // NOLINT: FCL callbacks convert implicitly
  CollideFn(WithIds f) : with_ids(f) {}  // NOLINT
  bool operator()(Object* a, ObjectId ia, Object* b, ObjectId ib, void* data) const {
    return with_ids != nullptr ? with_ids(a, ia, b, ib, data) : plain(a, b, data);
  }
};
/// CollideFn<S> as a parameter that takes no part in deducing S (so that an FCL callback, or a
/// test's, converts to it).
template <class T>
struct NonDeduced {
  using type = T;
};
template <typename S>
using CollideFnArg = typename NonDeduced<CollideFn<S>>::type;
/// What a distance walk calls for each pair near enough: FCL's distance callback, or one that is
/// also given the ids (as CollideFn).
template <typename S>
struct DistanceFn {
  using Object = fcl::CollisionObject<S>;
  using Plain = bool (*)(Object*, Object*, void*, S&);
  using WithIds = bool (*)(Object*, ObjectId, Object*, ObjectId, void*, S&);
  Plain plain = nullptr;
  WithIds with_ids = nullptr;

  DistanceFn(Plain f) : plain(f) {}       // NOLINT: FCL callbacks convert implicitly
  DistanceFn(WithIds f) : with_ids(f) {}  // NOLINT
  bool operator()(Object* a, ObjectId ia, Object* b, ObjectId ib, void* data, S& best) const {
    return with_ids != nullptr ? with_ids(a, ia, b, ib, data, best) : plain(a, b, data, best);
  }
};
template <typename S>
using DistanceFnArg = typename NonDeduced<DistanceFn<S>>::type;

/// A one-object view for queries: the caller owns the storage.
template <typename S>
struct SingleView {
  Node node;
  Item<S> item;
  SingleView(fcl::CollisionObject<S>* obj, const Box<S>& box, ObjectId id = kNone)
      : item{box, obj, 0, id} {
    roundOut(box, node.lo, node.hi);
    node.first = 0;
    node.count = 1;
  }
  View<S> view() const { return View<S>{&node, &item, 0, 1}; }
};

/// Calls fn(x, y, data) for every pair of distinct objects x of `a` and y of `b` whose boxes
/// overlap (closed) and that pass `gate` (if given). With `self` (a and b are the same view)
/// each unordered pair comes once. Returns true as soon as fn does (the query stops).
template <typename S>
bool walkCubePairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFnArg<S> fn,
                   QueryStats* stats = nullptr, const PairGate<S>* gate = nullptr);

/// The collide of two views every query runs (the walk chosen once, here): the pairs of
/// walkCubePairs(a, b, self, data, fn, stats, gate), found by collideAllPairs where
/// allPairsFit(a, b, self, all_pairs_limit), by the walk of one object down `a` where `b` is a
/// single object and there is no gate, else by the walk of cube pairs. fn comes third so that it
/// is passed in registers: from the stack, its first 16-byte load waited for the caller's two
/// 8-byte stores to retire (a measurable loss in the batch's body queries).
template <typename S>
bool collideViews(const View<S>& a, const View<S>& b, CollideFnArg<S> fn, void* data, bool self,
                  std::size_t all_pairs_limit, QueryStats* stats = nullptr,
                  const PairGate<S>* gate = nullptr);

/// collideViews(tree, object.view(), false, 0, data, fn, stats) for an object without a gate,
/// straight into the walk of one object down a tree: most queries are those, and short.
template <typename S>
bool collideObject(const View<S>& tree, const SingleView<S>& object, void* data, CollideFnArg<S> fn,
                   QueryStats* stats = nullptr);

/// Appends to `out` every pair of distinct objects x of `a` and y of `b` whose boxes overlap
/// (closed; with `self`, each unordered pair once) as id(x) << 32 | id(y): the pairs of
/// collideViews(a, b, self, all_pairs_limit, ...), by the same walk, in its order and argument
/// order. With a gate, only the pairs that pass it, oriented by it (an id of kNone stays kNone).
template <typename S>
void collectPairs(const View<S>& a, const View<S>& b, bool self, std::size_t all_pairs_limit,
                  std::vector<std::uint64_t>& out, const PairGate<S>* gate = nullptr);

/// The walk of collectPairs(a, b, self, all_pairs_limit, out, gate) cut into independent
/// subwalks (tasks), so that threads can take them: the pairs of task 0, then of task 1, and so
/// on, are collectPairs' pairs in its order. Each task is a pair of cubes where a walkPair of its
/// own starts. The top of the walk is opened one level at a time, each task replaced by the child
/// pairs the walk would visit, in the order it would visit them (a walk without a distance bound
/// is a preorder), until there are at least `min_tasks` tasks or only leaves are left: the cut
/// depends on the views alone, never on a thread count. Holds what the walk reads besides the
/// views (the float columns, the filter bits in slot order), shared read-only by the tasks. The
/// views and the gate must outlive it.
template <typename S>
class SplitWalk {
 public:
  SplitWalk(const View<S>& a, const View<S>& b, bool self, std::size_t all_pairs_limit,
            const PairGate<S>* gate, std::size_t min_tasks);
  ~SplitWalk();
  SplitWalk(const SplitWalk&) = delete;
  SplitWalk& operator=(const SplitWalk&) = delete;

  std::size_t tasks() const { return tasks_.size(); }
  /// Appends task i's pairs to `out` (as collectPairs writes them). Const and without shared
  /// writes: any number of threads may run tasks at once.
  void collect(std::size_t i, std::vector<std::uint64_t>& out) const;

 private:
  struct Task {
    std::uint32_t a, b;
  };
  View<S> a_, b_;
  bool self_;
  bool all_pairs_ = false;  // small views (allPairsFit): one task, the all-pairs kernel
  const PairGate<S>* gate_;
  std::vector<Task> tasks_;
  std::unique_ptr<ColumnStore> store_;  // large self walks: the leaves' float columns
  std::vector<Filter> bits_;            // self walks with filter bits: the bits per slot
};

/// Whether a collide of `a` with `b` (with `self`, of `a` with itself) tests every pair of boxes
/// at once (collideAllPairs) rather than walking the cubes: each side has at most `limit` slots
/// (Config::all_pairs_limit). In such small scenes the cubes' fixed cost per call outweighs their
/// pruning: a leaf of 8 objects against another is 64 box tests whatever the cubes said.
template <typename S>
bool allPairsFit(const View<S>& a, const View<S>& b, bool self, std::size_t limit) {
  return a.slots <= limit && (self || b.slots <= limit);
}

/// Collide of two views (with `self`, of `a` with itself) without their cubes: every pair of
/// objects is tested, several at a time in float, and pairs that pass are tested again exactly
/// before fn is called. Two views whose root cubes do not overlap give nothing at once. Same
/// pairs as walkCubePairs(a, b, self, ...), row by row in slot order of `a`, each row in slot
/// order of `b`. Requires a.slots and b.slots <= kAllPairsMax (std::logic_error otherwise, as
/// for a kernel this CPU lacks).
template <typename S>
bool collideAllPairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFnArg<S> fn,
                     QueryStats* stats = nullptr, PairKernel kernel = PairKernel::best,
                     const PairGate<S>* gate = nullptr);

/// The box tests the walks make between two leaves (each at most kMaskLeaf objects): bit
/// kMaskLeaf i + j of the result is set where xs[i] and ys[j] overlap (closed). With `self`, xs
/// and ys are the same run and only j > i counts. `kernel`: avx2 four double or eight float
/// pairs per instruction, portable or sse2 one pair at a time, best the table the walks use
/// between two leaves (pairKernels()). Throws std::logic_error on runs too long or a kernel the
/// CPU lacks. For the tests, which compare the kernels.
template <typename S>
std::uint64_t leafOverlapMask(const Item<S>* xs, std::uint32_t nx, const Item<S>* ys,
                              std::uint32_t ny, bool self, PairKernel kernel);

/// Branch and bound over the same pairs: calls fn(x, y, data, best) for pairs whose box distance
/// is below `best` (or whose boxes overlap), nearer cubes first; fn lowers `best`. Returns true
/// as soon as fn does. `stats`, if given, counts the work done; pairs that do not pass `gate`
/// (if given) are skipped.
template <typename S>
bool distancePairs(const View<S>& a, const View<S>& b, bool self, void* data, DistanceFnArg<S> fn,
                   S& best, QueryStats* stats = nullptr, const PairGate<S>* gate = nullptr);

/// The two views of one broadphase, its cubes and its unbounded list, and where each id is.
template <typename S>
struct Scene {
  View<S> cubes;
  View<S> unbounded;
  const std::uint32_t* loc;  ///< per id: slot in cubes, or place in unbounded | kUnboundedBit
  std::size_t all_pairs_limit;
  const Item<S>& item(ObjectId id) const {
    const std::uint32_t l = loc[id];
    return (l & kUnboundedBit) ? unbounded.items[l & ~kUnboundedBit] : cubes.items[l];
  }
};

/// A self query is three view pairs: cubes with cubes, cubes with the unbounded list, the list
/// with itself. Calls run(a, b, self) for each until one returns true; returns whether one did.
template <typename S, class Run>
bool forSelfViews(const Scene<S>& scene, Run&& run) {
  if (run(scene.cubes, scene.cubes, true)) return true;
  if (scene.unbounded.root == kNone) return false;
  return run(scene.cubes, scene.unbounded, false) || run(scene.unbounded, scene.unbounded, true);
}

/// A query against a view `q` (one object, or another broadphase's cubes or list): the cubes
/// against q, then the unbounded list against q. Empty views are not run: a walk's set-up is a
/// measurable share of a small query (a 30-object manager against a 32-object one).
template <typename S, class Run>
[[gnu::always_inline]] inline bool forObjectViews(const Scene<S>& scene, const View<S>& q,
                                                  Run&& run) {
  if (q.root == kNone) return false;
  if (scene.cubes.root != kNone && run(scene.cubes, q, false)) return true;
  return scene.unbounded.root != kNone && run(scene.unbounded, q, false);
}

}  // namespace detail
}  // namespace cube
