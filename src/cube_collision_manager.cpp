// The FCL adapter: checks input, reads AABBs from FCL objects, and maps every query onto the
// traversals over the cubes and the unbounded list.

#include "cube_collision/cube_collision_manager.h"

#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "cube_collision/detail/traversal.h"

namespace cube {

namespace {

using detail::Box;
using detail::BoxKind;
using detail::View;

template <typename S>
Box<S> boxOf(const fcl::CollisionObject<S>& obj) {
  const fcl::AABB<S>& a = obj.getAABB();
  Box<S> b;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = a.min_[k];
    b.hi[k] = a.max_[k];
  }
  return b;
}

template <typename S>
bool isValid(const Box<S>& b) {
  return detail::classify(b, std::numeric_limits<double>::infinity()) != BoxKind::invalid;
}

[[noreturn]] void fail(const char* where, const std::string& what) {
  throw std::invalid_argument(std::string("cube::CubeCollisionManager::") + where + ": " + what);
}

template <typename S>
std::string indexName(const detail::Hierarchy<S>& tree, const fcl::CollisionObject<S>* obj) {
  std::vector<fcl::CollisionObject<S>*> all;
  tree.objects(all);
  const auto it = std::find(all.begin(), all.end(), obj);
  return "object #" + std::to_string(it - all.begin()) + " (in getObjects() order)";
}

template <typename S>
Box<S> checkedQueryBox(const fcl::CollisionObject<S>* obj, const char* where) {
  if (obj == nullptr) fail(where, "null query object");
  const Box<S> b = boxOf(*obj);
  if (!isValid(b)) fail(where, "the query object's AABB has a NaN coordinate");
  return b;
}

// Re-reads one object's AABB; unknown objects are ignored, an invalid AABB is remembered. The
// location of a moved object goes to `changed`, if given.
template <typename S>
void moveOne(detail::Hierarchy<S>& tree, const fcl::CollisionObject<S>* obj,
             const fcl::CollisionObject<S>*& bad, std::vector<std::uint32_t>* changed) {
  if (obj == nullptr) return;
  const std::uint32_t loc = tree.locationOf(obj);
  if (loc == detail::kNone) return;
  const Box<S> b = boxOf(*obj);
  if (isValid(b)) {
    if (changed) changed->push_back(loc);
    tree.move(obj, b);
  } else if (bad == nullptr) {
    bad = obj;
  }
}

// Collide of two views; a small view against itself takes the all-pairs kernel.
template <typename S>
bool collideViews(const Config& config, const View<S>& a, const View<S>& b, bool self, void* data,
                  detail::CollideFn<S> fn, QueryStats* stats) {
  if (self && a.slots <= config.all_pairs_limit) return detail::collideAllPairs(a, data, fn, stats);
  return detail::collidePairs(a, b, self, data, fn, stats);
}

// Every query is a set of view pairs; `run(a, b, self)` traverses one pair of views and returns
// true when the callback stopped the query. These three functions say which pairs.

template <typename S, class Run>
void selfPairs(const detail::Hierarchy<S>& tree, Run&& run) {
  const View<S> cubes = tree.cubes();
  const View<S> unbounded = tree.unbounded();
  if (run(cubes, cubes, true) || unbounded.root == detail::kNone) return;
  if (run(cubes, unbounded, false)) return;
  run(unbounded, unbounded, true);
}

template <typename S, class Run>
void objectPairs(const detail::Hierarchy<S>& tree, fcl::CollisionObject<S>* obj, const Box<S>& box,
                 Run&& run) {
  const detail::SingleView<S> query(obj, box);
  if (run(tree.cubes(), query.view(), false) || tree.unbounded().root == detail::kNone) return;
  run(tree.unbounded(), query.view(), false);
}

template <typename S, class Run>
void managerPairs(const CubeCollisionManager<S>& self, fcl::BroadPhaseCollisionManager<S>* other,
                  const char* where, Run&& run) {
  if (other == nullptr) fail(where, "null manager");
  if (other == &self) {
    selfPairs(self.hierarchy(), run);
    return;
  }
  const detail::Hierarchy<S>& mine = self.hierarchy();
  if (const auto* cube = dynamic_cast<const CubeCollisionManager<S>*>(other)) {
    const detail::Hierarchy<S>& theirs = cube->hierarchy();
    for (const View<S>& a : {mine.cubes(), mine.unbounded()})
      for (const View<S>& b : {theirs.cubes(), theirs.unbounded()})
        if (run(a, b, false)) return;
    return;
  }
  // Another kind of manager: its objects one by one, without looking at its internals.
  std::vector<fcl::CollisionObject<S>*> objs;
  other->getObjects(objs);
  std::vector<Box<S>> boxes;
  boxes.reserve(objs.size());
  for (const auto* o : objs) boxes.push_back(checkedQueryBox(o, where));
  bool stopped = false;
  for (std::size_t i = 0; i < objs.size() && !stopped; ++i)
    objectPairs(mine, objs[i], boxes[i],
                [&](const View<S>& a, const View<S>& b, bool s) { return stopped = run(a, b, s); });
}

}  // namespace

