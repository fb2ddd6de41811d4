// The FCL adapter: FCL's manager interface over the broadphase core. It reads AABBs from FCL
// objects, checks input, refuses mutations from inside a query's callbacks, and maps other
// managers onto the core's queries.

#include "cube_collision/cube_collision_manager.h"

#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "adapter/manager_access.h"
#include "adapter/manager_walks.h"
#include "adapter/query_guard.h"
#include "core/broadphase.h"
#include "pipeline/pair_judge.h"
#include "pipeline/pair_volumes.h"

namespace cube {

namespace {

using detail::Box;

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
  return detail::classify(b, std::numeric_limits<double>::infinity()) != detail::BoxKind::invalid;
}

[[noreturn]] void fail(const char* where, const std::string& what) {
  throw std::invalid_argument(std::string("cube::CubeCollisionManager::") + where + ": " + what);
}

template <typename S>
std::string indexName(const detail::Broadphase<S>& core, const fcl::CollisionObject<S>* obj) {
  std::vector<fcl::CollisionObject<S>*> all;
  core.objects(all);
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

using detail::QueryScope;
using detail::refuseInsideQuery;

// Config::cull_pairs: the user's callback behind the pair judge (pair_judge.h), on the records of
// the object tables where they keep them (Config::tight_volumes), else built from the objects. The
// margin is sized for FCL's default GJK tolerance, the one the user's fcl::collide most likely
// runs with.
template <typename S>
struct CulledCallback {
  void* data;
  fcl::CollisionCallBack<S> fn;
  detail::PairVolumes<S> volumes{};
  detail::PairJudge<S> judge{S(1e-6), false, true};

  static bool call(fcl::CollisionObject<S>* a, detail::ObjectId ia, fcl::CollisionObject<S>* b,
                   detail::ObjectId ib, void* self) {
    auto& c = *static_cast<CulledCallback*>(self);
    detail::Records ra, rb;
    const bool records = c.volumes.of(a, ia, b, ib, ra.sphere, ra.shape, rb.sphere, rb.shape);
    const bool apart = c.judge.collide(*a, records ? &ra : nullptr, *b, records ? &rb : nullptr) ==
                       detail::Answer::kApart;
    return !apart && c.fn(a, b, c.data);
  }
  // The walk's callback: this wrapper, on the tables whose ids the walk gives (side b null:
  // objects of no table), when culling is on; else the user's (a null one stays null, for the
  // query's check).
  detail::CollideFn<S> install(bool on, void*& cdata, const detail::ObjectTable<S>& a,
                               const detail::ObjectTable<S>* b) {
    if (!on || fn == nullptr) return detail::CollideFn<S>(fn);
    a.wantVolumes();
    if (b != nullptr) b->wantVolumes();
    volumes.use(a.spheres(), a.shapes(), b != nullptr ? b->spheres() : nullptr,
                b != nullptr ? b->shapes() : nullptr, 0);
    cdata = this;
    return detail::CollideFn<S>(&CulledCallback::call);
  }
};

}  // namespace

template <typename S>
CubeCollisionManager<S>::CubeCollisionManager(const Config& config)
    : core_(std::make_unique<detail::Broadphase<S>>(config)) {}

template <typename S>
CubeCollisionManager<S>::~CubeCollisionManager() = default;

template <typename S>
const Config& CubeCollisionManager<S>::config() const {
  return core_->config();
}

template <typename S>
void CubeCollisionManager<S>::registerObjects(const std::vector<Object*>& other_objs) {
  refuseInsideQuery(core_.get(), "registerObjects");
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
    if (!isValid(boxes.back()) && !core_->contains(other_objs[i]))
      fail("registerObjects",
           "entry #" + std::to_string(i) + " has a NaN AABB coordinate; nothing registered");
  }
  core_->addMany(other_objs.data(), boxes.data(), other_objs.size());
}

