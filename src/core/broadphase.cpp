// The broadphase core: registrations, motions and queries over the object table, the cube tree
// and the unbounded list, with the rebuild policy asked between operations.

#include "core/broadphase.h"

#include <algorithm>
#include <cassert>
#include <exception>
#include <sstream>
#include <stdexcept>

namespace cube {

namespace detail {

template <typename S>
Broadphase<S>::Broadphase(const Config& config)
    : config_((config.check(), config)), tree_(config_), policy_(config_) {
  table_.keepVolumes(config_.tight_volumes);
  table_.attach(&tree_.items(), &unbounded_.items());
}

// ---------------------------------------------------------------------------------------------
// Placement

template <typename S>
void Broadphase<S>::place(ObjectId id, Object* obj, const Box<S>& box) {
  assert(classify(box, config_.unbounded_limit) != BoxKind::invalid);
  const Item<S> item{box, obj, kNone, id};
  if (classify(box, config_.unbounded_limit) == BoxKind::unbounded) {
    unbounded_.add(item, table_);
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
  unbounded_.remove(loc & ~kUnboundedBit, table_);
}

template <typename S>
void Broadphase<S>::rebuild() {
  tree_.rebuild(ids());
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
  addMany(objs, n, [boxes](std::size_t i, Box<S>& box) {
    box = boxes[i];
    return true;
  });
}

template <typename S>
void Broadphase<S>::placeBatch(ItemArray<S>&& bounded, const std::vector<Item<S>>& loose) {
  pairs_.invalidate();
  const std::size_t added = bounded.size() + loose.size();
  if (added < size() - added) {
    // A small batch into a large manager: insertions beat a build.
    for (const Item<S>& it : bounded) {
      place(it.id, it.obj, it.box);
      maintain();
    }
    for (const Item<S>& it : loose) {
      place(it.id, it.obj, it.box);
      maintain();
    }
    return;
  }
  // One build over everything.
  for (const Item<S>& it : loose) unbounded_.add(it, table_);
  tree_.rebuild(ids(), std::move(bounded));
}

template <typename S>
bool Broadphase<S>::remove(const Object* obj) {
  const ObjectId id = table_.find(obj);
  if (id == kNone) return false;
  pairs_.invalidate();
  unplace(id);
  table_.remove(id, obj);
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
    unbounded_.at(loc & ~kUnboundedBit).box = box;
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
    table_.rebuildVolume(id, *objs[i]);  // named: rebuilt whatever changed (a geometry too)
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
    pairs_.list(scene(), table_);
}

template <typename S>
void Broadphase<S>::setup() {
  // A manager that has never held an object has nothing to build: it stays as before any
  // setup(), and the first setup() after registrations builds.
  if (setupIsNoOp()) return;
  if (regroupDue() || policy_.dueAtSetup(tree_, !setup_done_)) rebuild();
  // A removal swaps the list's last object into the gap: put the list in registration order, so
  // that the first setup() makes the callback order a function of the live registrations alone.
  if (!setup_done_) unbounded_.orderBySeq(table_);
  setup_done_ = true;
}

template <typename S>
void Broadphase<S>::clear() {
  table_.clear();
  tree_.clear();
  unbounded_.clear();
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

// ---------------------------------------------------------------------------------------------
// Inspection

template <typename S>
std::size_t Broadphase<S>::bytes() const {
  return table_.bytes() + tree_.bytes() + unbounded_.bytes() + pairs_.bytes() +
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
    if (it.id >= table_.idBound() || !table_.live(it.id) || table_.object(it.id) != it.obj)
      return msg << "a slot of the cubes names the wrong id", fail();
    if (classify(it.box, config_.unbounded_limit) != BoxKind::finite)
      return msg << "an unbounded object sits in the cubes", fail();
  }
  if (!unbounded_.validate(table_, config_.unbounded_limit, why)) return false;
  if (tree_.size() + unbounded_.size() != table_.size())
    return msg << "the cubes and the list hold " << tree_.size() + unbounded_.size()
               << " objects, the table " << table_.size(),
           fail();
  return pairs_.validate(scene(), table_, why);
}

template class Broadphase<float>;
template class Broadphase<double>;

}  // namespace detail
}  // namespace cube