template <typename S>
CubeCollisionManager<S>::CubeCollisionManager(const Config& config) : tree_(config) {}

template <typename S>
CubeCollisionManager<S>::~CubeCollisionManager() = default;

template <typename S>
void CubeCollisionManager<S>::registerObjects(const std::vector<Object*>& other_objs) {
  std::vector<Box<S>> boxes;
  boxes.reserve(other_objs.size());
  // Each AABB sits in a separate object, usually not in cache: ask for a few ahead.
  constexpr std::size_t kAhead = 8;
  for (std::size_t i = 0; i < other_objs.size(); ++i) {
    if (other_objs[i] == nullptr)
      fail("registerObjects", "entry #" + std::to_string(i) + " is null; nothing registered");
    if (i + kAhead < other_objs.size() && other_objs[i + kAhead] != nullptr)
      __builtin_prefetch(&other_objs[i + kAhead]->getAABB());
    boxes.push_back(boxOf(*other_objs[i]));
    // A registered object is left alone, whatever its AABB says now (as registerObject does).
    if (!isValid(boxes.back()) && !tree_.contains(other_objs[i]))
      fail("registerObjects",
           "entry #" + std::to_string(i) + " has a NaN AABB coordinate; nothing registered");
  }
  std::size_t fresh = 0;
  for (const Object* o : other_objs) fresh += tree_.contains(o) ? 0 : 1;
  // A batch as large as what is registered: one build beats many insertions.
  if (fresh >= tree_.size()) {
    tree_.insertAndRebuild(other_objs, boxes);
  } else {
    for (std::size_t i = 0; i < other_objs.size(); ++i)
      if (!tree_.contains(other_objs[i])) tree_.insert(other_objs[i], boxes[i]);
  }
}

template <typename S>
void CubeCollisionManager<S>::registerObject(Object* obj) {
  if (obj == nullptr) fail("registerObject", "null object");
  if (tree_.contains(obj)) return;
  const Box<S> b = boxOf(*obj);
  if (!isValid(b))
    fail("registerObject", "object #" + std::to_string(tree_.size()) +
                               " (the next registration) has a NaN AABB coordinate");
  tree_.insert(obj, b);
}

template <typename S>
void CubeCollisionManager<S>::unregisterObject(Object* obj) {
  tree_.remove(obj);
}

template <typename S>
void CubeCollisionManager<S>::setup() {
  tree_.setup();
}

template <typename S>
void CubeCollisionManager<S>::rebuildIfDue(bool was_current) {
  const std::uint64_t layout = tree_.layoutVersion();
  std::vector<std::uint32_t> old_slot;  // filled only by a rebuild
  if (tree_.maybeRebuildAfterUpdate(was_current ? &old_slot : nullptr) && was_current)
    pairs_.remap(tree_, layout, old_slot, changed_);
}

