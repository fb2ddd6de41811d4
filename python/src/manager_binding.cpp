// The manager's Python class: construction, mutations and reads by name, pickling (the state
// read from the broadphase, which keeps the filter bits and margins). Queries: collide.cpp,
// distance.cpp, spatial.cpp, fcl_hooks.cpp, batch.cpp.

#include <pybind11/stl.h>

#include <mutex>

#include "manager.h"

namespace cubepy {

namespace {

py::dict getState(const Manager& m) {
  std::shared_lock lock(m.mutex);
  // The state is built under the read lock: a __del__ that an allocation here sets off and that
  // mutates the manager would wait for this lock forever; it gets RuntimeError, as in a query.
  CallbackScope refuse;
  py::list objects;
  for (const Entry* e : m.ordered()) {
    const auto [category, mask] = m.filterOf(*e);
    objects.append(
        py::make_tuple(e->name, e->geometry, toArray(e->obj->getTransform()), category, mask,
                       e->own_margin ? py::object(py::float_(m.marginOf(e))) : py::none()));
  }
  py::dict d;
  d["version"] = 1;
  d["backend"] = m.backend();
  d["threads"] = m.threads();
  d["margin"] = m.managerMargin();
  d["objects"] = objects;
  d["ignored"] = m.excludedPairs();  // the key of the first format, kept
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
    m->excludePair(p.first, p.second, true, "unpickling");
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
backend='fcl': FCL's DynamicAABBTreeCollisionManager as the broadphase, under the same pair
rules and through the same pipeline (the same answers; to compare broadphases). threads: the pipeline's threads for large queries (0: the
hardware's, 1: the calling thread only); answers do not depend on it.

Thread safety: any calls from several Python threads are safe. Queries run concurrently (each
releases the GIL); a mutation (add, remove, set_transform(s), filters, margins) waits for the
running queries and runs alone. A mutation from Python code that runs inside a query (a
callback of the python-fcl layer's _collide_python hooks, or a __del__ while a collide query or pickling
builds its result) raises RuntimeError instead of waiting for that query. Pickles: the copy is
rebuilt from geometry, names, transforms, filter bits, excluded pairs and margins.

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
          "Removes the object (and its excluded pairs). KeyError if no object has this name.")
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
            transformsFrom(a.data(), ns.size(), out.data(), [&](std::size_t i) {
              return transformFrom(a.data() + 16 * i, "transforms[" + std::to_string(i) + "]");
            });
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
            return self.filterOf(*self.find(nameOfArg(name)));
          },
          py::arg("name"), "(category, mask) of the object. KeyError for an unknown name.")
      .def(
          "exclude_pair",
          [](Manager& self, py::handle a, py::handle b) {
            self.excludePair(nameOfArg(a), nameOfArg(b), true, "exclude_pair");
          },
          py::arg("name_a"), py::arg("name_b"),
          "Excludes this pair: never tested or reported (an allowed-collision entry), in every "
          "collision and distance query. KeyError for an unknown name, ValueError for the same "
          "name twice.")
      .def(
          "include_pair",
          [](Manager& self, py::handle a, py::handle b) {
            self.excludePair(nameOfArg(a), nameOfArg(b), false, "include_pair");
          },
          py::arg("name_a"), py::arg("name_b"),
          "Undoes exclude_pair (no effect if the pair was not excluded). KeyError for an unknown "
          "name.")
      .def(
          "clear_excluded", [](Manager& self) { self.clearExcluded("clear_excluded"); },
          "Forgets every excluded pair.")
      .def_property_readonly(
          "excluded_pairs",
          [](const Manager& self) {
            std::shared_lock lock(self.mutex);
            return self.excludedPairs();
          },
          "The excluded pairs, sorted, as (name, name) tuples, each in the order the objects "
          "were added.")
      .def(
          "pair_passes",
          [](const Manager& self, py::handle a, py::handle b) {
            const std::string na = nameOfArg(a), nb = nameOfArg(b);
            std::shared_lock lock(self.mutex);
            return self.pairPasses(na, nb);
          },
          py::arg("name_a"), py::arg("name_b"), R"doc(
Whether the queries over this manager's own pairs (in_collision_internal,
min_distance_internal) test and report this pair once the two objects' boxes, each grown by its
margin, overlap: True if their filter bits pass (set_filter) and the pair is not excluded
(exclude_pair), decided where the queries decide it, on either backend. Either order names the
pair; False for the same name twice. KeyError for an unknown name, TypeError for a non-str
name.)doc")
      // The former names, kept for existing code.
      .def(
          "ignore_pair",
          [](Manager& self, py::handle a, py::handle b) {
            self.excludePair(nameOfArg(a), nameOfArg(b), true, "ignore_pair");
          },
          py::arg("name_a"), py::arg("name_b"), "Alias of exclude_pair.")
      .def(
          "unignore_pair",
          [](Manager& self, py::handle a, py::handle b) {
            self.excludePair(nameOfArg(a), nameOfArg(b), false, "unignore_pair");
          },
          py::arg("name_a"), py::arg("name_b"), "Alias of include_pair.")
      .def(
          "clear_ignored", [](Manager& self) { self.clearExcluded("clear_ignored"); },
          "Alias of clear_excluded.")
      .def_property_readonly(
          "ignored_pairs",
          [](const Manager& self) {
            std::shared_lock lock(self.mutex);
            return self.excludedPairs();
          },
          "Alias of excluded_pairs.")
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
  bindCollideQueries(cls);
  bindDistanceQueries(cls);
  bindSpatialQueries(cls);
  bindFclHooks(cls);
  bindManagerBatch(cls);
}

}  // namespace cubepy
