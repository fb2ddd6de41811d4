#pragma once

// The broadphase core: the object table, the cube tree, the list of unbounded objects, the
// rebuild policy and the pair list, behind one interface of registrations, motions and queries.
// It knows FCL's objects only as pointers it hands back to callbacks; FCL's manager class, the
// reading of AABBs and the checking of input are the adapter's
// (src/adapter/cube_collision_manager.cpp).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/cube_tree.h"
#include "core/kernels/box_ops.h"
#include "core/object_table.h"
#include "core/pair_gate.h"
#include "core/pair_list.h"
#include "core/rebuild_policy.h"
#include "core/task_sink.h"
#include "core/thread_policy.h"
#include "core/traversal.h"
#include "core/unbounded_list.h"
#include "core/walk.h"
#include "cube_collision/config.h"
#include "cube_collision/query_stats.h"

namespace cube {
namespace detail {

/// Hands region.leaf the runs of consecutive objects of items[0, n) that pass the query's filter
/// bits (gate.query) against their own: the regions need not know about filters.
template <typename S, class Region>
void filteredLeaf(Region& region, const PairGate<S>& gate, const Item<S>* items, std::uint32_t n,
                  const std::uint32_t* seq) {
  const auto pass = [&](const Item<S>& it) {
    return it.obj != nullptr && gate.bitsPass(it.id, kNone);
  };
  std::uint32_t i = 0;
  while (i < n) {
    while (i < n && !pass(items[i])) ++i;
    std::uint32_t j = i;
    while (j < n && pass(items[j])) ++j;
    if (j > i) region.leaf(items + i, j - i, seq);
    i = j;
  }
}

/// Broadphase::search's visitor of walkTree: the region's choices, cube by cube. Gated: the
/// query's filter bits too; a cube whose filter group they reject is not entered, a leaf whose
/// group they pass is handed on whole, the others object by object (filteredLeaf).
template <typename S, class Region, bool Gated = false>
struct RegionGuide {
  using State = typename Region::State;
  static constexpr bool kOrdered = Region::kOrdered;
  const View<S>& cubes;
  const std::uint32_t* seq;
  Region& region;
  const PairGate<S>* gate = nullptr;  ///< Gated: the query's bits (query) and the objects'
  static bool before(const State& x, const State& y) { return Region::before(x, y); }
  bool worth(const State& s) const { return region.worth(s); }
  /// 1: every object of the cube passes the bits, 0: none does, -1: unknown.
  int groupPasses(std::uint32_t cube) const {
    return cubes.groups == nullptr ? -1 : gate->groupsPass(cubes.groups[cube], kMixedGroup, true);
  }
  bool enter(std::uint32_t child, int, const State&, State& out) {
    const Node& n = cubes.nodes[child];
    if constexpr (Gated) {
      if (groupPasses(child) == 0) return false;
    }
    return region.enters(n.lo, n.hi, out);
  }
  Step at(std::uint32_t cube, const State&) {
    const Node& n = cubes.nodes[cube];
    if (!n.isLeaf()) return Step::open;
    if constexpr (Gated) {
      if (groupPasses(cube) != 1) {
        filteredLeaf(region, *gate, cubes.items + n.first, n.count, seq);
        return Step::skip;
      }
    }
    region.leaf(cubes.items + n.first, n.count, seq);
    return Step::skip;
  }
};

template <typename S>
class Broadphase {
 public:
  using Object = fcl::CollisionObject<S>;

  /// Throws std::invalid_argument if a knob is out of range.
  explicit Broadphase(const Config& config);

  const Config& config() const { return config_; }
  std::size_t size() const { return table_.size(); }
  bool contains(const Object* obj) const { return table_.find(obj) != kNone; }

  // Mutations. Boxes are checked by the caller: none is invalid (NaN).

