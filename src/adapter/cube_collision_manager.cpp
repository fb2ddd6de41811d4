// The FCL adapter: FCL's manager interface over the broadphase core, its mutations and per-object
// rules here (its queries in manager_queries.cpp). It reads AABBs from FCL objects, checks input
// and refuses mutations from inside a query's callbacks.

#include "cube_collision/cube_collision_manager.h"

#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "adapter/adapter_checks.h"
#include "adapter/manager_access.h"
#include "adapter/query_guard.h"
#include "core/broadphase.h"
namespace cube {

namespace {

using detail::Box;
using detail::refuseInsideQuery;
using detail::adapter::boxOf;
using detail::adapter::checkedQueryBox;
using detail::adapter::fail;
using detail::adapter::indexName;
using detail::adapter::isValid;

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
  // An empty batch on an empty manager changes nothing: return before any other call (an empty
  // manager runs no query, so the guard below could not refuse).
  if (other_objs.empty() && core_->size() == 0) return;
  refuseInsideQuery(core_.get(), "registerObjects");
  // Null entries first (the pointers alone); the AABBs are then read once, as the core
  // registers them, and a NaN one undoes the batch (a pass of its own read each AABB twice, and
  // an array of boxes would cost 48 bytes an object at the build's peak). Each AABB sits in an
  // object of its own, out of cache in a large batch: ask for a few ahead.
  const std::size_t n = other_objs.size();
  if (n == 0) return;  // nothing changes: no pass over the core's state
  for (std::size_t i = 0; i < n; ++i)
    if (other_objs[i] == nullptr)
      fail("registerObjects", "entry #" + std::to_string(i) + " is null; nothing registered");
  constexpr std::size_t kAhead = 8;
  const std::size_t refused = core_->addMany(other_objs.data(), n, [&](std::size_t i, Box<S>& box) {
    if (i + kAhead < n) __builtin_prefetch(&other_objs[i + kAhead]->getAABB());
    box = boxOf(*other_objs[i]);
    return isValid(box);
  });
  // A registered object is left alone, whatever its AABB says now (as registerObject does): the
  // core reads only the boxes of entries it registers.
  if (refused != n)
    fail("registerObjects",
         "entry #" + std::to_string(refused) + " has a NaN AABB coordinate; nothing registered");
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
  if (core_->setupIsNoOp()) return;  // as registerObjects: an empty manager runs no query
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

template <typename S>
bool CubeCollisionManager<S>::pairPasses(Object* a, Object* b, const Base* other) const {
  if (a == nullptr || b == nullptr) fail("pairPasses", "null object");
  // The side b is looked for as the queries look for it (manager_queries.cpp, againstManager).
  const auto* cube = other == this ? nullptr : dynamic_cast<const CubeCollisionManager*>(other);
  const detail::Broadphase<S>* there = cube != nullptr ? cube->core_.get() : nullptr;
  const bool as_query = other != nullptr && other != this && cube == nullptr;
  const detail::QueryScope scope(core_.get(), there);  // the pair filter is user code
  return core_->pairPasses(a, b, there, as_query);
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

}  // namespace cube
