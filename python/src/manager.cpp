// The manager: construction, mutations (arguments checked first, nothing changed on a bad one)
// and what queries and pickling read.

#include "manager.h"

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <mutex>

namespace cubepy {

thread_local int in_python_callback = 0;

void refuseFclCrashes(const Manager* a, const Manager* b, const std::vector<std::string>& kinds,
                      bool distance, const char* what) {
  std::size_t planes = 0, convexes = 0;
  // The 'fcl' backend keeps the limits of FCL's own managers, which crash on a distance to a
  // plane: a distance query in which one takes part is refused with a plane (the pipeline that
  // answers it would not crash; a comparison with FCL's managers should not pass where they fail).
  bool cube = a != nullptr || b != nullptr;
  for (const Manager* m : {a, b})
    if (m) {
      planes += m->planes();
      convexes += m->convexes();
      cube = cube && m->isCube();
    }
  for (const auto& k : kinds) {
    planes += k == "plane" || k == "halfspace";  // unbounded: FCL treats both alike
    convexes += k == "convex";
  }
  // The library answers a distance to a plane in closed form; FCL's own fcl::distance crashes.
  if (distance && planes && !cube)
    throw py::value_error(std::string(what) +
                          ": FCL 0.7's fcl::distance crashes on planes (the 'cube' backend "
                          "answers distances to planes)");
  if (planes && convexes)
    throw py::value_error(std::string(what) +
                          ": FCL 0.7 crashes on a plane against a convex; they cannot meet in one "
                          "query");
}

void checkMargin(double m) {
  if (!std::isfinite(m) || m < 0)
    throw py::value_error("margin must be finite and >= 0, got " + std::to_string(m));
}

namespace {

void noCallback(const char* what) {
  if (in_python_callback)
    throw std::runtime_error(std::string(what) +
                             ": the manager cannot change inside one of its own query callbacks");
}

}  // namespace

std::string nameOfArg(py::handle h) {
  if (!py::isinstance<py::str>(h))
    throw py::type_error("names must be str, got " + py::str(py::type::of(h)).cast<std::string>());
  return h.cast<std::string>();
}

Manager::Manager(const std::string& backend, int threads) : backend_(backend), threads_(threads) {
  if (backend == "cube") {
    auto c = std::make_unique<cube::CubeCollisionManagerd>();
    cube_ = c.get();
    bp_ = std::move(c);
  } else if (backend == "fcl") {
    auto f = std::make_unique<FclBackend>();
    fcl_ = f.get();
    bp_ = std::move(f);
  } else {
    throw py::value_error("backend must be 'cube' or 'fcl', got '" + backend + "'");
  }
}

Manager::~Manager() {
  bp_->clear();
}

Entry* Manager::find(const std::string& name) const {
  auto it = entries_.find(name);
  if (it == entries_.end()) throw UnknownName("no object named '" + name + "'");
  return it->second.get();
}

std::vector<const Entry*> Manager::ordered() const {
  std::vector<const Entry*> out;
  out.reserve(entries_.size());
  for (const auto& [name, e] : entries_) out.push_back(e.get());
  std::sort(out.begin(), out.end(), [](const Entry* a, const Entry* b) { return a->seq < b->seq; });
  return out;
}

const Entry* Manager::byGeometry(const fcl::CollisionGeometryd* g) const {
  auto it = by_geometry_.find(g);
  return it == by_geometry_.end() ? nullptr : it->second;
}

std::pair<std::uint64_t, std::uint64_t> Manager::filterOf(const Entry& e) const {
  return rules().filter(e.obj.get());
}

double Manager::marginOf(const Entry* e) const {
  return rules().margin(e ? e->obj.get() : nullptr);
}

std::vector<std::pair<std::string, std::string>> Manager::excludedPairs() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& [a, b] : rules().excludedPairs())
    out.emplace_back(entryOf(a)->name, entryOf(b)->name);
  std::sort(out.begin(), out.end());
  return out;
}

bool Manager::pairPasses(const std::string& a, const std::string& b) const {
  Object* oa = find(a)->obj.get();
  Object* ob = find(b)->obj.get();
  return rules().pairPasses(oa, ob);
}

void Manager::applyMargin(fcl::CollisionObjectd* obj, double margin) {
  if (cube_ && obj)
    cube_->setMargin(obj, margin);
  else if (cube_)
    cube_->setMargin(margin);
  else if (obj)
    fcl_->setMargin(obj, margin);
  else
    fcl_->setMargin(margin);
}