  /// Registers an object that is not registered yet.
  void add(Object* obj, const Box<S>& box);
  /// Registers a batch; registered or repeated entries are skipped. A batch at least as large as
  /// what is registered is placed by one build.
  void addMany(Object* const* objs, const Box<S>* boxes, std::size_t n);
  /// The same, the box of entry i read by read(i, box) when it is registered (once, in batch
  /// order): the boxes are never held apart from the slots. read returns false for a box it
  /// refuses: then nothing of the batch is registered, and the entry's index is returned; else n.
  template <class Read>
  std::size_t addMany(Object* const* objs, std::size_t n, Read&& read);
  /// Unregisters; false if not registered.
  bool remove(const Object* obj);
  /// update(): reads every object's box through read(obj, box), refits, rebuilds if due and
  /// brings the pair list up to date. An object whose new box is invalid keeps its old one;
  /// returns the earliest registered such object, or nullptr.
  template <class Read>
  const Object* updateAll(Read&& read);
  /// update(objects) and update(obj): sets the boxes of the given objects (unknown ones are
  /// ignored), then rebuilds if due. With `keep_list` the pair list is brought up to date, else
  /// dropped (a loop of single updates would pass over the whole list for each object).
  void updateSome(Object* const* objs, const Box<S>* boxes, std::size_t n, bool keep_list);
  /// setup(): builds or rebuilds as RebuildPolicy::dueAtSetup says.
  void setup();
  /// Whether setup() has nothing to do: no object now and no tree ever built (a manager that has
  /// never held an object stays as it was constructed until its first registrations).
  bool setupIsNoOp() const { return size() == 0 && !tree_.built(); }
  void clear();

  // Per-object properties. Boxes handed to the core are the objects' own (FCL's AABBs): the core
  // grows each by its margin before it keeps or tests it.

  /// Sets a registered object's filter bits; false if not registered. O(1), the pair list stays.
  bool setFilter(const Object* obj, const Filter& f);
  /// The filter bits of a registered object, or of any other (the default).
  Filter filter(const Object* obj) const;
  /// Excludes the pair of registered objects a != b (on), or admits it again: the table's
  /// exclusion, which the gate reads at every query. False if either is not registered.
  bool exclude(const Object* a, const Object* b, bool on) {
    const ObjectId x = table_.find(a), y = table_.find(b);
    if (x == kNone || y == kNone) return false;
    table_.exclude(x, y, on);
    return true;
  }
  /// The predicate every pair must pass after the filter bits (empty: none).
  void setPredicate(PairPredicate<S> p) { predicate_ = std::move(p); }
  const PairPredicate<S>& predicate() const { return predicate_; }
  /// Gives a registered object its own margin (>= 0) and its new box `box`; false if not
  /// registered.
  bool setMargin(const Object* obj, const Box<S>& box, S margin);
  /// The margin of objects without one of their own, then update() through `read`.
  template <class Read>
  const Object* setDefaultMargin(S margin, Read&& read) {
    default_margin_ = margin;
    any_margin_ = any_margin_ || margin != S(0);
    return updateAll(read);
  }
  /// The margin an object's box is grown by: its own, else the manager-wide one (also for
  /// objects not registered here, such as query objects).
  S margin(const Object* obj) const;
  S defaultMargin() const { return default_margin_; }
  /// The margin of a registered id (its own, else the manager-wide one): no lookup.
  S marginOf(ObjectId id) const {
    const S own = table_.ownMargin(id);
    return own < S(0) ? default_margin_ : own;
  }

  // Queries: const, no state touched, safe from any number of threads at once.

