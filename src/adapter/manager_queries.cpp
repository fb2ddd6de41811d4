// The FCL adapter's queries: FCL's collide and distance calls (self, one object, another
// manager) over the core's query entries, with their input checks, the query guard and
// Config::cull_pairs; and the library's own ways into them (manager_walks.h).

#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "adapter/adapter_checks.h"
#include "adapter/manager_access.h"
#include "adapter/manager_walks.h"
#include "adapter/query_guard.h"
#include "core/broadphase.h"
#include "cube_collision/cube_collision_manager.h"
#include "pipeline/pair_judge.h"
#include "pipeline/pair_volumes.h"
namespace cube {

namespace {

using detail::Box;
using detail::adapter::boxOf;
using detail::adapter::checkedQueryBox;
using detail::adapter::fail;
using detail::adapter::indexName;
using detail::adapter::isValid;

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
    detail::Answer answer;
    if (c.volumes.of(a, ia, b, ib, ra.sphere, ra.shape, rb.sphere, rb.shape)) {
      answer = c.judge.collide(ra, rb);  // a judge that culls
    } else {
      // Without records: the objects' levels, kept for the pairs still to come.
      detail::FlyVolumes<S>*fa, *fb;
      c.volumes.fly(a, ia, b, ib, fa, fb);
      answer = fa != nullptr ? c.judge.collide(*fa, *fb) : c.judge.collide(*a, *b);
    }
    return answer != detail::Answer::kApart && c.fn(a, b, c.data);
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
[[gnu::always_inline]] inline void runObjectCollide(const detail::Broadphase<S>& core,
                                                    fcl::CollisionObject<S>* obj, void* cdata,
                                                    detail::CollideFn<S> fn, QueryStats* stats) {
  if (obj == nullptr) fail("collide", "null query object");
  if (isNull(fn)) fail("collide", "null callback");
  // Nothing to meet: return before reading the query object, whose AABB is most likely out of
  // cache (FCL's managers read nothing either); the NaN check needs an object to pair with.
  if (core.size() == 0) return;
  const Box<S> box = checkedQueryBox(obj, "collide");
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

// collide(obj) with the user's callback, culled by Config::cull_pairs if set. Out of line: see
// the FCL entries below.
template <typename S>
[[gnu::noinline]] void collideObject(const detail::Broadphase<S>& core,
                                     fcl::CollisionObject<S>* obj, void* cdata,
                                     fcl::CollisionCallBack<S> callback, QueryStats* stats) {
  // Without the cull, the user's callback straight: none of the cull's set-up in a short query.
  if (!core.config().cull_pairs)
    return runObjectCollide(core, obj, cdata, detail::CollideFn<S>(callback), stats);
  CulledCallback<S> culled{cdata, callback};
  const auto fn = culled.install(true, cdata, core.table(), nullptr);
  runObjectCollide(core, obj, cdata, fn, stats);
}

}  // namespace

template <typename S>
void CubeCollisionManager<S>::collide(Object* obj, void* cdata, fcl::CollisionCallBack<S> callback,
                                      QueryStats* stats) const {
  collideObject(*core_, obj, cdata, callback, stats);
}

namespace {

template <typename S>
bool isNull(const detail::DistanceFn<S>& fn) {
  return fn.plain == nullptr && fn.with_ids == nullptr;
}

template <typename S>
[[gnu::noinline]] void runObjectDistance(const detail::Broadphase<S>& core,
                                         fcl::CollisionObject<S>* obj, void* cdata,
                                         detail::DistanceFn<S> fn, QueryStats* stats) {
  if (obj == nullptr) fail("distance", "null query object");
  if (isNull(fn)) fail("distance", "null callback");
  if (core.size() == 0) return;  // as runObjectCollide
  const Box<S> box = checkedQueryBox(obj, "distance");
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

// An empty manager answers in the FCL entries themselves, without the calls below (FCL's
// managers test their size first too); bad pointers go on to be refused. The query proper is
// kept out of line so that this test is all an empty manager's query runs: inlined, its register
// saves and stack frame would come first.
template <typename S>
void CubeCollisionManager<S>::collide(Object* obj, void* cdata,
                                      fcl::CollisionCallBack<S> callback) const {
  if (core_->size() == 0 && obj != nullptr && callback != nullptr) return;
  collideObject(*core_, obj, cdata, callback, nullptr);
}

template <typename S>
void CubeCollisionManager<S>::distance(Object* obj, void* cdata,
                                       fcl::DistanceCallBack<S> callback) const {
  if (core_->size() == 0 && obj != nullptr && callback != nullptr) return;
  runObjectDistance(*core_, obj, cdata, detail::DistanceFn<S>(callback), nullptr);
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
  // This manager empty: no pair, and the other's objects are not read (as runObjectCollide).
  if (detail::coreOf(self).size() == 0) return;
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

#define CUBE_INSTANTIATE_QUERIES(S)                                                                \
  template void CubeCollisionManager<S>::collide(void*, fcl::CollisionCallBack<S>) const;          \
  template void CubeCollisionManager<S>::collide(void*, fcl::CollisionCallBack<S>, QueryStats*)    \
      const;                                                                                       \
  template void CubeCollisionManager<S>::collide(Object*, void*, fcl::CollisionCallBack<S>) const; \
  template void CubeCollisionManager<S>::collide(Object*, void*, fcl::CollisionCallBack<S>,        \
                                                 QueryStats*) const;                               \
  template void CubeCollisionManager<S>::collide(Base*, void*, fcl::CollisionCallBack<S>) const;   \
  template void CubeCollisionManager<S>::collide(Base*, void*, fcl::CollisionCallBack<S>,          \
                                                 QueryStats*) const;                               \
  template void CubeCollisionManager<S>::distance(void*, fcl::DistanceCallBack<S>) const;          \
  template void CubeCollisionManager<S>::distance(void*, fcl::DistanceCallBack<S>, QueryStats*)    \
      const;                                                                                       \
  template void CubeCollisionManager<S>::distance(Object*, void*, fcl::DistanceCallBack<S>) const; \
  template void CubeCollisionManager<S>::distance(Object*, void*, fcl::DistanceCallBack<S>,        \
                                                  QueryStats*) const;                              \
  template void CubeCollisionManager<S>::distance(Base*, void*, fcl::DistanceCallBack<S>) const;   \
  template void CubeCollisionManager<S>::distance(Base*, void*, fcl::DistanceCallBack<S>,          \
                                                  QueryStats*) const;
CUBE_INSTANTIATE_QUERIES(double)
CUBE_INSTANTIATE_QUERIES(float)
#undef CUBE_INSTANTIATE_QUERIES

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