template <typename S>
void CubeCollisionManager<S>::syncPairs(bool was_current) {
  // Past a quarter of the objects moved, keeping the list would cost more than it saves: a
  // listing is a walk itself, and a query per moved object costs what the walk spends on 25 to
  // 50 objects. Scenes that move everything every step thus self-collide by walking, as without
  // the list.
  if (changed_.size() * 4 > tree_.size()) return;  // the list stays invalid
  // A refresh needs the list current before the boxes moved (and renumbered after a rebuild);
  // it lists afresh by itself if the update also rearranged the objects otherwise (a move to
  // or from the unbounded list).
  if (was_current)
    pairs_.refresh(tree_, changed_);
  else
    pairs_.recompute(tree_);
}

template <typename S>
void CubeCollisionManager<S>::update() {
  const bool keep = tree_.config().keep_pairs;
  const bool was_current = keep && pairs_.current(tree_);
  pairs_.invalidate();  // until synced: nothing below may leave it claiming to be current
  changed_.clear();
  const Object* bad =
      tree_.refitAll([](const Object* o, Box<S>& b) { b = boxOf(*o); }, keep ? &changed_ : nullptr);
  rebuildIfDue(was_current);
  if (keep) syncPairs(was_current);
  if (bad != nullptr)
    fail("update", indexName(tree_, bad) +
                       " has a NaN AABB coordinate; it keeps its previous "
                       "AABB, every other object was updated");
}

template <typename S>
void CubeCollisionManager<S>::update(Object* updated_obj) {
  const Object* bad = nullptr;
  // Dropped rather than refreshed: a refresh passes over the whole list, which a loop of single
  // updates would repeat for each object. The next update() or update(objects) lists afresh.
  pairs_.invalidate();
  moveOne(tree_, updated_obj, bad, nullptr);
  tree_.maybeRebuildAfterUpdate();
  if (bad != nullptr)
    fail("update", indexName(tree_, bad) +
                       " has a NaN AABB coordinate; it keeps its previous "
                       "AABB");
}

template <typename S>
void CubeCollisionManager<S>::update(const std::vector<Object*>& updated_objs) {
  const Object* bad = nullptr;
  const bool keep = tree_.config().keep_pairs;
  const bool was_current = keep && pairs_.current(tree_);
  pairs_.invalidate();
  changed_.clear();
  for (Object* obj : updated_objs) moveOne(tree_, obj, bad, keep ? &changed_ : nullptr);
  rebuildIfDue(was_current);
  if (keep) syncPairs(was_current);
  if (bad != nullptr)
    fail("update", indexName(tree_, bad) +
                       " has a NaN AABB coordinate; it keeps its previous "
                       "AABB, every other object was updated");
}

template <typename S>
void CubeCollisionManager<S>::clear() {
  tree_.clear();
  pairs_.release();
  changed_ = {};
}

template <typename S>
void CubeCollisionManager<S>::getObjects(std::vector<Object*>& objs) const {
  tree_.objects(objs);
}

template <typename S>
void CubeCollisionManager<S>::collide(Object* obj, void* cdata,
                                      fcl::CollisionCallBack<S> callback) const {
  collide(obj, cdata, callback, nullptr);
}

template <typename S>
void CubeCollisionManager<S>::distance(Object* obj, void* cdata,
                                       fcl::DistanceCallBack<S> callback) const {
  distance(obj, cdata, callback, nullptr);
}

template <typename S>
void CubeCollisionManager<S>::collide(void* cdata, fcl::CollisionCallBack<S> callback) const {
  collide(cdata, callback, nullptr);
}

template <typename S>
void CubeCollisionManager<S>::distance(void* cdata, fcl::DistanceCallBack<S> callback) const {
  distance(cdata, callback, nullptr);
}