  /// A query by an object of no table (a planner's link): the object handed to callbacks and to
  /// the pair predicate, its box (FCL's, or any box that holds it), the margin the core grows it
  /// by, and its filter bits.
  struct Probe {
    Object* obj;
    Box<S> box;
    S margin;
    Filter bits;
  };
  /// Objects whose box overlaps `box`: fn(managed, obj, data).
  bool collide(Object* obj, const Box<S>& box, void* data, CollideFn<S> fn,
               QueryStats* stats) const;
  /// Managed objects whose box overlaps the probe's grown box and whose bits and the predicate
  /// let them meet it: fn(managed, probe.obj, data), the probe's id kNone.
  bool collide(const Probe& probe, void* data, CollideFn<S> fn, QueryStats* stats) const;
  /// Every overlapping pair of managed objects; from the pair list when it is valid.
  bool collideSelf(void* data, CollideFn<S> fn, QueryStats* stats) const;
  /// collideSelf with the walk of a large scene cut into tasks (SplitWalk) that `threads` OpenMP
  /// threads walk: fn sees the same pairs in the same order, on this thread, and stops the query
  /// the same way. The tasks run in waves (threads tasks, then twice as many, ...), so a query
  /// that stops early walks little more than the serial one. The pair predicate too is asked on
  /// this thread, in walk order. Serial (collideSelf) for threads <= 1, a valid pair list, or
  /// fewer than kSplitMin objects in the cubes.
  bool collideSelfSplit(void* data, CollideFn<S> fn, int threads) const;
  /// collideSelfSplit whose tasks hand their pairs to `sink` on the threads that walked them
  /// (TaskSink), without a callback on this thread: for the narrow-phase pipeline, which answers
  /// them there. False (nothing done) where the walk is not split (as collideSelfSplit says), where
  /// pairs come in registration order (Config::canonical_pairs), or with a pair predicate (user
  /// code, asked on this thread in walk order).
  bool collideSelfTasks(TaskSink<S>& sink, int threads) const;
  /// Objects in the cubes from which collideSelfSplit splits the walk (thread_policy.h).
  static constexpr std::size_t kSplitMin = kSplitMinObjects;
  /// The tasks a split self walk is cut into, and those of a TaskSink's walk (thread_policy.h).
  static constexpr std::size_t kSplitTasks = kSplitWalkTasks;
  static constexpr std::size_t kSinkTasks = kSinkWalkTasks;
  /// Pairs (managed object, object of `body`) whose boxes overlap and that pass the filter bits
  /// (the body's per id, null: all default) and the predicate: one walk of the cubes, then of
  /// the unbounded list, against the body's view (BodyView), in walk order whatever
  /// canonical_pairs says; fn gets the body's ids. `table_ids`: per body id, the object's id in
  /// this table, for the rules read by id (a sweep's movers); null: objects of no table.
  bool collide(const View<S>& body, const Filter* bits, void* data, CollideFn<S> fn,
               QueryStats* stats, const ObjectId* table_ids = nullptr) const;
  /// A sweep of registered objects: objects `ids` (registered, each once) at boxes `boxes` (each
  /// grown here by its object's margin) with one another, then with every other registered
  /// object at its own box, under the gate of a self query (filter bits, the predicate; pairs of
  /// two movers oriented by registration number when canonical_pairs): fn(a, ia, b, ib, data)
  /// with the table's ids, a mover as b against an object that stays. Pairs in walk order.
  bool collideMoving(const ObjectId* ids, const Box<S>* boxes, std::size_t n, void* data,
                     CollideFn<S> fn) const;
  /// Pairs (object of this, object of other) whose boxes overlap.
  bool collide(const Broadphase& other, void* data, CollideFn<S> fn, QueryStats* stats) const;
  /// Branch and bound from `best` (lowered by fn) over the objects near `box`.
  bool distance(Object* obj, const Box<S>& box, void* data, DistanceFn<S> fn, S& best,
                QueryStats* stats) const;
  /// The same from a probe (its grown box, its bits).
  bool distance(const Probe& probe, void* data, DistanceFn<S> fn, S& best, QueryStats* stats) const;
  bool distanceSelf(void* data, DistanceFn<S> fn, S& best, QueryStats* stats) const;
  bool distance(const Broadphase& other, void* data, DistanceFn<S> fn, S& best,
                QueryStats* stats) const;

