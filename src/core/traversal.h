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

/// A predicate on two objects: false drops the pair before any callback.
template <typename S>
using KeepFn = std::function<bool(fcl::CollisionObject<S>*, fcl::CollisionObject<S>*)>;

/// What a pair of overlapping boxes must also pass to reach a callback: the two objects' filter
/// bits, the user's predicate, and, in self queries, the orientation (lower registration number
/// first). A null member leaves its rule out; walks without a gate test nothing more.
template <typename S>
struct PairGate {
  const Filter* filters_a = nullptr;   ///< per id of side a's objects; null: all default
  const Filter* filters_b = nullptr;   ///< per id of side b's objects; null: all default
  const Filter* groups_a = nullptr;    ///< per filter group of side a (View::groups index it)
  const Filter* groups_b = nullptr;    ///< per filter group of side b
  Filter query;                        ///< side b's object when its id is kNone
  const KeepFn<S>* keep = nullptr;     ///< the user's predicate, if any
  const std::uint32_t* seq = nullptr;  ///< self queries: orient pairs by these numbers

  /// The filter bits of the objects with ids x and y (y may be kNone: the query object).
  std::pair<const Filter*, const Filter*> bitsOf(ObjectId x, ObjectId y) const {
    static constexpr Filter kAll{};
    const Filter* fx = filters_a != nullptr ? filters_a + x : &kAll;
    const Filter* fy = y == kNone ? &query : filters_b != nullptr ? filters_b + y : &kAll;
    return {fx, fy};
  }
  /// Whether the filter bits let the objects with ids x and y pair.
  bool bitsPass(ObjectId x, ObjectId y) const {
    const auto f = bitsOf(x, y);
    return filtersPass(*f.first, *f.second);
  }
  /// Whether there are bits to test (else every pair passes them).
  bool hasBits() const { return filters_a != nullptr || filters_b != nullptr; }
  /// Whether every object of a cube of group ga (side a) may pair with every object of a cube
  /// of group gb (side b; kNone: the query object) by their bits: true (pass), false (none
  /// can), or unknown (a mixed cube, or no groups). Returns 1, 0 or -1.
  int groupsPass(Group ga, Group gb, bool query_b) const {
    if (ga == kMixedGroup || groups_a == nullptr) return -1;
    if (query_b) return filtersPass(groups_a[ga], query);
    if (gb == kMixedGroup || groups_b == nullptr) return -1;
    return filtersPass(groups_a[ga], groups_b[gb]);
  }
  /// `bits` with the pairs whose filter bits do not pass cleared; bits_of(b) points at bit b's
  /// two Filters. No branch per pair: whether a pair passes is a coin toss for the branch predictor
  /// when groups are mixed, and a mispredicted branch costs more than the test.
  template <class BitsOf>
  static std::uint64_t passing(std::uint64_t bits, BitsOf&& bits_of) {
    std::uint64_t out = bits;
    for (std::uint64_t m = bits; m != 0; m &= m - 1) {
      const unsigned b = static_cast<unsigned>(__builtin_ctzll(m));
      const auto f = bits_of(b);
      out &= ~(std::uint64_t(!filtersPass(*f.first, *f.second)) << b);
    }
    return out;
  }
  /// The rules after the bits, for a pair whose bits passed: orientation and the predicate.
  /// x and y are records or ids; obj(x) gives the object. Calls then(first, second) if it passes;
  /// false (the query goes on) otherwise.
  template <class T, class IdOf, class ObjOf, class Then>
  bool finish(const T& x, const T& y, IdOf&& id, ObjOf&& obj, Then&& then) const {
    const bool swap = seq != nullptr && seq[id(y)] < seq[id(x)];
    const T& first = swap ? y : x;
    const T& second = swap ? x : y;
    if (keep != nullptr && !(*keep)(obj(first), obj(second))) return false;
    return then(first, second);
  }
  /// Calls then(x, y) on the pair, oriented, if it passes; false (the query goes on) otherwise.
  template <class Then>
  bool through(const Item<S>& x, const Item<S>& y, Then&& then) const {
    if (!bitsPass(x.id, y.id)) return false;
    return finish(
        x, y, [](const Item<S>& i) { return i.id; }, [](const Item<S>& i) { return i.obj; }, then);
  }
};

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
bool collidePairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFnArg<S> fn,
                  QueryStats* stats = nullptr, const PairGate<S>* gate = nullptr);

/// An object query without a gate: collidePairs(tree, query.view(), false, data, fn, stats),
/// straight into the one-object walk. Most queries are short, and the set-up that pairs of
/// trees need was a tenth of their time.
template <typename S>
bool collideObject(const View<S>& tree, const SingleView<S>& query, void* data, CollideFnArg<S> fn,
                   QueryStats* stats = nullptr);

/// Appends to `out` every pair of distinct objects x of `a` and y of `b` whose boxes overlap
/// (closed; with `self`, each unordered pair once) as id(x) << 32 | id(y). In the order and with
/// the argument order in which a collide would call its callback: collidePairs, or
/// collideAllPairs where allPairsFit(a, b, self, all_pairs_limit). With a gate, only the
/// pairs that pass it, oriented by it (an id of kNone stays kNone).
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
/// pairs as collidePairs(a, b, self, ...), row by row in slot order of `a`, each row in slot
/// order of `b`. Requires a.slots and b.slots <= kAllPairsMax (std::logic_error otherwise, as
/// for a kernel this CPU lacks).
template <typename S>
bool collideAllPairs(const View<S>& a, const View<S>& b, bool self, void* data, CollideFnArg<S> fn,
                     QueryStats* stats = nullptr, PairKernel kernel = PairKernel::best,
                     const PairGate<S>* gate = nullptr);

/// The box tests the walks make between two leaves (each at most kMaskLeaf objects): bit
/// kMaskLeaf i + j of the result is set where xs[i] and ys[j] overlap (closed). With `self`, xs
/// and ys are the same run and only j > i counts. `kernel`: avx2 (double only) four pairs per
/// instruction, portable or sse2 one pair at a time, best the table the walks use between two
/// leaves (pairKernels()). Throws std::logic_error on runs too long, a kernel
/// the CPU lacks, or avx2 for float. For the tests, which compare the kernels.
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
bool forObjectViews(const Scene<S>& scene, const View<S>& q, Run&& run) {
  if (q.root == kNone) return false;
  if (scene.cubes.root != kNone && run(scene.cubes, q, false)) return true;
  return scene.unbounded.root != kNone && run(scene.unbounded, q, false);
}

}  // namespace detail
}  // namespace cube
