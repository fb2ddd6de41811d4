// The query plan of the broadphase core: every collide and distance query, whatever its other
// side (none: a self query; an object; a body of objects of no table; another broadphase), goes
// through plan() and one runner. The plan decides once: the gate (gate()), the source of pairs
// (the pair list, or the views: the cubes, then the unbounded list), how each pair of views is
// walked (all pairs, one object down a tree, cube pairs, or a walk cut into tasks for threads),
// and the delivery (in walk order, or gathered and called in registration order).

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <new>
#include <vector>

#include "core/body_view.h"
#include "core/broadphase.h"
#include "core/parallel_for.h"

namespace cube {
namespace detail {

template <typename S>
PairGate<S> Broadphase<S>::gate(const Against* b, Exclusions& room) const {
  PairGate<S> g;
  g.filters_a = table_.filters();
  g.groups_a = table_.groupFilters();
  g.predicate = predicate_ ? &predicate_ : nullptr;
  room = Exclusions{{table_.exclusions(), nullptr, nullptr, kNone},
                    {nullptr, nullptr, nullptr, kNone}};
  ExcludedView& mine = room.mine;  // side b's ids seen in this table
  if (b == nullptr) {
    g.filters_b = g.filters_a;
    g.groups_b = g.groups_a;
    if (config_.canonical_pairs) g.seq = table_.seqs();
  } else if (b->other != nullptr) {
    g.filters_b = b->other->table_.filters();
    g.groups_b = b->other->table_.groupFilters();
    mine.b = b->here;  // otherSide() made it where mine.set is
    room.theirs.set = b->other->table_.exclusions();
    room.theirs.a = b->there;
  } else {
    g.filters_b = b->ids;
    g.query = b->bits;
    if (mine.set != nullptr) {
      if (b->obj != nullptr) {  // a registered query object brings its pairs
        mine.query = table_.find(b->obj);
        if (mine.query == kNone) mine.set = nullptr;
      } else if (b->here != nullptr) {
        mine.b = b->here;
      } else {
        mine.set = nullptr;  // a body of no table: no pair of it is excluded here
      }
    }
  }
  if (mine.set != nullptr || room.theirs.set != nullptr) g.excluded_ids = &room;
  return g;
}

template <typename S>
typename Broadphase<S>::Against Broadphase<S>::otherSide(const Broadphase& other,
                                                         std::vector<ObjectId> (&ids)[2]) const {
  Against b;
  b.other = &other;
  // Per id of `seen`, its object's id in `rules`; only objects in a pair `rules` excludes need
  // one, the rest stay kNone.
  const auto idsIn = [](const ObjectTable<S>& rules, const ObjectTable<S>& seen,
                        std::vector<ObjectId>& out) -> const ObjectId* {
    const ExcludedSet* set = rules.exclusions();
    if (set == nullptr) return nullptr;
    out.assign(seen.idBound(), kNone);
    for (ObjectId r = 0; r < set->n; ++r) {
      if (set->count[r] == 0) continue;
      const ObjectId s = seen.find(rules.object(r));
      if (s != kNone) out[s] = r;
    }
    return out.data();
  };
  b.here = idsIn(table_, other.table_, ids[0]);
  b.there = idsIn(other.table_, table_, ids[1]);
  return b;
}

template <typename S>
[[gnu::always_inline]] inline const PairGate<S>* Broadphase<S>::gateIn(const Against* b,
                                                                       GateRoom& room) const {
  // Most queries have no rule to test: the gate is built only where one may be set.
  const bool maybe = table_.pairRules() || predicate_ ||
                     (b == nullptr && config_.canonical_pairs) ||
                     (b != nullptr && (b->ids != nullptr || !b->bits.isDefault() ||
                                       (b->other != nullptr && b->other->table_.pairRules())));
  if (!maybe) return nullptr;
  const PairGate<S> g = gate(b, room.exclusions);
  return g.active() ? new (&room.gate) PairGate<S>(g) : nullptr;
}

// Inline into each entry, as are forViews and collideRun: a short object query spent a tenth of
// its instructions passing the plan and the views between them.
template <typename S>
[[gnu::always_inline]] inline typename Broadphase<S>::Plan Broadphase<S>::plan(
    const Against* b, int threads, GateRoom& room) const {
  Plan p;
  p.gate = gateIn(b, room);
  const bool body = b != nullptr && b->other == nullptr && b->obj == nullptr;
  // A body's pairs come in walk order whatever canonical_pairs says (its ids are its own).
  p.canonical = config_.canonical_pairs && !body;
  p.from_list = b == nullptr && pairs_.valid();
  p.split = b == nullptr && threads > 1 && !p.from_list && tree_.size() >= kSplitMin;
  p.threads = threads;
  if (p.split) {  // large work: the team is sized now, once for the query (thread_policy.h)
    p.threads = regionTeam(threads);
    p.split = p.threads > 1;
  }
  // An object query walks the tree whatever its size: its walk is already one box at a time.
  const bool object = b != nullptr && b->obj != nullptr;
  p.all_pairs_limit = object ? 0 : config_.all_pairs_limit;
  p.one_object = object && !p.gate;
  return p;
}

template <typename S>
template <class Run>
[[gnu::always_inline]] inline bool Broadphase<S>::forViews(const Against* b, Run&& run) const {
  const Scene<S> mine = scene();
  if (b == nullptr) return forSelfViews(mine, run);
  if (b->other == nullptr) return forObjectViews(mine, *b->view, run);
  return forObjectViews(mine, b->other->tree_.view(), run) ||
         forObjectViews(mine, b->other->unbounded_.view(), run);
}

template <typename S>
[[gnu::always_inline]] inline bool Broadphase<S>::collideRun(const Against* b, int threads,
                                                             void* data, CollideFn<S> fn,
                                                             QueryStats* stats) const {
  GateRoom room;  // filled only if a rule is set
  const Plan p = plan(b, threads, room);
  const PairGate<S>* g = p.walkGate();
  if (!p.canonical) {
    if (p.from_list)
      return g != nullptr ? pairs_.collide(*g, data, fn, stats) : pairs_.collide(data, fn, stats);
    if (p.split) return collideSplit(p, data, fn, nullptr);
    if (p.one_object)
      return forViews(b, [&](const View<S>& x, const View<S>&, bool) {
        return collideObject(x, *b->one, data, fn, stats);
      });
    return forViews(b, [&](const View<S>& x, const View<S>& y, bool self) {
      return collideViews(x, y, fn, data, self, p.all_pairs_limit, stats, g);
    });
  }
  std::vector<std::uint64_t> found;
  if (p.from_list) {
    pairs_.collect(*p.gate, found);  // canonical order is a rule: the gate is set
  } else if (p.split) {
    collideSplit(p, data, fn, &found);
  } else {
    forViews(b, [&](const View<S>& x, const View<S>& y, bool self) {
      collectPairs(x, y, self, p.all_pairs_limit, found, g);
      return false;
    });
  }
  return callInOrder(found, b, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::collideSplit(const Plan& p, void* data, CollideFn<S> fn,
                                 std::vector<std::uint64_t>* out, TaskSink<S>* sink) const {
  // The walks test the filter bits and orient the pairs; the predicate, user code, is asked here
  // on this thread, in walk order, as the serial walk asks it.
  const PairGate<S> walk_gate = p.gate ? p.gate->withoutPredicate() : PairGate<S>{};
  const PairGate<S>* g = walk_gate.active() ? &walk_gate : nullptr;
  const int threads = p.threads;
  return forViews(nullptr, [&](const View<S>& a, const View<S>& b, bool self) {
    const SplitWalk<S> walk(a, b, self, p.all_pairs_limit, g,
                            sink != nullptr ? kSinkTasks : kSplitTasks);
    const std::size_t n = walk.tasks();
    std::vector<std::vector<std::uint64_t>> found(n);
    if (sink != nullptr) sink->begin(n, threads);
    // A task's pairs to the sink, as objects, on the thread that walked it (each worker reuses
    // its list).
    std::vector<std::vector<typename TaskSink<S>::Pair>> handed(sink != nullptr ? threads : 0);
    const auto hand = [&](int worker, std::size_t i) {
      auto& pairs = handed[std::size_t(worker)];
      pairs.clear();
      for (const std::uint64_t pair : found[i]) {
        const auto x = static_cast<ObjectId>(pair >> 32), y = static_cast<ObjectId>(pair);
        pairs.push_back({table_.object(x), table_.object(y), x, y});
      }
      std::vector<std::uint64_t>().swap(found[i]);
      sink->take(worker, i, pairs.data(), pairs.size());
    };
    // Waves of tasks (threads, then twice as many, ...): a query that stops early walks little
    // more than the serial one. Gathering, or a sink (which skips what it need not answer),
    // takes every task at once.
    const bool at_once = out != nullptr || sink != nullptr;
    for (std::size_t begin = 0, wave = std::size_t(threads); begin < n; begin += wave, wave *= 2) {
      const std::size_t end = at_once ? n : std::min(n, begin + wave);
      // Chunks of one task: the tasks of a clustered scene differ by orders of magnitude. Each
      // thread's scratch is its worker number for the sink (0 to threads - 1).
      std::atomic<int> workers{0};
      parallelForWith(
          end - begin, threads, 1, [&] { return workers.fetch_add(1, std::memory_order_relaxed); },
          [&](int worker, std::size_t k) {
            walk.collect(begin + k, found[begin + k]);
            if (sink != nullptr) hand(worker, begin + k);
          });
      for (std::size_t i = begin; i < end; ++i) {
        if (sink != nullptr) {
          if (sink->drain(i)) return true;
          continue;
        }
        for (const std::uint64_t pair : found[i]) {
          const auto x = static_cast<ObjectId>(pair >> 32), y = static_cast<ObjectId>(pair);
          Object* const ox = table_.object(x);
          Object* const oy = table_.object(y);
          if (p.gate && !p.gate->predicatePasses(ox, oy)) continue;
          if (out != nullptr)
            out->push_back(pair);
          else if (fn(ox, x, oy, y, data))
            return true;
        }
        std::vector<std::uint64_t>().swap(found[i]);
      }
      if (at_once) break;  // every task in one round
    }
    return false;
  });
}

template <typename S>
bool Broadphase<S>::callInOrder(const std::vector<std::uint64_t>& found, const Against* b,
                                void* data, CollideFn<S> fn, QueryStats* stats) const {
  // Side a is always this table; side b this table (self), the other's, or the query object.
  const std::uint32_t* seq_a = table_.seqs();
  const std::uint32_t* seq_b = b == nullptr          ? seq_a
                               : b->other != nullptr ? b->other->table_.seqs()
                                                     : nullptr;
  const ObjectTable<S>& table_b = b != nullptr && b->other != nullptr ? b->other->table_ : table_;
  Object* const single = b != nullptr ? b->obj : nullptr;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> order;
  order.reserve(found.size());
  for (const std::uint64_t p : found) {
    const auto x = static_cast<ObjectId>(p >> 32), y = static_cast<ObjectId>(p);
    order.emplace_back(std::uint64_t(seq_a[x]) << 32 | (seq_b != nullptr ? seq_b[y] : 0u), p);
  }
  std::sort(order.begin(), order.end());
  for (const auto& entry : order) {
    if (stats) ++stats->callbacks;
    const auto x = static_cast<ObjectId>(entry.second >> 32);
    const auto y = static_cast<ObjectId>(entry.second);
    if (fn(table_.object(x), x, single != nullptr ? single : table_b.object(y), y, data))
      return true;
  }
  return false;
}

template <typename S>
bool Broadphase<S>::distanceRun(const Against* b, void* data, DistanceFn<S> fn, S& best,
                                QueryStats* stats) const {
  GateRoom room;
  const PairGate<S>* gp = gateIn(b, room);
  return forViews(b, [&](const View<S>& x, const View<S>& y, bool self) {
    return distancePairs(x, y, self, data, fn, best, stats, gp);
  });
}

template <typename S>
typename Broadphase<S>::Against Broadphase<S>::objectSide(const SingleView<S>& one,
                                                          const View<S>& view, const Filter& bits) {
  Against b;
  b.view = &view;
  b.one = &one;
  b.obj = one.item.obj;
  b.bits = bits;
  return b;
}

// ---------------------------------------------------------------------------------------------
// The entries: each names its other side and runs the plan.

template <typename S>
bool Broadphase<S>::collide(Object* obj, const Box<S>& box, void* data, CollideFn<S> fn,
                            QueryStats* stats) const {
  const SingleView<S> one(obj, queryBox(obj, box));
  // A registered query object pairs by its own bits.
  const View<S> view = one.view();
  const Against b = objectSide(one, view, table_.filters() != nullptr ? filter(obj) : Filter{});
  return collideRun(&b, 1, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::collide(const Probe& probe, void* data, CollideFn<S> fn,
                            QueryStats* stats) const {
  const SingleView<S> one(probe.obj, grownBy(probe.box, probe.margin));
  const View<S> view = one.view();
  const Against b = objectSide(one, view, probe.bits);
  return collideRun(&b, 1, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::collide(const View<S>& body, const Filter* bits, void* data, CollideFn<S> fn,
                            QueryStats* stats, const ObjectId* table_ids) const {
  Against b;
  b.view = &body;
  b.ids = bits;
  b.here = table_ids;
  return collideRun(&b, 1, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::collideSelf(void* data, CollideFn<S> fn, QueryStats* stats) const {
  return collideRun(nullptr, 1, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::collideSelfSplit(void* data, CollideFn<S> fn, int threads) const {
  return collideRun(nullptr, threads, data, fn, nullptr);
}

template <typename S>
bool Broadphase<S>::collideSelfTasks(TaskSink<S>& sink, int threads) const {
  GateRoom room;
  const Plan p = plan(nullptr, threads, room);
  if (!p.split || p.canonical || (p.gate && p.gate->predicate != nullptr)) return false;
  collideSplit(p, nullptr, CollideFn<S>(typename CollideFn<S>::Plain(nullptr)), nullptr, &sink);
  return true;
}

template <typename S>
bool Broadphase<S>::collide(const Broadphase& other, void* data, CollideFn<S> fn,
                            QueryStats* stats) const {
  std::vector<ObjectId> ids[2];
  const Against b = otherSide(other, ids);
  return collideRun(&b, 1, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::distance(Object* obj, const Box<S>& box, void* data, DistanceFn<S> fn, S& best,
                             QueryStats* stats) const {
  const SingleView<S> one(obj, queryBox(obj, box));
  const View<S> view = one.view();
  const Against b = objectSide(one, view, table_.filters() != nullptr ? filter(obj) : Filter{});
  return distanceRun(&b, data, fn, best, stats);
}

template <typename S>
bool Broadphase<S>::distance(const Probe& probe, void* data, DistanceFn<S> fn, S& best,
                             QueryStats* stats) const {
  const SingleView<S> one(probe.obj, grownBy(probe.box, probe.margin));
  const View<S> view = one.view();
  const Against b = objectSide(one, view, probe.bits);
  return distanceRun(&b, data, fn, best, stats);
}

template <typename S>
bool Broadphase<S>::distanceSelf(void* data, DistanceFn<S> fn, S& best, QueryStats* stats) const {
  return distanceRun(nullptr, data, fn, best, stats);
}

template <typename S>
bool Broadphase<S>::distance(const Broadphase& other, void* data, DistanceFn<S> fn, S& best,
                             QueryStats* stats) const {
  std::vector<ObjectId> ids[2];
  const Against b = otherSide(other, ids);
  return distanceRun(&b, data, fn, best, stats);
}

template <typename S>
bool Broadphase<S>::pairPasses(Object* a, Object* b, const Broadphase* other, bool as_query) const {
  const ObjectId x = table_.find(a);
  if (x == kNone || a == b) return false;
  const auto passed = [](const auto&, const auto&) { return true; };
  const auto self_id = [](ObjectId i) { return i; };
  Exclusions room;
  if (other != nullptr) {
    const ObjectId y = other->table_.find(b);
    if (y == kNone) return false;
    // The gate of the query against `other`, its exclusions read through one-entry id maps
    // (each side of the pair at position 0, as collideMoving re-indexes its movers) rather than
    // otherSide()'s maps over every id. The bits read the tables' own ids; a gate against
    // another broadphase orients nothing, so finish() reads ids for the exclusions only.
    const ObjectId a_here[1] = {x}, b_there[1] = {y};
    const ObjectId b_here[1] = {table_.find(b)}, a_there[1] = {other->table_.find(a)};
    Against side;
    side.other = other;
    side.here = b_here;
    side.there = a_there;
    const PairGate<S> g = gate(&side, room);
    room.mine.a = a_here;
    room.theirs.b = b_there;
    struct At {
      ObjectId position;
      Object* obj;
    };
    return g.bitsPass(x, y) && g.finish(
                                   At{0, a}, At{0, b}, [](const At& t) { return t.position; },
                                   [](const At& t) { return t.obj; }, passed);
  }
  const ObjectId y = as_query ? kNone : table_.find(b);
  const auto obj = [&](ObjectId i) { return i == kNone ? b : table_.object(i); };
  if (y != kNone) {  // a self query's pair
    const PairGate<S> g = gate(nullptr, room);
    return g.bitsPass(x, y) && g.finish(x, y, self_id, obj, passed);
  }
  Against side;  // an object query's: b of no id, its bits and exclusions found by pointer
  side.obj = b;
  side.bits = filter(b);
  const PairGate<S> g = gate(&side, room);
  return g.bitsPass(x, kNone) && g.finish(x, kNone, self_id, obj, passed);
}

namespace {

// A 30-bit Morton code of a point within [lo, hi] (10 bits a coordinate); non-finite: 0.
inline std::uint32_t morton(const double* p, const double* lo, const double* span) {
  std::uint32_t code = 0;
  for (int k = 0; k < 3; ++k) {
    const double t = span[k] > 0 ? (p[k] - lo[k]) / span[k] : 0.0;
    const std::uint32_t q = t >= 0 && t <= 1 ? std::uint32_t(t * 1023.0) : 0u;
    for (int bit = 0; bit < 10; ++bit) code |= ((q >> bit) & 1u) << (3 * bit + k);
  }
  return code;
}

// What collideMoving's walks hand its callbacks: body positions back to table ids.
template <typename S>
struct Movers {
  const std::vector<ObjectId>* id_of;  // by body position
  const std::vector<char>* moving;     // by table id
  void* data;
  CollideFn<S> fn;
  static bool withMover(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b,
                        ObjectId ib, void* d) {
    const Movers& m = *static_cast<Movers*>(d);
    return m.fn(a, (*m.id_of)[ia], b, (*m.id_of)[ib], m.data);
  }
  static bool withStill(fcl::CollisionObject<S>* a, ObjectId ia, fcl::CollisionObject<S>* b,
                        ObjectId ib, void* d) {
    const Movers& m = *static_cast<Movers*>(d);
    if ((*m.moving)[ia]) return false;  // two movers: met at their swept boxes already
    return m.fn(a, ia, b, (*m.id_of)[ib], m.data);
  }
};

}  // namespace

template <typename S>
bool Broadphase<S>::collideMoving(const ObjectId* ids, const Box<S>* boxes, std::size_t n,
                                  void* data, CollideFn<S> fn) const {
  if (n == 0) return false;
  // The movers as a body whose consecutive positions lie near one another (Morton order of
  // their boxes' centres), so that its tree of consecutive runs is a sound one.
  std::vector<Box<S>> grown_boxes(n);
  constexpr double inf = std::numeric_limits<double>::infinity();
  double lo[3] = {inf, inf, inf}, hi[3] = {-inf, -inf, -inf};
  std::vector<std::array<double, 3>> centre(n);
  for (std::size_t i = 0; i < n; ++i) {
    grown_boxes[i] = grown(boxes[i], ids[i]);
    for (int k = 0; k < 3; ++k) {
      centre[i][k] = 0.5 * (double(grown_boxes[i].lo[k]) + double(grown_boxes[i].hi[k]));
      if (std::isfinite(centre[i][k])) {
        lo[k] = std::min(lo[k], centre[i][k]);
        hi[k] = std::max(hi[k], centre[i][k]);
      }
    }
  }
  double span[3];
  for (int k = 0; k < 3; ++k) span[k] = hi[k] > lo[k] ? hi[k] - lo[k] : 0.0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> order(n);
  for (std::size_t i = 0; i < n; ++i)
    order[i] = {morton(centre[i].data(), lo, span), std::uint32_t(i)};
  std::sort(order.begin(), order.end());

  BodyView<S> body(std::uint32_t(n), kBodyLeaf);
  std::vector<ObjectId> id_of(n);
  std::vector<Filter> bits;
  std::vector<std::uint32_t> seq(n);
  if (table_.filters() != nullptr) bits.resize(n);
  std::vector<char> moving(table_.idBound(), 0);
  for (std::uint32_t p = 0; p < n; ++p) {
    const std::uint32_t i = order[p].second;
    id_of[p] = ids[i];
    moving[ids[i]] = 1;
    body.setObject(p, table_.object(ids[i]));
    body.box(p) = grown_boxes[i];
    seq[p] = table_.seq(ids[i]);
    if (!bits.empty()) bits[p] = table_.filter(ids[i]);
  }
  body.refit();
  Movers<S> movers{&id_of, &moving, data, fn};
  // Movers with movers: this table's gate, its per-id columns read per body position, its
  // other rules by id through id_of.
  Exclusions room;
  PairGate<S> g = gate(nullptr, room);
  g.filters_a = g.filters_b = bits.empty() ? nullptr : bits.data();
  g.groups_a = g.groups_b = nullptr;
  if (g.seq != nullptr) g.seq = seq.data();
  room.mine.a = room.mine.b = id_of.data();
  const View<S> v = body.view();
  if (collideViews(v, v, CollideFn<S>(&Movers<S>::withMover), &movers, true, 0, nullptr,
                   g.active() ? &g : nullptr))
    return true;
  // Movers with the objects that stay: the body query, the world's side first.
  return collide(v, bits.empty() ? nullptr : bits.data(), &movers,
                 CollideFn<S>(&Movers<S>::withStill), nullptr, id_of.data());
}

template class Broadphase<float>;
template class Broadphase<double>;

}  // namespace detail
}  // namespace cube