  /// A query by a region of space rather than by an object (a ray, a box, a ball): the region
  /// says which cubes it enters, and is handed the objects of every leaf it reaches, the
  /// unbounded list first (a plane often bounds a ray's search), then the cubes' leaves in the
  /// order of walkTree with the region as its guide. The region: `using State`,
  /// `static constexpr bool kOrdered`, `static bool before(State, State)` and
  /// `bool worth(State)` as walkTree's visitor; `bool enters(const float* lo, const float* hi,
  /// State& out)` for a cube (and the root); `void leaf(const Item<S>* items, std::uint32_t n,
  /// const std::uint32_t* seq)` for a run of objects, dead slots (obj null) included, seq the
  /// registration numbers by id. With `bits` (null: every object), only the objects whose filter
  /// bits and `bits` pass filtersPass reach the region (as an object query's id kNone: the gate's
  /// bits and groups, not its other rules, which rule pairs of objects).
  template <class Region>
  void search(Region& region, const Filter* bits = nullptr) const;

  /// Whether the gate of this broadphase's queries lets the pair (a, b) reach a callback, were
  /// their boxes to overlap: the gate the query builds (gate()), asked for this one pair, the
  /// predicate called as that query calls it. a is registered here; b is, with `other`, an
  /// object registered there (a query against that broadphase), else an object registered here
  /// (a self query's pair, unless `as_query`) or a query object (an object query's: its bits
  /// and exclusions this table's if registered here). False, with nothing asked, if a is not
  /// registered here, b not in `other`, or a == b (no walk meets an object with itself).
  bool pairPasses(Object* a, Object* b, const Broadphase* other, bool as_query) const;

  /// Registered objects in registration order.
  void objects(std::vector<Object*>& out) const { table_.objects(out); }
  /// Whether the next self-collide reads the pair list.
  bool pairsListed() const { return pairs_.valid(); }

  /// The cubes and the unbounded list as views, and where each id is: for the core's own
  /// components and white-box tests. Queries go through the entries above, never through this.
  Scene<S> scene() const {
    return Scene<S>{tree_.view(), unbounded_.view(), table_.locations(), config_.all_pairs_limit};
  }
  // Inspection: the components, read-only.
  const CubeTree<S>& tree() const { return tree_; }
  const ItemArray<S>& unboundedItems() const { return unbounded_.items(); }
  const ObjectTable<S>& table() const { return table_; }
  /// Frees the table's per-object volumes until a query wants them again.
  void dropVolumes() { table_.dropVolumes(); }
  std::size_t bytes() const;
  /// Checks every component's invariants and how they agree; on failure says why.
  bool validate(std::string* why) const;

 private:
  /// With the filter groups the tree should keep apart, if any (see CubeTree::rebuild).
  IdArrays ids() {
    const bool apart = table_.separable(config_.filter_groups);
    return IdArrays{table_.seqs(), table_.locations(), apart ? table_.groups() : nullptr};
  }
  /// Builds the tree afresh over everything in it.
  void rebuild();
  /// A batch's new items into the cubes (`bounded`, taken) and the unbounded list (`loose`):
  /// one build, or insertions if the batch is small against what is registered.
  void placeBatch(ItemArray<S>&& bounded, const std::vector<Item<S>>& loose);
  /// Whether the objects' filter groups should be kept apart and the cubes do not record them
  /// (bits changed since the last build): update() and setup() then rebuild.
  bool regroupDue() const {
    return !tree_.empty() && !tree_.grouped() && table_.separable(config_.filter_groups);
  }
  /// Puts a registered id with a valid box where its kind says: the cubes or the unbounded list.
  void place(ObjectId id, Object* obj, const Box<S>& box);
  /// Takes an id out of wherever it is.
  void unplace(ObjectId id);
  /// Sets one registered object's box, moving it between the cubes and the list if its kind
  /// changed; false if not registered. Rebuilds nothing: the caller asks the policy after.
  bool move(const Object* obj, const Box<S>& box);
  /// Between operations: rebuild if the policy says so, else compact a sparse tree.
  void maintain();
  /// `box` grown by the margin of id (kNone: the manager-wide margin). Inline: update() calls it
  /// for every object.
  Box<S> grown(const Box<S>& box, ObjectId id) const {
    const S own = id == kNone ? S(-1) : table_.ownMargin(id);
    return grownBy(box, own < S(0) ? default_margin_ : own);
  }
  static Box<S> grownBy(const Box<S>& box, S m) {
    if (m == S(0)) return box;
    Box<S> g;
    for (int k = 0; k < 3; ++k) {
      g.lo[k] = box.lo[k] - m;
      g.hi[k] = box.hi[k] + m;
    }
    return g;
  }
  /// A query object's box grown by its margin; without margins in use, no lookup.
  Box<S> queryBox(const Object* obj, const Box<S>& box) const {
    return any_margin_ ? grown(box, table_.find(obj)) : box;
  }