void Manager::add(std::vector<NewObject> objects, const char* what) {
  noCallback(what);
  for (const auto& o : objects) {
    if (o.margin >= 0) checkMargin(o.margin);
    if (!cube_ && (o.geometry->kind == "plane" || o.geometry->kind == "halfspace"))
      throw py::value_error(std::string(what) +
                            ": the FCL backend's tree needs bounded objects; planes and "
                            "halfspaces only with backend='cube'");
  }
  // Made and, on failure, dropped with the GIL (declared before it is released).
  std::vector<py::object> pynames;
  pynames.reserve(objects.size());
  for (const auto& o : objects) pynames.push_back(py::str(o.name));
  std::vector<std::unique_ptr<Entry>> made;
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  std::unordered_set<std::string> fresh;
  std::vector<std::string> kinds;
  for (const auto& o : objects) {
    if (entries_.count(o.name)) throw py::value_error("an object named '" + o.name + "' exists");
    if (!fresh.insert(o.name).second)
      throw py::value_error(std::string(what) + ": '" + o.name + "' is named twice");
    kinds.push_back(o.geometry->kind);
  }
  refuseFclCrashes(this, nullptr, kinds, false, what);
  std::vector<fcl::CollisionObjectd*> raw;
  std::unordered_set<const fcl::CollisionGeometryd*> taken;  // by this batch
  for (auto& o : objects) {
    auto e = std::make_unique<Entry>();
    e->name = o.name;
    e->pyname = std::move(pynames[made.size()]);
    e->seq = next_seq_ + made.size();
    e->geometry = o.geometry;
    e->own_margin = o.margin >= 0;
    // One object per FCL geometry in a manager, so that FCL's results (which name geometries)
    // name one object: a geometry added again is copied.
    const fcl::CollisionGeometryd* p = o.geometry->fcl.get();
    const bool again = by_geometry_.count(p) || !taken.insert(p).second;
    auto g = again ? cloneFcl(*o.geometry) : o.geometry->fcl;
    e->obj = std::make_unique<Object>(g, o.tf);
    e->obj->setUserData(e.get());
    e->obj->computeAABB();
    raw.push_back(e->obj.get());
    made.push_back(std::move(e));
  }
  const bool was_empty = entries_.empty();
  // A batch into an empty manager: the cube manager's batch build, FCL's top-down init.
  bp_->registerObjects(raw);
  for (std::size_t i = 0; i < made.size(); ++i) {
    const NewObject& o = objects[i];
    fcl::CollisionObjectd* obj = made[i]->obj.get();
    if (o.category != 1 || o.mask != ~std::uint64_t(0)) rules().setFilter(obj, o.category, o.mask);
    if (o.margin >= 0) applyMargin(obj, o.margin);
  }
  if (!cube_ && raw.size() == 1)
    bp_->update(raw[0]);  // FCL rebalances its tree incrementally, as after any update
  else if (!cube_ && !was_empty)
    bp_->update();  // objects inserted one by one: rebalance
  next_seq_ += made.size();
  for (auto& e : made) {
    const std::string& kind = e->geometry->kind;
    if (e->own_margin) ++own_margins_;
    meshes_ += kind == "mesh";
    planes_ += kind == "plane" || kind == "halfspace";
    convexes_ += kind == "convex";
    by_geometry_[e->obj->collisionGeometry().get()] = e.get();
    std::string name = e->name;
    entries_.emplace(std::move(name), std::move(e));
  }
}

void Manager::remove(const std::string& name) {
  noCallback("remove_object");
  std::unique_ptr<Entry> dead;  // dropped once the GIL is back (its pyname)
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  Entry* e = find(name);
  bp_->unregisterObject(e->obj.get());
  if (!cube_) bp_->setup();
  // The rules object forgot the object's bits, margin and excluded pairs as it unregistered it.
  if (e->own_margin) --own_margins_;
  if (e->geometry->kind == "mesh") --meshes_;
  if (e->geometry->kind == "plane" || e->geometry->kind == "halfspace") --planes_;
  if (e->geometry->kind == "convex") --convexes_;
  by_geometry_.erase(e->obj->collisionGeometry().get());
  const auto it = entries_.find(name);
  dead = std::move(it->second);
  entries_.erase(it);
}

void Manager::setTransforms(const std::vector<std::string>& names,
                            const std::vector<fcl::Transform3d>& tfs) {
  noCallback("set_transform");
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  std::vector<Entry*> es;
  es.reserve(names.size());
  std::unordered_set<const Entry*> seen;
  for (const auto& n : names) {
    es.push_back(find(n));
    if (!seen.insert(es.back()).second)
      throw py::value_error("set_transforms: '" + n + "' is named twice");
  }
  std::vector<fcl::CollisionObjectd*> objs;
  objs.reserve(es.size());
  for (std::size_t i = 0; i < es.size(); ++i) {
    es[i]->obj->setTransform(tfs[i]);
    es[i]->obj->computeAABB();  // FCL's tree grows it by the margin at its update
    objs.push_back(es[i]->obj.get());
  }
  // One update of the tree: every moved object's path refitted once.
  if (objs.size() == 1)
    bp_->update(objs[0]);
  else if (objs.size() * 4 >= entries_.size())
    bp_->update();
  else if (!objs.empty())
    bp_->update(objs);
}

void Manager::setFilter(const std::string& name, std::uint64_t category, std::uint64_t mask) {
  noCallback("set_filter");
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  Entry* e = find(name);
  rules().setFilter(e->obj.get(), category, mask);
}

void Manager::excludePair(const std::string& a, const std::string& b, bool on, const char* where) {
  noCallback(where);
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  Entry* ea = find(a);
  Entry* eb = find(b);
  if (ea == eb) throw py::value_error(std::string(where) + ": an object never pairs with itself");
  rules().excludePair(ea->obj.get(), eb->obj.get(), on);
}

void Manager::clearExcluded(const char* where) {
  noCallback(where);
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  for (const auto& [a, b] : rules().excludedPairs()) rules().excludePair(a, b, false);
}

void Manager::setMargin(double margin, const std::string* name) {
  noCallback("set_margin");
  checkMargin(margin);
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  if (name) {
    Entry* e = find(*name);
    applyMargin(e->obj.get(), margin);
    if (!e->own_margin) ++own_margins_;
    e->own_margin = true;
  } else {
    applyMargin(nullptr, margin);
  }
}

}  // namespace cubepy
