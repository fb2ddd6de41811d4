// The hooks of the python-fcl layer (cube_collision.fcl): a manager walked with a Python
// callback per candidate pair (a user's callback), python-fcl's default callbacks run in C++, and
// python-fcl's collide() / distance() on two placed geometries; and FCL's own pair calls
// (pair_in_collision, pair_distance), the tests' oracle.

#include <cube_collision/continuous.h>
#include <cube_collision/queries.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <pybind11/stl.h>

#include <exception>
#include <optional>

#include "handle.h"
#include "query_common.h"

namespace cubepy {

namespace {

// A Python callable per candidate pair, as python-fcl's manager calls a user's callback, with a
// new Python object per side per call as python-fcl makes.
Handle handleOf(ObjPtr o) {
  const Entry* e = Manager::entryOf(o);
  return {nameOf(o), o, e ? py::cast(e->geometry) : py::none()};
}

// Every exception of the callback (a Python one, or a result of the wrong type) is kept and
// stops the walk: none crosses the broadphase, whose walk is left as it would be after a stop.
struct PyDrive {
  py::function fn;
  const char* what;
  std::exception_ptr error;

  template <class Call>
  static bool guarded(void* data, Call&& call) {
    auto& d = *static_cast<PyDrive*>(data);
    try {
      return call(d);
    } catch (const py::cast_error& e) {
      d.error = std::make_exception_ptr(py::type_error(
          std::string(d.what) + ": the callback returned the wrong type (" + e.what() + ")"));
    } catch (...) {
      d.error = std::current_exception();
    }
    return true;
  }
  static bool collideCb(ObjPtr a, ObjPtr b, void* data) {
    return guarded(data, [&](PyDrive& d) { return d.fn(handleOf(a), handleOf(b)).cast<bool>(); });
  }
  static bool distanceCb(ObjPtr a, ObjPtr b, void* data, double& dist) {
    return guarded(data, [&](PyDrive& d) {
      py::tuple r = d.fn(handleOf(a), handleOf(b));
      const double got = r[1].cast<double>();
      const bool stop = r[0].cast<bool>();
      dist = got;
      return stop;
    });
  }
  /// Runs a hook's walk on m with the thread marked as in a callback (restored on every exit),
  /// then rethrows what a callback raised.
  template <class Walk>
  void run(const Manager& m, const Manager* other, Walk&& walk) {
    {
      ReadLocks lock(m, other);
      CallbackScope scope;
      walk();
    }
    if (error) std::rethrow_exception(error);
  }
};

// What a query of the python-fcl layer (cube_collision.fcl) pairs the manager's objects with:
// none (among themselves), another manager, or a (geometry, transform) tuple (a query object,
// not registered: its user data is null, its name "__external").
struct Target {
  const Manager* other = nullptr;
  GeometryPtr geometry;
  std::unique_ptr<Object> query;
};

Target targetOf(const Manager& m, py::handle target, const char* what) {
  Target t;
  if (target.is_none()) return t;
  if (py::isinstance<Manager>(target)) {
    const Manager* o = target.cast<const Manager*>();
    if (o->isCube() != m.isCube())
      throw py::value_error(std::string(what) + ": both managers must have the same backend");
    t.other = o == &m ? nullptr : o;
    return t;
  }
  if (!py::isinstance<py::tuple>(target) || py::len(target) != 2)
    throw py::type_error(std::string(what) +
                         ": target must be None, a CollisionManager or (geometry, transform)");
  py::tuple tup = py::reinterpret_borrow<py::tuple>(target);
  t.geometry = geometryOf(tup[0]);
  t.query = std::make_unique<Object>(t.geometry->fcl, transform(tup[1]));
  return t;
}

// python-fcl's request objects (cube_collision.fcl's CollisionRequest / DistanceRequest, or any
// object with their attributes), read as python-fcl's collide() and distance() read them.
fcl::CollisionRequestd collisionRequestOf(py::handle r) {
  const auto n = r.attr("num_max_contacts").cast<long long>();
  if (n < 1) throw py::value_error("num_max_contacts must be >= 1");
  fcl::CollisionRequestd req(static_cast<std::size_t>(n), r.attr("enable_contact").cast<bool>(),
                             r.attr("num_max_cost_sources").cast<std::size_t>(),
                             r.attr("enable_cost").cast<bool>(),
                             r.attr("use_approximate_cost").cast<bool>());
  req.gjk_solver_type = static_cast<fcl::GJKSolverType>(r.attr("gjk_solver_type").cast<int>());
  return req;
}

fcl::DistanceRequestd distanceRequestOf(py::handle r) {
  fcl::DistanceRequestd req(r.attr("enable_nearest_points").cast<bool>());
  req.enable_signed_distance =
      py::getattr(r, "enable_signed_distance", py::bool_(false)).cast<bool>();
  req.gjk_solver_type = static_cast<fcl::GJKSolverType>(r.attr("gjk_solver_type").cast<int>());
  return req;
}

// A python-fcl Contact (contact_type called as Contact(o1, o2, b1, b2, normal, pos,
// penetration_depth)) from FCL's contact between the objects whose FCL geometry is ga (Python
// geometry pa) and the other (pb). Without enable_contact FCL leaves normal and pos unset: zeros.
py::object makeContact(py::handle contact_type, const fcl::Contactd& c,
                       const fcl::CollisionGeometryd* ga, py::handle pa, py::handle pb,
                       bool positions) {
  const bool a_first = c.o1 == ga;
  const fcl::Vector3d zero = fcl::Vector3d::Zero();
  return contact_type(a_first ? pa : pb, a_first ? pb : pa, c.b1, c.b2,
                      toArray(positions ? c.normal : zero), toArray(positions ? c.pos : zero),
                      c.penetration_depth);
}

}  // namespace

void bindFclHooks(ManagerClass& cls) {
  cls.def(
         "_collide_python",
         [](const Manager& m, py::function fn, py::object target) {
           Target t = targetOf(m, target, "_collide_python");
           PyDrive d{fn, "_collide_python", nullptr};
           d.run(m, t.other, [&] {
             if (t.query)
               m.broadphase().collide(t.query.get(), &d, &PyDrive::collideCb);
             else if (t.other)
               m.broadphase().collide(&t.other->broadphase(), &d, &PyDrive::collideCb);
             else
               m.broadphase().collide(&d, &PyDrive::collideCb);
           });
         },
         py::arg("callback"), py::arg("target") = py::none(),
         "Hook of the benchmark (trimesh's way over python-fcl) and of cube_collision.fcl's "
         "managers with a user's callback: the backend's collide calling "
         "callback(handle_a, handle_b) -> bool (True stops) for every candidate pair; target: "
         "None (self-collide), another manager of the same backend, or (geometry, transform) "
         "(handle name '__external'). The manager's pair rules apply as in its queries. The "
         "managers must not change "
         "from the callback (RuntimeError). What the callback raises stops the walk and is "
         "raised here; TypeError for a result that is not a bool.")
      .def(
          "_distance_python",
          [](const Manager& m, py::function fn, py::object target) {
            Target t = targetOf(m, target, "_distance_python");
            PyDrive d{fn, "_distance_python", nullptr};
            d.run(m, t.other, [&] {
              if (t.query)
                m.broadphase().distance(t.query.get(), &d, &PyDrive::distanceCb);
              else if (t.other)
                m.broadphase().distance(&t.other->broadphase(), &d, &PyDrive::distanceCb);
              else
                m.broadphase().distance(&d, &PyDrive::distanceCb);
            });
          },
          py::arg("callback"), py::arg("target") = py::none(),
          "Hook as _collide_python for the backend's distance: callback(handle_a, handle_b) -> "
          "(stop, best distance so far) for every pair it visits (TypeError for a result that "
          "is not (bool, float)).")
      .def(
          "_fcl_collide_all",
          [](const Manager& m, py::object target, py::object request, py::object result,
             py::object contact_type, py::dict geoms, py::object other_geoms,
             py::object query_geom) {
            const fcl::CollisionRequestd req = collisionRequestOf(request);
            const bool prior = result.attr("is_collision").cast<bool>();
            py::list contacts = result.attr("contacts");
            const std::size_t prior_count = py::len(contacts);
            Target t = targetOf(m, target, "collide");
            struct Row {
              ObjPtr a, b;
              fcl::Contactd c;
            };
            std::vector<Row> rows;
            bool any = false, done = false;
            std::optional<ReadLocks> lock;
            {
              py::gil_scoped_release nogil;
              lock.emplace(m, t.other);
              const auto& c = m.broadphase();
              const std::vector<cube::ObjectPair<double>> pairs =
                  t.query   ? cube::overlappingPairs(c, t.query.get())
                  : t.other ? cube::overlappingPairs(c, t.other->broadphase())
                            : cube::overlappingPairs(c);
              cube::NarrowPhaseOptions<double> opt;
              opt.threads = m.threads();
              // python-fcl's defaultCollisionCallback: fcl::collide per candidate pair (a fresh
              // result each, its contacts appended), done once the result holds more than
              // num_max_contacts contacts (costs aside). Pairs go to the pipeline at once when
              // the budget is at least their number, else in chunks that double from 64, so
              // that an early stop wastes little.
              std::size_t count = prior_count;
              std::size_t chunk = req.num_max_contacts < pairs.size() ? 64 : pairs.size();
              for (std::size_t start = 0; start < pairs.size() && !done;
                   start += chunk, chunk = std::min<std::size_t>(2 * chunk, 8192)) {
                const std::vector<cube::ObjectPair<double>> sub(
                    pairs.begin() + static_cast<std::ptrdiff_t>(start),
                    pairs.begin() +
                        static_cast<std::ptrdiff_t>(std::min(pairs.size(), start + chunk)));
                const auto results = cube::collidePairs(sub, req, opt);
                for (std::size_t i = 0; i < sub.size(); ++i) {
                  if (results[i].isCollision()) {
                    any = true;
                    for (std::size_t k = 0; k < results[i].numContacts(); ++k)
                      rows.push_back({sub[i].first, sub[i].second, results[i].getContact(k)});
                    count += results[i].numContacts();
                  }
                  if (!req.enable_cost && (prior || any) && count > req.num_max_contacts) {
                    done = true;
                    break;
                  }
                }
              }
            }
            // Built while the locks keep the entries; Python code run by an allocation may not
            // change a manager (as collideQuery).
            CallbackScope refuse;
            const auto geomOf = [&](ObjPtr o) -> py::object {
              const Entry* e = Manager::entryOf(o);
              if (!e) return query_geom;
              PyObject* g = PyDict_GetItem(geoms.ptr(), e->pyname.ptr());
              if (!g && PyDict_Check(other_geoms.ptr()))
                g = PyDict_GetItem(other_geoms.ptr(), e->pyname.ptr());
              return g ? py::reinterpret_borrow<py::object>(g) : py::object(py::none());
            };
            ObjPtr last_a = nullptr, last_b = nullptr;
            py::object pa, pb;
            for (const Row& r : rows) {
              if (r.a != last_a || r.b != last_b) {
                last_a = r.a;
                last_b = r.b;
                pa = geomOf(r.a);
                pb = geomOf(r.b);
              }
              contacts.append(makeContact(contact_type, r.c, r.a->collisionGeometry().get(), pa, pb,
                                          req.enable_contact));
            }
            result.attr("is_collision") = prior || any;
            return done;
          },
          py::arg("target"), py::arg("request"), py::arg("result"), py::arg("contact_type"),
          py::arg("geoms"), py::arg("other_geoms"), py::arg("query_geom"),
          "cube_collision.fcl's managers with python-fcl's defaultCollisionCallback, in C++: "
          "fcl::collide with `request` on every candidate pair (target as _collide_python) in "
          "the walk's order, each pair's contacts appended to result.contacts as "
          "contact_type(o1, o2, b1, b2, normal, pos, depth), o1 / o2 the Python geometries "
          "geoms[name] (or other_geoms[name]; query_geom for the query object), until the "
          "result holds more than num_max_contacts contacts. Sets result.is_collision; returns "
          "whether that limit stopped the query (python-fcl's cdata.done).")
      .def(
          "_fcl_distance_all",
          [](const Manager& m, py::object target, py::object request, py::object result,
             py::dict geoms, py::object other_geoms, py::object query_geom) {
            const fcl::DistanceRequestd req = distanceRequestOf(request);
            Target t = targetOf(m, target, "distance");
            DistOut o;
            {
              py::gil_scoped_release nogil;
              ReadLocks lock(m, t.other);
              refuseFclCrashes(
                  &m, t.other,
                  t.query ? std::vector<std::string>{t.geometry->kind} : std::vector<std::string>{},
                  true, "distance");
              o = distance(m, t.query.get(), t.other, req.enable_nearest_points);
            }
            if (!o.found || !(o.distance < result.attr("min_distance").cast<double>())) return;
            const auto geomOf = [&](const std::string& name) -> py::object {
              if (name == kExternal) return query_geom;
              py::str key(name);
              PyObject* g = PyDict_GetItem(geoms.ptr(), key.ptr());
              if (!g && PyDict_Check(other_geoms.ptr()))
                g = PyDict_GetItem(other_geoms.ptr(), key.ptr());
              return g ? py::reinterpret_borrow<py::object>(g) : py::object(py::none());
            };
            result.attr("min_distance") = o.distance;
            py::list pts;
            pts.append(toArray(o.pa));
            pts.append(toArray(o.pb));
            result.attr("nearest_points") = pts;
            result.attr("o1") = geomOf(o.a);
            result.attr("o2") = geomOf(o.b);
            result.attr("b1") = o.ba;
            result.attr("b2") = o.bb;
          },
          py::arg("target"), py::arg("request"), py::arg("result"), py::arg("geoms"),
          py::arg("other_geoms"), py::arg("query_geom"),
          "cube_collision.fcl's managers with python-fcl's defaultDistanceCallback, in C++: the "
          "smallest distance (the package's minimum-distance query; target as _collide_python) "
          "written to result (min_distance, nearest_points, o1 / o2 as _fcl_collide_all, b1, "
          "b2) if smaller than result.min_distance. ValueError with a plane (FCL 0.7 has no "
          "distance for it).");
}

void bindPairCalls(py::module_& m) {
  py::class_<Handle>(m, "_Handle",
                     "An object handed to the callback of _collide_python / _distance_python.")
      .def_readonly("name", &Handle::name)
      .def_readonly("geometry", &Handle::geometry);
  // cube_collision.fcl's collide() and distance(): python-fcl's, on two placed geometries.
  m.def(
      "_fcl_pair_collide",
      [](py::handle ga, py::handle ta, py::handle gb, py::handle tb, py::object request,
         py::object result, py::object contact_type, py::object pa, py::object pb) {
        const fcl::CollisionRequestd req = collisionRequestOf(request);
        GeometryPtr a = geometryOf(ga), b = geometryOf(gb);
        Object oa(a->fcl, transform(ta, "transform_a")), ob(b->fcl, transform(tb, "transform_b"));
        fcl::CollisionResultd res;
        {
          py::gil_scoped_release nogil;
          // The pipeline's narrow phase on one pair: fcl::collide, except for a convex against
          // a plane, on which FCL 0.7 crashes (answered from the convex's vertices).
          cube::NarrowPhaseOptions<double> opt;
          opt.threads = 1;
          res = cube::collidePairs<double>({{&oa, &ob}}, req, opt)[0];
        }
        result.attr("is_collision") = result.attr("is_collision").cast<bool>() || res.isCollision();
        py::list contacts = result.attr("contacts");
        for (std::size_t k = 0; k < res.numContacts(); ++k)
          contacts.append(makeContact(contact_type, res.getContact(k), a->fcl.get(), pa, pb,
                                      req.enable_contact));
        return res.numContacts();
      },
      py::arg("geometry_a"), py::arg("transform_a"), py::arg("geometry_b"), py::arg("transform_b"),
      py::arg("request"), py::arg("result"), py::arg("contact_type"), py::arg("o1"), py::arg("o2"),
      "cube_collision.fcl.collide: fcl::collide with a python-fcl request on two placed "
      "geometries; contacts appended to result.contacts as contact_type(o1, o2, b1, b2, normal, "
      "pos, depth) naming the Python geometries o1 / o2; returns the number of contacts.");
  m.def(
      "_fcl_pair_distance",
      [](py::handle ga, py::handle ta, py::handle gb, py::handle tb, py::object request,
         py::object result, py::object pa, py::object pb) {
        const fcl::DistanceRequestd req = distanceRequestOf(request);
        GeometryPtr a = geometryOf(ga), b = geometryOf(gb);
        refuseFclCrashes(nullptr, nullptr, {a->kind, b->kind}, true, "distance");
        Object oa(a->fcl, transform(ta, "transform_a")), ob(b->fcl, transform(tb, "transform_b"));
        fcl::DistanceResultd res;
        double d;
        {
          py::gil_scoped_release nogil;
          d = fcl::distance(&oa, &ob, req, res);
        }
        if (res.min_distance < result.attr("min_distance").cast<double>()) {
          const bool a_first = res.o1 == a->fcl.get();
          result.attr("min_distance") = res.min_distance;
          py::list pts;
          pts.append(toArray(res.nearest_points[0]));
          pts.append(toArray(res.nearest_points[1]));
          result.attr("nearest_points") = pts;
          result.attr("o1") = a_first ? pa : pb;
          result.attr("o2") = a_first ? pb : pa;
          result.attr("b1") = res.b1;
          result.attr("b2") = res.b2;
        }
        return d;
      },
      py::arg("geometry_a"), py::arg("transform_a"), py::arg("geometry_b"), py::arg("transform_b"),
      py::arg("request"), py::arg("result"), py::arg("o1"), py::arg("o2"),
      "cube_collision.fcl.distance: fcl::distance with a python-fcl request on two placed "
      "geometries; result updated if closer (python-fcl's rule); returns the distance. "
      "ValueError with a plane (FCL 0.7's fcl::distance crashes on it).");

  m.def(
      "_fcl_pair_continuous",
      [](py::handle ga, py::handle ta, py::handle ta_end, py::handle gb, py::handle tb,
         py::handle tb_end, py::object request) {
        fcl::ContinuousCollisionRequestd req;
        req.num_max_iterations = request.attr("num_max_iterations").cast<std::size_t>();
        req.toc_err = request.attr("toc_err").cast<double>();
        req.ccd_motion_type =
            static_cast<fcl::CCDMotionType>(request.attr("ccd_motion_type").cast<int>());
        req.gjk_solver_type =
            static_cast<fcl::GJKSolverType>(request.attr("gjk_solver_type").cast<int>());
        req.ccd_solver_type =
            static_cast<fcl::CCDSolverType>(request.attr("ccd_solver_type").cast<int>());
        GeometryPtr a = geometryOf(ga), b = geometryOf(gb);
        refuseFclCrashes(nullptr, nullptr, {a->kind, b->kind}, false, "continuousCollide");
        Object oa(a->fcl, transform(ta, "transform_a")), ob(b->fcl, transform(tb, "transform_b"));
        const std::vector<cube::Motion<double>> motions = {{&oa, transform(ta_end, "tf1_end")},
                                                           {&ob, transform(tb_end, "tf2_end")}};
        std::vector<cube::ContinuousContact> hits;
        {
          py::gil_scoped_release nogil;
          // A manager of the two objects: the library's continuousCollideAll gives
          // fcl::continuousCollide's answer for the pair (with its rule for FCL's defects).
          cube::CubeCollisionManagerd pair;
          pair.registerObject(&oa);
          pair.registerObject(&ob);
          pair.setup();
          hits = cube::continuousCollideAll(pair, motions, req);
          pair.clear();
        }
        if (hits.empty()) return py::make_tuple(false, 1.0, py::none(), py::none());
        const auto& h = hits.front();
        const bool a_first = h.a == &oa;
        return py::make_tuple(true, h.time_of_contact, toArray(a_first ? h.tf_a : h.tf_b),
                              toArray(a_first ? h.tf_b : h.tf_a));
      },
      py::arg("geometry_a"), py::arg("transform_a"), py::arg("end_a"), py::arg("geometry_b"),
      py::arg("transform_b"), py::arg("end_b"), py::arg("request"),
      "cube_collision.fcl.continuousCollide: fcl::continuousCollide of two geometries moving "
      "from transform_* to end_* with a python-fcl ContinuousCollisionRequest, through the "
      "library's continuousCollideAll. Returns (is_collide, time_of_contact (1.0 if none), "
      "contact transform a, b (None if none)). ValueError for a motion type the library "
      "refuses (CCDM_LINEAR, CCDM_SPLINE) and for pairs that crash FCL 0.7.");

  auto pairObjects = [](py::handle ga, py::handle ta, py::handle gb, py::handle tb) {
    GeometryPtr a = geometryOf(ga), b = geometryOf(gb);
    return std::make_pair(std::make_unique<Object>(a->fcl, transform(ta, "transform_a")),
                          std::make_unique<Object>(b->fcl, transform(tb, "transform_b")));
  };
  m.def(
      "pair_in_collision",
      [pairObjects](py::handle ga, py::handle ta, py::handle gb, py::handle tb) {
        auto [a, b] = pairObjects(ga, ta, gb, tb);
        refuseFclCrashes(nullptr, nullptr, {geometryOf(ga)->kind, geometryOf(gb)->kind}, false,
                         "pair_in_collision");
        py::gil_scoped_release nogil;
        fcl::CollisionResultd res;
        fcl::collide(a.get(), b.get(), fcl::CollisionRequestd(), res);
        return res.isCollision();
      },
      py::arg("geometry_a"), py::arg("transform_a"), py::arg("geometry_b"), py::arg("transform_b"),
      "FCL's own fcl::collide on two placed geometries (FCL's default request): no broadphase, "
      "for checks and tests; FCL 0.7's answer as it is (a cylinder against a plane: its "
      "defective yes/no test, which the managers correct). TypeError / ValueError for bad "
      "geometry or transforms.");
  m.def(
      "pair_distance",
      [pairObjects](py::handle ga, py::handle ta, py::handle gb, py::handle tb) {
        auto [a, b] = pairObjects(ga, ta, gb, tb);
        refuseFclCrashes(nullptr, nullptr, {geometryOf(ga)->kind, geometryOf(gb)->kind}, true,
                         "pair_distance");
        py::gil_scoped_release nogil;
        fcl::DistanceResultd res;
        fcl::distance(a.get(), b.get(), fcl::DistanceRequestd(), res);
        return res.min_distance;
      },
      py::arg("geometry_a"), py::arg("transform_a"), py::arg("geometry_b"), py::arg("transform_b"),
      "fcl::distance on two placed geometries (<= 0 when they touch). As pair_in_collision; "
      "ValueError for a plane (FCL 0.7's fcl::distance crashes on it).");
}

}  // namespace cubepy