  // The query plan (core/query_plan.cpp): every query names its other side, and plan() decides
  // once, for all of them, the gate, the source of pairs and how they are delivered.

  /// The other side of a query (a self query has none): another broadphase, or objects of no
  /// table seen as one view (a query object: one leaf; a body: its small tree).
  struct Against {
    const Broadphase* other = nullptr;
    /// The other side's view, not a copy: the caller's view was just written, and a copy's wide
    /// loads of it waited for those stores (a measurable loss in the batch's body queries).
    const View<S>* view = nullptr;
    const SingleView<S>* one = nullptr;  ///< a query object: its view's storage (ids kNone)
    Object* obj = nullptr;               ///< a query object: the object
    Filter bits{};                       ///< a query object: its filter bits
    const Filter* ids = nullptr;         ///< a body: bits per body id (null: all default)
    /// Side b's ids in this table (a body's, another table's), for the rules read by id; null:
    /// none there (a body), or none needed (no exclusions here).
    const ObjectId* here = nullptr;
    /// Another table: this table's ids in it (null: none needed, no exclusions there).
    const ObjectId* there = nullptr;
  };
  /// The other side of a query against another broadphase. Where either table excludes pairs,
  /// `ids` holds each side's ids in the other table (Against::here, there).
  Against otherSide(const Broadphase& other, std::vector<ObjectId> (&ids)[2]) const;
  /// What plan() decided.
  struct Plan {
    const PairGate<S>* gate = nullptr;  ///< set when a rule is (walks without one ask nothing)
    bool canonical = false;             ///< gather the pairs, then call in registration order
    bool from_list = false;             ///< a self query read from the valid pair list
    bool split = false;                 ///< a self walk cut into tasks for `threads` threads
    bool one_object = false;            ///< an object query without a gate: collideObject's walk
    int threads = 1;
    std::size_t all_pairs_limit = 0;  ///< views up to this many slots take the all-pairs test
    const PairGate<S>* walkGate() const { return gate; }
  };
  /// A query's room for its gate and the excluded pairs the gate reads: left unset (nothing
  /// written, as most queries have no rule) until plan() or gate() fills it.
  struct GateRoom {
    GateRoom() {}
    union {
      PairGate<S> gate;
    };
    Exclusions exclusions;
  };
  /// The gate of a query against `b` (null: a self query): the one place where a gate is built.
  /// `room`: the query's room for the excluded pairs, filled if a table excludes some (the gate
  /// then points at it). Not inlined: the queries without a rule (most) would set up the whole
  /// gate before plan() knows it is not needed.
  [[gnu::noinline]] PairGate<S> gate(const Against* b, Exclusions& room) const;
  /// The gate of a query against `b`, built in `room`, if a rule is set; else null.
  const PairGate<S>* gateIn(const Against* b, GateRoom& room) const;
  Plan plan(const Against* b, int threads, GateRoom& room) const;
  /// Runs run(a, b, self) on the view pairs of a query against `b` (null: self) until one returns
  /// true: the cubes, then the unbounded list.
  template <class Run>
  bool forViews(const Against* b, Run&& run) const;
  /// The one collide runner: a plan's pairs to fn.
  [[gnu::always_inline]] inline bool collideRun(const Against* b, int threads, void* data,
                                                CollideFn<S> fn, QueryStats* stats) const;
  /// The one distance runner.
  bool distanceRun(const Against* b, void* data, DistanceFn<S> fn, S& best,
                   QueryStats* stats) const;
  /// A split self walk's pairs (Plan::split): delivered wave by wave, or, with `out`, gathered,
  /// or, with `sink`, handed to it on the threads.
  bool collideSplit(const Plan& p, void* data, CollideFn<S> fn, std::vector<std::uint64_t>* out,
                    TaskSink<S>* sink = nullptr) const;
  /// Canonical delivery: `found` sorted by registration numbers, then to fn.
  bool callInOrder(const std::vector<std::uint64_t>& found, const Against* b, void* data,
                   CollideFn<S> fn, QueryStats* stats) const;
  /// The other side of an object query: the object in `one` (its grown box), its bits.
  static Against objectSide(const SingleView<S>& one, const View<S>& view, const Filter& bits);
  /// After motions: rebuild if due, then, with `keep`, keep the pair list (moved_ holds the ids
  /// whose box changed; `was_valid` whether the list was valid before).
  void afterMotion(bool keep, bool was_valid);

