#include "fcl_backend.h"

#include "manager.h"

namespace cubepy {

// One query's callback behind the rules object: rules_.pairPasses for each pair, with the other
// side's rules (another backend's rules object, a cube manager; any other manager's objects are
// query objects there).
struct FclBackend::Gate {
  Gate(const FclBackend* s, const fcl::BroadPhaseCollisionManagerd* o, void* d,
       fcl::CollisionCallBack<double> c, fcl::DistanceCallBack<double> dc)
      : rules(&s->rules_), cdata(d), collide_cb(c), distance_cb(dc) {
    const auto* f = dynamic_cast<const FclBackend*>(o);
    other = f != nullptr ? &f->rules_ : o;
  }

  const cube::CubeCollisionManagerd* rules;
  const fcl::BroadPhaseCollisionManagerd* other = nullptr;  // the other side's rules, or null
  void* cdata;
  fcl::CollisionCallBack<double> collide_cb;
  fcl::DistanceCallBack<double> distance_cb;
  bool stopped = false;

  static bool collide(Obj* a, Obj* b, void* data) {
    auto& g = *static_cast<Gate*>(data);
    if (!g.rules->pairPasses(a, b, g.other)) return false;
    return g.stopped = g.collide_cb(a, b, g.cdata);
  }
  static bool distance(Obj* a, Obj* b, void* data, double& dist) {
    auto& g = *static_cast<Gate*>(data);
    if (!g.rules->pairPasses(a, b, g.other)) return false;
    return g.stopped = g.distance_cb(a, b, g.cdata, dist);
  }
};

void FclBackend::grow(Obj* obj) const {
  // Every object registered by the Python manager is its Object (manager.h).
  static_cast<Object*>(obj)->refresh(rules_.margin(obj));
}

void FclBackend::setMargin(double margin) {
  rules_.setMargin(margin);
  update();
}

void FclBackend::setMargin(Obj* obj, double margin) {
  rules_.setMargin(obj, margin);
  update(obj);
}

void FclBackend::registerObjects(const std::vector<Obj*>& objs) {
  rules_.registerObjects(objs);  // first: it refuses a bad batch whole
  for (Obj* o : objs) grow(o);
  tree_.registerObjects(objs);
}

void FclBackend::registerObject(Obj* obj) {
  rules_.registerObject(obj);
  grow(obj);
  tree_.registerObject(obj);
}

void FclBackend::unregisterObject(Obj* obj) {
  tree_.unregisterObject(obj);
  rules_.unregisterObject(obj);
}

void FclBackend::update() {
  std::vector<Obj*> objs;
  tree_.getObjects(objs);
  for (Obj* o : objs) grow(o);
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