template <typename S>
void CubeCollisionManager<S>::collide(Base* other_manager, void* cdata,
                                      fcl::CollisionCallBack<S> callback) const {
  collide(other_manager, cdata, callback, nullptr);
}

template <typename S>
void CubeCollisionManager<S>::distance(Base* other_manager, void* cdata,
                                       fcl::DistanceCallBack<S> callback) const {
  distance(other_manager, cdata, callback, nullptr);
}

template <typename S>
void CubeCollisionManager<S>::collide(Object* obj, void* cdata, fcl::CollisionCallBack<S> callback,
                                      QueryStats* stats) const {
  const Box<S> box = checkedQueryBox(obj, "collide");
  if (callback == nullptr) fail("collide", "null callback");
  objectPairs(tree_, obj, box, [&](const View<S>& a, const View<S>& b, bool self) {
    return detail::collidePairs(a, b, self, cdata, callback, stats);
  });
}

template <typename S>
void CubeCollisionManager<S>::distance(Object* obj, void* cdata, fcl::DistanceCallBack<S> callback,
                                       QueryStats* stats) const {
  const Box<S> box = checkedQueryBox(obj, "distance");
  if (callback == nullptr) fail("distance", "null callback");
  S best = std::numeric_limits<S>::max();
  objectPairs(tree_, obj, box, [&](const View<S>& a, const View<S>& b, bool self) {
    return detail::distancePairs(a, b, self, cdata, callback, best, stats);
  });
}

template <typename S>
void CubeCollisionManager<S>::collide(void* cdata, fcl::CollisionCallBack<S> callback,
                                      QueryStats* stats) const {
  if (callback == nullptr) fail("collide", "null callback");
  if (pairs_.current(tree_)) {
    pairs_.collide(tree_, cdata, callback, stats);
    return;
  }
  selfPairs(tree_, [&](const View<S>& a, const View<S>& b, bool self) {
    return collideViews(tree_.config(), a, b, self, cdata, callback, stats);
  });
}

template <typename S>
void CubeCollisionManager<S>::distance(void* cdata, fcl::DistanceCallBack<S> callback,
                                       QueryStats* stats) const {
  if (callback == nullptr) fail("distance", "null callback");
  S best = std::numeric_limits<S>::max();
  selfPairs(tree_, [&](const View<S>& a, const View<S>& b, bool self) {
    return detail::distancePairs(a, b, self, cdata, callback, best, stats);
  });
}

template <typename S>
void CubeCollisionManager<S>::collide(Base* other_manager, void* cdata,
                                      fcl::CollisionCallBack<S> callback, QueryStats* stats) const {
  if (callback == nullptr) fail("collide", "null callback");
  if (other_manager == this && pairs_.current(tree_)) {  // a self-collide, as collide(cdata, ...)
    pairs_.collide(tree_, cdata, callback, stats);
    return;
  }
  managerPairs(*this, other_manager, "collide", [&](const View<S>& a, const View<S>& b, bool self) {
    return collideViews(tree_.config(), a, b, self, cdata, callback, stats);
  });
}

template <typename S>
void CubeCollisionManager<S>::distance(Base* other_manager, void* cdata,
                                       fcl::DistanceCallBack<S> callback, QueryStats* stats) const {
  if (callback == nullptr) fail("distance", "null callback");
  S best = std::numeric_limits<S>::max();
  managerPairs(*this, other_manager, "distance",
               [&](const View<S>& a, const View<S>& b, bool self) {
                 return detail::distancePairs(a, b, self, cdata, callback, best, stats);
               });
}

template <typename S>
bool CubeCollisionManager<S>::validate(std::string* why) const {
  return tree_.validate(why) && pairs_.validate(tree_, why);
}

template <typename S>
bool CubeCollisionManager<S>::empty() const {
  return tree_.size() == 0;
}

template <typename S>
size_t CubeCollisionManager<S>::size() const {
  return tree_.size();
}

template class CubeCollisionManager<double>;
template class CubeCollisionManager<float>;

}  // namespace cube
