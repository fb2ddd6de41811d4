#include "fcl_backend.h"

#include <cube_collision/cube_collision_manager.h>

#include "manager.h"

namespace cubepy {

// One query's callback behind the rules: the bits of both objects (each read from the manager
// that holds it), the predicate within this manager, never an object with itself.
struct FclBackend::Gate {
  Gate(const FclBackend* s, const fcl::BroadPhaseCollisionManagerd* o, void* d,
       fcl::CollisionCallBack<double> c, fcl::DistanceCallBack<double> dc)
      : self(s),
        other(o),
        other_fcl(dynamic_cast<const FclBackend*>(o)),
        other_cube(dynamic_cast<const cube::CubeCollisionManagerd*>(o)),
        cdata(d),
        collide_cb(c),
        distance_cb(dc) {}

  const FclBackend* self;
  const fcl::BroadPhaseCollisionManagerd* other;  // the other side's manager, or null
  const FclBackend* other_fcl;                    // other, if of these two kinds
  const cube::CubeCollisionManagerd* other_cube;
  void* cdata;
  fcl::CollisionCallBack<double> collide_cb;
  fcl::DistanceCallBack<double> distance_cb;
  bool stopped = false;

  std::pair<std::uint64_t, std::uint64_t> bits(const Obj* o) const {
    const auto it = self->rules_.find(o);
    if (it != self->rules_.end()) return {it->second.category, it->second.mask};
    if (other_fcl) return other_fcl->filter(o);
    if (other_cube) return other_cube->filter(o);
    return {1, ~std::uint64_t(0)};  // a query object
  }
  bool pass(Obj* a, Obj* b) const {
    if (a == b) return false;
    const auto ba = bits(a), bb = bits(b);
    if ((ba.first & bb.second) == 0 || (bb.first & ba.second) == 0) return false;
    return other != nullptr || !self->keep_ || self->keep_(a, b);
  }
  static bool collide(Obj* a, Obj* b, void* data) {
    auto& g = *static_cast<Gate*>(data);
    if (!g.pass(a, b)) return false;
    return g.stopped = g.collide_cb(a, b, g.cdata);
  }
  static bool distance(Obj* a, Obj* b, void* data, double& dist) {
    auto& g = *static_cast<Gate*>(data);
    if (!g.pass(a, b)) return false;
    return g.stopped = g.distance_cb(a, b, g.cdata, dist);
  }
};

void FclBackend::grow(Obj* obj) const {
  // Every object registered by the Python manager is its Object (manager.h).
  static_cast<Object*>(obj)->refresh(margin(obj));
}

void FclBackend::setFilter(Obj* obj, std::uint64_t category, std::uint64_t mask) {
  Rule& r = rules_.at(obj);
  r.category = category;
  r.mask = mask;
}

std::pair<std::uint64_t, std::uint64_t> FclBackend::filter(const Obj* obj) const {
  const auto it = rules_.find(obj);
  if (it == rules_.end()) return {1, ~std::uint64_t(0)};
  return {it->second.category, it->second.mask};
}

void FclBackend::setMargin(double margin) {
  margin_ = margin;
  update();
}

void FclBackend::setMargin(Obj* obj, double margin) {
  rules_.at(obj).margin = margin;
  update(obj);
}

double FclBackend::margin(const Obj* obj) const {
  const auto it = rules_.find(obj);
  return it == rules_.end() || it->second.margin < 0 ? margin_ : it->second.margin;
}

void FclBackend::registerObjects(const std::vector<Obj*>& objs) {
  for (Obj* o : objs) {
    rules_.emplace(o, Rule());
    grow(o);
  }
  tree_.registerObjects(objs);
}

void FclBackend::registerObject(Obj* obj) {
  rules_.emplace(obj, Rule());
  grow(obj);
  tree_.registerObject(obj);
}

void FclBackend::unregisterObject(Obj* obj) {
  tree_.unregisterObject(obj);
  rules_.erase(obj);
}

void FclBackend::update() {
  for (const auto& [o, r] : rules_) grow(const_cast<Obj*>(o));
  tree_.update();
}

void FclBackend::update(Obj* obj) {
  grow(obj);
  tree_.update(obj);
}

void FclBackend::update(const std::vector<Obj*>& objs) {
  for (Obj* o : objs) grow(o);
  tree_.update(objs);
}

void FclBackend::clear() {
  tree_.clear();
  rules_.clear();
}

void FclBackend::collide(Obj* obj, void* cdata, fcl::CollisionCallBack<double> cb) const {
  Gate g(this, nullptr, cdata, cb, nullptr);
  tree_.collide(obj, &g, &Gate::collide);
}

void FclBackend::distance(Obj* obj, void* cdata, fcl::DistanceCallBack<double> cb) const {
  Gate g(this, nullptr, cdata, nullptr, cb);
  tree_.distance(obj, &g, &Gate::distance);
}

void FclBackend::collide(void* cdata, fcl::CollisionCallBack<double> cb) const {
  Gate g(this, nullptr, cdata, cb, nullptr);
  tree_.collide(&g, &Gate::collide);
}

void FclBackend::distance(void* cdata, fcl::DistanceCallBack<double> cb) const {
  Gate g(this, nullptr, cdata, nullptr, cb);
  tree_.distance(&g, &Gate::distance);
}

void FclBackend::collide(fcl::BroadPhaseCollisionManagerd* other, void* cdata,
                         fcl::CollisionCallBack<double> cb) const {
  if (other == this) return collide(cdata, cb);
  Gate g(this, other, cdata, cb, nullptr);
  if (auto* f = dynamic_cast<FclBackend*>(other))
    return tree_.collide(&f->tree_, &g, &Gate::collide);
  std::vector<Obj*> objs;
  other->getObjects(objs);
  for (Obj* o : objs) {
    tree_.collide(o, &g, &Gate::collide);
    if (g.stopped) return;
  }
}

void FclBackend::distance(fcl::BroadPhaseCollisionManagerd* other, void* cdata,
                          fcl::DistanceCallBack<double> cb) const {
  if (other == this) return distance(cdata, cb);
  Gate g(this, other, cdata, nullptr, cb);
  if (auto* f = dynamic_cast<FclBackend*>(other))
    return tree_.distance(&f->tree_, &g, &Gate::distance);
  std::vector<Obj*> objs;
  other->getObjects(objs);
  for (Obj* o : objs) {
    tree_.distance(o, &g, &Gate::distance);
    if (g.stopped) return;
  }
}

}  // namespace cubepy
