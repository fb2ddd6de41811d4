// The broadphase core: registrations, motions and queries over the object table, the cube tree
// and the unbounded list, with the rebuild policy asked between operations.

#include "core/broadphase.h"

#include <algorithm>
#include <cassert>
#include <exception>
#include <sstream>
#include <stdexcept>

namespace cube {

void Config::check() const {
  if (max_depth < 0) throw std::invalid_argument("cube::Config: max_depth must be >= 0");
  if (leaf_size < 1) throw std::invalid_argument("cube::Config: leaf_size must be >= 1");
  if (!(rebuild_threshold > 1.0))
    throw std::invalid_argument("cube::Config: rebuild_threshold must be > 1");
  if (!(unbounded_limit > 0.0))
    throw std::invalid_argument("cube::Config: unbounded_limit must be > 0");
  if (all_pairs_limit > kMaxAllPairsLimit)
    throw std::invalid_argument("cube::Config: all_pairs_limit must be <= 64");
  if (filter_groups < 0 || filter_groups > 64)
    throw std::invalid_argument("cube::Config: filter_groups must be in [0, 64]");
}

namespace detail {

namespace {

// Collide of two views; small ones (allPairsFit) take the all-pairs kernel.
template <typename S>
bool collideViews(std::size_t all_pairs_limit, const View<S>& a, const View<S>& b, bool self,
                  void* data, CollideFn<S> fn, QueryStats* stats,
                  const PairGate<S>* gate = nullptr) {
  if (allPairsFit(a, b, self, all_pairs_limit))
    return collideAllPairs(a, b, self, data, fn, stats, PairKernel::best, gate);
  return collidePairs(a, b, self, data, fn, stats, gate);
}

// Config::canonical_pairs: the callbacks for `pairs` (id of side a << 32 | id of side b) in the
// order of (key_a(id a), key_b(id b)), each a registration number (so the order is the tree's
// business no more); obj_a and obj_b give the objects. Stops when fn returns true.
template <typename S, class KeyA, class KeyB, class ObjA, class ObjB>
bool callInOrder(const std::vector<std::uint64_t>& pairs, KeyA&& key_a, KeyB&& key_b, ObjA&& obj_a,
                 ObjB&& obj_b, void* data, CollideFn<S> fn, QueryStats* stats) {
  std::vector<std::pair<std::uint64_t, std::uint64_t>> order;
  order.reserve(pairs.size());
  for (const std::uint64_t p : pairs) {
    const auto a = static_cast<ObjectId>(p >> 32), b = static_cast<ObjectId>(p);
    order.emplace_back(std::uint64_t(key_a(a)) << 32 | key_b(b), p);
  }
  std::sort(order.begin(), order.end());
  for (const auto& entry : order) {
    if (stats) ++stats->callbacks;
    const auto a = static_cast<ObjectId>(entry.second >> 32);
    const auto b = static_cast<ObjectId>(entry.second);
    if (fn(obj_a(a), a, obj_b(b), b, data)) return true;
  }
  return false;
}

}  // namespace

template <typename S>
Broadphase<S>::Broadphase(const Config& config)
    : config_((config.check(), config)), tree_(config_), policy_(config_) {
  for (int k = 0; k < 3; ++k) {
    unbounded_node_.lo[k] = -std::numeric_limits<float>::infinity();
    unbounded_node_.hi[k] = std::numeric_limits<float>::infinity();
  }
  unbounded_node_.first = 0;
  unbounded_node_.count = 0;
  table_.keepVolumes(config_.tight_volumes);
}

// ---------------------------------------------------------------------------------------------
// Placement

template <typename S>
void Broadphase<S>::place(ObjectId id, Object* obj, const Box<S>& box) {
  assert(classify(box, config_.unbounded_limit) != BoxKind::invalid);
  const Item<S> item{box, obj, kNone, id};
  if (classify(box, config_.unbounded_limit) == BoxKind::unbounded) {
    table_.setLocation(id, std::uint32_t(unbounded_.size()) | kUnboundedBit);
    unbounded_.push_back(item);
    unbounded_node_.count = std::uint32_t(unbounded_.size());
  } else {
    tree_.insert(item, ids());
  }
}

template <typename S>
void Broadphase<S>::unplace(ObjectId id) {
  const std::uint32_t loc = table_.location(id);
  if (!(loc & kUnboundedBit)) {
    tree_.remove(loc, ids());
    return;
  }
  const std::uint32_t pos = loc & ~kUnboundedBit;
  if (pos + 1 != unbounded_.size()) {
    unbounded_[pos] = unbounded_.back();
    table_.setLocation(unbounded_[pos].id, pos | kUnboundedBit);
  }
  unbounded_.pop_back();
  unbounded_node_.count = std::uint32_t(unbounded_.size());
  table_.setLocation(id, kNone);
}

template <typename S>
void Broadphase<S>::rebuild(const std::vector<Item<S>>& extra) {
  tree_.rebuild(ids(), extra);
}

template <typename S>
void Broadphase<S>::maintain() {
  if (policy_.dueAfterChange(tree_))
    rebuild();
  else if (tree_.sparse())
    tree_.compactIfSparse(ids());
}

// ---------------------------------------------------------------------------------------------
// Mutations

template <typename S>
void Broadphase<S>::add(Object* obj, const Box<S>& box) {
  assert(!contains(obj));
  pairs_.invalidate();
  const ObjectId id = table_.add(obj);
  place(id, obj, grown(box, id));
  maintain();
}

template <typename S>
void Broadphase<S>::addMany(Object* const* objs, const Box<S>* boxes, std::size_t n) {
  // Entries registered already, or earlier in the batch, are skipped by the table. The new ones
  // are sorted on the way: bounded ones for the build, unbounded ones (rare: no allocation
  // unless there are some) for their list.
  std::vector<Item<S>> bounded, loose;
  bounded.reserve(n);
  const std::size_t added = table_.addBatch(objs, n, [&](std::size_t i, ObjectId id) {
    const Item<S> item{grown(boxes[i], id), objs[i], kNone, id};
    if (classify(item.box, config_.unbounded_limit) == BoxKind::unbounded)
      loose.push_back(item);
    else
      bounded.push_back(item);
  });
  if (added == 0) return;
  pairs_.invalidate();
  if (added < size() - added) {
    // A small batch into a large manager: insertions beat a build.
    for (const std::vector<Item<S>>* items : {&bounded, &loose})
      for (const Item<S>& it : *items) {
        place(it.id, it.obj, it.box);
        maintain();
      }
    return;
  }
  // One build over everything.
  for (const Item<S>& it : loose) {
    table_.setLocation(it.id, std::uint32_t(unbounded_.size()) | kUnboundedBit);
    unbounded_.push_back(it);
  }
  unbounded_node_.count = std::uint32_t(unbounded_.size());
  rebuild(bounded);
}

template <typename S>
bool Broadphase<S>::remove(const Object* obj) {
  const ObjectId id = table_.find(obj);
  if (id == kNone) return false;
  pairs_.invalidate();
  unplace(id);
  table_.remove(id);
  maintain();
  return true;
}

template <typename S>
bool Broadphase<S>::move(const Object* obj, const Box<S>& box) {
  const ObjectId id = table_.find(obj);
  if (id == kNone) return false;
  const std::uint32_t loc = table_.location(id);
  const bool was_unbounded = (loc & kUnboundedBit) != 0;
  const bool is_unbounded = classify(box, config_.unbounded_limit) == BoxKind::unbounded;
  if (was_unbounded && is_unbounded) {
    unbounded_[loc & ~kUnboundedBit].box = box;
  } else if (!was_unbounded && !is_unbounded) {
    Item<S>& it = tree_.slots()[loc];
    it.box = box;
    tree_.refitPath(it.leaf);
  } else {
    // Crossing between the cubes and the unbounded list: out and in again, same id.
    Object* const o = table_.object(id);
    unplace(id);
    place(id, o, box);
  }
  return true;
}

template <typename S>
void Broadphase<S>::updateSome(Object* const* objs, const Box<S>* boxes, std::size_t n,
                               bool keep_list) {
  const bool keep = keep_list && config_.keep_pairs;
  const bool was_valid = keep && pairs_.valid();
  pairs_.invalidate();
  moved_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const ObjectId id = table_.find(objs[i]);
    if (id == kNone) continue;
    table_.rebuildVolume(id);  // named: rebuilt whatever changed (a geometry in place, too)
    move(objs[i], grown(boxes[i], id));
    if (keep) moved_.push_back(id);
  }
  if (keep) {
    // Each id once: a refresh queries every entry.
    std::sort(moved_.begin(), moved_.end());
    moved_.erase(std::unique(moved_.begin(), moved_.end()), moved_.end());
  }
  afterMotion(keep, was_valid);
}

template <typename S>
void Broadphase<S>::afterMotion(bool keep, bool was_valid) {
  if (regroupDue() || policy_.dueAfterUpdate(tree_))
    rebuild();
  else if (tree_.sparse())
    tree_.compactIfSparse(ids());
  if (!keep) return;
  // Past a quarter of the objects moved, keeping the list would cost more than it saves: a
  // listing is a walk itself, and a query per moved object costs what the walk spends on 25 to
  // 50 objects. Scenes that move everything every step thus self-collide by walking.
  if (moved_.size() * 4 > size()) return;  // the list stays invalid
  if (was_valid)
    pairs_.refresh(scene(), moved_, table_.idBound());
  else
    pairs_.list(scene());
}

template <typename S>
void Broadphase<S>::setup() {
  if (regroupDue() || policy_.dueAtSetup(tree_, !setup_done_)) rebuild();
  // A removal swaps the list's last object into the gap: put the list in registration order, so
  // that the first setup() makes the callback order a function of the live registrations alone.
  if (!setup_done_) orderUnbounded();
  setup_done_ = true;
}

template <typename S>
void Broadphase<S>::orderUnbounded() {
  std::sort(unbounded_.begin(), unbounded_.end(), [&](const Item<S>& a, const Item<S>& b) {
    return table_.seq(a.id) < table_.seq(b.id);
  });
  for (std::size_t p = 0; p < unbounded_.size(); ++p)
    table_.setLocation(unbounded_[p].id, std::uint32_t(p) | kUnboundedBit);
}

template <typename S>
void Broadphase<S>::clear() {
  table_.clear();
  tree_.clear();
  unbounded_ = {};
  unbounded_node_.count = 0;
  pairs_.release();
  moved_ = {};
  setup_done_ = false;
}

// ---------------------------------------------------------------------------------------------
// Per-object properties

template <typename S>
bool Broadphase<S>::setFilter(const Object* obj, const Filter& f) {
  const ObjectId id = table_.find(obj);
  if (id == kNone) return false;
  // Read by every query; the pair list holds boxes only, untouched. The cubes' groups are no
  // longer true: forgotten now (O(1)), laid out again by the next update() or setup(), not
  // here, so that a loop setting many objects' bits rebuilds once.
  if (table_.setFilter(id, f)) tree_.forgetGroups();  // then regroupDue()
  return true;
}

template <typename S>
Filter Broadphase<S>::filter(const Object* obj) const {
  const ObjectId id = table_.find(obj);
  return id == kNone ? Filter{} : table_.filter(id);
}

template <typename S>
bool Broadphase<S>::setMargin(const Object* obj, const Box<S>& box, S margin) {
  const ObjectId id = table_.find(obj);
  if (id == kNone) return false;
  table_.setOwnMargin(id, margin);
  any_margin_ = true;
  Object* o = table_.object(id);
  updateSome(&o, &box, 1, true);
  return true;
}

template <typename S>
S Broadphase<S>::margin(const Object* obj) const {
  const ObjectId id = table_.find(obj);
  const S own = id == kNone ? S(-1) : table_.ownMargin(id);
  return own < S(0) ? default_margin_ : own;
}

template <typename S>
PairGate<S> Broadphase<S>::selfGate() const {
  PairGate<S> g;
  g.filters_a = g.filters_b = table_.filters();
  g.groups_a = g.groups_b = table_.groupFilters();
  g.keep = keep_ ? &keep_ : nullptr;
  if (config_.canonical_pairs) g.seq = table_.seqs();
  return g;
}

template <typename S>
PairGate<S> Broadphase<S>::crossGate(const Broadphase* other, const Object* obj) const {
  PairGate<S> g;
  g.filters_a = table_.filters();
  g.groups_a = table_.groupFilters();
  if (other != nullptr) {
    g.filters_b = other->table_.filters();
    g.groups_b = other->table_.groupFilters();
  } else if (g.filters_a != nullptr) {
    g.query = filter(obj);
  }
  g.keep = keep_ ? &keep_ : nullptr;
  return g;
}

// ---------------------------------------------------------------------------------------------
// Queries

// Each query has a plain path (no filter bits, predicate or canonical order: the walk reports
// every pair of overlapping boxes) and a gated one. Canonical order gathers the pairs first and
// calls back in the order of registration numbers.

template <typename S>
PairGate<S> Broadphase<S>::probeGate(const Filter& bits) const {
  PairGate<S> g;
  g.filters_a = table_.filters();
  g.groups_a = table_.groupFilters();
  g.query = bits;
  g.keep = keep_ ? &keep_ : nullptr;
  return g;
}

template <typename S>
bool Broadphase<S>::collide(Object* obj, const Box<S>& box, void* data, CollideFn<S> fn,
                            QueryStats* stats) const {
  if (!gated()) return collideQuery(obj, queryBox(obj, box), nullptr, data, fn, stats);
  const PairGate<S> gate = crossGate(nullptr, obj);
  return collideQuery(obj, queryBox(obj, box), &gate, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::collide(const Probe& probe, void* data, CollideFn<S> fn,
                            QueryStats* stats) const {
  const Box<S> box = grownBy(probe.box, probe.margin);
  if (!gated() && probe.bits.isDefault())
    return collideQuery(probe.obj, box, nullptr, data, fn, stats);
  const PairGate<S> gate = probeGate(probe.bits);
  return collideQuery(probe.obj, box, &gate, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::collide(const View<S>& body, const Filter* bits, void* data, CollideFn<S> fn,
                            QueryStats* stats) const {
  const bool gate_on = gated() || bits != nullptr;
  PairGate<S> gate = gate_on ? probeGate(Filter{}) : PairGate<S>{};
  gate.filters_b = bits;
  const PairGate<S>* g = gate_on ? &gate : nullptr;
  return forObjectViews(scene(), body, [&](const View<S>& x, const View<S>& y, bool) {
    return collideViews(config_.all_pairs_limit, x, y, false, data, fn, stats, g);
  });
}

template <typename S>
bool Broadphase<S>::collideQuery(Object* obj, const Box<S>& box, const PairGate<S>* gate,
                                 void* data, CollideFn<S> fn, QueryStats* stats) const {
  const SingleView<S> query(obj, box);
  // forObjectViews' order by hand: building the Scene costs a measurable share of a short query.
  if (gate == nullptr)
    return collideObject(tree_.view(), query, data, fn, stats) ||
           (!unbounded_.empty() && collideObject(unboundedView(), query, data, fn, stats));
  if (!config_.canonical_pairs)
    return forObjectViews(scene(), query.view(), [&](const View<S>& a, const View<S>& b, bool) {
      return collidePairs(a, b, false, data, fn, stats, gate);
    });
  std::vector<std::uint64_t> found;
  forObjectViews(scene(), query.view(), [&](const View<S>& a, const View<S>& b, bool) {
    collectPairs(a, b, false, 0, found, gate);
    return false;
  });
  const std::uint32_t* seq = table_.seqs();
  return callInOrder(
      found, [&](ObjectId a) { return seq[a]; }, [](ObjectId) { return 0u; },
      [&](ObjectId a) { return table_.object(a); }, [&](ObjectId) { return obj; }, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::collideSelf(void* data, CollideFn<S> fn, QueryStats* stats) const {
  if (!gated()) {
    if (pairs_.valid()) return pairs_.collide(table_, data, fn, stats);
    return forSelfViews(scene(), [&](const View<S>& a, const View<S>& b, bool self) {
      return collideViews(config_.all_pairs_limit, a, b, self, data, fn, stats);
    });
  }
  const PairGate<S> gate = selfGate();
  if (!config_.canonical_pairs) {
    if (pairs_.valid()) return pairs_.collide(table_, gate, data, fn, stats);
    return forSelfViews(scene(), [&](const View<S>& a, const View<S>& b, bool self) {
      return collideViews(config_.all_pairs_limit, a, b, self, data, fn, stats, &gate);
    });
  }
  std::vector<std::uint64_t> found;
  if (pairs_.valid()) {
    pairs_.collect(table_, gate, found);
  } else {
    forSelfViews(scene(), [&](const View<S>& a, const View<S>& b, bool self) {
      collectPairs(a, b, self, config_.all_pairs_limit, found, &gate);
      return false;
    });
  }
  const std::uint32_t* seq = table_.seqs();
  const auto key = [&](ObjectId id) { return seq[id]; };
  const auto object = [&](ObjectId id) { return table_.object(id); };
  return callInOrder(found, key, key, object, object, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::collideSelfSplit(void* data, CollideFn<S> fn, int threads) const {
  if (threads <= 1 || pairs_.valid() || tree_.size() < kSplitMin)
    return collideSelf(data, fn, nullptr);
  // The walks test the filter bits and orient the pairs; the predicate, user code, is asked here
  // on this thread, in walk order, as the serial walk asks it.
  PairGate<S> walk_gate = selfGate();
  walk_gate.keep = nullptr;
  const PairGate<S>* gate = gated() ? &walk_gate : nullptr;
  const auto kept = [&](ObjectId a, ObjectId b) {
    return !keep_ || keep_(table_.object(a), table_.object(b));
  };
  std::vector<std::uint64_t> in_order;  // canonical order: every pair, sorted after
  const bool canonical = config_.canonical_pairs;
  const bool stopped = forSelfViews(scene(), [&](const View<S>& a, const View<S>& b, bool self) {
    const SplitWalk<S> walk(a, b, self, config_.all_pairs_limit, gate, kSplitTasks);
    const std::size_t n = walk.tasks();
    std::vector<std::vector<std::uint64_t>> found(n);
    std::exception_ptr error;
    for (std::size_t begin = 0, wave = std::size_t(threads); begin < n; begin += wave, wave *= 2) {
      const std::size_t end = canonical ? n : std::min(n, begin + wave);
      // Dynamic: the tasks of a clustered scene differ by orders of magnitude.
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
      for (std::ptrdiff_t i = std::ptrdiff_t(begin); i < std::ptrdiff_t(end); ++i) {
        try {
          walk.collect(std::size_t(i), found[std::size_t(i)]);
        } catch (...) {  // std::bad_alloc: no exception may leave an OpenMP region
#pragma omp critical(cube_split_walk_error)
          if (!error) error = std::current_exception();
        }
      }
      if (error) std::rethrow_exception(error);
      for (std::size_t i = begin; i < end; ++i) {
        for (const std::uint64_t p : found[i]) {
          const auto x = static_cast<ObjectId>(p >> 32), y = static_cast<ObjectId>(p);
          if (!kept(x, y)) continue;
          if (canonical)
            in_order.push_back(p);
          else if (fn(table_.object(x), x, table_.object(y), y, data))
            return true;
        }
        std::vector<std::uint64_t>().swap(found[i]);
      }
      if (canonical) break;
    }
    return false;
  });
  if (stopped || !canonical) return stopped;
  const std::uint32_t* seq = table_.seqs();
  const auto key = [&](ObjectId id) { return seq[id]; };
  const auto object = [&](ObjectId id) { return table_.object(id); };
  return callInOrder(in_order, key, key, object, object, data, fn, nullptr);
}

template <typename S>
bool Broadphase<S>::collide(const Broadphase& other, void* data, CollideFn<S> fn,
                            QueryStats* stats) const {
  const Scene<S> mine = scene();
  const bool gate_on = gated() || other.table_.filters() != nullptr;
  const PairGate<S> gate = gate_on ? crossGate(&other, nullptr) : PairGate<S>{};
  const PairGate<S>* g = gate_on ? &gate : nullptr;
  std::vector<std::uint64_t> found;
  for (const View<S>& b : {other.tree_.view(), other.unboundedView()})
    if (forObjectViews(mine, b, [&](const View<S>& x, const View<S>& y, bool) {
          if (config_.canonical_pairs) {
            collectPairs(x, y, false, config_.all_pairs_limit, found, g);
            return false;
          }
          return collideViews(config_.all_pairs_limit, x, y, false, data, fn, stats, g);
        }))
      return true;
  if (!config_.canonical_pairs) return false;
  const std::uint32_t* mine_seq = table_.seqs();
  const std::uint32_t* other_seq = other.table_.seqs();
  return callInOrder(
      found, [&](ObjectId a) { return mine_seq[a]; }, [&](ObjectId b) { return other_seq[b]; },
      [&](ObjectId a) { return table_.object(a); },
      [&](ObjectId b) { return other.table_.object(b); }, data, fn, stats);
}

template <typename S>
bool Broadphase<S>::distance(Object* obj, const Box<S>& box, void* data, DistanceFn<S> fn, S& best,
                             QueryStats* stats) const {
  const PairGate<S> gate = crossGate(nullptr, obj);
  return distanceQuery(obj, queryBox(obj, box), gated() ? &gate : nullptr, data, fn, best, stats);
}

template <typename S>
bool Broadphase<S>::distance(const Probe& probe, void* data, DistanceFn<S> fn, S& best,
                             QueryStats* stats) const {
  const PairGate<S> gate = probeGate(probe.bits);
  const bool gate_on = gated() || !probe.bits.isDefault();
  return distanceQuery(probe.obj, grownBy(probe.box, probe.margin), gate_on ? &gate : nullptr, data,
                       fn, best, stats);
}

template <typename S>
bool Broadphase<S>::distanceQuery(Object* obj, const Box<S>& box, const PairGate<S>* gate,
                                  void* data, DistanceFn<S> fn, S& best, QueryStats* stats) const {
  const SingleView<S> query(obj, box);
  return forObjectViews(scene(), query.view(), [&](const View<S>& a, const View<S>& b, bool) {
    return distancePairs(a, b, false, data, fn, best, stats, gate);
  });
}

template <typename S>
bool Broadphase<S>::distanceSelf(void* data, DistanceFn<S> fn, S& best, QueryStats* stats) const {
  const PairGate<S> gate = selfGate();
  const PairGate<S>* g = gated() ? &gate : nullptr;
  return forSelfViews(scene(), [&](const View<S>& a, const View<S>& b, bool self) {
    return distancePairs(a, b, self, data, fn, best, stats, g);
  });
}

template <typename S>
bool Broadphase<S>::distance(const Broadphase& other, void* data, DistanceFn<S> fn, S& best,
                             QueryStats* stats) const {
  const Scene<S> mine = scene();
  const PairGate<S> gate = crossGate(&other, nullptr);
  const PairGate<S>* g = gated() || other.table_.filters() != nullptr ? &gate : nullptr;
  for (const View<S>& b : {other.tree_.view(), other.unboundedView()})
    if (forObjectViews(mine, b, [&](const View<S>& x, const View<S>& y, bool) {
          return distancePairs(x, y, false, data, fn, best, stats, g);
        }))
      return true;
  return false;
}

// ---------------------------------------------------------------------------------------------
// Inspection

template <typename S>
std::size_t Broadphase<S>::bytes() const {
  return table_.bytes() + tree_.bytes() + unbounded_.capacity() * sizeof(Item<S>) + pairs_.bytes() +
         moved_.capacity() * sizeof(ObjectId);
}

template <typename S>
bool Broadphase<S>::validate(std::string* why) const {
  if (!table_.validate(why) || !tree_.validate(table_.locations(), table_.groups(), why))
    return false;
  std::ostringstream msg;
  auto fail = [&]() {
    if (why) *why = msg.str();
    return false;
  };
  for (const Item<S>& it : tree_.items()) {
    if (it.obj == nullptr) continue;
    if (it.id >= table_.idBound() || table_.object(it.id) != it.obj)
      return msg << "a slot of the cubes names the wrong id", fail();
    if (classify(it.box, config_.unbounded_limit) != BoxKind::finite)
      return msg << "an unbounded object sits in the cubes", fail();
  }
  if (unbounded_node_.count != unbounded_.size()) return msg << "unbounded count wrong", fail();
  for (std::size_t p = 0; p < unbounded_.size(); ++p) {
    const Item<S>& it = unbounded_[p];
    if (it.id >= table_.idBound() || table_.object(it.id) != it.obj)
      return msg << "an entry of the unbounded list names the wrong id", fail();
    if (classify(it.box, config_.unbounded_limit) != BoxKind::unbounded)
      return msg << "bounded object in the unbounded list", fail();
    if (table_.location(it.id) != (std::uint32_t(p) | kUnboundedBit))
      return msg << "location wrong for unbounded object " << p, fail();
  }
  if (tree_.size() + unbounded_.size() != table_.size())
    return msg << "the cubes and the list hold " << tree_.size() + unbounded_.size()
               << " objects, the table " << table_.size(),
           fail();
  return pairs_.validate(scene(), why);
}

template class Broadphase<float>;
template class Broadphase<double>;

}  // namespace detail
}  // namespace cube
