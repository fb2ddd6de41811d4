// The manager's construction, mutations and pickling.

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
  // A distance query among cube managers only runs the library's pipeline; one with an
  // FCL-backend manager calls fcl::distance on the cube side's objects too.
  bool cube = a != nullptr || b != nullptr;
  for (const Manager* m : {a, b})
    if (m) {
      planes += m->planes();
      convexes += m->convexes();
      cube = cube && m->isCube();
    }
  for (const auto& k : kinds) {
    planes += k == "plane";
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

namespace {

void checkMargin(double m) {
  if (!std::isfinite(m) || m < 0)
    throw py::value_error("margin must be finite and >= 0, got " + std::to_string(m));
}

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
    bp_ = std::make_unique<fcl::DynamicAABBTreeCollisionManagerd>();
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

bool Manager::ignoredPair(const Entry* a, const Entry* b) const {
  // The cube backend's ignored pairs are its manager's excluded pairs, decided in its walks.
  if (cube_) return cube_->isExcluded(a->obj.get(), b->obj.get());
  if (!a->ignores || !b->ignores) return false;
  auto [lo, hi] = ignored_.equal_range(key(a, b));
  for (auto it = lo; it != hi; ++it)
    if ((it->second.first == a && it->second.second == b) ||
        (it->second.first == b && it->second.second == a))
      return true;
  return false;
}

bool Manager::allowed(const Entry* a, const Entry* b) const {
  const std::uint64_t ca = a ? a->category : 1, ma = a ? a->mask : ~std::uint64_t(0);
  const std::uint64_t cb = b ? b->category : 1, mb = b ? b->mask : ~std::uint64_t(0);
  if ((ca & mb) == 0 || (cb & ma) == 0) return false;
  if (a && b && ignoredPair(a, b)) return false;
  return true;
}

std::vector<std::pair<std::string, std::string>> Manager::ignored() const {
  std::vector<std::pair<std::string, std::string>> out;
  if (cube_)
    for (const auto& [a, b] : cube_->excludedPairs())
      out.emplace_back(entryOf(a)->name, entryOf(b)->name);
  else
    for (const auto& [k, p] : ignored_) out.emplace_back(p.first->name, p.second->name);
  std::sort(out.begin(), out.end());
  return out;
}

void Manager::refresh(Entry& e) {
  // The cube manager grows the boxes by the margins itself; FCL's tree reads the grown box.
  e.obj->refresh(cube_ ? 0.0 : marginOf(&e));
}

void Manager::add(std::vector<NewObject> objects, const char* what) {
  noCallback(what);
  for (const auto& o : objects) {
    if (o.margin >= 0) checkMargin(o.margin);
    if (!cube_ && o.geometry->kind == "plane")
      throw py::value_error(std::string(what) +
                            ": the FCL backend's tree needs bounded objects; planes only with "
                            "backend='cube'");
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
    e->category = o.category;
    e->mask = o.mask;
    e->margin = o.margin;
    // One object per FCL geometry in a manager, so that FCL's results (which name geometries)
    // name one object: a geometry added again is copied.
    const fcl::CollisionGeometryd* p = o.geometry->fcl.get();
    const bool again = by_geometry_.count(p) || !taken.insert(p).second;
    auto g = again ? cloneFcl(*o.geometry) : o.geometry->fcl;
    e->obj = std::make_unique<Object>(g, o.tf);
    e->obj->setUserData(e.get());
    refresh(*e);
    raw.push_back(e->obj.get());
    made.push_back(std::move(e));
  }
  const bool was_empty = entries_.empty();
  // A batch into an empty manager: the cube manager's batch build, FCL's top-down init.
  bp_->registerObjects(raw);
  if (cube_) {
    for (const auto& e : made) {
      if (e->category != 1 || e->mask != ~std::uint64_t(0))
        cube_->setFilter(e->obj.get(), e->category, e->mask);
      if (e->margin >= 0) cube_->setMargin(e->obj.get(), e->margin);
    }
  } else if (raw.size() == 1) {
    bp_->update(raw[0]);  // FCL rebalances its tree incrementally, as after any update
  } else if (!was_empty) {
    bp_->update();  // objects inserted one by one: rebalance
  }
  next_seq_ += made.size();
  for (auto& e : made) {
    const std::string& kind = e->geometry->kind;
    if (e->margin >= 0) ++own_margins_;
    meshes_ += kind == "mesh";
    planes_ += kind == "plane";
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
  // The cube manager forgot the object's excluded pairs as it unregistered it.
  if (e->ignores)
    for (auto it = ignored_.begin(); it != ignored_.end();) {
      if (it->second.first == e || it->second.second == e) {
        const Entry* other = it->second.first == e ? it->second.second : it->second.first;
        const_cast<Entry*>(other)->ignores--;
        it = ignored_.erase(it);
      } else {
        ++it;
      }
    }
  if (e->margin >= 0) --own_margins_;
  if (e->geometry->kind == "mesh") --meshes_;
  if (e->geometry->kind == "plane") --planes_;
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
    refresh(*es[i]);
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
  if (cube_) cube_->setFilter(e->obj.get(), category, mask);
  e->category = category;
  e->mask = mask;
}

void Manager::ignorePair(const std::string& a, const std::string& b, bool ignore) {
  noCallback("ignore_pair");
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  Entry* ea = find(a);
  Entry* eb = find(b);
  if (ea == eb) throw py::value_error("ignore_pair: an object never pairs with itself");
  if (cube_) {
    cube_->excludePair(ea->obj.get(), eb->obj.get(), ignore);
    return;
  }
  const bool present = ignoredPair(ea, eb);
  if (ignore && !present) {
    ignored_.emplace(key(ea, eb), std::make_pair(ea, eb));
    ea->ignores++;
    eb->ignores++;
  } else if (!ignore && present) {
    auto [lo, hi] = ignored_.equal_range(key(ea, eb));
    for (auto it = lo; it != hi; ++it)
      if ((it->second.first == ea && it->second.second == eb) ||
          (it->second.first == eb && it->second.second == ea)) {
        ignored_.erase(it);
        break;
      }
    ea->ignores--;
    eb->ignores--;
  }
}

void Manager::clearIgnored() {
  noCallback("clear_ignored");
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  if (cube_)
    for (const auto& [a, b] : cube_->excludedPairs()) cube_->excludePair(a, b, false);
  ignored_.clear();
  for (auto& [n, e] : entries_) e->ignores = 0;
}

void Manager::setMargin(double margin, const std::string* name) {
  noCallback("set_margin");
  checkMargin(margin);
  py::gil_scoped_release nogil;
  std::unique_lock lock(mutex);
  if (name) {
    Entry* e = find(*name);
    if (cube_) cube_->setMargin(e->obj.get(), margin);
    if (e->margin < 0) ++own_margins_;
    e->margin = margin;
    if (!cube_) {
      refresh(*e);
      bp_->update(e->obj.get());
    }
  } else {
    if (cube_) cube_->setMargin(margin);
    margin_ = margin;
    if (!cube_) {
      for (auto& [n, e] : entries_) refresh(*e);
      bp_->update();
    }
  }
}

namespace {

py::dict getState(const Manager& m) {
  std::shared_lock lock(m.mutex);
  // The state is built under the read lock: a __del__ that an allocation here sets off and that
  // mutates the manager would wait for this lock forever; it gets RuntimeError, as in a query.
  CallbackScope refuse;
  py::list objects;
  for (const Entry* e : m.ordered()) {
    objects.append(py::make_tuple(e->name, e->geometry, toArray(e->obj->getTransform()),
                                  e->category, e->mask,
                                  e->margin >= 0 ? py::object(py::float_(e->margin)) : py::none()));
  }
  py::dict d;
  d["version"] = 1;
  d["backend"] = m.backend();
  d["threads"] = m.threads();
  d["margin"] = m.managerMargin();
  d["objects"] = objects;
  d["ignored"] = m.ignored();
  return d;
}

std::shared_ptr<Manager> fromState(const py::dict& d) {
  if (!d.contains("version") || d["version"].cast<int>() != 1)
    throw py::value_error("not a cube_collision.CollisionManager state");
  auto m = std::make_shared<Manager>(d["backend"].cast<std::string>(), d["threads"].cast<int>());
  const double margin = d["margin"].cast<double>();
  if (margin > 0) m->setMargin(margin, nullptr);
  std::vector<Manager::NewObject> objs;
  for (py::handle h : d["objects"]) {
    auto t = h.cast<py::tuple>();
    objs.push_back({t[0].cast<std::string>(), geometryOf(t[1]), transform(t[2]),
                    t[3].cast<std::uint64_t>(), t[4].cast<std::uint64_t>(),
                    t[5].is_none() ? -1.0 : t[5].cast<double>()});
  }
  m->add(std::move(objs), "unpickling");
  for (py::handle h : d["ignored"]) {
    auto p = h.cast<std::pair<std::string, std::string>>();
    m->ignorePair(p.first, p.second, true);
  }
  return m;
}

}  // namespace

void bindManager(py::module_& m) {
  // Made once, kept for the process (as pybind11's own exception types).
  static PyObject* unknown_name = [&] {
    py::tuple bases = py::make_tuple(py::handle(PyExc_KeyError), py::handle(PyExc_ValueError));
    PyObject* cls = PyErr_NewExceptionWithDoc(
        "cube_collision.UnknownNameError",
        "No object has this name: both a KeyError (this package's word) and a ValueError (what "
        "trimesh raises), so that either except clause catches it.",
        bases.ptr(), nullptr);
    if (!cls) throw py::error_already_set();
    return cls;
  }();
  m.attr("UnknownNameError") = py::handle(unknown_name);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const UnknownName& e) {
      PyErr_SetString(unknown_name, e.what());
    }
  });
  ManagerClass cls(m, "CollisionManager", R"doc(
Named collision objects with trimesh.collision.CollisionManager's vocabulary, every query run in
C++ (broadphase, culling and FCL's narrow phase, the GIL released).

backend='cube' (default): the cube hierarchy of this library and its narrow-phase pipeline.
backend='fcl': FCL's DynamicAABBTreeCollisionManager with FCL's narrow phase per pair, in C++
(the same answers; for comparison). threads: the pipeline's threads for large queries (0: the
hardware's, 1: the calling thread only); answers do not depend on it.

Thread safety: any calls from several Python threads are safe. Queries run concurrently (each
releases the GIL); a mutation (add, remove, set_transform(s), filters, margins) waits for the
running queries and runs alone. A mutation from Python code that runs inside a query (a
callback of the private _collide_python hooks, or a __del__ while a collide query or pickling
builds its result) raises RuntimeError instead of waiting for that query. Pickles: the copy is
rebuilt from geometry, names, transforms, filter bits, ignored pairs and margins.

An unknown name raises cube_collision.UnknownNameError, both the KeyError that the calls below
name and the ValueError that trimesh raises.)doc");
  cls.def(py::init<const std::string&, int>(), py::arg("backend") = "cube", py::arg("threads") = 0,
          "An empty manager. ValueError for a backend other than 'cube' or 'fcl'.")
      .def_property_readonly("backend", &Manager::backend, "'cube' or 'fcl'.")
      .def_property_readonly("threads", &Manager::threads,
                             "Threads given at construction (0: the hardware's).")
      .def(
          "add_object",
          [](Manager& self, py::handle name, py::handle geometry, py::handle transform_,
             py::handle mesh, std::uint64_t category, std::uint64_t mask, py::object margin) {
            const std::string n = nameOfArg(name);
            GeometryPtr g = geometryOf(geometryArg(geometry, mesh, "add_object"));
            const fcl::Transform3d tf = transform(transform_);
            double own = -1;  // none: the manager-wide margin
            if (!margin.is_none()) {
              own = margin.cast<double>();
              checkMargin(own);
            }
            self.add({{n, g, tf, category, mask, own}}, "add_object");
            return g;
          },
          py::arg("name"), py::arg("geometry") = py::none(), py::arg("transform") = py::none(),
          py::kw_only(), py::arg("mesh") = py::none(), py::arg("category") = 1,
          py::arg("mask") = ~std::uint64_t(0), py::arg("margin") = py::none(), R"doc(
Adds an object: `geometry` (a Geometry, or a trimesh.Trimesh / anything with vertices and faces:
as trimesh, a solid convex (FCL's Convex) if its is_convex is true, else a mesh, a surface)
placed by `transform` (4x4 rigid, None: identity). mesh: trimesh's name for `geometry` (as
trimesh's scene_to_collision calls add_object(name=..., mesh=..., transform=...)); give one of
the two. category / mask: filter bits (set_filter). margin: the object's own margin
(set_margin). A geometry added under several names is copied once per name (trimesh also builds
one BVH per add_object).
Returns the Geometry the object was added with (the one get_geometry returns; a trimesh is
converted). trimesh returns python-fcl's CollisionObject, which this package has no binding
for: move and read objects by name (set_transform, get_transform).
Raises TypeError (name not a str, not a geometry, both or neither of geometry and mesh,
non-numeric transform), ValueError (an object with this name exists: unlike trimesh, which
replaces it; a transform that is not 4x4, finite and rigid; a bad margin; a plane with
backend='fcl'); nothing is added then.)doc")
      .def(
          "add_objects",
          [](Manager& self, py::handle names, py::handle geometries, py::handle transforms) {
            std::vector<Manager::NewObject> objs;
            for (py::handle h : names) {
              objs.emplace_back();
              objs.back().name = nameOfArg(h);
            }
            std::size_t i = 0;
            for (py::handle h : geometries) {
              if (i == objs.size())
                throw py::value_error("add_objects: more geometries than names");
              objs[i++].geometry = geometryOf(h);
            }
            if (i != objs.size()) throw py::value_error("add_objects: fewer geometries than names");
            if (transforms.is_none()) {
              for (auto& o : objs) o.tf = fcl::Transform3d::Identity();
            } else {
              Array a = floats(transforms, "transforms",
                               {static_cast<py::ssize_t>(objs.size()), 4, 4}, false);
              for (std::size_t k = 0; k < objs.size(); ++k)
                objs[k].tf =
                    transformFrom(a.data() + 16 * k, "transforms[" + std::to_string(k) + "]");
            }
            self.add(std::move(objs), "add_objects");
          },
          py::arg("names"), py::arg("geometries"), py::arg("transforms") = py::none(), R"doc(
Adds many objects in one call and one build of the tree (the cube manager's batch build; FCL's
top-down build into an empty FCL backend): names (n str), geometries (n Geometry or trimeshes),
transforms (n, 4, 4) or None (identities). Everything is checked first and nothing is added on
an error: as add_object, plus ValueError for a name given twice or lengths that differ.)doc")
      .def(
          "remove_object", [](Manager& self, py::handle name) { self.remove(nameOfArg(name)); },
          py::arg("name"),
          "Removes the object (and its ignored pairs). KeyError if no object has this name.")
      .def(
          "set_transform",
          [](Manager& self, py::handle name, py::handle tf) {
            const std::string n = nameOfArg(name);
            // transform() reads None as the identity (add_object's default); a move needs one.
            if (tf.is_none())
              throw py::type_error(
                  "set_transform: transform must be a 4x4 rigid transform, got "
                  "None (np.eye(4) is the identity)");
            self.setTransforms({n}, {transform(tf)});
          },
          py::arg("name"), py::arg("transform"),
          "Moves one object (4x4 rigid transform). KeyError for an unknown name, TypeError / "
          "ValueError for a bad transform (TypeError for None, as trimesh and set_transforms); "
          "nothing changes then.")
      .def(
          "set_transforms",
          [](Manager& self, py::handle names, py::handle tfs) {
            std::vector<std::string> ns;
            for (py::handle h : names) ns.push_back(nameOfArg(h));
            Array a = floats(tfs, "transforms", {static_cast<py::ssize_t>(ns.size()), 4, 4}, false);
            std::vector<fcl::Transform3d> out(ns.size());
            for (std::size_t i = 0; i < ns.size(); ++i)
              out[i] = transformFrom(a.data() + 16 * i, "transforms[" + std::to_string(i) + "]");
            self.setTransforms(ns, out);
          },
          py::arg("names"), py::arg("transforms"), R"doc(
Moves many objects in one call and one update of the tree: transforms is an (n, 4, 4) array for
the n names. Everything is checked before anything moves: KeyError for an unknown name,
ValueError for a name given twice, a wrong shape, a non-finite or non-rigid transform (named by
index), TypeError for non-str names or a non-numeric array.)doc")
      .def(
          "get_transform",
          [](const Manager& self, py::handle name) {
            const std::string n = nameOfArg(name);
            fcl::Transform3d tf;
            {
              std::shared_lock lock(self.mutex);
              tf = self.find(n)->obj->getTransform();
            }
            return toArray(tf);  // allocates: after the lock (a __del__ may mutate the manager)
          },
          py::arg("name"), "The object's 4x4 transform (a copy). KeyError for an unknown name.")
      .def(
          "get_geometry",
          [](const Manager& self, py::handle name) {
            std::shared_lock lock(self.mutex);
            return self.find(nameOfArg(name))->geometry;
          },
          py::arg("name"), "The Geometry the object was added with. KeyError if unknown.")
      .def(
          "set_filter",
          [](Manager& self, py::handle name, std::uint64_t category, std::uint64_t mask) {
            self.setFilter(nameOfArg(name), category, mask);
          },
          py::arg("name"), py::arg("category"), py::arg("mask"), R"doc(
Filter bits (Box2D's rule, 64 bits each): a pair is tested only if (a.category & b.mask) and
(b.category & a.mask) are both non-zero. Default: category 1, mask all ones (every pair). Every
collision and distance query applies them; query geometries of *_single have the default
bits. KeyError for an unknown name; TypeError for a negative or too large int.)doc")
      .def(
          "get_filter",
          [](const Manager& self, py::handle name) {
            std::shared_lock lock(self.mutex);
            const Entry* e = self.find(nameOfArg(name));
            return std::make_pair(e->category, e->mask);
          },
          py::arg("name"), "(category, mask) of the object. KeyError for an unknown name.")
      .def(
          "ignore_pair",
          [](Manager& self, py::handle a, py::handle b) {
            self.ignorePair(nameOfArg(a), nameOfArg(b), true);
          },
          py::arg("name_a"), py::arg("name_b"),
          "Never report or test this pair (an allowed-collision entry), in every collision and "
          "distance query. KeyError for an unknown name, ValueError for the same name twice.")
      .def(
          "unignore_pair",
          [](Manager& self, py::handle a, py::handle b) {
            self.ignorePair(nameOfArg(a), nameOfArg(b), false);
          },
          py::arg("name_a"), py::arg("name_b"),
          "Undoes ignore_pair (no effect if the pair was not ignored). KeyError for an unknown "
          "name.")
      .def("clear_ignored", &Manager::clearIgnored, "Forgets every ignored pair.")
      .def_property_readonly(
          "ignored_pairs",
          [](const Manager& self) {
            std::shared_lock lock(self.mutex);
            return self.ignored();
          },
          "The ignored pairs, sorted, as (name, name) tuples (on the cube backend each in the "
          "order the objects were added).")
      .def(
          "set_margin",
          [](Manager& self, double margin, py::object name) {
            if (name.is_none()) {
              self.setMargin(margin, nullptr);
            } else {
              const std::string n = nameOfArg(name);
              self.setMargin(margin, &n);
            }
          },
          py::arg("margin"), py::arg("name") = py::none(), R"doc(
Contact margin (>= 0): with name, that object's own; without, every object without its own and
the query geometries of *_single. Once a margin is set, in_collision_internal and
in_collision_single report the pairs closer than margin(a) + margin(b) as well as the colliding
ones (FCL's distance; a clearance check). in_collision_other and the distance queries ignore
margins. ValueError for a negative or non-finite margin, KeyError for an unknown name.)doc")
      .def(
          "get_margin",
          [](const Manager& self, py::object name) {
            std::shared_lock lock(self.mutex);
            if (name.is_none()) return self.managerMargin();
            return self.marginOf(self.find(nameOfArg(name)));
          },
          py::arg("name") = py::none(),
          "The margin of the named object (its own, else the manager's), or the manager's.")
      .def_property_readonly(
          "names",
          [](const Manager& self) {
            std::shared_lock lock(self.mutex);
            std::vector<std::string> out;
            for (const Entry* e : self.ordered()) out.push_back(e->name);
            return out;
          },
          "The names, in the order they were added.")
      .def("__len__", [](const Manager& self) { return self.size(); })
      .def("__contains__",
           [](const Manager& self, py::handle name) {
             if (!py::isinstance<py::str>(name)) return false;
             std::shared_lock lock(self.mutex);
             try {
               self.find(name.cast<std::string>());
               return true;
             } catch (const UnknownName&) {
               return false;
             }
           })
      .def("__repr__",
           [](const Manager& self) {
             return "cube_collision.CollisionManager(backend='" + self.backend() + "', " +
                    std::to_string(self.size()) + " objects)";
           })
      .def(py::pickle([](const Manager& self) { return getState(self); },
                      [](py::dict d) { return fromState(d); }));
  bindManagerQueries(cls);
  bindManagerBatch(cls);
}

}  // namespace cubepy