template <typename S>
void CubeCollisionManager<S>::registerObject(Object* obj) {
  refuseInsideQuery(core_.get(), "registerObject");
  if (obj == nullptr) fail("registerObject", "null object");
  if (core_->contains(obj)) return;
  const Box<S> b = boxOf(*obj);
  if (!isValid(b))
    fail("registerObject", "object #" + std::to_string(core_->size()) +
                               " (the next registration) has a NaN AABB coordinate");
  core_->add(obj, b);
}

template <typename S>
void CubeCollisionManager<S>::unregisterObject(Object* obj) {
  refuseInsideQuery(core_.get(), "unregisterObject");
  core_->remove(obj);
}

template <typename S>
void CubeCollisionManager<S>::setup() {
  refuseInsideQuery(core_.get(), "setup");
  core_->setup();
}

template <typename S>
void CubeCollisionManager<S>::update() {
  refuseInsideQuery(core_.get(), "update");
  const Object* bad = core_->updateAll([](const Object* o, Box<S>& b) { b = boxOf(*o); });
  if (bad != nullptr)
    fail("update", indexName(*core_, bad) +
                       " has a NaN AABB coordinate; it keeps its previous "
                       "AABB, every other object was updated");
}

template <typename S>
void CubeCollisionManager<S>::update(Object* updated_obj) {
  refuseInsideQuery(core_.get(), "update");
  if (updated_obj == nullptr || !core_->contains(updated_obj)) return;
  const Box<S> b = boxOf(*updated_obj);
  if (!isValid(b))
    fail("update", indexName(*core_, updated_obj) +
                       " has a NaN AABB coordinate; it keeps its previous "
                       "AABB");
  core_->updateSome(&updated_obj, &b, 1, false);
}

template <typename S>
void CubeCollisionManager<S>::update(const std::vector<Object*>& updated_objs) {
  refuseInsideQuery(core_.get(), "update");
  const Object* bad = nullptr;
  std::vector<Object*> objs;
  std::vector<Box<S>> boxes;
  objs.reserve(updated_objs.size());
  boxes.reserve(updated_objs.size());
  for (Object* obj : updated_objs) {
    if (obj == nullptr || !core_->contains(obj)) continue;
    const Box<S> b = boxOf(*obj);
    if (isValid(b)) {
      objs.push_back(obj);
      boxes.push_back(b);
    } else if (bad == nullptr) {
      bad = obj;
    }
  }
  core_->updateSome(objs.data(), boxes.data(), objs.size(), true);
  if (bad != nullptr)
    fail("update", indexName(*core_, bad) +
                       " has a NaN AABB coordinate; it keeps its previous "
                       "AABB, every other object was updated");
}

template <typename S>
void CubeCollisionManager<S>::clear() {
  refuseInsideQuery(core_.get(), "clear");
  core_->clear();
}