  Config config_;
  ObjectTable<S> table_;
  CubeTree<S> tree_;
  RebuildPolicy policy_;
  UnboundedList<S> unbounded_;  // objects too large for the cubes, tested by every query
  PairList<S> pairs_;
  std::vector<ObjectId> moved_;  // update()'s scratch: ids whose box changed
  PairPredicate<S> predicate_;   // the user's pair predicate (setPairFilter)
  S default_margin_ = 0;         // manager-wide margin
  bool any_margin_ = false;      // a margin was ever set: query objects need a lookup
  bool setup_done_ = false;
};

template <typename S>
template <class Read>
const typename Broadphase<S>::Object* Broadphase<S>::updateAll(Read&& read) {
  const bool keep = config_.keep_pairs;
  const bool was_valid = keep && pairs_.valid();
  pairs_.invalidate();  // until brought up to date below
  moved_.clear();
  std::uint32_t bad_seq = kNone;
  const Object* bad = nullptr;
  std::vector<std::pair<ObjectId, Box<S>>> crossers;  // change of kind: rare, allocation is fine
  // A few moved objects refit their paths to the root (stopping where nothing changes); many
  // refit every cube in one pass, which costs about as much as refitting 1/32 of the paths.
  const std::size_t path_limit = std::max<std::size_t>(8, tree_.size() / 32);
  std::size_t refits = 0;
  // Margins are rare: without them the loop reads no per-id margin. Stale records too (a small
  // table's): without them the loop looks for none.
  const auto pass = [&](Item<S>* items, std::uint32_t n, BoxKind home, auto margins, auto stale) {
    for (std::uint32_t p = 0; p < n; ++p) {
      Item<S>& it = items[p];
      if (it.obj == nullptr) continue;
      Box<S> b;  // here, not outside the loop: kept in registers, not stored for every object
      read(it.obj, b);
      if constexpr (decltype(margins)::value) b = grown(b, it.id);
      if (sameBox(it.box, b)) {  // unmoved: same kind, nothing to refit
        // But a rotation may keep the box.
        if constexpr (decltype(stale)::value)
          table_.refreshStaleVolume(it.id, *it.obj);
        else
          table_.refreshVolume(it.id, *it.obj);
        continue;
      }
      table_.moveVolume(it.id, *it.obj);
      const BoxKind kind = classify(b, config_.unbounded_limit);
      if (kind == home) {
        it.box = b;
        if (keep) moved_.push_back(it.id);
        if (home == BoxKind::finite && ++refits <= path_limit) tree_.refitPath(it.leaf);
      } else if (kind != BoxKind::invalid) {
        crossers.emplace_back(it.id, b);
      } else if (table_.seq(it.id) < bad_seq) {
        bad_seq = table_.seq(it.id);
        bad = it.obj;
      }
    }
  };
  const auto passes = [&](auto margins, auto stale) {
    pass(tree_.slots(), tree_.slotCount(), BoxKind::finite, margins, stale);
    pass(unbounded_.data(), std::uint32_t(unbounded_.size()), BoxKind::unbounded, margins, stale);
  };
  const bool stale = table_.anyStale();
  if (any_margin_ && stale)
    passes(std::true_type{}, std::true_type{});
  else if (any_margin_)
    passes(std::true_type{}, std::false_type{});
  else if (stale)
    passes(std::false_type{}, std::true_type{});
  else
    passes(std::false_type{}, std::false_type{});
  if (refits > path_limit) tree_.refitAll();
  for (const auto& [id, box] : crossers) {
    Object* const obj = table_.object(id);
    unplace(id);
    place(id, obj, box);
    if (keep) moved_.push_back(id);
  }
  afterMotion(keep, was_valid);
  return bad;
}

template <typename S>
template <class Read>
std::size_t Broadphase<S>::addMany(Object* const* objs, std::size_t n, Read&& read) {
  // Entries registered already, or earlier in the batch, are skipped by the table. The new ones
  // are sorted on the way: bounded ones into the array the build takes as its slots, unbounded
  // ones (rare: no allocation unless there are some) for their list.
  ItemArray<S> bounded;
  std::vector<Item<S>> loose;
  bounded.reserve(n);
  Box<S> box;
  std::size_t refused = n;
  const std::size_t added = table_.addBatch(objs, n, [&](std::size_t i, ObjectId id) {
    if (!read(i, box)) {
      refused = i;
      return false;
    }
    const Item<S> item{grown(box, id), objs[i], kNone, id};
    if (classify(item.box, config_.unbounded_limit) == BoxKind::unbounded)
      loose.push_back(item);
    else
      bounded.push_back(item);
    return true;
  });
  if (refused != n) return refused;  // the table undid the batch: nothing was placed
  if (added != 0) placeBatch(std::move(bounded), loose);
  return n;
}

template <typename S>
template <class Region>
void Broadphase<S>::search(Region& region, const Filter* bits) const {
  const std::uint32_t* seq = table_.seqs();
  const View<S> cubes = tree_.view();
  typename Region::State start{};
  // Objects without bits of their own all have the default: one answer for every object (a
  // region's gate reads the table's bits alone).
  if (bits != nullptr && table_.filters() != nullptr) {
    Exclusions room;  // read by no region: a region asks only the bits
    Against query;
    query.bits = *bits;
    const PairGate<S> gated = gate(&query, room);
    if (!unbounded_.empty())
      filteredLeaf(region, gated, unbounded_.items().data(), std::uint32_t(unbounded_.size()), seq);
    if (cubes.root == kNone) return;
    const Node& root = cubes.nodes[cubes.root];
    RegionGuide<S, Region, true> guide{cubes, seq, region, &gated};
    if (guide.groupPasses(cubes.root) == 0 || !region.enters(root.lo, root.hi, start)) return;
    walkTree(cubes.nodes, cubes.root, start, guide);
    return;
  }
  if (bits != nullptr && !filtersPass(Filter{}, *bits)) return;
  if (!unbounded_.empty()) region.leaf(unbounded_.items().data(), unbounded_.size(), seq);
  if (cubes.root == kNone) return;
  const Node& root = cubes.nodes[cubes.root];
  if (!region.enters(root.lo, root.hi, start)) return;
  RegionGuide<S, Region> guide{cubes, seq, region};
  walkTree(cubes.nodes, cubes.root, start, guide);
}

extern template class Broadphase<float>;
extern template class Broadphase<double>;

}  // namespace detail
}  // namespace cube