template <typename S>
void CubeCollisionManager<S>::getObjects(std::vector<Object*>& objs) const {
  core_->objects(objs);
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

namespace {

template <typename S>
bool isNull(const detail::CollideFn<S>& fn) {
  return fn.plain == nullptr && fn.with_ids == nullptr;
}

// The collides behind FCL's interface and the library's (manager_walks.h), after the cull of
// Config::cull_pairs, if any, is installed.
template <typename S>
void runObjectCollide(const detail::Broadphase<S>& core, fcl::CollisionObject<S>* obj, void* cdata,
                      detail::CollideFn<S> fn, QueryStats* stats) {
  const Box<S> box = checkedQueryBox(obj, "collide");
  if (isNull(fn)) fail("collide", "null callback");
  if (core.size() == 0) return;  // checked, nothing to meet: skip the set-up of a walk
  const QueryScope scope(&core);
  core.collide(obj, box, cdata, fn, stats);
}

template <typename S>
void runSelfCollide(const detail::Broadphase<S>& core, void* cdata, detail::CollideFn<S> fn,
                    QueryStats* stats) {
  if (isNull(fn)) fail("collide", "null callback");
  if (core.size() < 2) return;  // no pair
  const QueryScope scope(&core);
  core.collideSelf(cdata, fn, stats);
}

}  // namespace

template <typename S>
void CubeCollisionManager<S>::collide(Object* obj, void* cdata, fcl::CollisionCallBack<S> callback,
                                      QueryStats* stats) const {
  CulledCallback<S> culled{cdata, callback};
  const auto fn = culled.install(core_->config().cull_pairs, cdata, core_->table(), nullptr);
  runObjectCollide(*core_, obj, cdata, fn, stats);
}

namespace {

template <typename S>
bool isNull(const detail::DistanceFn<S>& fn) {
  return fn.plain == nullptr && fn.with_ids == nullptr;
}

template <typename S>
void runObjectDistance(const detail::Broadphase<S>& core, fcl::CollisionObject<S>* obj, void* cdata,
                       detail::DistanceFn<S> fn, QueryStats* stats) {
  const Box<S> box = checkedQueryBox(obj, "distance");
  if (isNull(fn)) fail("distance", "null callback");
  if (core.size() == 0) return;
  const QueryScope scope(&core);
  S best = std::numeric_limits<S>::max();
  core.distance(obj, box, cdata, fn, best, stats);
}

template <typename S>
void runSelfDistance(const detail::Broadphase<S>& core, void* cdata, detail::DistanceFn<S> fn,
                     QueryStats* stats) {
  if (isNull(fn)) fail("distance", "null callback");
  if (core.size() < 2) return;  // no pair
  const QueryScope scope(&core);
  S best = std::numeric_limits<S>::max();
  core.distanceSelf(cdata, fn, best, stats);
}

}  // namespace

template <typename S>
void CubeCollisionManager<S>::distance(Object* obj, void* cdata, fcl::DistanceCallBack<S> callback,
                                       QueryStats* stats) const {
  runObjectDistance(*core_, obj, cdata, detail::DistanceFn<S>(callback), stats);
}

template <typename S>
void CubeCollisionManager<S>::collide(void* cdata, fcl::CollisionCallBack<S> callback,
                                      QueryStats* stats) const {
  CulledCallback<S> culled{cdata, callback};
  const auto fn =
      culled.install(core_->config().cull_pairs, cdata, core_->table(), &core_->table());
  runSelfCollide(*core_, cdata, fn, stats);
}

template <typename S>
void CubeCollisionManager<S>::distance(void* cdata, fcl::DistanceCallBack<S> callback,
                                       QueryStats* stats) const {
  runSelfDistance(*core_, cdata, detail::DistanceFn<S>(callback), stats);
}

namespace {

// Manager against manager: itself (a self query), another cube manager (tree against tree), or
// any other kind through its objects, one query each, without looking at its internals.
// `self_run()`, `cube_run(core)` and `object_run(obj, box)` run the query; each returns true when
// the callback stopped it.
template <typename S, class Self, class Cube, class One>
void againstManager(const CubeCollisionManager<S>& self, fcl::BroadPhaseCollisionManager<S>* other,
                    const char* where, Self&& self_run, Cube&& cube_run, One&& object_run) {
  if (other == nullptr) fail(where, "null manager");
  if (other == &self) {
    const QueryScope scope(&detail::coreOf(self));
    self_run();
    return;
  }
  if (const auto* cube = dynamic_cast<const CubeCollisionManager<S>*>(other)) {
    const QueryScope scope(&detail::coreOf(self), &detail::coreOf(*cube));
    cube_run(detail::coreOf(*cube));
    return;
  }
  std::vector<fcl::CollisionObject<S>*> objs;
  other->getObjects(objs);
  std::vector<Box<S>> boxes;
  boxes.reserve(objs.size());
  for (const auto* o : objs) boxes.push_back(checkedQueryBox(o, where));
  const QueryScope scope(&detail::coreOf(self));
  for (std::size_t i = 0; i < objs.size(); ++i)
    if (object_run(objs[i], boxes[i])) return;
}

}  // namespace

namespace {

template <typename S>
void runManagerCollide(const CubeCollisionManager<S>& manager,
                       fcl::BroadPhaseCollisionManager<S>* other_manager, void* cdata,
                       detail::CollideFn<S> fn, QueryStats* stats) {
  if (isNull(fn)) fail("collide", "null callback");
  const detail::Broadphase<S>& core = detail::coreOf(manager);
  againstManager(
      manager, other_manager, "collide", [&] { core.collideSelf(cdata, fn, stats); },
      [&](const detail::Broadphase<S>& other) { core.collide(other, cdata, fn, stats); },
      [&](fcl::CollisionObject<S>* obj, const Box<S>& box) {
        return core.collide(obj, box, cdata, fn, stats);
      });
}

}  // namespace

template <typename S>
void CubeCollisionManager<S>::collide(Base* other_manager, void* cdata,
                                      fcl::CollisionCallBack<S> callback, QueryStats* stats) const {
  // Side b's ids: this manager's (itself), another cube manager's, or none.
  const auto* cube =
      other_manager == this ? this : dynamic_cast<const CubeCollisionManager<S>*>(other_manager);
  CulledCallback<S> culled{cdata, callback};
  const auto fn = culled.install(core_->config().cull_pairs, cdata, core_->table(),
                                 cube != nullptr ? &detail::coreOf(*cube).table() : nullptr);
  runManagerCollide(*this, other_manager, cdata, fn, stats);
}

namespace {

template <typename S>
void runManagerDistance(const CubeCollisionManager<S>& manager,
                        fcl::BroadPhaseCollisionManager<S>* other_manager, void* cdata,
                        detail::DistanceFn<S> fn, QueryStats* stats) {
  if (isNull(fn)) fail("distance", "null callback");
  const detail::Broadphase<S>& core = detail::coreOf(manager);
  S best = std::numeric_limits<S>::max();
  againstManager(
      manager, other_manager, "distance", [&] { core.distanceSelf(cdata, fn, best, stats); },
      [&](const detail::Broadphase<S>& other) { core.distance(other, cdata, fn, best, stats); },
      [&](fcl::CollisionObject<S>* obj, const Box<S>& box) {
        return core.distance(obj, box, cdata, fn, best, stats);
      });
}

}  // namespace

template <typename S>
void CubeCollisionManager<S>::distance(Base* other_manager, void* cdata,
                                       fcl::DistanceCallBack<S> callback, QueryStats* stats) const {
  runManagerDistance(*this, other_manager, cdata, detail::DistanceFn<S>(callback), stats);
}

template <typename S>
void CubeCollisionManager<S>::setFilter(Object* obj, std::uint64_t category, std::uint64_t mask) {
  refuseInsideQuery(core_.get(), "setFilter");
  if (obj == nullptr) fail("setFilter", "null object");
  if (!core_->setFilter(obj, detail::Filter{category, mask}))
    fail("setFilter", "the object is not registered");
}

template <typename S>
std::pair<std::uint64_t, std::uint64_t> CubeCollisionManager<S>::filter(const Object* obj) const {
  const detail::Filter f = core_->filter(obj);
  return {f.category, f.mask};
}

template <typename S>
void CubeCollisionManager<S>::setPairFilter(std::function<bool(Object*, Object*)> keep) {
  refuseInsideQuery(core_.get(), "setPairFilter");
  core_->setPredicate(std::move(keep));
}

template <typename S>
void CubeCollisionManager<S>::excludePair(Object* a, Object* b, bool excluded) {
  refuseInsideQuery(core_.get(), "excludePair");
  if (a == nullptr || b == nullptr) fail("excludePair", "null object");
  if (a == b) fail("excludePair", "an object never pairs with itself");
  if (!core_->exclude(a, b, excluded)) fail("excludePair", "the object is not registered");
}

template <typename S>
bool CubeCollisionManager<S>::isExcluded(const Object* a, const Object* b) const {
  const detail::ObjectTable<S>& table = core_->table();
  return table.excluded(table.find(a), table.find(b));
}

template <typename S>
std::vector<
    std::pair<typename CubeCollisionManager<S>::Object*, typename CubeCollisionManager<S>::Object*>>
CubeCollisionManager<S>::excludedPairs() const {
  const detail::ObjectTable<S>& table = core_->table();
  std::vector<std::pair<detail::ObjectId, detail::ObjectId>> ids;
  table.excludedPairs(ids);
  std::vector<std::pair<Object*, Object*>> out;
  out.reserve(ids.size());
  for (const auto& [x, y] : ids) out.emplace_back(table.object(x), table.object(y));
  return out;
}

namespace {

template <typename S>
void checkMargin(S margin, const char* where) {
  if (!(margin >= S(0)) || !std::isfinite(margin))
    fail(where, "the margin must be finite and >= 0");
}

}  // namespace

template <typename S>
void CubeCollisionManager<S>::setMargin(S margin) {
  refuseInsideQuery(core_.get(), "setMargin");
  checkMargin(margin, "setMargin");
  const Object* bad =
      core_->setDefaultMargin(margin, [](const Object* o, Box<S>& b) { b = boxOf(*o); });
  if (bad != nullptr)
    fail("setMargin", indexName(*core_, bad) +
                          " has a NaN AABB coordinate; it keeps its previous AABB, the margin "
                          "applies to every other object");
}

template <typename S>
void CubeCollisionManager<S>::setMargin(Object* obj, S margin) {
  refuseInsideQuery(core_.get(), "setMargin");
  checkMargin(margin, "setMargin");
  if (obj == nullptr) fail("setMargin", "null object");
  if (!core_->contains(obj)) fail("setMargin", "the object is not registered");
  const Box<S> b = boxOf(*obj);
  if (!isValid(b))
    fail("setMargin", indexName(*core_, obj) + " has a NaN AABB coordinate; nothing changed");
  core_->setMargin(obj, b, margin);
}

template <typename S>
S CubeCollisionManager<S>::margin(const Object* obj) const {
  return core_->margin(obj);
}

template <typename S>
bool CubeCollisionManager<S>::validate(std::string* why) const {
  return core_->validate(why);
}

template <typename S>
std::size_t CubeCollisionManager<S>::bytes() const {
  return core_->bytes();
}

template <typename S>
void CubeCollisionManager<S>::dropVolumes() {
  refuseInsideQuery(core_.get(), "dropVolumes");
  core_->dropVolumes();
}

template <typename S>
bool CubeCollisionManager<S>::pairsListed() const {
  return core_->pairsListed();
}

template <typename S>
bool CubeCollisionManager<S>::empty() const {
  return core_->size() == 0;
}

template <typename S>
size_t CubeCollisionManager<S>::size() const {
  return core_->size();
}

template class CubeCollisionManager<double>;
template class CubeCollisionManager<float>;

namespace detail {

template <typename S>
void collideSelfOnThreadsWithIds(const CubeCollisionManager<S>& manager, void* cdata,
                                 CollideFn<S> fn, int threads) {
  if (isNull(fn)) fail("collide", "null callback");
  const Broadphase<S>& core = detail::coreOf(manager);
  if (core.size() < 2) return;  // no pair
  const QueryScope scope(&core);
  core.collideSelfSplit(cdata, fn, threads);
}

template <typename S>
bool collideSelfInTasks(const CubeCollisionManager<S>& manager, TaskSink<S>& sink, int threads) {
  const Broadphase<S>& core = detail::coreOf(manager);
  if (core.size() < 2) return true;  // no pair
  const QueryScope scope(&core);
  return core.collideSelfTasks(sink, threads);
}

template <typename S>
void collideSelfOnThreads(const CubeCollisionManager<S>& manager, void* cdata,
                          fcl::CollisionCallBack<S> callback, int threads) {
  const Broadphase<S>& core = detail::coreOf(manager);
  CulledCallback<S> culled{cdata, callback};
  const auto fn = culled.install(core.config().cull_pairs, cdata, core.table(), &core.table());
  collideSelfOnThreadsWithIds(manager, cdata, fn, threads);
}

template <typename S>
void collideWithIds(const CubeCollisionManager<S>& manager, void* cdata, CollideFn<S> fn) {
  runSelfCollide(coreOf(manager), cdata, fn, nullptr);
}

template <typename S>
void collideWithIds(const CubeCollisionManager<S>& manager, fcl::CollisionObject<S>* obj,
                    void* cdata, CollideFn<S> fn) {
  runObjectCollide(coreOf(manager), obj, cdata, fn, nullptr);
}

template <typename S>
void collideWithIds(const CubeCollisionManager<S>& manager,
                    fcl::BroadPhaseCollisionManager<S>* other, void* cdata, CollideFn<S> fn) {
  runManagerCollide(manager, other, cdata, fn, nullptr);
}

template <typename S>
void distanceWithIds(const CubeCollisionManager<S>& manager, void* cdata, DistanceFn<S> fn) {
  runSelfDistance(coreOf(manager), cdata, fn, nullptr);
}

template <typename S>
void distanceWithIds(const CubeCollisionManager<S>& manager, fcl::CollisionObject<S>* obj,
                     void* cdata, DistanceFn<S> fn) {
  runObjectDistance(coreOf(manager), obj, cdata, fn, nullptr);
}

template <typename S>
void distanceWithIds(const CubeCollisionManager<S>& manager,
                     fcl::BroadPhaseCollisionManager<S>* other, void* cdata, DistanceFn<S> fn) {
  runManagerDistance(manager, other, cdata, fn, nullptr);
}

#define CUBE_INSTANTIATE_WALKS(S)                                                                  \
  template bool collideSelfInTasks<S>(const CubeCollisionManager<S>&, TaskSink<S>&, int);          \
  template void collideSelfOnThreadsWithIds<S>(const CubeCollisionManager<S>&, void*,              \
                                               CollideFn<S>, int);                                 \
  template void collideWithIds<S>(const CubeCollisionManager<S>&, void*, CollideFn<S>);            \
  template void collideWithIds<S>(const CubeCollisionManager<S>&, fcl::CollisionObject<S>*, void*, \
                                  CollideFn<S>);                                                   \
  template void collideWithIds<S>(const CubeCollisionManager<S>&,                                  \
                                  fcl::BroadPhaseCollisionManager<S>*, void*, CollideFn<S>);       \
  template void distanceWithIds<S>(const CubeCollisionManager<S>&, void*, DistanceFn<S>);          \
  template void distanceWithIds<S>(const CubeCollisionManager<S>&, fcl::CollisionObject<S>*,       \
                                   void*, DistanceFn<S>);                                          \
  template void distanceWithIds<S>(const CubeCollisionManager<S>&,                                 \
                                   fcl::BroadPhaseCollisionManager<S>*, void*, DistanceFn<S>);
CUBE_INSTANTIATE_WALKS(double)
CUBE_INSTANTIATE_WALKS(float)
#undef CUBE_INSTANTIATE_WALKS

template void collideSelfOnThreads<double>(const CubeCollisionManager<double>&, void*,
                                           fcl::CollisionCallBack<double>, int);
template void collideSelfOnThreads<float>(const CubeCollisionManager<float>&, void*,
                                          fcl::CollisionCallBack<float>, int);

}  // namespace detail

}  // namespace cube
